//! The prepared scene packed for the GPU: one `GpuFace` record per face (plane, chart, material
//! index, twin, tile slot) and the material table they index (`crate::material`), shared by
//! propagation, the renderer and the reference path tracer.

use super::PreparedScene;
use crate::gpu::types::{GpuFace, GpuMaterial, FACE_EMITTER, NO_FACE};

/// A face with a specular part (an ideal mirror or a glossy lobe) smaller than this, in the
/// normalised space's units² (four tiles' footprint at the default settings: 8 cells of a
/// 256-cell grid over [-1, 1], squared, times 4), gets no tiles: propagation sends its specular
/// light on as diffuse light of the part's carried reflectance (a glossy lobe's times its mean
/// albedo), and the views still trace its reflections (shaders/common/bsdf.wgsl,
/// carried_diffusely). A tile costs the same in every direction however little of it a face
/// covers: a chair's metal frame of thousands of small faces would take a tile in each of the
/// 2001 directions per face (a generated classroom's 36,288 metal faces: 4.6e9 tile cells),
/// where their reflections barely move the room's light. The bound does not follow the grid, so
/// a coarse preset keeps the same faces' tiles as the default (the Cornell box's mirror box).
pub const SPECULAR_TILES_MIN_AREA: f64 = 4.0 * (8.0 * 2.0 / 256.0) * (8.0 * 2.0 / 256.0);

/// Does face f have tiles: a specular part (ideal or glossy) on a face of at least
/// `SPECULAR_TILES_MIN_AREA`?
pub fn non_diffuse_faces(prepared: &PreparedScene) -> Vec<bool> {
    (0..prepared.faces.len())
        .map(|f| {
            prepared.material_of(f).is_delta() && prepared.faces[f].area >= SPECULAR_TILES_MIN_AREA
        })
        .collect()
}

/// How many faces with a specular part carry it diffusely (no tiles: `non_diffuse_faces`).
pub fn specular_faces_without_tiles(prepared: &PreparedScene) -> usize {
    let tiled = non_diffuse_faces(prepared);
    (0..prepared.faces.len())
        .filter(|&f| prepared.material_of(f).is_delta() && !tiled[f])
        .count()
}

/// GPU face records for a prepared scene; `tile_slot[f]` is face f's index
/// among the non-diffuse faces (NO_FACE for diffuse-only faces).
pub fn gpu_faces(prepared: &PreparedScene, tile_slot: &[u32]) -> Vec<GpuFace> {
    let density = prepared.texel_density as f32;
    prepared
        .faces
        .iter()
        .enumerate()
        .map(|(fi, f)| {
            // a two-sided surface's back does not emit
            let emissive = prepared.material_of(fi).emits() && !f.is_back;
            let v3 = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32];
            GpuFace {
                normal: v3(f.normal),
                plane_offset: f.plane_offset as f32,
                origin: v3(f.origin),
                texel_density: density,
                axis_a: v3(f.axis_a),
                material: f.material,
                axis_b: v3(f.axis_b),
                flags: if emissive { FACE_EMITTER } else { 0 },
                atlas_x: f.atlas.x,
                atlas_y: f.atlas.y,
                atlas_w: f.atlas.w,
                atlas_h: f.atlas.h,
                twin: f.twin.unwrap_or(NO_FACE),
                tile_slot: tile_slot[fi],
                _pad0: 0,
                _pad1: 0,
            }
        })
        .collect()
}

/// The material table of a prepared scene, which its face records index.
pub fn gpu_materials(prepared: &PreparedScene) -> Vec<GpuMaterial> {
    crate::material::material_table(&prepared.materials)
}
