// End of one shooting iteration, driven by src/propagate/transport.rs: total += next * scale
// (1/pi turns texel radiosity into radiance; 1 for mirror tiles, which hold radiance), and
// per-workgroup sums of the new unshot power (power weight per element times r+g+b) and of the
// sky's share of it, from which the CPU forms the residual. The tree-shaped reduction has a fixed order, so
// the residual is repeatable too.
#include "common/types.wgsl"

@group(0) @binding(0) var<uniform> params: AccumulateParams;
@group(0) @binding(1) var<storage, read> next: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> total: array<vec4<f32>>;
// power per unit of value: texel area x coverage, or cell area x solid angle for tile cells
@group(0) @binding(3) var<storage, read> power_weight: array<f32>;
@group(0) @binding(4) var<storage, read_write> partials: array<vec2<f32>>;

const REDUCE_THREADS: u32 = 256u;
var<workgroup> reduce_scratch: array<vec2<f32>, REDUCE_THREADS>;

@compute @workgroup_size(256)
fn accumulate(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let texel = gid.x + gid.y * groups.x * REDUCE_THREADS;
    var power = vec2<f32>(0.0);
    if texel < params.count {
        let n = next[texel];
        total[texel] += vec4<f32>(n.xyz * params.scale, 0.0);
        let c = power_weight[texel];
        power = vec2<f32>((n.x + n.y + n.z) * c, n.w * c);
    }
    reduce_scratch[lid] = power;
    workgroupBarrier();
    for (var stride = REDUCE_THREADS / 2u; stride > 0u; stride /= 2u) {
        if lid < stride {
            reduce_scratch[lid] += reduce_scratch[lid + stride];
        }
        workgroupBarrier();
    }
    if lid == 0u {
        partials[wg.x + wg.y * groups.x] = reduce_scratch[0];
    }
}
