// Diffuse textures (map_Kd), driven by src/propagate/transport.rs and dispatched only for
// textured scenes: after the gather, each texel's next radiosity is multiplied by its texture
// factor (Kd itself is already in the face's albedo). Untextured scenes bind none of this.
#include "common/types.wgsl"

@group(0) @binding(0) var<uniform> params: AccumulateParams;
@group(0) @binding(1) var<storage, read_write> next: array<vec4<f32>>;
// per texel: the map_Kd value at its sample point (1 on untextured faces)
@group(0) @binding(2) var<storage, read> texture_albedo: array<vec4<f32>>;

@compute @workgroup_size(256)
fn modulate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let texel = gid.x + gid.y * groups.x * 256u;
    if texel >= params.count {
        return;
    }
    let n = next[texel];
    next[texel] = vec4<f32>(n.xyz * texture_albedo[texel].xyz, n.w);
}
