//! glTF 2.0 import (`.gltf` with external or embedded buffers, `.glb`) through the `gltf` crate,
//! into the same [`ImportedMesh`] the OBJ importer yields, so prepare and propagate do not know
//! where a scene came from. docs/guide/gltf.md states what is read and the approximation rules:
//! - geometry: the default scene's node hierarchy with its transforms, every primitive
//!   (triangles; strips and fans converted; points and lines skipped with a warning);
//! - materials (`material.rs`): base colour (factor x sRGB texture) as diffuse, or as an ideal
//!   mirror for smooth metals; emissive factor x texture x `KHR_materials_emissive_strength`;
//!   `doubleSided`; `KHR_texture_transform`; one warning per material naming what it dropped;
//! - cameras (perspective) become scene cameras; `KHR_lights_punctual` lights are named in a
//!   warning (the light field needs emitting surfaces).
//!
//! Accessors are read here rather than through the crate's reader, with every offset, stride
//! and index checked first: bad input is an error naming the file and the accessor, never a
//! panic.

use super::obj::ImportedMesh;
use super::texels::{self, TextureMemory, TextureUse};
use super::weld;
use super::{Camera, Material, MaterialOverride, Texture, Triangle};
use crate::error::{Result, VlfError};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use glam::{DMat4, DVec3, DVec4};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

mod material;
mod metal_rough;

/// Extensions whose content is read (the others are named in a warning, or refused when
/// the file requires them).
const READ_EXTENSIONS: [&str; 5] = [
    "KHR_texture_transform",
    "KHR_materials_emissive_strength",
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_mesh_quantization",
];
/// Node instances walked at most (a hierarchy that shares subtrees can multiply them).
const MAX_INSTANCES: usize = 1 << 20;
const MAX_DEPTH: usize = 256;
/// Elements at most in an accessor without a buffer view (zeros, but for sparse values).
const MAX_ZERO_ELEMENTS: usize = 1 << 24;

/// A triangle as read, in world coordinates, before welding.
struct RawTriangle {
    corners: [[f32; 3]; 3],
    material: u32,
    uv: Option<[[f32; 2]; 3]>,
}

/// Everything read from the node hierarchy.
#[derive(Default)]
struct Walk {
    triangles: Vec<RawTriangle>,
    cameras: Vec<Camera>,
    lights: Vec<String>,
    skipped_points_lines: usize,
    missing_uv: BTreeMap<String, usize>,
    orthographic: usize,
}

