// Shooting iterations of diffuse transport by gathering, driven by src/propagate/transport.rs.
// This stage serves diffuse-only scenes: it binds no tiles (specular.wgsl serves the rest).
// For every texel and every direction pair (+w_i, -w_i), the texel looks itself up in the
// cell lists built by visibility.wgsl and takes the layer just upstream as its sender: no
// atomics, a fixed weight per texel, bit-for-bit repeatable. The CPU twin is
// src/propagate/cpu.rs, written to read like this file.
#include "common/types.wgsl"
#include "common/atlas.wgsl"
#include "common/upstream.wgsl"

// A diffuse-only scene: senders have no mirror part.
fn sender_specular(s: Face, xs: vec3<f32>, dir_index: u32, travel: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}

@compute @workgroup_size(64)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    gather_and_store(gid.x + gid.y * groups.x * 64u);
}
