//! `vlf generate --format gltf`: the generated OBJ + MTL written again as glTF 2.0 (a .gltf
//! with its .bin). Each run of faces with one material becomes a primitive, in the OBJ's
//! order, its vertices numbered in order of first use and polygons cut into fans from their
//! first corner, as the OBJ importer does; so both formats give the same scene and light field.

use crate::error::{Result, VlfError};
use std::collections::HashMap;

/// The glTF JSON (referring to `bin_name`) and its buffer, from generated OBJ and MTL text.
pub fn from_obj(obj: &str, mtl: &str, bin_name: &str) -> Result<(String, Vec<u8>)> {
    let bad = |m: String| VlfError::Parameter {
        name: "format",
        message: format!("cannot write the generated mesh as glTF: {m}"),
    };
    let (names, materials) = materials(mtl);
    let mut v: Vec<[f32; 3]> = Vec::new();
    // runs of (material, polygons as 0-based vertex indices)
    let mut runs: Vec<(String, Vec<Vec<usize>>)> = Vec::new();
    let mut current = String::new();
    for line in obj.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let p: Vec<f32> = w.filter_map(|x| x.parse().ok()).collect();
                v.push([p[0], p[1], p[2]]);
            }
            Some("usemtl") => current = w.next().unwrap_or_default().to_string(),
            Some("f") => {
                let poly = w
                    .map(|c| c.parse::<usize>().map(|i| i - 1))
                    .collect::<std::result::Result<Vec<_>, _>>()
                    .map_err(|e| bad(format!("face {line:?}: {e}")))?;
                if runs.last().is_none_or(|r| r.0 != current) {
                    runs.push((current.clone(), Vec::new()));
                }
                runs.last_mut().unwrap().1.push(poly);
            }
            _ => {}
        }
    }
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut primitives) = (Vec::new(), Vec::new(), Vec::new());
    for (material, polygons) in &runs {
        let mut local: HashMap<usize, u32> = HashMap::new();
        let (mut pos, mut idx) = (Vec::<[f32; 3]>::new(), Vec::<u32>::new());
        for poly in polygons {
            let ids: Vec<u32> = poly
                .iter()
                .map(|&i| {
                    *local.entry(i).or_insert_with(|| {
                        pos.push(v[i]);
                        pos.len() as u32 - 1
                    })
                })
                .collect();
            for k in 1..ids.len() - 1 {
                idx.extend([ids[0], ids[k], ids[k + 1]]);
            }
        }
        let (lo, hi) = pos
            .iter()
            .fold(([f32::MAX; 3], [f32::MIN; 3]), |(l, h), p| {
                (
                    std::array::from_fn(|c| l[c].min(p[c])),
                    std::array::from_fn(|c| h[c].max(p[c])),
                )
            });
        let at = bin.len();
        bin.extend(pos.iter().flatten().flat_map(|x| x.to_le_bytes()));
        views.push(serde_json::json!({"buffer": 0, "byteOffset": at, "byteLength": bin.len() - at, "target": 34962}));
        accessors.push(serde_json::json!({"bufferView": views.len() - 1, "componentType": 5126, "count": pos.len(), "type": "VEC3", "min": lo, "max": hi}));
        let at = bin.len();
        bin.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
        views.push(serde_json::json!({"buffer": 0, "byteOffset": at, "byteLength": bin.len() - at, "target": 34963}));
        accessors.push(serde_json::json!({"bufferView": views.len() - 1, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}));
        let m = names
            .iter()
            .position(|n| n == material)
            .ok_or_else(|| bad(format!("material {material:?} is not in the MTL")))?;
        primitives.push(serde_json::json!({"attributes": {"POSITION": accessors.len() - 2}, "indices": accessors.len() - 1, "material": m}));
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0", "generator": "vlf generate"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "buffers": [{"uri": bin_name, "byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
        "materials": materials,
        "meshes": [{"primitives": primitives}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    let text = serde_json::to_string_pretty(&json).map_err(|e| bad(e.to_string()))?;
    Ok((text, bin))
}

/// MTL `Kd` as base colour (metallic 0), `Ke` as emissive factor x strength.
fn materials(mtl: &str) -> (Vec<String>, Vec<serde_json::Value>) {
    let (mut names, mut out) = (Vec::new(), Vec::<serde_json::Value>::new());
    for line in mtl.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["newmtl", name] => {
                names.push(name.to_string());
                out.push(serde_json::json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
            }
            ["Kd", r, g, b] => {
                let c: Vec<f32> = [r, g, b].iter().map(|x| x.parse().unwrap_or(0.0)).collect();
                if let Some(m) = out.last_mut() {
                    m["pbrMetallicRoughness"]["baseColorFactor"] =
                        serde_json::json!([c[0], c[1], c[2], 1.0]);
                }
            }
            ["Ke", r, g, b] => {
                let c: Vec<f32> = [r, g, b].iter().map(|x| x.parse().unwrap_or(0.0)).collect();
                let s = c.iter().cloned().fold(0.0f32, f32::max);
                if let (Some(m), true) = (out.last_mut(), s > 0.0) {
                    m["emissiveFactor"] = serde_json::json!([c[0] / s, c[1] / s, c[2] / s]);
                    m["extensions"] = serde_json::json!({"KHR_materials_emissive_strength": {"emissiveStrength": s}});
                }
            }
            _ => {}
        }
    }
    (names, out)
}