pub fn import(path: &Path, overrides: &BTreeMap<String, MaterialOverride>) -> Result<ImportedMesh> {
    let err = |message: String| VlfError::Mesh {
        path: path.to_path_buf(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| VlfError::io(path, e))?;
    let gltf = parse(&bytes).map_err(err)?;
    let doc = &gltf.document;
    for ext in doc.extensions_required() {
        if !READ_EXTENSIONS.contains(&ext) {
            return Err(err(format!(
                "requires the extension {ext}, which vlf cannot read (it reads {})",
                READ_EXTENSIONS.join(", ")
            )));
        }
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut source_files = vec![path.to_path_buf()];
    let buffers = load_buffers(doc, gltf.blob.as_deref(), dir, &mut source_files).map_err(err)?;
    let mut warnings = Vec::new();
    let ignored: Vec<&str> = doc
        .extensions_used()
        .filter(|e| !READ_EXTENSIONS.contains(e))
        .collect();
    if !ignored.is_empty() {
        warnings.push(format!(
            "{}: extension(s) {} not read: ignored",
            path.display(),
            ignored.join(", ")
        ));
    }

    let plans = material::plan_all(doc, overrides, path)?;
    let mut walk = Walk::default();
    walk_nodes(doc, &buffers, &plans, &mut walk).map_err(err)?;
    report_walk(path, &walk, &mut warnings);

    let (positions, triangles, repairs) = weld(&walk.triangles, path)?;
    warnings.extend(repairs);
    let uses = texture_uses(&plans, &positions, &triangles);
    let mut textures = Vec::new();
    let (mut full_bytes, mut reduced) = (0u64, 0u32);
    let mut texture_of_image: HashMap<usize, u32> = HashMap::new();
    for (image, usage) in &uses {
        let (bytes, name) = image_bytes(doc, *image, &buffers, dir, path, &mut source_files)
            .map_err(|m| err(format!("image {image}: {m}")))?;
        let alpha = (plans.iter().any(|p| p.alpha_image() == Some(*image)))
            .then_some(texels::AlphaSource::Channel);
        let (t, full) = texels::decode(&bytes, name.clone(), *usage, alpha).map_err(|e| {
            err(format!(
                "image {image} ({}): not a readable PNG or JPEG image: {e}",
                name.display()
            ))
        })?;
        full_bytes += full;
        reduced += u32::from(t.width as u64 * t.height as u64 * 12 < full);
        texture_of_image.insert(*image, textures.len() as u32);
        textures.push(t);
    }
    // normal textures: raw values at full resolution, a texture of their own
    let mut normal_of_image: HashMap<usize, u32> = HashMap::new();
    for image in plans.iter().filter_map(|p| Some(p.normal_image()?.0)) {
        if normal_of_image.contains_key(&image) {
            continue;
        }
        let (bytes, name) = image_bytes(doc, image, &buffers, dir, path, &mut source_files)
            .map_err(|m| err(format!("image {image}: {m}")))?;
        let t =
            texels::decode_normals(&bytes, name, texels::NormalSource::Normals).map_err(|e| {
                err(format!(
                    "image {image}: not a readable PNG or JPEG image: {e}"
                ))
            })?;
        full_bytes += t.texels.len() as u64 * 12;
        normal_of_image.insert(image, textures.len() as u32);
        textures.push(t);
    }
    let mut materials =
        material::finish(&plans, &texture_of_image, &normal_of_image, &mut warnings);
    let images = ImageSource {
        doc,
        buffers: &buffers,
        dir,
        path,
    };
    full_bytes += split_metals(
        &plans,
        &triangles,
        (&mut materials, &mut textures),
        &images,
        &mut source_files,
    )?;
    drop_unused_textures(&mut textures, &mut materials);
    if triangles.iter().any(|t| t.material as usize == plans.len()) {
        materials.push(Material::default_grey());
        warnings.push(format!(
            "{}: primitives without a material get a grey diffuse default (0.5)",
            path.display()
        ));
    }
    let texture_memory = TextureMemory::of(&textures, full_bytes, reduced);
    Ok(ImportedMesh {
        positions,
        triangles,
        materials,
        textures,
        warnings,
        source_files,
        cameras: walk.cameras,
        texture_memory,
    })
}

/// Parse and validate. The crate's validation indexes the POSITION accessor before checking
/// that it exists (gltf-json 1.4 panics there): that index is checked first.
pub(crate) fn parse(bytes: &[u8]) -> std::result::Result<::gltf::Gltf, String> {
    let raw = ::gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| gltf_message(&e))?;
    let json = raw.document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = ::gltf::json::validation::Checked::Valid(::gltf::Semantic::Positions);
            if let Some(i) = prim.attributes.get(&position) {
                if i.value() >= json.accessors.len() {
                    return Err(format!(
                        "not a valid glTF 2.0 file: meshes[{m}].primitives[{p}].attributes[\"POSITION\"]: accessor {} does not exist ({} accessors)",
                        i.value(),
                        json.accessors.len()
                    ));
                }
            }
        }
    }
    let document =
        ::gltf::Document::from_json(raw.document.into_json()).map_err(|e| gltf_message(&e))?;
    Ok(::gltf::Gltf {
        document,
        blob: raw.blob,
    })
}

/// The crate's errors, made readable: validation errors list their JSON paths.
fn gltf_message(e: &::gltf::Error) -> String {
    match e {
        ::gltf::Error::Validation(list) => {
            let shown: Vec<String> = list
                .iter()
                .take(5)
                .map(|(p, e)| format!("{p}: {e}"))
                .collect();
            let more = list.len().saturating_sub(5);
            format!(
                "not a valid glTF 2.0 file: {}{}",
                shown.join("; "),
                if more > 0 {
                    format!(" (and {more} more)")
                } else {
                    String::new()
                }
            )
        }
        ::gltf::Error::Binary(b) => format!("not a valid binary glTF (.glb): {b}"),
        ::gltf::Error::Deserialize(j) => format!("not valid glTF JSON: {j}"),
        other => format!("not a valid glTF file: {other}"),
    }
}

