// Headless view rendering from the resident light field, driven by src/render/mod.rs.
// Every pixel does the same fixed work: rasterise the visible face, then one bilinear lookup of
// its converged outgoing radiance (emission included) in the diffuse atlas; in scenes with
// mirrors (fs_mixed) every pixel also looks up the three directions around the view direction
// in the face's tiles, so the cost stays the same whatever the pixel sees. Output is linear
// radiance; tonemapping happens on the CPU when a PNG is written.
#include "common/types.wgsl"
#include "common/atlas.wgsl"
#include "common/directions.wgsl"
#include "common/tiles.wgsl"

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> radiance: array<vec4<f32>>;
// view-dependent part, bound only for scenes with mirrors (fs_mixed)
@group(1) @binding(0) var<storage, read> directions: array<Direction>;
@group(1) @binding(1) var<storage, read> geodesic_points: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> geodesic_index: array<u32>;
@group(1) @binding(3) var<storage, read> tile_rects: array<vec4<u32>>;
@group(1) @binding(4) var<storage, read> tile_index: array<u32>;
@group(1) @binding(5) var<storage, read> tile_radiance: array<vec4<f32>>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) face: u32,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) face: u32) -> VertexOut {
    var out: VertexOut;
    out.clip = view.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    out.face = face;
    return out;
}

fn visible_face(face: u32, front: bool) -> u32 {
    if front {
        return face;
    }
    // the back of a one-sided face absorbs: it looks black
    return faces[face].twin;
}

fn diffuse_part(f: Face, p: vec3<f32>) -> vec3<f32> {
    let taps = atlas_taps(f, p, view.atlas_width);
    return radiance[taps.index.x].xyz * taps.weight.x + radiance[taps.index.y].xyz * taps.weight.y
        + radiance[taps.index.z].xyz * taps.weight.z + radiance[taps.index.w].xyz * taps.weight.w;
}

@fragment
fn fs_diffuse(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let face_id = visible_face(in.face, front);
    if face_id == NO_FACE {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    return vec4<f32>(diffuse_part(faces[face_id], in.world), 1.0);
}

// The mirror part seen from the eye: three fixed directions around the view direction.
fn view_dependent_part(f: Face, p: vec3<f32>) -> vec3<f32> {
    let out_dir = normalize(view.eye - p);
    let taps = lookup_direction(out_dir, view.geodesic_frequency);
    var sum = vec3<f32>(0.0);
    var found = 0.0;
    for (var k = 0u; k < 3u; k++) {
        let d = directions[taps.index[k]];
        // tiles hold the radiance leaving the front; a tap behind the face drops out
        if dot(d.w * taps.sign[k], f.normal) <= 0.0 {
            continue;
        }
        let v = tile_bilinear(taps.index[k], d, f.tile_slot, p, view.cell_size, view.tile_size, view.tile_face_count);
        sum += v.xyz * taps.weight[k] * min(v.w, 1.0);
        found += taps.weight[k] * min(v.w, 1.0);
    }
    if found <= 0.0 {
        return vec3<f32>(0.0);
    }
    return sum / found;
}

@fragment
fn fs_mixed(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let face_id = visible_face(in.face, front);
    if face_id == NO_FACE {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let f = faces[face_id];
    var l = diffuse_part(f, in.world);
    // Only mirror pixels pay for the view-dependent lookups. Doing them everywhere measured
    // ~30 ms per 1920x1200 view on an H200 (slow fragment path) and still left sky pixels
    // without work: constant per-pixel cost needs a compute resolve over a visibility buffer.
    if f.tile_slot != NO_FACE {
        l += view_dependent_part(f, in.world);
    }
    return vec4<f32>(l, 1.0);
}
