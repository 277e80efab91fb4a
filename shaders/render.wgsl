// Headless view rendering from the resident light field, driven by src/render/mod.rs.
// Every pixel does the same fixed work: rasterise the visible face, then one bilinear lookup of
// its converged outgoing radiance (emission included) in the diffuse atlas. Output is linear
// radiance; tonemapping happens on the CPU when a PNG is written.
#include "common/types.wgsl"
#include "common/atlas.wgsl"

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> radiance: array<vec4<f32>>;

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

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    var face_id = in.face;
    if !front {
        // the back of a one-sided face absorbs: it looks black
        face_id = faces[face_id].twin;
        if face_id == NO_FACE {
            return vec4<f32>(0.0, 0.0, 0.0, 1.0);
        }
    }
    let f = faces[face_id];
    let taps = atlas_taps(f, in.world, view.atlas_width);
    let l = radiance[taps.index.x].xyz * taps.weight.x + radiance[taps.index.y].xyz * taps.weight.y
        + radiance[taps.index.z].xyz * taps.weight.z + radiance[taps.index.w].xyz * taps.weight.w;
    return vec4<f32>(l, 1.0);
}