fn report_walk(path: &Path, walk: &Walk, warnings: &mut Vec<String>) {
    let p = path.display();
    if walk.skipped_points_lines > 0 {
        warnings.push(format!(
            "{p}: skipped {} point/line primitive(s): only surfaces carry light",
            walk.skipped_points_lines
        ));
    }
    for (material, n) in &walk.missing_uv {
        warnings.push(format!("{p}: {n} primitive(s) with the textured material {material:?} have no texture coordinates: their textures are ignored"));
    }
    if walk.orthographic > 0 {
        warnings.push(format!(
            "{p}: {} orthographic camera(s) skipped (only perspective cameras are used)",
            walk.orthographic
        ));
    }
    if !walk.lights.is_empty() {
        warnings.push(format!(
            "{p}: KHR_lights_punctual light(s) {} cannot be represented (the light field is lit by emitting surfaces and the sky) and are ignored: give an emissive material or a [sky] instead",
            walk.lights.join(", ")
        ));
    }
}

/// Every buffer's bytes: the GLB chunk, a data: URI or a file beside the model.
pub(crate) fn load_buffers(
    doc: &::gltf::Document,
    blob: Option<&[u8]>,
    dir: &Path,
    source_files: &mut Vec<PathBuf>,
) -> std::result::Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        let at = format!("buffer {}", b.index());
        let data = match b.source() {
            ::gltf::buffer::Source::Bin => blob
                .ok_or_else(|| {
                    format!("{at} is the GLB binary chunk, which the file does not have")
                })?
                .to_vec(),
            ::gltf::buffer::Source::Uri(uri) => {
                read_uri(uri, dir, source_files).map_err(|m| format!("{at}: {m}"))?
            }
        };
        if data.len() < b.length() {
            return Err(format!(
                "{at}: byteLength says {} bytes, but only {} are there (truncated?)",
                b.length(),
                data.len()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// A data: URI's bytes, or a relative file's (percent-decoded, beside the model).
fn read_uri(
    uri: &str,
    dir: &Path,
    source_files: &mut Vec<PathBuf>,
) -> std::result::Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or("a data: URI that is not base64")?;
        return base64_decode(payload).ok_or_else(|| "a data: URI with bad base64".to_string());
    }
    if uri.contains("://") {
        return Err(format!(
            "{uri:?}: only files beside the model and data: URIs are read"
        ));
    }
    let file = dir.join(percent_decode(uri));
    let bytes =
        std::fs::read(&file).map_err(|e| format!("{}: cannot read: {e}", file.display()))?;
    source_files.push(file);
    Ok(bytes)
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' | b'-' => Some(62),
        b'/' | b'_' => Some(63),
        _ => None,
    };
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for &c in s.trim_end_matches('=').as_bytes() {
        if c.is_ascii_whitespace() {
            continue;
        }
        acc = (acc << 6) | value(c)? as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

/// Where a document's images are read from (`image_bytes`).
struct ImageSource<'d> {
    doc: &'d ::gltf::Document,
    buffers: &'d [Vec<u8>],
    dir: &'d Path,
    path: &'d Path,
}

/// Split every material whose metal varies over its surface, or that is a textured metal
/// (`metal_rough`), where its triangles carry texture coordinates; elsewhere its factors decide.
/// Returns the bytes the metallic-roughness images held.
fn split_metals(
    plans: &[material::Plan],
    triangles: &[Triangle],
    (materials, textures): (&mut [Material], &mut Vec<Texture>),
    images: &ImageSource,
    source_files: &mut Vec<PathBuf>,
) -> Result<u64> {
    let textured = textured_materials(plans.len(), triangles);
    let mut read_bytes = 0;
    for (k, plan) in plans.iter().enumerate() {
        let Some(split) = plan.split() else { continue };
        let m = &mut materials[k];
        if textured[k] {
            read_bytes += split_metal(m, split, images, textures, source_files)?;
            continue;
        }
        // no texture coordinates to read the textures with (report_walk says so): the factors
        // decide, everywhere
        let rules = metal_rough::MetalRough {
            metallic: split.metallic,
            roughness: split.roughness,
            texture: None,
        };
        let uniform = metal_rough::split(split.base_factor, None, &rules, &m.name);
        (m.diffuse, m.mirror, m.roughness) = (uniform.diffuse, uniform.mirror, uniform.roughness);
    }
    Ok(read_bytes)
}

/// Per material (of `count`), whether some triangle of it has texture coordinates.
fn textured_materials(count: usize, triangles: &[Triangle]) -> Vec<bool> {
    let mut textured = vec![false; count + 1];
    for t in triangles.iter().filter(|t| t.uv.is_some()) {
        textured[t.material as usize] = true;
    }
    textured
}

/// Split material `m` per texel (`metal_rough`): its metallic-roughness image read raw, its
/// base colour texture (already its `diffuse_texture`) and the split's two textures appended to
/// `textures`. Returns the bytes the read image held.
fn split_metal(
    m: &mut Material,
    plan: &material::SplitPlan,
    images: &ImageSource,
    textures: &mut Vec<Texture>,
    source_files: &mut Vec<PathBuf>,
) -> Result<u64> {
    let err = |message: String| VlfError::Mesh {
        path: images.path.to_path_buf(),
        message,
    };
    let mr = match plan.image {
        Some(image) => {
            let (bytes, name) = image_bytes(
                images.doc,
                image,
                images.buffers,
                images.dir,
                images.path,
                source_files,
            )
            .map_err(|m| err(format!("image {image}: {m}")))?;
            let t = texels::decode_normals(&bytes, name, texels::NormalSource::Normals).map_err(
                |e| {
                    err(format!(
                        "image {image}: not a readable PNG or JPEG image: {e}"
                    ))
                },
            )?;
            Some(t)
        }
        None => None,
    };
    let rules = metal_rough::MetalRough {
        metallic: plan.metallic,
        roughness: plan.roughness,
        texture: mr.as_ref(),
    };
    let base = m.diffuse_texture.map(|i| &textures[i as usize]);
    let name = base.map_or_else(|| m.name.clone(), |b| b.path.display().to_string());
    let split = metal_rough::split(plan.base_factor, base, &rules, &name);
    let mut add = |t: Option<Texture>| {
        t.map(|t| {
            textures.push(t);
            textures.len() as u32 - 1
        })
    };
    m.diffuse_texture = add(split.diffuse_texture);
    m.specular_texture = add(split.specular_texture);
    m.diffuse = split.diffuse;
    m.mirror = split.mirror;
    m.roughness = split.roughness;
    Ok(mr.map_or(0, |t| t.texels.len() as u64 * 12))
}

/// Drop the textures no material names (a split material's base colour texture, once split),
/// renumbering the materials' references.
fn drop_unused_textures(textures: &mut Vec<Texture>, materials: &mut [Material]) {
    let mut used = vec![false; textures.len()];
    for m in materials.iter_mut() {
        for t in texture_refs(m) {
            used[*t as usize] = true;
        }
    }
    let mut new_index = vec![u32::MAX; textures.len()];
    let mut kept = 0u32;
    for (i, &u) in used.iter().enumerate() {
        if u {
            new_index[i] = kept;
            kept += 1;
        }
    }
    let mut i = 0;
    textures.retain(|_| {
        i += 1;
        used[i - 1]
    });
    for m in materials.iter_mut() {
        for t in texture_refs(m) {
            *t = new_index[*t as usize];
        }
    }
}

/// Every texture reference of a material.
fn texture_refs(m: &mut Material) -> impl Iterator<Item = &mut u32> {
    [
        m.diffuse_texture.as_mut(),
        m.emission_texture.as_mut(),
        m.cutout.as_mut().map(|c| &mut c.texture),
        m.normal_map.as_mut().map(|n| &mut n.texture),
        m.specular_texture.as_mut(),
    ]
    .into_iter()
    .flatten()
}

/// An image's encoded bytes and the name it goes by (its file, or the model + index).
fn image_bytes(
    doc: &::gltf::Document,
    index: usize,
    buffers: &[Vec<u8>],
    dir: &Path,
    model: &Path,
    source_files: &mut Vec<PathBuf>,
) -> std::result::Result<(Vec<u8>, PathBuf), String> {
    let image = doc.images().nth(index).ok_or("no such image")?;
    match image.source() {
        ::gltf::image::Source::View { view, .. } => {
            let data = &buffers[view.buffer().index()];
            let (start, len) = (view.offset() as u64, view.length() as u64);
            let bytes = data
                .get(start as usize..(start + len).min(usize::MAX as u64) as usize)
                .filter(|_| start + len <= data.len() as u64)
                .ok_or_else(|| {
                    format!(
                        "buffer view {} lies outside its buffer ({} bytes)",
                        view.index(),
                        data.len()
                    )
                })?;
            Ok((
                bytes.to_vec(),
                PathBuf::from(format!("{}#image{index}", model.display())),
            ))
        }
        ::gltf::image::Source::Uri { uri, .. } => {
            let name = if uri.starts_with("data:") {
                PathBuf::from(format!("{}#image{index}", model.display()))
            } else {
                dir.join(percent_decode(uri))
            };
            Ok((read_uri(uri, dir, source_files)?, name))
        }
    }
}

/// The nodes of the default scene (or of every scene, or every root node), depth first.
fn walk_nodes(
    doc: &::gltf::Document,
    buffers: &[Vec<u8>],
    plans: &[material::Plan],
    walk: &mut Walk,
) -> std::result::Result<(), String> {
    let roots: Vec<::gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            let children: HashSet<usize> = doc
                .nodes()
                .flat_map(|n| n.children().map(|c| c.index()))
                .collect();
            doc.nodes()
                .filter(|n| !children.contains(&n.index()))
                .collect()
        }
    };
    let mut stack: Vec<(::gltf::Node, DMat4, usize)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, DMat4::IDENTITY, 0))
        .collect();
    let mut instances = 0usize;
    let mut names = HashSet::new();
    while let Some((node, parent, depth)) = stack.pop() {
        instances += 1;
        if depth > MAX_DEPTH || instances > MAX_INSTANCES {
            return Err(format!(
                "the node hierarchy is deeper than {MAX_DEPTH} levels or has more than {MAX_INSTANCES} instances (a cycle?) at node {}",
                node.index()
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                read_primitive(&prim, &world, buffers, plans, walk).map_err(|m| {
                    format!("mesh {} primitive {}: {m}", mesh.index(), prim.index())
                })?;
            }
        }
        if let Some(camera) = node.camera() {
            camera_of(&camera, &node, &world, &mut names, walk);
        }
        if let Some(light) = node.light() {
            walk.lights.push(match light.name() {
                Some(n) => format!("{n:?}"),
                None => format!("#{}", light.index()),
            });
        }
        // reversed, so that children are walked in the file's order
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
    }
    Ok(())
}

