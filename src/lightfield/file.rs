//! The `.vlf` file: a versioned header, then checksummed sections (metadata as JSON, faces,
//! render mesh, radiance). Written atomically and durably (temporary file, fsync, rename), so
//! a crash or a full disk never leaves a half file or loses the previous one.

use super::{LightField, LightFieldMeta};
use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuFace, GpuMaterial, RenderVertex};
use std::io::Write;
use std::path::Path;

pub const MAGIC: &[u8; 8] = b"VLFIELD\0";
pub const FORMAT_VERSION: u32 = 5;
/// Files of this version (before normal maps) are still read: they have the first
/// `SECTIONS_V3` sections.
const SECTIONS_V3: usize = 12;
/// Files of this version (before specular textures) are still read: they have the first
/// `SECTIONS_V4` sections.
const SECTIONS_V4: usize = 14;
/// Files of this version (before the texture detail) are still read: they have the first
/// `SECTIONS_V2` sections.
const OLDEST_READ_VERSION: u32 = 2;
const SECTIONS_V2: usize = 7;
/// Metadata, faces, render mesh, texel radiance, then the mirror tiles (empty when diffuse-only):
/// rectangles, index, radiance; then the texture detail (empty without diffuse textures,
/// `textures::SurfaceDetail`): texture records, texels, face textures, render triangles' texture
/// coordinates, texel factors; then the normal maps (empty without them): per face its normal
/// texture, per texel its light direction; then per face its specular texture (empty without
/// them).
const SECTIONS: [&[u8; 4]; 15] = [
    b"META", b"FACE", b"RVTX", b"TOTL", b"TRCT", b"TIDX", b"TTOT", b"TXIN", b"TXTL", b"FTEX",
    b"RUVS", b"TALB", b"NMAP", b"NDIR", b"SPEC",
];

/// The container: magic, version, then (tag, length, CRC32, payload) per section.
pub fn encode_sections(magic: &[u8; 8], version: u32, sections: &[(&[u8; 4], &[u8])]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(sections.len() as u32).to_le_bytes());
    for (tag, payload) in sections {
        out.extend_from_slice(*tag);
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
        out.extend_from_slice(payload);
    }
    out
}

/// Write bytes atomically and durably: a temporary file beside the target, fsync, rename,
/// fsync the folder. `VLF_SAVE_DELAY_MS` (a test hook) waits between writing and renaming.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_else(|| "lightfield.vlf".into());
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        if let Some(ms) = std::env::var("VLF_SAVE_DELAY_MS")
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
        {
            std::thread::sleep(std::time::Duration::from_millis(ms));
        }
        std::fs::rename(&tmp, path)?;
        if let Ok(d) = std::fs::File::open(dir) {
            let _ = d.sync_all();
        }
        Ok(())
    };
    write().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        VlfError::write(path, e)
    })
}

/// Read a container written by `encode_sections`, checking magic, version, tags and CRCs.
pub fn decode_sections<'a>(
    bytes: &'a [u8],
    magic: &[u8; 8],
    version: u32,
    tags: &[&[u8; 4]],
    what: &str,
) -> std::result::Result<Vec<&'a [u8]>, String> {
    let mut r = Reader { bytes, at: 0 };
    let found = r.take(8, "the header")?;
    if found != magic {
        return Err(format!(
            "wrong magic {:?}: this is not a {what}",
            String::from_utf8_lossy(found)
        ));
    }
    let found_version = r.u32("the format version")?;
    if found_version != version {
        return Err(format!(
            "format version {found_version}, but this vlf ({}) reads version {version}; re-run `vlf propagate` to make a new file",
            env!("CARGO_PKG_VERSION")
        ));
    }
    let count = r.u32("the section count")?;
    if count as usize != tags.len() {
        return Err(format!("{count} sections, expected {}", tags.len()));
    }
    let mut payloads = Vec::new();
    for expected in tags {
        let tag = r.take(4, "a section tag")?;
        let name = String::from_utf8_lossy(*expected).to_string();
        if tag != *expected {
            return Err(format!(
                "expected section {name}, found {:?}",
                String::from_utf8_lossy(tag)
            ));
        }
        let len = r.u64(&format!("section {name}'s length"))?;
        let crc = r.u32(&format!("section {name}'s checksum"))?;
        let len = usize::try_from(len).map_err(|_| format!("section {name} claims {len} bytes"))?;
        let payload = r.take(len, &format!("section {name}"))?;
        let actual = crc32fast::hash(payload);
        if actual != crc {
            return Err(format!(
                "section {name} is corrupt (checksum {actual:08x}, recorded {crc:08x})"
            ));
        }
        payloads.push(payload);
    }
    if r.at != bytes.len() {
        return Err(format!(
            "{} unexpected bytes after the last section",
            bytes.len() - r.at
        ));
    }
    Ok(payloads)
}

