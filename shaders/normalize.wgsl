// Closes an iteration whose directions came in batches (a memory budget, or visibility too
// large for one binding), driven by src/propagate/transport.rs. Each batch added raw quadrature
// sums to `next` and the weights it used to `weight_sums`; here each element is divided by its
// own weight sum, the same normalisation the one-batch gather applies in place (upstream.wgsl
// for texels: pi / sum of cosine weights; specular.wgsl for tile cells: 1 / sum of tap weights).
#include "common/types.wgsl"

@group(0) @binding(0) var<uniform> params: AccumulateParams;
@group(0) @binding(1) var<storage, read_write> next: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> weight_sums: array<f32>;

@compute @workgroup_size(256)
fn normalize(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 256u;
    if i >= params.count {
        return;
    }
    let w = weight_sums[params.weight_offset + i];
    next[i] = select(vec4<f32>(0.0), next[i] * (params.scale / w), w > 0.0);
}