fn camera_of(
    camera: &::gltf::Camera,
    node: &::gltf::Node,
    world: &DMat4,
    names: &mut HashSet<String>,
    walk: &mut Walk,
) {
    let ::gltf::camera::Projection::Perspective(p) = camera.projection() else {
        walk.orthographic += 1;
        return;
    };
    let eye = world.transform_point3(DVec3::ZERO);
    let forward = world.transform_vector3(-DVec3::Z).normalize_or_zero();
    let up = world.transform_vector3(DVec3::Y).normalize_or_zero();
    let fov = (p.yfov() as f64).to_degrees();
    let aspect = p.aspect_ratio().map_or(4.0 / 3.0, |a| a as f64);
    let ok = eye.is_finite()
        && forward != DVec3::ZERO
        && forward.cross(up).length_squared() > 1e-12
        && fov > 0.0
        && fov < 180.0
        && aspect.is_finite()
        && aspect > 0.0;
    if !ok {
        return;
    }
    let base = camera
        .name()
        .or(node.name())
        .map(str::to_string)
        .unwrap_or_else(|| format!("camera{}", camera.index()));
    let mut name = base.clone();
    let mut k = 2;
    while !names.insert(name.clone()) {
        name = format!("{base}#{k}");
        k += 1;
    }
    let height = 768u32;
    let width = ((height as f64 * aspect).round() as u32).clamp(1, 16384);
    let f = |v: DVec3| v.as_vec3().to_array();
    walk.cameras.push(Camera {
        name,
        eye: f(eye),
        target: f(eye + forward),
        up: f(up),
        fov_y_deg: fov as f32,
        size: [width, height],
    });
}

