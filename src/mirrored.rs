//! Every Rust struct that mirrors a WGSL struct, listed with its fields' offsets so that
//! tests/shaders.rs can check them member by member against naga's layout of the WGSL. It sits
//! above the modules that own the structs (gpu, display, reference) and nothing depends on it.

use crate::bvh::{GpuBvhNode, GpuBvhPair, GpuTriangle};
use crate::display::post::GpuWarp;
use crate::gpu::types::*;
use crate::reference::GpuTraceParams;

/// A Rust struct that mirrors a WGSL struct: its size and each field's offset, for the test
/// that checks them member by member against naga's layout of the WGSL (tests/shaders.rs).
pub struct MirroredStruct {
    pub rust: &'static str,
    pub wgsl: &'static str,
    /// a stage whose expanded source declares the WGSL struct
    pub stage: &'static str,
    pub size: usize,
    /// (name, byte offset) of every Rust field, in declaration order
    pub fields: Vec<(&'static str, usize)>,
}

/// Lists a mirrored struct's fields; the destructuring pattern makes the compiler refuse a
/// list that misses one, so a field added in Rust cannot escape the offset check.
macro_rules! mirrored {
    ($rust:ident => $wgsl:literal in $stage:literal { $($field:ident),* $(,)? }) => {{
        #[allow(unused)]
        fn complete(v: $rust) {
            let $rust { $($field: _),* } = v;
        }
        MirroredStruct {
            rust: stringify!($rust),
            wgsl: $wgsl,
            stage: $stage,
            size: std::mem::size_of::<$rust>(),
            fields: vec![$((stringify!($field), std::mem::offset_of!($rust, $field))),*],
        }
    }};
}

/// Every Rust struct that mirrors a WGSL one (uniforms and storage elements of every stage).
pub fn mirrored_structs() -> Vec<MirroredStruct> {
    vec![
        mirrored!(GpuAccumulate => "AccumulateParams" in "accumulate.wgsl" {
            count, scale, weight_offset, _pad1
        }),
        mirrored!(GpuDirection => "Direction" in "render.wgsl" {
            w, solid_angle, u, _pad0, v, _pad1
        }),
        mirrored!(GpuFace => "Face" in "render.wgsl" {
            normal, plane_offset, origin, texel_density, axis_a, material, axis_b, flags,
            atlas_x, atlas_y, atlas_w, atlas_h, twin, tile_slot, _pad0, _pad1
        }),
        mirrored!(GpuMaterial => "Material" in "render.wgsl" {
            diffuse, flags, mirror, roughness, emission, lobe_albedo
        }),
        mirrored!(GpuGrid => "GridParams" in "render.wgsl" {
            resolution, direction_count, triangle_count, triangle_base, texel_count,
            atlas_width, iteration, flags, sky, cell_size, depth_epsilon, geodesic_frequency,
            tile_size, tile_face_count, direction_weight, tile_cell_count, first_direction,
            tile_page_cells, texel_page_cells, specular_words, _pad2, _pad3
        }),
        mirrored!(GpuView => "View" in "render.wgsl" {
            view_proj, inv_view_proj, eye, samples_per_pixel, mirror_bounces, paced_samples,
            paced_fraction, fixed_work, exhaustive_triangles, moving_root, moving_first, moving_flags,
            msaa_samples, lobe_samples, glossy_light_samples, edge_samples, edge_contrast,
            _pad3, _pad4, _pad5
        }),
        mirrored!(GpuField => "Field" in "render.wgsl" {
            sky, cell_size, atlas_width, geodesic_frequency, tile_size, tile_face_count,
            grid_resolution, tile_page_cells, tile_cell_count, texel_page_cells, normal_records,
            normal_texels, specular_records
        }),
        mirrored!(GpuPresent => "PresentParams" in "present.wgsl" {
            viewport_origin, viewport_size, exposure, encode_srgb, show_overlay, _pad0
        }),
        mirrored!(GpuPageRange => "PageRange" in "specular.wgsl" { base, cells, _pad0, _pad1 }),
        mirrored!(GpuRayTriangle => "RayTriangle" in "render.wgsl" { u, v, w }),
        mirrored!(GpuEmitter => "Emitter" in "direct.wgsl" {
            v0, face, e1, textured, e2, chance, radiance
        }),
        mirrored!(GpuMirrorTriangle => "MirrorTriangle" in "direct.wgsl" {
            v0, face, e1, _pad0, e2, _pad1
        }),
        mirrored!(GpuDirectParams => "DirectParams" in "direct.wgsl" {
            emitter_count, emitter_samples, sky_samples, mirror_count
        }),
        mirrored!(GpuWarp => "WarpParams" in "warp.wgsl" {
            inv_view_proj, eye, wand_origin, wand_direction, wand_colour, source_size,
            output_size, grid_size, use_mask, _pad0
        }),
        mirrored!(GpuTraceParams => "TraceParams" in "reference.wgsl" {
            inv_view_proj, eye, width, sky, height, samples_per_pass, pass_index, seed,
            light_count, light_weight_total, _pad
        }),
        mirrored!(GpuTriangle => "Triangle" in "reference.wgsl" {
            v0, face, e1, _pad0, e2, _pad1, uv01, uv2
        }),
        mirrored!(GpuBvhNode => "BvhNode" in "reference.wgsl" { lo, index, hi, count }),
        mirrored!(GpuMovingParams => "MovingParams" in "moving.wgsl" {
            vertex_count, triangle_count, first_triangle, first_pair
        }),
        mirrored!(GpuMovingVertex => "MovingVertex" in "moving.wgsl" {
            position, normal, joints, weights
        }),
        mirrored!(GpuMovingTriangle => "MovingTriangle" in "render.wgsl" { n0, n1, n2 }),
        mirrored!(GpuMovingMaterial => "MovingMaterial" in "render.wgsl" { albedo, emission }),
        mirrored!(GpuProbeGrid => "ProbeGrid" in "probes.wgsl" {
            origin, rays, spacing, emitter_count, counts, shadow_samples, sky_shadow_samples,
            shadow_subdivision, vertex_light, direct_sampled
        }),
        mirrored!(GpuMovingLight => "MovingLight" in "moving_light.wgsl" {
            vertex_count, emitter_samples, sky_samples, occlusion_rays
        }),
        mirrored!(GpuShadowAtlas => "ShadowAtlas" in "shadow_atlas.wgsl" {
            face_count, texel_capacity, item_capacity, box_count, samples, sky_reach,
            indirect_rays, indirect_reach, _pad0, _pad1, _pad2
        }),
        mirrored!(GpuBvhPair => "BvhPair" in "render.wgsl" {
            lo_left, left, hi_left, right, lo_right, _pad0, hi_right, _pad1
        }),
    ]
}
