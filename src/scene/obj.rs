//! OBJ/MTL import. A line scan first finds the faults a parser would report without a line
//! number (non-finite vertices, face indices out of range); the lines are then read on the
//! CPU's threads by `obj_lines` with tobj's rules, or by tobj itself where the file steps
//! outside what `obj_lines` reads; the material libraries through tobj. After it, degenerate
//! and duplicated triangles are dropped with a count in a warning.

use super::obj_lines::{self, ObjGeometry};
use super::texels::NormalSource;
use super::weld::{self, Kept};
use super::{check_color, Material, MaterialOverride, Texture, Triangle};
use crate::error::{Result, VlfError};
use crate::material::Cutout;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub struct ImportedMesh {
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub warnings: Vec<String>,
    /// The OBJ and every material library it loaded, for the scene hash.
    pub source_files: Vec<PathBuf>,
    /// cameras the mesh file defines (glTF; none from an OBJ)
    pub cameras: Vec<super::Camera>,
    pub texture_memory: super::texels::TextureMemory,
}

pub fn import(path: &Path, overrides: &BTreeMap<String, MaterialOverride>) -> Result<ImportedMesh> {
    import_with(path, overrides, true)
}

/// `import`, its OBJ parsed on the CPU's threads where `threaded` and the file allows, else by
/// tobj (the tests compare the two).
fn import_with(
    path: &Path,
    overrides: &BTreeMap<String, MaterialOverride>,
    threaded: bool,
) -> Result<ImportedMesh> {
    let text = std::fs::read_to_string(path).map_err(|e| VlfError::io(path, e))?;
    prescan(&text).map_err(|m| mesh_error(path, m))?;
    let (geometry, materials, mut source_files) = parse_with(path, &text, threaded)?;
    let mtl_path = source_files
        .get(1)
        .cloned()
        .unwrap_or_else(|| path.to_path_buf());

    let mut warnings = Vec::new();
    let (mut out_materials, requests) =
        convert_materials(&materials, overrides, &mtl_path, &mut warnings)?;
    let geometry = weld_models(&geometry, &out_materials, path, &mut warnings);
    if geometry.uses_default {
        warnings.push(format!(
            "{}: faces without `usemtl` get a grey diffuse default (Kd 0.5)",
            path.display()
        ));
        out_materials.push(Material::default_grey());
    }
    warnings.extend(geometry.kept.warnings(path));
    let (positions, triangles) = (geometry.positions, geometry.triangles);
    if triangles.is_empty() {
        return Err(mesh_error(
            path,
            "the mesh has no triangles with area: nothing to light".into(),
        ));
    }
    let (textures, texture_memory) = load_textures(
        &requests,
        &positions,
        &triangles,
        &out_materials,
        &mtl_path,
        &mut source_files,
    )?;
    Ok(ImportedMesh {
        positions,
        triangles,
        materials: out_materials,
        textures,
        warnings,
        source_files,
        cameras: Vec::new(),
        texture_memory,
    })
}

fn mesh_error(path: &Path, message: String) -> VlfError {
    VlfError::Mesh {
        path: path.to_path_buf(),
        message,
    }
}

/// The OBJ's geometry and materials, and the files read (the OBJ, then each material library):
/// through `obj_lines` on the CPU's threads where `threaded` and the file allows, else through
/// tobj. A material library that cannot be read or parsed is an error naming it.
fn parse_with(
    path: &Path,
    text: &str,
    threaded: bool,
) -> Result<(ObjGeometry, Vec<tobj::Material>, Vec<PathBuf>)> {
    let libraries = Libraries::new(path);
    if threaded {
        if let Some((geometry, materials)) = obj_lines::parse(text, |mtl| libraries.load(mtl)) {
            return libraries.finish(path, geometry, materials);
        }
    }
    let libraries = Libraries::new(path);
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let mut reader = std::io::BufReader::new(text.as_bytes());
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, |mtl| libraries.load(mtl))
        .map_err(|e| mesh_error(path, format!("cannot parse OBJ: {e}")))?;
    libraries.finish(path, ObjGeometry::from_models(&models), materials)
}