/// One primitive's triangles, in world coordinates, with the material's texture coordinates.
fn read_primitive(
    prim: &::gltf::Primitive,
    world: &DMat4,
    buffers: &[Vec<u8>],
    plans: &[material::Plan],
    walk: &mut Walk,
) -> std::result::Result<(), String> {
    let mode = prim.mode();
    if matches!(
        mode,
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
    ) {
        walk.skipped_points_lines += 1;
        return Ok(());
    }
    let positions = prim
        .get(&::gltf::Semantic::Positions)
        .ok_or("has no POSITION attribute")?;
    let points = read_accessor(&positions, buffers, 3).map_err(|m| format!("POSITION {m}"))?;
    let count = points.len() / 3;
    let indices: Vec<u32> = match prim.indices() {
        Some(a) => read_indices(&a, buffers, count).map_err(|m| format!("indices {m}"))?,
        None => (0..count as u32).collect(),
    };
    let corners = assemble(mode, &indices);
    let material = prim.material().index().map_or(plans.len(), |i| i) as u32;
    let plan = plans.get(material as usize);
    let uv: Option<Vec<f32>> = match plan.and_then(|p| p.uv_set()) {
        Some(set) => match prim.get(&::gltf::Semantic::TexCoords(set)) {
            Some(a) => {
                Some(read_accessor(&a, buffers, 2).map_err(|m| format!("TEXCOORD_{set} {m}"))?)
            }
            None => {
                *walk
                    .missing_uv
                    .entry(plan.map_or(String::new(), |p| p.name.clone()))
                    .or_default() += 1;
                None
            }
        },
        None => None,
    };
    if let Some(uv) = &uv {
        if uv.len() / 2 < count {
            return Err(format!(
                "TEXCOORD has {} elements, POSITION {count}",
                uv.len() / 2
            ));
        }
    }
    let identity = *world == DMat4::IDENTITY;
    let flip = world.determinant() < 0.0;
    let place = |i: u32| -> [f32; 3] {
        let p = &points[3 * i as usize..3 * i as usize + 3];
        if identity {
            [p[0], p[1], p[2]]
        } else {
            let q = *world * DVec4::new(p[0] as f64, p[1] as f64, p[2] as f64, 1.0);
            [q.x as f32, q.y as f32, q.z as f32]
        }
    };
    let transform = plan.map(|p| p.uv_transform);
    if plan.is_some_and(|p| p.open) {
        // a cut-out open everywhere (material.rs): nothing of it is there
        return Ok(());
    }
    for tri in corners {
        let tri = if flip { [tri[0], tri[2], tri[1]] } else { tri };
        walk.triangles.push(RawTriangle {
            corners: tri.map(place),
            material,
            uv: uv.as_ref().map(|uv| {
                tri.map(|i| {
                    let (u, v) = (uv[2 * i as usize], uv[2 * i as usize + 1]);
                    let [u, v] = transform.map_or([u, v], |t| t.apply([u, v]));
                    // glTF's v runs down the image, the scene's (OBJ's) up
                    [u, 1.0 - v]
                })
            }),
        });
    }
    Ok(())
}

