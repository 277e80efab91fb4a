// Irradiance probes from the converged light field, driven by src/render/probes.rs: one
// workgroup per probe of the grid (common/irradiance.wgsl), whose 64 threads cast
// PROBE_RAYS rays on a spherical Fibonacci set through the scene exactly as eye rays are cast
// (common/scene_cast.wgsl; the moving objects are not in it), read the radiance where each lands
// (the atlas, and one mirror reflection; not the direct light a moving surface samples itself)
// and project it on the nine spherical harmonics.
#include "common/types.wgsl"
#include "common/bsdf.wgsl"
#include "common/atlas.wgsl"
#include "common/directions.wgsl"
#include "common/light_field.wgsl"
#include "common/ray.wgsl"
#include "common/textures.wgsl"
#include "common/texture_cutouts.wgsl"
#include "common/scene_cast.wgsl"
#include "common/irradiance.wgsl"
#include "common/arriving.wgsl"

const LIGHT_FIELD_GROUP: u32 = 1u;
// the probes see the static scene only
const MOVING_OBJECTS: u32 = 0u;

// the view's only use here: the mesh's casting mode (exhaustive_triangles) and no moving tree
@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> pairs: array<BvhPair>;
@group(0) @binding(4) var<uniform> probe_grid: ProbeGrid;
@group(0) @binding(5) var<storage, read> ray_triangles: array<RayTriangle>;
@group(0) @binding(6) var<storage, read_write> probes: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> materials: array<Material>;

// rays per probe: a multiple of the workgroup's 64 (src/render/probes.rs sets it)
const PROBE_RAYS: u32 = 256u;

// no moving object is cast here (view.moving_root is NO_NODE)
fn moving_radiance(index: u32, point: vec3<f32>, ray: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}

// Direction k of n on the spherical Fibonacci set: equal areas, no preferred axis.
fn fibonacci_direction(k: u32, n: u32) -> vec3<f32> {
    let z = 1.0 - (2.0 * f32(k) + 1.0) / f32(n);
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = f32(k) * 2.399963230;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// The radiance arriving at `origin` from direction -`ray` (what a ray along `ray` meets; see
// common/arriving.wgsl).
fn arriving(origin: vec3<f32>, ray: vec3<f32>) -> vec4<f32> {
    return arriving_from(origin, ray, cast_ray(origin, ray, false));
}

var<workgroup> partial: array<array<vec4<f32>, 9>, 64>;

@compute @workgroup_size(64)
fn bake(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let probe = group.x + group.y * groups.x;
    let counts = probe_grid.counts;
    let total = counts.x * counts.y * counts.z;
    let at = vec3<u32>(probe % counts.x, (probe / counts.x) % counts.y, probe / (counts.x * counts.y));
    let origin = probe_grid.origin + probe_grid.spacing * vec3<f32>(at);
    var sum: array<vec4<f32>, 9>;
    for (var k = lane; k < PROBE_RAYS; k += 64u) {
        let d = fibonacci_direction(k, PROBE_RAYS);
        let l = arriving(origin, d);
        let y = sh_basis(d);
        for (var i = 0u; i < 9u; i++) {
            sum[i] += vec4<f32>(l.xyz * y[i], l.w);
        }
    }
    partial[lane] = sum;
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        workgroupBarrier();
        if lane < stride {
            for (var i = 0u; i < 9u; i++) {
                partial[lane][i] += partial[lane + stride][i];
            }
        }
    }
    workgroupBarrier();
    if lane == 0u && probe < total {
        // each ray stands for the solid angle 4 pi / PROBE_RAYS
        let weight = 4.0 * PI / f32(PROBE_RAYS);
        for (var i = 0u; i < 9u; i++) {
            let c = partial[0][i];
            probes[probe * PROBE_COEFFICIENTS + i] = vec4<f32>(c.xyz * weight, select(0.0, c.w / f32(PROBE_RAYS), i == 0u));
        }
    }
}