/// The material libraries an OBJ names, read as the parser comes to them: the files read, and
/// the first that could not be.
struct Libraries {
    dir: PathBuf,
    source_files: std::cell::RefCell<Vec<PathBuf>>,
    missing: std::cell::RefCell<Option<String>>,
}

impl Libraries {
    fn new(obj: &Path) -> Libraries {
        Libraries {
            dir: obj.parent().unwrap_or(Path::new(".")).to_path_buf(),
            source_files: std::cell::RefCell::new(vec![obj.to_path_buf()]),
            missing: Default::default(),
        }
    }

    fn load(&self, mtl: &Path) -> tobj::MTLLoadResult {
        let full = self.dir.join(mtl);
        match std::fs::read_to_string(&full) {
            Ok(t) => {
                // tobj panics on a colour line with fewer than three numbers: catch it first
                if let Err(e) = prescan_mtl(&t) {
                    *self.missing.borrow_mut() =
                        Some(format!("material library {}: {e}", full.display()));
                    return Err(tobj::LoadError::MaterialParseError);
                }
                self.source_files.borrow_mut().push(full);
                tobj::load_mtl_buf(&mut std::io::BufReader::new(t.as_bytes()))
            }
            Err(e) => {
                *self.missing.borrow_mut() = Some(format!(
                    "material library {} (named by mtllib): {e}",
                    full.display()
                ));
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    }

    /// The parse's result, or the error of a library that could not be used.
    fn finish(
        self,
        path: &Path,
        geometry: ObjGeometry,
        materials: obj_lines::Materials,
    ) -> Result<(ObjGeometry, Vec<tobj::Material>, Vec<PathBuf>)> {
        if let Some(m) = self.missing.into_inner() {
            return Err(mesh_error(path, format!("cannot use {m}")));
        }
        let materials = materials
            .map_err(|e| mesh_error(path, format!("cannot parse its material library: {e}")))?;
        Ok((geometry, materials, self.source_files.into_inner()))
    }
}

/// The cutoff of an MTL cut-out: `map_d` x `d` below it is a hole (MTL names none: glTF's
/// default, and what its BLEND with a texture is taken as).
pub const MTL_CUTOFF: f32 = 0.5;

/// The scene's materials and the textures they name: textures are read once the geometry
/// says how finely they are needed (texels.rs).
fn convert_materials(
    materials: &[tobj::Material],
    overrides: &BTreeMap<String, MaterialOverride>,
    mtl_path: &Path,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Material>, Vec<TextureRequest>)> {
    let mut out_materials: Vec<Material> = Vec::new();
    let mut requests: Vec<TextureRequest> = Vec::new();
    for m in materials {
        let mut material = convert_material(m, overrides.get(&m.name), mtl_path, warnings)?;
        let mtl_dir = mtl_path.parent().unwrap_or(Path::new("."));
        // a metal's (Pm) base colour texture is not read: it has no diffuse part to colour
        material.diffuse_texture = (m.diffuse_texture.as_ref())
            .filter(|_| mtl_metal(m).is_none())
            .map(|t| request(&mut requests, mtl_dir.join(t), &m.name, "map_Kd"));
        material.emission_texture = m
            .unknown_param
            .get("map_Ke")
            .map(|t| request(&mut requests, mtl_dir.join(t.trim()), &m.name, "map_Ke"));
        material.normal_map = normal_map(m, mtl_dir, &mut requests);
        let d = m.dissolve.unwrap_or(1.0);
        material.cutout = m.dissolve_texture.as_ref().map(|t| {
            let texture = request(&mut requests, mtl_dir.join(t.trim()), &m.name, "map_d");
            requests[texture as usize].alpha = true;
            Cutout {
                texture,
                cutoff: MTL_CUTOFF / d.max(1e-6),
            }
        });
        // dissolve without a map is glass-like (one alpha everywhere): as glTF's BLEND without
        // a texture, opaque; with map_d, a cut-out of map_d x d at MTL_CUTOFF
        if d < 1.0 {
            warnings.push(match material.cutout {
                None => format!(
                    "material {:?}: transparency (d < 1) cannot be represented; treated as opaque",
                    m.name
                ),
                Some(_) => format!(
                    "material {:?}: transparency (d {d} x map_d) taken as a cut-out at {MTL_CUTOFF}",
                    m.name
                ),
            });
        }
        out_materials.push(material);
    }
    Ok((out_materials, requests))
}

/// A material's normal map: MTL `norm` (a tangent-space normal map, `-bm` its scale), else
/// `bump` / `map_Bump` (a height map, `-bm` its multiplier, turned into normals).
fn normal_map(
    m: &tobj::Material,
    mtl_dir: &Path,
    requests: &mut Vec<TextureRequest>,
) -> Option<crate::material::NormalMap> {
    let (line, key) = match m.unknown_param.get("norm") {
        Some(line) => (line.as_str(), "norm"),
        None => (m.normal_texture.as_deref()?, "bump"),
    };
    // options before the file name: only -bm (the multiplier) is read
    let words: Vec<&str> = line.split_whitespace().collect();
    let file = words.last()?;
    let bm = (words.iter().position(|w| *w == "-bm"))
        .and_then(|i| words.get(i + 1)?.parse::<f32>().ok())
        .filter(|b| b.is_finite())
        .unwrap_or(1.0);
    let source = match key {
        "norm" => NormalSource::Normals,
        _ => NormalSource::Height(bm),
    };
    let texture = request(requests, mtl_dir.join(file), &m.name, key);
    requests[texture as usize].normals = Some(source);
    Some(crate::material::NormalMap {
        texture,
        scale: if key == "norm" { bm } else { 1.0 },
    })
}

/// The models' triangles over welded positions, and whether some face has no material.
struct Geometry {
    positions: Vec<[f32; 3]>,
    triangles: Vec<Triangle>,
    kept: Kept,
    uses_default: bool,
}

/// Weld equal positions across objects so that connectivity is seen across groups, then keep
/// the triangles with area that repeat none kept; faces without a material get the one after
/// `materials` (the default, added by the caller).
fn weld_models(
    geometry: &ObjGeometry,
    materials: &[Material],
    path: &Path,
    warnings: &mut Vec<String>,
) -> Geometry {
    let default_material = materials.len() as u32;
    let points = &geometry.points;
    let extent = (points.iter().flatten()).fold(0.0f64, |m, &x| m.max(x.abs() as f64));
    let welded = weld::weld(points);
    let mut uses_default = false;
    let mut material_of = Vec::with_capacity(geometry.corners.len());
    for object in &geometry.objects {
        let material = match object.material {
            Some(id) => id as u32,
            None => {
                uses_default = true;
                default_material
            }
        };
        let textured = object.material.is_some_and(|id| {
            let m = &materials[id];
            m.diffuse_texture.is_some()
                || m.emission_texture.is_some()
                || m.cutout.is_some()
                || m.normal_map.is_some()
        });
        if object.partly_textured {
            warnings.push(format!("{}: object {:?} gives texture coordinates (vt) to some face corners and not to others; its texture coordinates are ignored", path.display(), object.name));
        } else if textured && !object.textured {
            warnings.push(format!("{}: object {:?} has a textured material but no texture coordinates (vt); its textures are ignored", path.display(), object.name));
        }
        material_of.extend(std::iter::repeat_n(material, object.triangles));
    }
    let corners: Vec<[u32; 3]> = crate::parallel::map_indices(geometry.corners.len(), |t| {
        geometry.corners[t].map(|p| welded.ids[p as usize])
    });
    let kept = weld::keep_triangles(&corners, &welded.positions, extent);
    let triangles = (0..corners.len())
        .filter(|&t| kept.keep[t])
        .map(|t| Triangle {
            vertices: corners[t],
            material: material_of[t],
            uv: geometry.uv[t],
        })
        .collect();
    Geometry {
        positions: welded.positions,
        triangles,
        kept,
        uses_default,
    }
}

/// Read the requested textures at the density the geometry needs; their files join
/// `source_files`.
fn load_textures(
    requests: &[TextureRequest],
    positions: &[[f32; 3]],
    triangles: &[Triangle],
    materials: &[Material],
    mtl_path: &Path,
    source_files: &mut Vec<PathBuf>,
) -> Result<(Vec<Texture>, super::texels::TextureMemory)> {
    let uses = super::texels::uses(positions, triangles, materials, requests.len());
    let mut textures: Vec<Texture> = Vec::new();
    let (mut full, mut reduced) = (0u64, 0u32);
    for (r, usage) in requests.iter().zip(uses) {
        let (t, whole) = load_texture(r, usage, mtl_path)?;
        full += whole;
        reduced += u32::from(t.width as u64 * t.height as u64 * 12 < whole);
        source_files.push(t.path.clone());
        textures.push(t);
    }
    let texture_memory = super::texels::TextureMemory::of(&textures, full, reduced);
    Ok((textures, texture_memory))
}

/// The specular part's roughness from MTL's PBR extension: `Pr` (perceptual roughness r, GGX
/// alpha r²) where the material has a specular part; `Ns` (Phong exponents) is not read, as
/// MTL files set it on every material whatever their intent.
fn mtl_roughness(m: &tobj::Material, ks: [f32; 3]) -> Option<f32> {
    let pr = mtl_number(m, "Pr")?;
    (ks.iter().any(|&k| k > 0.0)).then_some(pr * pr)
}

/// A number in [0, 1] of MTL's PBR extension (`Pr`, `Pm`), where given.
fn mtl_number(m: &tobj::Material, key: &str) -> Option<f32> {
    let v: f32 = m.unknown_param.get(key)?.trim().parse().ok()?;
    (0.0..=1.0).contains(&v).then_some(v)
}

/// A metal of MTL's PBR extension, by glTF's rules (`crate::material`, as `super::gltf`
/// applies them): `Pm` (metallic) at least 0.5 and `Pr` (roughness, 0 where not given) at most
/// 0.6 make the base colour `Kd` the specular part (an ideal mirror up to roughness 0.2, a GGX
/// lobe of alpha Pr² above) and no diffuse part: the lobe's alpha; None for a dielectric or a
/// rougher metal.
fn mtl_metal(m: &tobj::Material) -> Option<f32> {
    use crate::material::{GLOSSY_ROUGHNESS, MIRROR_METALLIC, MIRROR_ROUGHNESS};
    let metallic = mtl_number(m, "Pm")?;
    let roughness = mtl_number(m, "Pr").unwrap_or(0.0);
    if metallic < MIRROR_METALLIC || roughness > GLOSSY_ROUGHNESS {
        return None;
    }
    let alpha = match roughness > MIRROR_ROUGHNESS {
        true => roughness * roughness,
        false => 0.0,
    };
    Some(alpha)
}

fn convert_material(
    m: &tobj::Material,
    o: Option<&MaterialOverride>,
    mtl_path: &Path,
    warnings: &mut Vec<String>,
) -> Result<Material> {
    let err = |message: String| VlfError::Material {
        path: mtl_path.to_path_buf(),
        material: m.name.clone(),
        message,
    };
    let kd = m.diffuse.unwrap_or([0.0; 3]);
    let ks = m.specular.unwrap_or([0.0; 3]);
    let ke = m.emissive.unwrap_or([0.0; 3]);
    check_color(&kd, true).map_err(|e| err(format!("Kd {e}")))?;
    check_color(&ks, true).map_err(|e| err(format!("Ks {e}")))?;
    check_color(&ke, false).map_err(|e| err(format!("Ke {e}")))?;
    let o = o.cloned().unwrap_or_default();
    // a metal (`Pm`): its base colour is its specular part
    let metal = mtl_metal(m);
    let (kd, ks, roughness) = match metal {
        Some(alpha) => ([0.0; 3], kd, Some(alpha)),
        None => (kd, ks, mtl_roughness(m, ks)),
    };
    if metal.is_some() && m.diffuse_texture.is_some() {
        warnings.push(format!(
            "material {:?}: a metal (Pm): map_Kd cannot colour its specular part (one colour per material) and is ignored; Kd is",
            m.name
        ));
    }
    let material = Material {
        name: m.name.clone(),
        diffuse: o.diffuse.unwrap_or(kd),
        mirror: o.mirror.unwrap_or(ks),
        roughness: o.roughness.or(roughness).unwrap_or(0.0),
        emission: o.emission.unwrap_or(ke),
        two_sided: o.two_sided.unwrap_or(false),
        diffuse_texture: None,
        emission_texture: None,
        cutout: None,
        normal_map: None,
        specular_texture: None,
    };
    if let Some(message) = material
        .energy_error()
        .or_else(|| material.roughness_error())
    {
        return Err(err(message));
    }
    if let Some(t) = &m.specular_texture {
        warnings.push(format!("material {:?}: map_Ks {t} cannot be represented (only map_Kd, map_Ke, map_d, norm and bump are) and is ignored", m.name));
    }
    Ok(material)
}

/// The words of an OBJ or MTL line, its `#` comment left out: the prescans' one reading of a
/// line (the vertex count of a piece and its checks must agree on what a vertex line is).
fn words(raw: &str) -> std::str::SplitWhitespace<'_> {
    raw.split('#').next().unwrap_or("").split_whitespace()
}

/// Colour lines (Ka, Kd, Ks, Ke, Tf) need three numbers; tobj would panic on fewer.
fn prescan_mtl(text: &str) -> std::result::Result<(), String> {
    for (index, raw) in text.lines().enumerate() {
        let mut words = words(raw);
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke" | "Tf")) = words.next() {
            let numbers: Vec<&str> = words.collect();
            if numbers.len() < 3 || numbers[..3].iter().any(|w| w.parse::<f32>().is_err()) {
                return Err(format!(
                    "line {}: {key} needs three numbers (r g b), found {:?}",
                    index + 1,
                    numbers.join(" ")
                ));
            }
        }
    }
    Ok(())
}