/// Triangles (as corner indices) from a list, strip or fan.
pub(crate) fn assemble(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i + 1], idx[i], idx[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[0], idx[i], idx[i + 1]])
            .collect(),
        _ => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

/// Index accessor values, each checked against the vertex count.
pub(crate) fn read_indices(
    a: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    vertices: usize,
) -> std::result::Result<Vec<u32>, String> {
    if a.dimensions() != Dimensions::Scalar
        || !matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "(accessor {}) must be SCALAR unsigned integers",
            a.index()
        ));
    }
    // exact integers where the indices are plain: through read_accessor's f32 an index above
    // 2^24 would round to a neighbouring vertex
    let values: Vec<u64> = match (a.view(), a.sparse()) {
        (Some(view), None) => {
            let at = format!("(accessor {})", a.index());
            let bytes = view_bytes(&view, buffers).map_err(|m| format!("{at}: {m}"))?;
            let comp = a.data_type().size();
            let stride = view.stride().unwrap_or(comp);
            check_span(bytes.len(), a.offset(), stride, a.count(), comp)
                .map_err(|m| format!("{at}: {m}"))?;
            (0..a.count())
                .map(|i| {
                    let b = &bytes[a.offset() + i * stride..][..comp];
                    match a.data_type() {
                        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64,
                        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u64,
                        _ => b[0] as u64,
                    }
                })
                .collect()
        }
        _ => (read_accessor(a, buffers, 1)?.iter().map(|&v| v as u64)).collect(),
    };
    values
        .iter()
        .map(|&v| {
            if (v as usize) < vertices {
                Ok(v as u32)
            } else {
                Err(format!(
                    "(accessor {}): index {v} is out of range ({vertices} vertices)",
                    a.index()
                ))
            }
        })
        .collect()
}

/// Whether `count` elements of `element` bytes, `stride` apart from byte `offset`, lie within a
/// buffer view of `len` bytes.
fn check_span(
    len: usize,
    offset: usize,
    stride: usize,
    count: usize,
    element: usize,
) -> std::result::Result<(), String> {
    if count == 0 {
        return Ok(());
    }
    let end = (offset as u64)
        .checked_add((stride as u64).saturating_mul(count as u64 - 1))
        .and_then(|e| e.checked_add(element as u64));
    match end {
        Some(e) if e <= len as u64 => Ok(()),
        _ => Err(format!(
            "{count} elements from byte {offset}, {stride} apart, overrun its buffer view ({len} bytes)"
        )),
    }
}