/// A face as the `FACE` section stores it (format 2): the face record with its material's parts
/// in it (the GPU keeps them apart: `GpuFace` indexes the material table). The file's layout
/// stays the same whatever the GPU's is.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable, PartialEq)]
pub struct FaceRecord {
    pub normal: [f32; 3],
    pub plane_offset: f32,
    pub origin: [f32; 3],
    pub texel_density: f32,
    pub axis_a: [f32; 3],
    pub _pad0: f32,
    pub axis_b: [f32; 3],
    pub flags: u32,
    pub albedo: [f32; 3],
    pub atlas_x: u32,
    /// emitted radiance on an emitting side (`FACE_EMITTER`), else 0
    pub emission: [f32; 3],
    pub atlas_y: u32,
    pub atlas_w: u32,
    pub atlas_h: u32,
    pub twin: u32,
    pub tile_slot: u32,
    pub mirror: [f32; 3],
    /// the specular part's GGX roughness (0: an ideal mirror; files before it hold 0 here)
    pub roughness: f32,
}

/// The file's face records of `faces` and the material table they index.
pub fn face_records(faces: &[GpuFace], materials: &[GpuMaterial]) -> Vec<FaceRecord> {
    (faces.iter())
        .map(|f| {
            let m = crate::material::material_of(materials, f);
            FaceRecord {
                normal: f.normal,
                plane_offset: f.plane_offset,
                origin: f.origin,
                texel_density: f.texel_density,
                axis_a: f.axis_a,
                _pad0: 0.0,
                axis_b: f.axis_b,
                flags: f.flags,
                albedo: m.diffuse,
                atlas_x: f.atlas_x,
                emission: crate::material::emitted(materials, f).to_array(),
                atlas_y: f.atlas_y,
                atlas_w: f.atlas_w,
                atlas_h: f.atlas_h,
                twin: f.twin,
                tile_slot: f.tile_slot,
                mirror: m.mirror,
                roughness: m.roughness,
            }
        })
        .collect()
}

/// Face records back into faces and the distinct materials they use (in order of first use;
/// a face that does not emit keeps emission 0 in its material).
pub fn split_face_records(records: &[FaceRecord]) -> (Vec<GpuFace>, Vec<GpuMaterial>) {
    let mut materials: Vec<GpuMaterial> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let faces = (records.iter())
        .map(|r| {
            // keyed by the record's material fields, so a glossy lobe's mean albedo (a
            // numerical integral in with_roughness) is computed once per material, not per face
            let fields = [r.albedo, r.mirror, r.emission, [r.roughness, 0.0, 0.0]];
            let key: Vec<u8> = bytemuck::cast_slice(&fields).to_vec();
            let material = *index.entry(key).or_insert_with(|| {
                let m = GpuMaterial::new(r.albedo, r.mirror, r.emission);
                materials.push(m.with_roughness(r.roughness));
                materials.len() as u32 - 1
            });
            GpuFace {
                normal: r.normal,
                plane_offset: r.plane_offset,
                origin: r.origin,
                texel_density: r.texel_density,
                axis_a: r.axis_a,
                material,
                axis_b: r.axis_b,
                flags: r.flags,
                atlas_x: r.atlas_x,
                atlas_y: r.atlas_y,
                atlas_w: r.atlas_w,
                atlas_h: r.atlas_h,
                twin: r.twin,
                tile_slot: r.tile_slot,
                _pad0: 0,
                _pad1: 0,
            }
        })
        .collect();
    if materials.is_empty() {
        materials = crate::material::material_table(&[]);
    }
    (faces, materials)
}