/// Line-numbered checks tobj cannot report well: vertex coordinates that are not finite,
/// face indices that point outside the vertices defined so far. The text is checked in pieces
/// on the CPU's threads (each told the lines and vertices before it); the first mistake in the
/// file is the one reported.
fn prescan(text: &str) -> std::result::Result<(), String> {
    let threads = crate::parallel::threads();
    let pieces = crate::parallel::line_pieces(text, threads * 4);
    let counts: Vec<(usize, i64)> = std::thread::scope(|scope| {
        let counting: Vec<_> = (pieces.iter())
            .map(|piece| {
                scope.spawn(move || {
                    let vertices = (piece.lines())
                        .filter(|l| words(l).next() == Some("v"))
                        .count();
                    (piece.lines().count(), vertices as i64)
                })
            })
            .collect();
        counting
            .into_iter()
            .map(|h| h.join().expect("prescan"))
            .collect()
    });
    let mut before = (0usize, 0i64);
    let starts: Vec<(usize, i64)> = (counts.iter())
        .map(|&(lines, vertices)| {
            let start = before;
            before = (before.0 + lines, before.1 + vertices);
            start
        })
        .collect();
    std::thread::scope(|scope| {
        let checking: Vec<_> = (pieces.iter().zip(starts))
            .map(|(piece, (lines, vertices))| {
                scope.spawn(move || prescan_piece(piece, lines, vertices))
            })
            .collect();
        checking
            .into_iter()
            .try_for_each(|h| h.join().expect("prescan"))
    })
}

