// The moving objects' own direct light, once per frame per vertex for every view, driven by
// src/render/moving_light.rs after the moving objects' refit (the same compute pass): at each
// shown skinned vertex, on the side its normal faces, the direct irradiance of the emitters and
// the sky by shadow rays against the scene and the moving objects themselves
// (common/moving_surface.wgsl, direct_samples), into `vertex_light`, which a moving surface the
// views meet interpolates over its triangle's corners (moving_radiance) instead of casting its
// own shadow rays per eye ray. Its cost follows the objects' vertices, not the views or their
// pixels. A vertex's sample pattern is fixed (a hash of its index), so the pattern moves with the
// body and a still body does not flicker.
#include "common/types.wgsl"
#include "common/bsdf.wgsl"
#include "common/atlas.wgsl"
#include "common/directions.wgsl"
#include "common/light_field.wgsl"
#include "common/textures.wgsl"
#include "common/texture_cutouts.wgsl"
#include "common/ray.wgsl"
#include "common/sampling.wgsl"
#include "common/scene_cast.wgsl"
#include "common/irradiance.wgsl"
#include "common/moving_surface.wgsl"

const LIGHT_FIELD_GROUP: u32 = 1u;
const MOVING_OBJECTS: u32 = 1u;

// mirrors gpu::types::GpuMovingLight
struct MovingLight {
    vertex_count: u32,
    // shadow rays per vertex: to the emitters, to the sky
    emitter_samples: u32,
    sky_samples: u32,
    _pad: u32,
}

// the scene as the renderer binds it (its view uniform for the casting mode and the moving tree)
@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> pairs: array<BvhPair>;
@group(0) @binding(4) var<storage, read> ray_triangles: array<RayTriangle>;
@group(0) @binding(5) var<storage, read> materials: array<Material>;
@group(0) @binding(6) var<uniform> light: MovingLight;

// the skinned vertices (w: 1 where shown) and normals (moving.wgsl), and what this pass writes:
// per vertex the direct irradiance (rgb) on the side its normal faces
@group(3) @binding(0) var<storage, read> posed: array<vec4<f32>>;
@group(3) @binding(1) var<storage, read> posed_normals: array<vec4<f32>>;
@group(3) @binding(2) var<storage, read_write> lit: array<vec4<f32>>;

// Threads per vertex: each casts every LANES-th of the vertex's shadow rays (one thread casting
// them all in turn waits on each ray's traversal: a few thousand vertices would keep a GPU
// mostly idle), and the first sums them. A multiple of LANES make a workgroup.
const LANES: u32 = 8u;

var<workgroup> parts: array<vec3<f32>, 64>;

@compute @workgroup_size(64)
fn light_vertices(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let thread = (group.x + group.y * groups.x) * 64u + lane;
    let i = thread / LANES;
    let part = thread % LANES;
    var e = vec3<f32>(0.0);
    if i < light.vertex_count {
        let p = posed[i];
        let n = posed_normals[i].xyz;
        if p.w != 0.0 && dot(n, n) >= 0.5 {
            // the offset a moving surface's own shadow rays start from (moving_radiance)
            let seed = hash(i ^ 0x27d4eb2du);
            let counts = vec2<u32>(light.emitter_samples, light.sky_samples);
            e = direct_samples_part(p.xyz + n * 1e-3, n, seed, false, counts, vec2<u32>(part, LANES));
        }
    }
    parts[lane] = e;
    workgroupBarrier();
    if part == 0u && i < light.vertex_count {
        var sum = vec3<f32>(0.0);
        for (var k = 0u; k < LANES; k++) {
            sum += parts[lane + k];
        }
        lit[i] = vec4<f32>(sum, 0.0);
    }
}