/// The faces and materials as a light field holds them: the distinct materials its faces use,
/// in order of first use, as a `.vlf` file gives them back.
pub fn canonical_materials(
    faces: &[GpuFace],
    materials: &[GpuMaterial],
) -> (Vec<GpuFace>, Vec<GpuMaterial>) {
    split_face_records(&face_records(faces, materials))
}

pub fn encode(lf: &LightField) -> Vec<u8> {
    let meta = serde_json::to_vec_pretty(&lf.meta).expect("metadata serialises");
    let (rects, index, tiles): (&[u8], &[u8], &[u8]) = match &lf.tiles {
        Some(t) => (
            bytemuck::cast_slice(&t.rects),
            bytemuck::cast_slice(&t.index),
            bytemuck::cast_slice(&t.total),
        ),
        None => (&[], &[], &[]),
    };
    let faces = face_records(&lf.faces, &lf.materials);
    let none = super::textures::SurfaceDetail::default();
    let detail = lf.detail.as_ref().unwrap_or(&none);
    let payloads: [&[u8]; 15] = [
        &meta,
        bytemuck::cast_slice(&faces),
        bytemuck::cast_slice(&lf.render_vertices),
        bytemuck::cast_slice(&lf.total),
        rects,
        index,
        tiles,
        bytemuck::cast_slice(&detail.textures.info),
        bytemuck::cast_slice(&detail.textures.texels),
        bytemuck::cast_slice(&detail.textures.face_textures),
        bytemuck::cast_slice(&detail.triangle_uv),
        bytemuck::cast_slice(&detail.texel_albedo),
        bytemuck::cast_slice(&detail.face_normal_maps),
        bytemuck::cast_slice(&detail.texel_directions),
        bytemuck::cast_slice(&detail.textures.face_specular),
    ];
    let sections: Vec<(&[u8; 4], &[u8])> = SECTIONS.iter().copied().zip(payloads).collect();
    encode_sections(MAGIC, FORMAT_VERSION, &sections)
}

/// Save atomically and durably (see `write_atomic`): never a half file, never the old one lost.
pub fn save(lf: &LightField, path: &Path) -> Result<()> {
    write_atomic(path, &encode(lf))
}

/// Whether `path` names a light field file (`.vlf`, any case) rather than a scene to propagate.
pub fn is_vlf_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vlf"))
}

