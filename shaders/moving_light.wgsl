// The moving objects' own light, once per frame per vertex for every view, driven by
// src/render/moving_light.rs after the moving objects' refit (the same compute pass), in two
// steps whose results a moving surface the views meet interpolates over its triangle's corners
// (moving_radiance):
// - light_vertices: at each shown skinned vertex, on the side its normal faces, the direct
//   irradiance of the emitters and the sky by shadow rays against the scene and the moving
//   objects themselves (common/moving_surface.wgsl, direct_samples);
// - occlude_vertices: what the objects themselves change of the probes' irradiance there. The
//   probes are baked from the static scene alone, so an armpit or the inside of a knee would get
//   the room's light from directions its own body covers. Cosine-weighted rays against the
//   moving objects: each that meets one takes away the probes' radiance from its direction and
//   adds what the object shows there (its albedo times the probes' irradiance and the first
//   step's direct light at the point met, plus its emission: one bounce within the objects).
//   A ray that meets no object takes away, where the static surface it meets lies in the
//   objects' shadow, the light that shadow takes from it (the shadow atlas, filled before this
//   step). Where no ray meets either, nothing changes: the probes' own irradiance stands, exact
//   for the smooth light they hold.
// Their cost follows the objects' vertices, not the views or their pixels. A vertex's shadow
// rays follow a pattern fixed per vertex (a hash of its index) and its occlusion rays one
// pattern for all, turned to its normal, so the patterns move with the body and a still body
// does not flicker.
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
#include "common/moving_shadow.wgsl"

const LIGHT_FIELD_GROUP: u32 = 1u;
const MOVING_OBJECTS: u32 = 1u;
// this pass samples direct light per point (common/moving_surface.wgsl)
const SAMPLED_DIRECT: u32 = 1u;

// mirrors gpu::types::GpuMovingLight
struct MovingLight {
    vertex_count: u32,
    // shadow rays per vertex: to the emitters, to the sky
    emitter_samples: u32,
    sky_samples: u32,
    // rays per vertex against the moving objects for the probes' correction (0: none)
    occlusion_rays: u32,
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
// per vertex its two entries of common/moving_surface.wgsl's vertex_light (the direct
// irradiance at 2 i, the probes' correction at 2 i + 1)
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
    vertex_step(group.x + group.y * groups.x, lane, 0u);
}

@compute @workgroup_size(64)
fn occlude_vertices(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    vertex_step(group.x + group.y * groups.x, lane, 1u);
}

// One step's entry `step` of lit (0: the direct light, 1: the probes' correction) for the
// vertices of workgroup `group`: LANES threads per vertex, each its share of the rays, summed
// by the first.
fn vertex_step(group: u32, lane: u32, step: u32) {
    let thread = group * 64u + lane;
    let i = thread / LANES;
    let part = thread % LANES;
    var e = vec3<f32>(0.0);
    if i < light.vertex_count {
        let p = posed[i];
        let n = posed_normals[i].xyz;
        if p.w != 0.0 && dot(n, n) >= 0.5 {
            // the offset a moving surface's own shadow rays start from (moving_radiance)
            let origin = p.xyz + n * 1e-3;
            if step == 0u {
                let seed = hash(i ^ 0x27d4eb2du);
                let counts = vec2<u32>(light.emitter_samples, light.sky_samples);
                e = direct_samples_part(origin, n, seed, false, counts, vec2<u32>(part, LANES));
            } else {
                e = occlusion_part(origin, n, vec2<u32>(part, LANES));
            }
        }
    }
    parts[lane] = e;
    workgroupBarrier();
    if part == 0u && i < light.vertex_count {
        var sum = vec3<f32>(0.0);
        for (var k = 0u; k < LANES; k++) {
            sum += parts[lane + k];
        }
        lit[2u * i + step] = vec4<f32>(sum, 0.0);
    }
}

// What the objects change of the probes' irradiance at `origin` (facing `normal`), over the
// occlusion rays part.x, part.x + part.y, ... (part.y threads share one vertex's rays and their
// parts sum to the whole).
fn occlusion_part(origin: vec3<f32>, normal: vec3<f32>, part: vec2<u32>) -> vec3<f32> {
    let m = light.occlusion_rays;
    let coefficients = radiance_coefficients_at(origin);
    let frame = moving_frame(normal);
    var change = vec3<f32>(0.0);
    for (var k = part.x; k < m; k += part.y) {
        let ray = cosine_direction(frame, hammersley(k, m, vec2<f32>(0.0)));
        let hit = cast_bvh(origin, ray, view.moving_root, NO_NODE, Hit(1e30, NO_FACE, 0.0, 0.0), false);
        if hit.tri != NO_FACE {
            change += shown_by_object(hit.tri - view.moving_first, origin + ray * hit.t, ray) - sh_radiance(coefficients, ray);
        } else if (view.moving_flags & MOVING_SHADOW_ATLAS) != 0u {
            change -= shadowed_by_objects(origin, ray);
        }
    }
    // each cosine-weighted ray stands for pi / m of the irradiance
    return change * (PI / f32(max(m, 1u)));
}

// The light the moving objects' shadows take from the static surface a ray along `ray` meets
// first (the shadow atlas, filled before this step): the floor under a figure sends less light
// up to its legs than the probes, baked without the figure, hold.
fn shadowed_by_objects(origin: vec3<f32>, ray: vec3<f32>) -> vec3<f32> {
    let hit = cast_bvh(origin, ray, 0u, NO_NODE, Hit(1e30, NO_FACE, 0.0, 0.0), false);
    if hit.tri == NO_FACE {
        return vec3<f32>(0.0);
    }
    let face = triangles[hit.tri].face;
    // the back of a one-sided face has no twin: it sends nothing either way
    let seen = select(faces[face].twin, face, dot(faces[face].normal, ray) < 0.0);
    if seen == NO_FACE {
        return vec3<f32>(0.0);
    }
    return moving_shadow(seen, origin + ray * hit.t, 0u);
}

// What moving triangle `index` shows at `point` toward a ray along `ray`: on its front, its
// albedo times the probes' irradiance there and the direct light of its corners (written by
// light_vertices before this step), plus its emission; its back (the inside of a closed body,
// met where two of its parts pass into each other) none.
fn shown_by_object(index: u32, point: vec3<f32>, ray: vec3<f32>) -> vec3<f32> {
    let at = moving_point(index, point, ray);
    if !at.front {
        return vec3<f32>(0.0);
    }
    let c = moving_corners[index] * 2u;
    let direct = lit[c.x].xyz * (1.0 - at.u - at.v) + lit[c.y].xyz * at.u + lit[c.z].xyz * at.v;
    return at.material.albedo.xyz / PI * (irradiance_at(point, at.n) + direct) + at.material.emission.xyz;
}
