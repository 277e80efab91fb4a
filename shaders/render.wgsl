// View rendering from the resident light field, driven by src/render/mod.rs, in two passes:
// 1. `vs_main` + `fs_visibility` rasterise the scene into a visibility buffer: per pixel, the
//    face it sees (the twin for the back of a two-sided surface, NO_FACE for the sky or an
//    absorbing back). Four bytes a pixel: cheap even where raster throughput is scarce.
// 2. `resolve_diffuse` / `resolve_mixed` (compute) turn it into radiance. Every pixel does the
//    same fixed work, whatever it sees: the eye ray meets the face's plane, one bilinear lookup
//    in the diffuse atlas, and in scenes with mirrors the three directions around the view
//    direction looked up in the face's tiles. Pixels that see the sky or a diffuse face do the
//    same lookups on a stand-in and multiply them by zero, so a view full of mirrors costs what
//    a view without one does: a constant per-eye frame time.
// Output is linear radiance; tonemapping happens at display (present.wgsl) or on the CPU.
#include "common/types.wgsl"
#include "common/atlas.wgsl"
#include "common/directions.wgsl"
#include "common/tiles.wgsl"

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> radiance: array<vec4<f32>>;
@group(0) @binding(3) var visibility: texture_2d<u32>;
@group(0) @binding(4) var image: texture_storage_2d<rgba32float, write>;
// view-dependent part, bound only for scenes with mirrors (resolve_mixed)
@group(1) @binding(0) var<storage, read> directions: array<Direction>;
@group(1) @binding(1) var<storage, read> geodesic_points: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> geodesic_index: array<u32>;
@group(1) @binding(3) var<storage, read> tile_rects: array<vec4<u32>>;
@group(1) @binding(4) var<storage, read> tile_index: array<u32>;
@group(1) @binding(5) var<storage, read> tile_radiance: array<vec4<f32>>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) face: u32,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) face: u32) -> VertexOut {
    var out: VertexOut;
    out.clip = view.view_proj * vec4<f32>(position, 1.0);
    out.face = face;
    return out;
}

@fragment
fn fs_visibility(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) u32 {
    if front {
        return in.face;
    }
    // the back of a one-sided face absorbs: it looks black (its twin is NO_FACE)
    return faces[in.face].twin;
}

fn diffuse_part(f: Face, p: vec3<f32>) -> vec3<f32> {
    let taps = atlas_taps(f, p, view.atlas_width);
    return radiance[taps.index.x].xyz * taps.weight.x + radiance[taps.index.y].xyz * taps.weight.y
        + radiance[taps.index.z].xyz * taps.weight.z + radiance[taps.index.w].xyz * taps.weight.w;
}

// The mirror part seen from the eye: three fixed directions around the view direction.
fn view_dependent_part(f: Face, slot: u32, p: vec3<f32>) -> vec3<f32> {
    let out_dir = normalize(view.eye - p);
    let taps = lookup_direction(out_dir, view.geodesic_frequency);
    var sum = vec3<f32>(0.0);
    var found = 0.0;
    for (var k = 0u; k < 3u; k++) {
        let d = directions[taps.index[k]];
        // tiles hold the radiance leaving the front; a tap behind the face drops out
        let front = select(0.0, 1.0, dot(d.w * taps.sign[k], f.normal) > 0.0);
        let v = tile_bilinear(taps.index[k], d, slot, p, view.cell_size, view.tile_size, view.tile_face_count);
        let w = taps.weight[k] * min(v.w, 1.0) * front;
        sum += v.xyz * w;
        found += w;
    }
    return select(vec3<f32>(0.0), sum / found, found > 0.0);
}

// The visibility buffer's clear value: the pixel sees no geometry, only the sky.
const SKY: u32 = 0xfffffffdu;

struct Pixel {
    // the face to look up (a stand-in, face 0, where the pixel sees none)
    face: u32,
    // 1 where the pixel sees a face, 0 where it sees the sky or an absorbing back
    seen: f32,
    // what the pixel shows instead when it sees no face: the sky, or black
    background: vec3<f32>,
    point: vec3<f32>,
}

// Where the pixel's eye ray meets its face's plane: exact, whatever the depth precision.
fn pixel_point(pixel: vec2<u32>, size: vec2<u32>) -> Pixel {
    let id = textureLoad(visibility, pixel, 0).x;
    var out: Pixel;
    let none = id == NO_FACE || id == SKY;
    out.seen = select(1.0, 0.0, none);
    out.face = select(id, 0u, none);
    out.background = select(vec3<f32>(0.0), view.sky.xyz, id == SKY);
    let ndc = vec2<f32>((f32(pixel.x) + 0.5) / f32(size.x) * 2.0 - 1.0, 1.0 - (f32(pixel.y) + 0.5) / f32(size.y) * 2.0);
    let near = view.inv_view_proj * vec4<f32>(ndc, 0.0, 1.0);
    let far = view.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let origin = near.xyz / near.w;
    let ray = far.xyz / far.w - origin;
    let f = faces[out.face];
    let denom = dot(f.normal, ray);
    let t = select(0.0, (f.plane_offset - dot(f.normal, origin)) / denom, abs(denom) > 1e-12);
    out.point = origin + ray * t;
    return out;
}

fn store_pixel(pixel: vec2<u32>, px: Pixel, l: vec3<f32>) {
    textureStore(image, pixel, vec4<f32>(l * px.seen + px.background, 1.0));
}

@compute @workgroup_size(8, 8)
fn resolve_diffuse(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = textureDimensions(visibility);
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let px = pixel_point(gid.xy, size);
    store_pixel(gid.xy, px, diffuse_part(faces[px.face], px.point));
}

@compute @workgroup_size(8, 8)
fn resolve_mixed(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = textureDimensions(visibility);
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let px = pixel_point(gid.xy, size);
    let f = faces[px.face];
    // a face without tiles looks up the first mirror face's (slot 0) and keeps none of it
    let mirror = select(1.0, 0.0, f.tile_slot == NO_FACE);
    let slot = select(f.tile_slot, 0u, f.tile_slot == NO_FACE);
    let l = diffuse_part(f, px.point) + view_dependent_part(f, slot, px.point) * mirror;
    store_pixel(gid.xy, px, l);
}