/// An accessor's values as f32, `dims` per element, with every byte range checked. Integer
/// components are normalised when the accessor says so. Sparse substitutions are applied.
pub(crate) fn read_accessor(
    a: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    dims: usize,
) -> std::result::Result<Vec<f32>, String> {
    let at = format!("(accessor {})", a.index());
    if a.dimensions().multiplicity() != dims {
        return Err(format!(
            "{at} has {:?} elements, {dims} components expected",
            a.dimensions()
        ));
    }
    let comp = a.data_type().size();
    let count = a.count();
    // the data must be there before anything is allocated for it
    let room = match a.view() {
        Some(view) => view_bytes(&view, buffers)
            .map_err(|m| format!("{at}: {m}"))?
            .len(),
        None => MAX_ZERO_ELEMENTS * comp * dims,
    };
    if count.saturating_mul(comp * dims) > room + comp * dims {
        return Err(format!(
            "{at}: {count} elements of {} bytes do not fit in the {room} bytes of its buffer view",
            comp * dims
        ));
    }
    let mut out = vec![0.0f32; count * dims];
    if let Some(view) = a.view() {
        let stride = view.stride().unwrap_or(comp * dims);
        let bytes = view_bytes(&view, buffers).map_err(|m| format!("{at}: {m}"))?;
        read_elements(bytes, a.offset(), stride, count, a, dims, &mut out)
            .map_err(|m| format!("{at}: {m}"))?;
    }
    if let Some(sparse) = a.sparse() {
        let n = sparse.count();
        let iv = sparse.indices();
        let itype = match iv.index_type() {
            ::gltf::accessor::sparse::IndexType::U8 => DataType::U8,
            ::gltf::accessor::sparse::IndexType::U16 => DataType::U16,
            ::gltf::accessor::sparse::IndexType::U32 => DataType::U32,
        };
        let ibytes = view_bytes(&iv.view(), buffers).map_err(|m| format!("{at} sparse: {m}"))?;
        let mut idx = vec![0.0f32; n];
        read_raw(
            ibytes,
            iv.offset(),
            itype.size(),
            n,
            itype,
            false,
            1,
            &mut idx,
        )
        .map_err(|m| format!("{at} sparse indices: {m}"))?;
        let vv = sparse.values();
        let vbytes = view_bytes(&vv.view(), buffers).map_err(|m| format!("{at} sparse: {m}"))?;
        let mut vals = vec![0.0f32; n * dims];
        read_elements(vbytes, vv.offset(), comp * dims, n, a, dims, &mut vals)
            .map_err(|m| format!("{at} sparse values: {m}"))?;
        for (k, &i) in idx.iter().enumerate() {
            let i = i as usize;
            if i >= count {
                return Err(format!("{at}: sparse index {i} is out of range ({count})"));
            }
            out[i * dims..(i + 1) * dims].copy_from_slice(&vals[k * dims..(k + 1) * dims]);
        }
    }
    if out.iter().any(|v| !v.is_finite()) {
        return Err(format!("{at} holds a value that is not finite"));
    }
    Ok(out)
}

fn view_bytes<'b>(
    view: &::gltf::buffer::View,
    buffers: &'b [Vec<u8>],
) -> std::result::Result<&'b [u8], String> {
    let data = &buffers[view.buffer().index()];
    let (start, len) = (view.offset() as u64, view.length() as u64);
    if start + len > data.len() as u64 {
        return Err(format!(
            "buffer view {} (bytes {start}..{}) lies outside buffer {} ({} bytes)",
            view.index(),
            start + len,
            view.buffer().index(),
            data.len()
        ));
    }
    Ok(&data[start as usize..(start + len) as usize])
}

fn read_elements(
    bytes: &[u8],
    offset: usize,
    stride: usize,
    count: usize,
    a: &::gltf::Accessor,
    dims: usize,
    out: &mut [f32],
) -> std::result::Result<(), String> {
    let comp = a.data_type().size();
    if stride < comp * dims {
        return Err(format!(
            "byteStride {stride} is smaller than an element ({} bytes)",
            comp * dims
        ));
    }
    read_raw(
        bytes,
        offset,
        stride,
        count,
        a.data_type(),
        a.normalized(),
        dims,
        out,
    )
}

