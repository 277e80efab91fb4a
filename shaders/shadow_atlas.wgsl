// The moving objects' shadows on the static scene, once per frame for every view, driven by
// src/render/shadow_atlas.rs after the moving objects' refit (the same compute pass): for the
// texels of the static faces a moving object can shadow, the irradiance the objects block: the
// direct light (common/moving_surface.wgsl, direct_samples: emitter samples through the alias
// table and cosine-weighted sky samples, counted where a moving object blocks and the scene does
// not) and, near the objects, the indirect light (indirect_part: the light field's radiance from
// the directions they cover, less what they send back), into texels laid out per face as the light
// field's atlas lays out its chart, which the views read (common/moving_shadow.wgsl). Four
// steps: `reset` the counters; `cull` the faces (one thread each: a face is a candidate where a
// moving object's box meets the hull of the face's chart and a group of emitters' box, or lies
// within shadow.sky_reach of it under a sky or within shadow.indirect_reach; each candidate
// takes its texels and its ITEM_TEXELS-texel items); `evaluate` the items, a workgroup per item
// and LANES threads per texel, each casting a share of the texel's rays. The sample pattern of a
// texel is fixed (a hash of the face and texel), so a still scene does not flicker.
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
#include "common/arriving.wgsl"

const LIGHT_FIELD_GROUP: u32 = 1u;
const MOVING_OBJECTS: u32 = 1u;
// this pass samples direct light per point (common/moving_surface.wgsl)
const SAMPLED_DIRECT: u32 = 1u;