/// [`prescan`] of one piece, after `lines_before` lines holding `vertices_before` vertices.
fn prescan_piece(
    text: &str,
    lines_before: usize,
    vertices_before: i64,
) -> std::result::Result<(), String> {
    let mut vertex_count = vertices_before;
    for (index, raw) in text.lines().enumerate() {
        let line_no = lines_before + index + 1;
        let mut words = words(raw);
        match words.next() {
            Some("v") => {
                vertex_count += 1;
                for (axis, w) in words.take(3).enumerate() {
                    match w.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        Ok(_) => {
                            return Err(format!(
                                "line {line_no}: vertex {vertex_count} has a non-finite coordinate {:?} ({})",
                                w,
                                ["x", "y", "z"][axis]
                            ))
                        }
                        Err(_) => return Err(format!("line {line_no}: vertex coordinate {w:?} is not a number")),
                    }
                }
            }
            Some("f") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    return Err(format!(
                        "line {line_no}: a face needs at least 3 corners, found {}",
                        corners.len()
                    ));
                }
                for corner in corners {
                    let first = corner.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| {
                        format!("line {line_no}: face corner {corner:?} is not a vertex index")
                    })?;
                    let resolved = if i < 0 { vertex_count + 1 + i } else { i };
                    if i == 0 || resolved < 1 || resolved > vertex_count {
                        return Err(format!(
                            "line {line_no}: face index {i} is out of range (only {vertex_count} vertices are defined before it)"
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// A texture a material names: read after the geometry.
struct TextureRequest {
    path: PathBuf,
    material: String,
    key: &'static str,
    /// a material cuts holes with it (`map_d`): keep its coverage
    alpha: bool,
    /// a normal map (`norm`, `bump`): read raw at full resolution
    normals: Option<NormalSource>,
}

/// The texture's index, naming each file once.
fn request(
    requests: &mut Vec<TextureRequest>,
    path: PathBuf,
    material: &str,
    key: &'static str,
) -> u32 {
    // a normal map's image is read otherwise than a colour's: one request each
    let normals = matches!(key, "norm" | "bump");
    if let Some(i) =
        (requests.iter()).position(|r| r.path == path && r.normals.is_some() == normals)
    {
        return i as u32;
    }
    requests.push(TextureRequest {
        path,
        material: material.to_string(),
        key,
        alpha: false,
        normals: None,
    });
    requests.len() as u32 - 1
}

/// Read a texture, decoding sRGB to linear at texel density. Errors name the material and file.
fn load_texture(
    r: &TextureRequest,
    usage: super::texels::TextureUse,
    mtl_path: &Path,
) -> Result<(Texture, u64)> {
    let (path, key) = (&r.path, r.key);
    let err = |message: String| VlfError::Material {
        path: mtl_path.to_path_buf(),
        material: r.material.clone(),
        message,
    };
    let bytes = std::fs::read(path)
        .map_err(|e| err(format!("{key} {}: cannot read: {e}", path.display())))?;
    if let Some(source) = r.normals {
        let t = super::texels::decode_normals(&bytes, path.clone(), source).map_err(|e| {
            err(format!(
                "{key} {}: not a readable PNG or JPEG image: {e}",
                path.display()
            ))
        })?;
        let whole = t.texels.len() as u64 * 12;
        return Ok((t, whole));
    }
    let alpha = r.alpha.then_some(super::texels::AlphaSource::ChannelOrGrey);
    super::texels::decode(&bytes, path.clone(), usage, alpha).map_err(|e| {
        err(format!(
            "{key} {}: not a readable PNG or JPEG image: {e}",
            path.display()
        ))
    })
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    const LIBRARY: &str =
        "newmtl a\nKd 0.5 0.5 0.5\nnewmtl b\nKd 0.2 0.3 0.4\nnewmtl t\nKd 1 1 1\nmap_Kd t.png\n";
    const SECOND_LIBRARY: &str = "newmtl b\nKd 0.7 0.1 0.1\nnewmtl c\nKe 1 1 1\nKd 0 0 0\n";

    /// The OBJ `text` imported through `obj_lines` and through tobj, in a folder with two
    /// material libraries and a texture: the same positions, triangles, materials, warnings and
    /// files, or the same error. Returns whether `obj_lines` read it (false: it left it to tobj)
    /// and the warnings (or the error).
    fn both_ways(text: &str) -> (bool, Vec<String>) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.mtl"), LIBRARY).unwrap();
        std::fs::write(dir.path().join("n.mtl"), SECOND_LIBRARY).unwrap();
        image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
            .save(dir.path().join("t.png"))
            .unwrap();
        let path = dir.path().join("scene.obj");
        std::fs::write(&path, text).unwrap();
        let overrides = BTreeMap::new();
        let threaded = super::import_with(&path, &overrides, true);
        let tobj = super::import_with(&path, &overrides, false);
        match (&threaded, &tobj) {
            (Ok(a), Ok(b)) => {
                assert_eq!(a.positions, b.positions);
                assert_eq!(a.triangles, b.triangles);
                let names = |m: &super::ImportedMesh| {
                    (m.materials.iter())
                        .map(|m| (m.name.clone(), m.diffuse))
                        .collect::<Vec<_>>()
                };
                assert_eq!(names(a), names(b));
                assert_eq!(a.warnings, b.warnings);
                assert_eq!(a.source_files, b.source_files);
                assert_eq!(a.textures.len(), b.textures.len());
            }
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
            _ => panic!("one way failed: {:?} / {:?}", threaded.err(), tobj.err()),
        }
        let libraries = super::Libraries::new(&path);
        let threaded = super::obj_lines::parse(text, |mtl| libraries.load(mtl)).is_some();
        (
            threaded,
            tobj.map_or_else(|e| vec![e.to_string()], |m| m.warnings),
        )
    }

    /// Corners of every form, relative indices, quads and polygons (fans), objects split by
    /// `o`, `g` and changes of `usemtl` (an unknown name too), a second library that renames a
    /// material, CRLF lines, comments, a trailing object without faces, duplicated and flat
    /// triangles: read the same both ways, and by `obj_lines`.
    #[test]
    fn the_threaded_reader_reads_what_tobj_reads() {
        let text = "# a comment\r\nmtllib m.mtl\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\n\
            vt 0 0\nvt 1 0\nvt 1 1 0\nvt 0 1\nvn 0 0 1\ns off\n\
            usemtl a\nf 1 2 3\nf -4 -2 -1\no second\nusemtl t\nf 1/1 2/2 3/3 4/4\n\
            f 1/1/1 3/3/1 4/4/1\ng third\nusemtl a\nf 1//1 2//1 3//1\nusemtl nothing\n\
            v 2 0 0\nv 2 1 0\nf 2 5 6 3\nusemtl a\nf 1 2 3 4 5\nf 1 2 3\nf 3 1 2\nf 1 1 2\n\
            mtllib n.mtl\nusemtl b\nf 5 6 3\nusemtl c\no\nf 6 5 2\ng \nusemtl t\nf 1 2 3\no last\n";
        assert!(both_ways_threaded(text));
        // no material at all: the default grey
        assert!(both_ways_threaded("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
        // a library after the first faces; faces before any object
        assert!(both_ways_threaded(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nmtllib n.mtl\nusemtl c\nf 3 2 1\n"
        ));
        // a library that cannot be read: the same error
        assert!(both_ways_threaded(
            "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
        ));
    }

    /// What `obj_lines` leaves to tobj (so that such files import, or fail, as before): an
    /// object whose corners have texture coordinates only in part, `l` elements, a vertex with
    /// a weight, a texture index to a later `vt`, a corner with a fourth part, a `usemtl`
    /// without a name.
    #[test]
    fn what_the_threaded_reader_leaves_to_tobj_reads_as_before() {
        let head = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\n";
        for tail in [
            "f 1/1 2/1 3/1\nf 1 2 3\n",
            "l 1 2\nf 1 2 3\n",
            "v 1 1 1 2\nf 1 2 4\n",
            "f 1/2 2/1 3/1\nvt 1 1\n",
            "f 1/1/1/ 2 3\n",
            "usemtl\nf 1 2 3\n",
        ] {
            assert!(!both_ways(&format!("{head}{tail}")).0, "{tail}");
        }
        // tobj lists texture coordinates only for the corners that have them: such an object
        // (which panicked the importer before) keeps none, and says so
        let (_, warnings) = both_ways(&format!("{head}f 1/1 2/1 3/1\nf 3 2 1\n"));
        assert!(
            warnings
                .iter()
                .any(|w| w.contains("to some face corners and not to others")),
            "{warnings:?}"
        );
    }

    fn both_ways_threaded(text: &str) -> bool {
        both_ways(text).0
    }

    /// Random files of every line the readers meet (positions, texture coordinates, normals,
    /// faces of 3 to 5 corners in every corner form with absolute and relative indices, objects,
    /// groups, known, unknown and empty `usemtl`, libraries, comments, blank and CRLF lines, the
    /// odd `l` element or weighted vertex): each imports the same both ways (or fails the same),
    /// and about half are read by `obj_lines`.
    #[test]
    fn random_files_read_the_same_both_ways() {
        let mut next = crate::stats::seeded(2024);
        let mut threaded = 0;
        for _ in 0..200 {
            let (mut text, mut v, mut vt, mut vn) = (String::new(), 0u64, 0u64, 0u64);
            // one corner form a file (mixed forms in one object are tobj's to read)
            let form = next(4);
            for _ in 0..40 {
                let line = match next(20) {
                    0..=5 => {
                        v += 1;
                        format!("v {} {} {}", next(9), next(9), next(9))
                    }
                    6 => {
                        vt += 1;
                        format!("vt 0.{} 0.{}", next(10), next(10))
                    }
                    7 => {
                        vn += 1;
                        "vn 0 0 1".into()
                    }
                    8..=12 if v >= 3 => {
                        let corner = |next: &mut dyn FnMut(u64) -> u64, form: u64| {
                            let index = |next: &mut dyn FnMut(u64) -> u64, count: u64| match next(3)
                            {
                                0 => format!("-{}", 1 + next(count)),
                                _ => format!("{}", 1 + next(count)),
                            };
                            let p = index(next, v);
                            match form {
                                1 if vt > 0 => format!("{p}/{}", index(next, vt)),
                                2 if vn > 0 => format!("{p}//{}", index(next, vn)),
                                3 if vt > 0 && vn > 0 => {
                                    format!("{p}/{}/{}", index(next, vt), index(next, vn))
                                }
                                _ => p,
                            }
                        };
                        let corners: Vec<String> =
                            (0..3 + next(3)).map(|_| corner(&mut next, form)).collect();
                        format!("f {}", corners.join(" "))
                    }
                    13 => ["o chair", "g legs", "o", "g  two words "][next(4) as usize].into(),
                    14 => [
                        "usemtl a",
                        "usemtl b",
                        "usemtl t",
                        "usemtl c",
                        "usemtl gone",
                    ][next(5) as usize]
                        .into(),
                    15 => ["mtllib m.mtl", "mtllib n.mtl"][next(2) as usize].into(),
                    16 => "# a comment".into(),
                    17 => "".into(),
                    18 if next(8) == 0 => "l 1 2".into(),
                    19 if next(8) == 0 => "v 1 2 3 1".into(),
                    _ => "s 1".into(),
                };
                text.push_str(&line);
                text.push_str(if next(6) == 0 { "\r\n" } else { "\n" });
            }
            threaded += usize::from(both_ways(&text).0);
        }
        // 95 of the 200 (the rest: an `l`, a weighted vertex, or an object whose faces before
        // its first `vt` have no texture coordinates and later ones do)
        assert!(threaded >= 80, "obj_lines read only {threaded} of 200");
    }

    /// A file of many pieces (one a thread), with objects, materials and relative indices
    /// reaching back across the pieces' borders: the same both ways.
    #[test]
    fn a_file_read_in_many_pieces_is_read_as_one() {
        let mut text = String::from("mtllib m.mtl\nmtllib n.mtl\n");
        let mut next = crate::stats::seeded(7);
        let mut vertices = 0;
        for i in 0..30_000 {
            if i % 997 == 0 {
                text.push_str(&format!("o part{i}\n"));
            }
            if i % 389 == 0 {
                text.push_str(["usemtl a\n", "usemtl b\n", "usemtl c\n"][next(3) as usize]);
            }
            text.push_str(&format!("v {} {} {}\n", next(100), next(100), next(7)));
            vertices += 1;
            if vertices >= 4 {
                let back = 1 + next(3.min(vertices - 1));
                text.push_str(&format!("f -1 -{} {}\n", back + 1, 1 + next(vertices)));
            }
        }
        assert!(crate::parallel::line_pieces(&text, 8).len() >= 4);
        assert!(both_ways_threaded(&text));
    }

    /// A file checked in many pieces reports the first mistake with its own line number and
    /// the vertices defined before it, as one pass over the whole file does.
    #[test]
    fn a_mistake_far_into_a_large_file_is_named_by_its_line() {
        let mut text = String::new();
        for i in 0..20_000 {
            text.push_str(&format!("v {i} 0 0\nv {i} 1 0\nv {i} 0 1\nf -3 -2 -1\n"));
        }
        assert!(crate::parallel::line_pieces(&text, 8).len() >= 8);
        assert_eq!(super::prescan(&text), Ok(()));
        // line 70,001: the 52,501st vertex line is not a number; a face after it points past
        let bad = text.replacen("v 17500 0 0", "v x 0 0", 1) + "f 1 2 60001\n";
        let e = super::prescan(&bad).unwrap_err();
        assert!(e.contains("line 70001") && e.contains("\"x\""), "{e}");
        let e = super::prescan(&(text + "f 1 2 60001\n")).unwrap_err();
        assert!(
            e.contains("line 80001") && e.contains("only 60000 vertices"),
            "{e}"
        );
    }
}