/// `count` elements of `dims` components of type `ty` from `bytes`, `stride` apart.
#[allow(clippy::too_many_arguments)]
fn read_raw(
    bytes: &[u8],
    offset: usize,
    stride: usize,
    count: usize,
    ty: DataType,
    normalized: bool,
    dims: usize,
    out: &mut [f32],
) -> std::result::Result<(), String> {
    if count == 0 {
        return Ok(());
    }
    let comp = ty.size();
    check_span(bytes.len(), offset, stride, count, comp * dims)?;
    for i in 0..count {
        for c in 0..dims {
            let o = offset + i * stride + c * comp;
            let b = &bytes[o..o + comp];
            out[i * dims + c] = match ty {
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
                DataType::U16 => {
                    let v = u16::from_le_bytes([b[0], b[1]]) as f32;
                    if normalized {
                        v / 65535.0
                    } else {
                        v
                    }
                }
                DataType::I16 => {
                    let v = i16::from_le_bytes([b[0], b[1]]) as f32;
                    if normalized {
                        (v / 32767.0).max(-1.0)
                    } else {
                        v
                    }
                }
                DataType::U8 => {
                    let v = b[0] as f32;
                    if normalized {
                        v / 255.0
                    } else {
                        v
                    }
                }
                DataType::I8 => {
                    let v = b[0] as i8 as f32;
                    if normalized {
                        (v / 127.0).max(-1.0)
                    } else {
                        v
                    }
                }
            };
        }
    }
    Ok(())
}

/// Welded positions and triangles, as the OBJ importer makes them: equal positions share an
/// id (numbered in order of first use), zero-area and duplicated triangles are dropped.
/// Positions, triangles and the repair warnings.
type Welded = (Vec<[f32; 3]>, Vec<Triangle>, Vec<String>);

fn weld(raw: &[RawTriangle], path: &Path) -> Result<Welded> {
    let points: Vec<[f32; 3]> = raw.iter().flat_map(|t| t.corners).collect();
    let extent = (points.iter().flatten()).fold(0.0f64, |m, &x| m.max(x.abs() as f64));
    let welded = weld::weld(&points);
    let corners: Vec<[u32; 3]> = (welded.ids.chunks(3)).map(|c| [c[0], c[1], c[2]]).collect();
    let kept = weld::keep_triangles(&corners, &welded.positions, extent);
    let triangles: Vec<Triangle> = (raw.iter().zip(corners).zip(&kept.keep))
        .filter(|(_, &keep)| keep)
        .map(|((t, vertices), _)| Triangle {
            vertices,
            material: t.material,
            uv: t.uv,
        })
        .collect();
    if triangles.is_empty() {
        return Err(VlfError::Mesh {
            path: path.to_path_buf(),
            message: "the model has no triangles with area: nothing to light".into(),
        });
    }
    Ok((welded.positions, triangles, kept.warnings(path)))
}

/// Per image: the texture-coordinate and surface area it covers (in the normalised scene).
fn texture_uses(
    plans: &[material::Plan],
    positions: &[[f32; 3]],
    triangles: &[Triangle],
) -> Vec<(usize, TextureUse)> {
    let scale = crate::scene::normalise::normalise(positions).scale;
    let mut per_material = vec![TextureUse::default(); plans.len() + 1];
    for t in triangles {
        let Some(uv) = t.uv else { continue };
        let [a, b, c] = t
            .vertices
            .map(|i| DVec3::from(positions[i as usize].map(|x| x as f64)));
        let u = &mut per_material[t.material as usize];
        u.surface_area += (b - a).cross(c - a).length() * 0.5 * scale * scale;
        let (e1, e2) = (
            [uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]],
            [uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]],
        );
        u.uv_area += ((e1[0] * e2[1] - e1[1] * e2[0]) as f64).abs() * 0.5;
    }
    let mut by_image: BTreeMap<usize, TextureUse> = BTreeMap::new();
    // images of materials no textured triangle uses are not read
    for (m, plan) in plans.iter().enumerate() {
        if per_material[m].surface_area <= 0.0 {
            continue;
        }
        for image in plan.images() {
            let u = by_image.entry(image).or_default();
            u.uv_area += per_material[m].uv_area;
            u.surface_area += per_material[m].surface_area;
        }
    }
    by_image.into_iter().collect()
}