// mirrors gpu::types::GpuShadowAtlas
struct ShadowAtlas {
    face_count: u32,
    // texels and items the buffers hold
    texel_capacity: u32,
    item_capacity: u32,
    // the boxes of the groups of emitting triangles (`emitter_boxes`)
    box_count: u32,
    // shadow rays per texel: to the emitters, to the sky
    samples: vec2<u32>,
    // the sky's shadow within this distance of the objects' boxes (normalised space), fading
    // over the outer half
    sky_reach: f32,
    // rays per texel against the moving objects for the indirect light they block (0: none),
    // within this distance of their boxes, fading over the outer half
    indirect_rays: u32,
    indirect_reach: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// the scene as the renderer binds it (its view uniform for the casting mode and the moving tree)
@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> pairs: array<BvhPair>;
@group(0) @binding(4) var<storage, read> ray_triangles: array<RayTriangle>;
@group(0) @binding(5) var<storage, read> materials: array<Material>;
@group(0) @binding(6) var<uniform> shadow: ShadowAtlas;
// per group of emitting triangles, its box: lo, hi
@group(0) @binding(7) var<storage, read> emitter_boxes: array<vec4<f32>>;

// the atlas: per face its first texel (NO_FACE: none this frame); per texel the blocked
// irradiance; [texels taken, items taken, faces left out, -]; per item [face, first texel]
@group(3) @binding(0) var<storage, read_write> shadow_slots: array<u32>;
@group(3) @binding(1) var<storage, read_write> shadow_texels: array<vec4<f32>>;
@group(3) @binding(2) var<storage, read_write> counters: array<atomic<u32>, 4>;
@group(3) @binding(3) var<storage, read_write> items: array<vec2<u32>>;

// A box no ray enters (moving.wgsl's "never": an empty side of the tree's top).
fn empty_box(lo: vec3<f32>) -> bool {
    return lo.x >= 1e37;
}

// Where t in 0..1 keeps a * t <= b, intersected with `range`.
fn keep_below(range: vec2<f32>, a: f32, b: f32) -> vec2<f32> {
    if a > 0.0 {
        return vec2<f32>(range.x, min(range.y, b / a));
    }
    if a < 0.0 {
        return vec2<f32>(max(range.x, b / a), range.y);
    }
    return select(vec2<f32>(1.0, 0.0), range, b >= 0.0);
}

// Whether box b meets the convex hull of boxes f and e: that hull is the union over t in 0..1 of
// the boxes (1 - t) f + t e, so per axis two linear bounds on t, and the hull is met where some t
// keeps all six.
fn meets_hull(f_lo: vec3<f32>, f_hi: vec3<f32>, e_lo: vec3<f32>, e_hi: vec3<f32>, b_lo: vec3<f32>, b_hi: vec3<f32>) -> bool {
    var t = vec2<f32>(0.0, 1.0);
    for (var i = 0u; i < 3u; i++) {
        t = keep_below(t, e_lo[i] - f_lo[i], b_hi[i] - f_lo[i]);
        t = keep_below(t, f_hi[i] - e_hi[i], f_hi[i] - b_lo[i]);
    }
    return t.x <= t.y;
}

// The distance between boxes a and b (0 where they meet).
fn box_distance(a_lo: vec3<f32>, a_hi: vec3<f32>, b_lo: vec3<f32>, b_hi: vec3<f32>) -> f32 {
    return length(max(max(a_lo - b_hi, b_lo - a_hi), vec3<f32>(0.0)));
}

// Whether face f can take a moving object's shadow this frame, for a side of the tree's top
// (box lo..hi): the box rises above the face's plane, and it meets the hull of the face's chart
// and one group of emitters, or under a sky lies within shadow.sky_reach of the chart, or within
// shadow.indirect_reach where the indirect light's shadow is taken.
fn side_shadows(f: Face, f_lo: vec3<f32>, f_hi: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    if empty_box(lo) || dot(select(lo, hi, f.normal > vec3<f32>(0.0)) - f.origin, f.normal) <= 0.0 {
        return false;
    }
    // a margin for the refit's rounding
    let b_lo = lo - vec3<f32>(1e-4);
    let b_hi = hi + vec3<f32>(1e-4);
    if shadow.samples.x > 0u {
        for (var k = 0u; k < shadow.box_count; k++) {
            if meets_hull(f_lo, f_hi, emitter_boxes[2u * k].xyz, emitter_boxes[2u * k + 1u].xyz, b_lo, b_hi) {
                return true;
            }
        }
    }
    let sky = field.sky.xyz;
    let apart = box_distance(f_lo, f_hi, b_lo, b_hi);
    let sky_shadow = shadow.samples.y > 0u && max(sky.x, max(sky.y, sky.z)) > 0.0 && apart < shadow.sky_reach;
    return sky_shadow || (shadow.indirect_rays > 0u && apart < shadow.indirect_reach);
}

// Whether face f is a candidate: a diffuse albedo, and a side of the moving objects' tree that
// can shadow it.
fn candidate(f: Face) -> bool {
    let albedo = diffuse_reflectance(material_of(f));
    if max(albedo.x, max(albedo.y, albedo.z)) <= 0.0 {
        return false;
    }
    let wa = f.axis_a * (f32(f.atlas_w) / f.texel_density);
    let wb = f.axis_b * (f32(f.atlas_h) / f.texel_density);
    let f_lo = min(min(f.origin, f.origin + wa), min(f.origin + wb, f.origin + wa + wb));
    let f_hi = max(max(f.origin, f.origin + wa), max(f.origin + wb, f.origin + wa + wb));
    let top = pairs[view.moving_root];
    return side_shadows(f, f_lo, f_hi, top.lo_left, top.hi_left) || side_shadows(f, f_lo, f_hi, top.lo_right, top.hi_right);
}

@compute @workgroup_size(1)
fn reset() {
    for (var i = 0u; i < 4u; i++) {
        atomicStore(&counters[i], 0u);
    }
}

@compute @workgroup_size(64)
fn cull(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let face = gid.x + gid.y * groups.x * 64u;
    if face >= shadow.face_count {
        return;
    }
    let f = shadow_chart(faces[face]);
    var slot = NO_FACE;
    if candidate(f) {
        let texels = f.atlas_w * f.atlas_h;
        let chunks = (texels + ITEM_TEXELS - 1u) / ITEM_TEXELS;
        let first = atomicAdd(&counters[0], texels);
        let item = atomicAdd(&counters[1], chunks);
        let fits = first + texels <= shadow.texel_capacity && item + chunks <= shadow.item_capacity;
        slot = select(NO_FACE, first, fits);
        // a face left out still writes its items, void (the count includes them)
        for (var c = 0u; c < chunks && item + c < shadow.item_capacity; c++) {
            items[item + c] = vec2<u32>(select(NO_FACE, face, fits), c * ITEM_TEXELS);
        }
        if !fits {
            atomicAdd(&counters[2], 1u);
        }
    }
    shadow_slots[face] = slot;
}

// The distance from p to a side's box (far where the side is empty).
fn side_distance(p: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> f32 {
    return select(box_distance(p, p, lo, hi), 1e30, empty_box(lo));
}

// Workgroups of the evaluation, each taking every EVALUATION_GROUPS-th item: about as many as an
// H100 keeps resident at once, with no indirect dispatch (whose arguments buffer could not be bound
// beside the others in one pass).
const EVALUATION_GROUPS: u32 = 4096u;
// Threads per texel, each casting every LANES-th of its rays (one thread casting them all in turn
// waits on each ray's traversal: the few thousand texels near a body would keep a GPU mostly
// idle), and the texels of an item: a workgroup's 64 threads.
const LANES: u32 = 8u;
const ITEM_TEXELS: u32 = 8u;

var<workgroup> parts: array<vec3<f32>, 64>;
var<workgroup> item_count: u32;

// This thread's share (`part` of LANES) of the irradiance the moving objects block at texel
// `texel` of face `face`.
fn texel_part(face: u32, texel: u32, part: u32) -> vec3<f32> {
    let f = shadow_chart(faces[face]);
    let x = f32(texel % f.atlas_w) + 0.5;
    let y = f32(texel / f.atlas_w) + 0.5;
    let p = f.origin + (f.axis_a * x + f.axis_b * y) / f.texel_density;
    let origin = p + f.normal * 1e-5;
    let seed = hash(face ^ hash(texel ^ 0x5bd1e995u));
    let lanes = vec2<u32>(part, LANES);
    var blocked = direct_samples_part(origin, f.normal, seed, true, vec2<u32>(shadow.samples.x, 0u), lanes);
    // the sky's shadow near the objects (contact darkening): full within half the reach, none
    // past it
    let top = pairs[view.moving_root];
    let d = min(side_distance(p, top.lo_left, top.hi_left), side_distance(p, top.lo_right, top.hi_right));
    let fade = clamp(2.0 - 2.0 * d / max(shadow.sky_reach, 1e-20), 0.0, 1.0);
    if fade > 0.0 && shadow.samples.y > 0u {
        blocked += fade * direct_samples_part(origin, f.normal, seed, true, vec2<u32>(0u, shadow.samples.y), lanes);
    }
    let indirect_fade = clamp(2.0 - 2.0 * d / max(shadow.indirect_reach, 1e-20), 0.0, 1.0);
    if indirect_fade > 0.0 && shadow.indirect_rays > 0u {
        blocked += indirect_fade * indirect_part(origin, f.normal, seed, lanes);
    }
    return blocked;
}

// This thread's share (`part`) of the indirect irradiance the moving objects take from a static
// point at `origin` facing `normal`: shadow.indirect_rays cosine-weighted rays, each that meets a
// moving object before the scene taking away the light field's radiance from its direction (what
// arrives there from the static surface behind the object, as the probes are baked from it:
// common/arriving.wgsl, without the emitters' and the sky's own light, which the shadow rays
// take) and giving back what the object shows toward the point (moving_radiance: its albedo lit
// by the probes and the vertices' light, its emission). Each ray stands for pi / indirect_rays
// of the irradiance.
fn indirect_part(origin: vec3<f32>, normal: vec3<f32>, seed: u32, part: vec2<u32>) -> vec3<f32> {
    let m = shadow.indirect_rays;
    let frame = moving_frame(normal);
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x68e31da4u)), unit_float(hash(seed + 0x1b56c4e9u)));
    var blocked = vec3<f32>(0.0);
    for (var k = part.x; k < m; k += part.y) {
        let ray = cosine_direction(frame, hammersley(k, m, shift));
        let hit = cast_bvh(origin, ray, view.moving_root, NO_NODE, Hit(1e30, NO_FACE, 0.0, 0.0), false);
        if hit.tri == NO_FACE {
            continue;
        }
        let s = cast_ray(origin, ray, false);
        // the object hides the scene only where the scene lies behind it (the sky's stand-in
        // point is the origin itself: behind everything)
        if all(s.point == origin) || distance(s.point, origin) > hit.t {
            blocked += arriving_from(origin, ray, s).xyz - moving_radiance(hit.tri - view.moving_first, origin + ray * hit.t, ray);
        }
    }
    return blocked * (PI / f32(max(m, 1u)));
}

@compute @workgroup_size(64)
fn evaluate(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if lane == 0u {
        item_count = min(atomicLoad(&counters[1]), shadow.item_capacity);
    }
    let count = workgroupUniformLoad(&item_count);
    let at_texel = lane / LANES;
    let part = lane % LANES;
    for (var item = group.x; item < count; item += EVALUATION_GROUPS) {
        let at = items[item];
        let f = shadow_chart(faces[min(at.x, shadow.face_count - 1u)]);
        let texel = at.y + at_texel;
        let real = at.x != NO_FACE && texel < f.atlas_w * f.atlas_h;
        var e = vec3<f32>(0.0);
        if real {
            e = texel_part(at.x, texel, part);
        }
        parts[lane] = e;
        workgroupBarrier();
        if real && part == 0u {
            var sum = vec3<f32>(0.0);
            for (var k = 0u; k < LANES; k++) {
                sum += parts[lane + k];
            }
            shadow_texels[shadow_slots[at.x] + texel] = vec4<f32>(sum, 0.0);
        }
        workgroupBarrier();
    }
}