pub fn load(path: &Path) -> Result<LightField> {
    let bytes = std::fs::read(path).map_err(|e| VlfError::io(path, e))?;
    decode(&bytes).map_err(|message| VlfError::LightFieldFile {
        path: path.to_path_buf(),
        message,
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> std::result::Result<&'a [u8], String> {
        if self.bytes.len() - self.at < n {
            return Err(format!(
                "truncated: {what} needs {n} bytes at offset {}, the file ends at {}",
                self.at,
                self.bytes.len()
            ));
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn u32(&mut self, what: &str) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    fn u64(&mut self, what: &str) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
}

fn pod_vec<T: bytemuck::Pod>(payload: &[u8], what: &str) -> std::result::Result<Vec<T>, String> {
    let size = std::mem::size_of::<T>();
    if !payload.len().is_multiple_of(size) {
        return Err(format!(
            "section {what} holds {} bytes, not a whole number of {size}-byte records",
            payload.len()
        ));
    }
    Ok(payload
        .chunks_exact(size)
        .map(bytemuck::pod_read_unaligned)
        .collect())
}

pub fn decode(bytes: &[u8]) -> std::result::Result<LightField, String> {
    // a version 2 file (no texture detail) is read as it was written
    let found = bytes
        .get(8..12)
        .map(|v| u32::from_le_bytes([v[0], v[1], v[2], v[3]]));
    let old = found == Some(OLDEST_READ_VERSION);
    let (version, tags) = match found {
        Some(OLDEST_READ_VERSION) => (OLDEST_READ_VERSION, &SECTIONS[..SECTIONS_V2]),
        Some(3) => (3, &SECTIONS[..SECTIONS_V3]),
        Some(4) => (4, &SECTIONS[..SECTIONS_V4]),
        _ => (FORMAT_VERSION, &SECTIONS[..]),
    };
    let payloads = decode_sections(bytes, MAGIC, version, tags, "vlf light field file")?;
    let meta: LightFieldMeta = serde_json::from_slice(payloads[0])
        .map_err(|e| format!("section META is not valid metadata: {e}"))?;
    let records: Vec<FaceRecord> = pod_vec(payloads[1], "FACE")?;
    let (faces, materials) = split_face_records(&records);
    let render_vertices: Vec<RenderVertex> = pod_vec(payloads[2], "RVTX")?;
    let total: Vec<[f32; 4]> = pod_vec(payloads[3], "TOTL")?;
    let rects: Vec<[u32; 4]> = pod_vec(payloads[4], "TRCT")?;
    let index: Vec<u32> = pod_vec(payloads[5], "TIDX")?;
    let tile_total: Vec<[f32; 4]> = pod_vec(payloads[6], "TTOT")?;
    let tiles = if rects.is_empty() && index.is_empty() && tile_total.is_empty() {
        None
    } else {
        let directions = meta.direction_count.max(1) as usize;
        if !rects.len().is_multiple_of(directions) {
            return Err(format!(
                "{} tile rectangles do not divide among {directions} directions",
                rects.len()
            ));
        }
        Some(super::TileField {
            face_count: (rects.len() / directions) as u32,
            rects,
            index,
            total: tile_total,
        })
    };
    let detail = if old {
        None
    } else {
        decode_detail(&payloads[7..])?
    };
    let lf = LightField {
        meta,
        faces,
        materials,
        render_vertices,
        total,
        tiles,
        detail,
    };
    check_consistency(&lf)?;
    if let Some(d) = &lf.detail {
        d.check(lf.render_vertices.len() / 3, lf.total.len(), lf.faces.len())?;
    }
    Ok(lf)
}

/// The texture detail's sections (all empty: none).
fn decode_detail(
    payloads: &[&[u8]],
) -> std::result::Result<Option<super::textures::SurfaceDetail>, String> {
    if payloads.iter().all(|p| p.is_empty()) {
        return Ok(None);
    }
    // a version 3 file has no normal-map sections, a version 4 file no specular textures
    fn optional<T: bytemuck::Pod>(
        payloads: &[&[u8]],
        i: usize,
        what: &str,
    ) -> std::result::Result<Vec<T>, String> {
        match payloads.get(i) {
            Some(p) => pod_vec(p, what),
            None => Ok(Vec::new()),
        }
    }
    Ok(Some(super::textures::SurfaceDetail {
        textures: super::textures::SurfaceTextures {
            info: pod_vec(payloads[0], "TXIN")?,
            texels: pod_vec(payloads[1], "TXTL")?,
            face_textures: pod_vec(payloads[2], "FTEX")?,
            face_specular: optional(payloads, 7, "SPEC")?,
        },
        triangle_uv: pod_vec(payloads[3], "RUVS")?,
        texel_albedo: pod_vec(payloads[4], "TALB")?,
        face_normal_maps: optional(payloads, 5, "NMAP")?,
        texel_directions: optional(payloads, 6, "NDIR")?,
    }))
}

/// Everything a GPU lookup could index must be in range.
fn check_consistency(lf: &LightField) -> std::result::Result<(), String> {
    let (w, h) = (lf.meta.atlas_width as u64, lf.meta.atlas_height as u64);
    if lf.total.len() as u64 != w * h {
        return Err(format!(
            "radiance holds {} texels, the atlas is {w} x {h}",
            lf.total.len()
        ));
    }
    for (i, f) in lf.faces.iter().enumerate() {
        if f.atlas_w == 0
            || f.atlas_h == 0
            || (f.atlas_x + f.atlas_w) as u64 > w
            || (f.atlas_y + f.atlas_h) as u64 > h
        {
            return Err(format!("face {i}'s texel rectangle lies outside the atlas"));
        }
        if f.twin != crate::gpu::types::NO_FACE && f.twin as usize >= lf.faces.len() {
            return Err(format!("face {i}'s twin {} does not exist", f.twin));
        }
    }
    if !lf.render_vertices.len().is_multiple_of(3) {
        return Err("the render mesh is not made of whole triangles".into());
    }
    if let Some(v) = lf
        .render_vertices
        .iter()
        .find(|v| v.face as usize >= lf.faces.len())
    {
        return Err(format!(
            "a render vertex names face {}, but there are {}",
            v.face,
            lf.faces.len()
        ));
    }
    if lf.total.iter().flatten().any(|x| !x.is_finite()) {
        return Err("radiance holds NaN or infinite values".into());
    }
    let no_face = crate::gpu::types::NO_FACE;
    match &lf.tiles {
        None => {
            if lf.faces.iter().any(|f| f.tile_slot != no_face) {
                return Err("faces name mirror tiles, but the file holds none".into());
            }
        }
        Some(t) => {
            let m = lf.meta.params.tile_size as usize;
            if m == 0 || t.total.len() % (m * m) != 0 {
                return Err(format!(
                    "{} tile cells are not whole {m}x{m} tiles",
                    t.total.len()
                ));
            }
            let slots = (t.total.len() / (m * m)) as u32;
            if let Some(f) = lf
                .faces
                .iter()
                .position(|f| f.tile_slot != no_face && f.tile_slot >= t.face_count)
            {
                return Err(format!(
                    "face {f} names tile slot {}, but there are {}",
                    lf.faces[f].tile_slot, t.face_count
                ));
            }
            for (i, r) in t.rects.iter().enumerate() {
                let cells = (r[1] & 0xffff) as usize * (r[1] >> 16) as usize;
                if r[2] as usize + cells > t.index.len() {
                    return Err(format!("tile rectangle {i} reaches past the tile index"));
                }
            }
            if t.index.iter().any(|&s| s != no_face && s >= slots) {
                return Err("the tile index names tiles that are not stored".into());
            }
            if t.total.iter().flatten().any(|x| !x.is_finite()) {
                return Err("mirror radiance holds NaN or infinite values".into());
            }
        }
    }
    Ok(())
}

impl LightField {
    /// Refuse a light field made for another scene (or another version of it).
    pub fn check_scene(&self, scene: &crate::scene::Scene, file: &Path) -> Result<()> {
        if self.meta.scene_hash != scene.hash {
            return Err(VlfError::LightFieldFile {
                path: file.to_path_buf(),
                message: format!(
                    "it was made for scene {:?} (hash {}), but {} is {:?} with hash {}; re-run `vlf propagate {}`",
                    self.meta.scene_name,
                    &self.meta.scene_hash[..12.min(self.meta.scene_hash.len())],
                    scene.source.display(),
                    scene.name,
                    &scene.hash[..12],
                    scene.source.display()
                ),
            });
        }
        Ok(())
    }
}
