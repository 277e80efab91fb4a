// View rendering from the resident light field, driven by src/render/mod.rs: one compute
// pass, one thread per pixel, and every pixel does the same fixed work whatever it sees:
// - antialiasing: view.samples_per_pixel eye rays per pixel on a Hammersley set (for 2^m of
//   them, one in every elementary box of the pixel), averaged with a box filter: an edge pixel
//   shows the covered fraction;
// - each eye ray finds the face it meets (the twin for the back of a two-sided surface, none for
//   an absorbing back or the sky) and the exact point: against every triangle of a small mesh
//   (the same work for every ray), through the BVH of a large one (cast_bvh, over the tree
//   stored as child pairs, nearer child first: logarithmic, though no longer exactly equal per
//   pixel). No rasteriser: its
//   cost grows with how many surfaces overlap a pixel, and it is scarce on compute GPUs such
//   as the H100/H200;
// - one bilinear lookup in the diffuse atlas for the diffuse part (and emission);
// - mirrors by ray tracing, the paper's rendering method (ii): the ray reflects off a mirror
//   (or a mixed surface's mirror part) view.mirror_bounces times and reads the converged
//   radiance where it lands, with the geometric sharpness of a path tracer. Every reflection is
//   traced whatever it carries (a pixel that sees no mirror traces a stand-in and multiplies
//   it by zero), and two eye rays share one chain of reflections. Where a chain of mirrors can
//   be longer than that (facing mirrors), pair_mixed ends it with the mirror tiles: the
//   three fixed directions around the reflected ray, looked up in the face's tiles (a diffuse
//   or sky sample does the same lookups on a stand-in, times zero).
// - edge antialiasing (view.edge_samples > 0; src/render/edges.rs): one eye ray through each
//   pixel's centre, then find_edges lists the pixels that differ from a neighbour and refine
//   adds eye rays there, up to view.edge_samples, on one progressive (Sobol) set.
// With raster first hits (src/render/raster.rs, RASTER_FIRST_HITS 1) the eye rays' first hits
// come from a visibility buffer the hardware rasteriser drew before this pass
// (visibility_raster.wgsl): each MSAA sample names the triangle its eye ray meets, the ray meets
// that triangle's plane at the exact point, and everything after the first hit is the same.
// Output is linear radiance; tonemapping happens at display (present.wgsl) or on the CPU. Beside
// it, each pixel's depth: the view's clip depth of the nearest point its eye rays first meet
// (1 where they meet nothing), which the headset submits so the runtime can reproject.
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
#include "common/normal_map.wgsl"

// the light field's bindings (common/light_field.wgsl: layout, atlas, directions, tiles)
const LIGHT_FIELD_GROUP: u32 = 1u;
// 1: the pipeline draws moving objects (src/render/mod.rs sets 0 for a renderer without them)
const MOVING_OBJECTS: u32 = 1u;
// 1: moving surfaces sample their direct light per point, or shadows are drawn per pixel
// (common/moving_surface.wgsl; src/render/mod.rs sets 0 where the vertices and the shadow atlas
// carry both)
const SAMPLED_DIRECT: u32 = 1u;
// 1: the light field has texture detail, read per pixel (src/render/mod.rs sets 0 without it)
const SURFACE_TEXTURES: u32 = 1u;
// 1: eye rays take their first hits from `visibility` (raster first hits); 0: they cast rays
// (src/render/mod.rs sets it)
const RASTER_FIRST_HITS: u32 = 0u;
// 1: some face has a normal map (in the texture detail; src/render/mod.rs sets 0 without one)
const NORMAL_MAPS: u32 = 1u;
// 1: the light field has mirror tiles, which end chains of reflections (pair_mixed); 0: it has
// none (pair_diffuse; src/render/mod.rs sets it)
const TILES: u32 = 1u;

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
// the BVH (src/bvh.rs) as child pairs: each internal node holds both children's boxes
@group(0) @binding(3) var<storage, read> pairs: array<BvhPair>;
@group(0) @binding(4) var image: texture_storage_2d<rgba32float, write>;
// the small mesh's triangles as affine maps (rows u, v, w: world -> the triangle's barycentric
// u, v and its plane distance w), in the order of `triangles`
@group(0) @binding(5) var<storage, read> ray_triangles: array<RayTriangle>;
// the depth of what each pixel sees, in the view's clip depth (0 near, 1 far)
@group(0) @binding(6) var depth_image: texture_storage_2d<r32float, write>;
// the material table the faces index (common/bsdf.wgsl)
@group(0) @binding(7) var<storage, read> materials: array<Material>;
// raster first hits: per MSAA sample, the triangle its eye ray meets first plus one (0: none),
// in two 16-bit halves (visibility_raster.wgsl); a placeholder that is never read without them
@group(0) @binding(8) var visibility: texture_multisampled_2d<u32>;
// edge antialiasing (view.edge_samples > 0): each pixel's first pass, the pixels find_edges
// picks and the refine pass's workgroups (one buffer: the stage is at the 32 storage buffers
// some adapters allow)
@group(0) @binding(9) var<storage, read_write> edges: EdgeBuffer;

// A pixel as the first pass of edge antialiasing leaves it.
struct EdgePixel {
    colour: vec3<f32>,
    // edge_signature of its first eye ray, | EDGE_MIXED where its eye rays met different things
    signature: u32,
}

// Edge antialiasing's buffer: the refine pass's workgroups (x, y, z: the arguments of
// dispatch_workgroups_indirect, written by edge_dispatch), how many pixels it refines, then in
// `words` every pixel's EdgePixel row by row (4 words each: edge_pixel) and after them the
// pixels it refines (x | y << 16: edge_listed).
struct EdgeBuffer {
    x: u32,
    y: u32,
    z: u32,
    count: atomic<u32>,
    words: array<u32>,
}

// Pixel `i`'s first pass (row by row).
fn edge_pixel(i: u32) -> EdgePixel {
    let w = 4u * i;
    let colour = vec3<f32>(bitcast<f32>(edges.words[w]), bitcast<f32>(edges.words[w + 1u]), bitcast<f32>(edges.words[w + 2u]));
    return EdgePixel(colour, edges.words[w + 3u]);
}

fn store_edge_pixel(i: u32, p: EdgePixel) {
    let w = 4u * i;
    edges.words[w] = bitcast<u32>(p.colour.x);
    edges.words[w + 1u] = bitcast<u32>(p.colour.y);
    edges.words[w + 2u] = bitcast<u32>(p.colour.z);
    edges.words[w + 3u] = p.signature;
}

// Where entry `j` of the list of refined pixels is in `words`, for a view of `size`.
fn edge_listed(j: u32, size: vec2<u32>) -> u32 {
    return 4u * size.x * size.y + j;
}

// EdgePixel.signature: a pixel's eye rays met more than one thing.
const EDGE_MIXED: u32 = 0x80000000u;
// edge_signature of an eye ray that meets no face (the sky, or nothing)
const SIGNATURE_SKY: u32 = 0x7fffffffu;
// edge_signature of an eye ray that meets a moving object or an absorbing back
const SIGNATURE_OTHER: u32 = 0x7ffffffeu;
// refine's workgroup size, and the most workgroups one indirect dispatch may have
const REFINE_GROUP: u32 = 64u;
const MAX_GROUPS: u32 = 65535u;

// The view's clip depth of `point`, the first point an eye ray from `origin` meets: 1 (far)
// where it meets nothing (cast_ray leaves such a ray's stand-in point at its origin).
fn eye_depth(origin: vec3<f32>, point: vec3<f32>) -> f32 {
    let clip = view.view_proj * vec4<f32>(point, 1.0);
    return select(clamp(clip.z / clip.w, 0.0, 1.0), 1.0, all(point == origin));
}

// The radiance leaving the point surface `s` (on face f) shows: the atlas's, and on a face with
// a diffuse texture that does not emit, with the texture at the point (texture detail:
// common/light_field.wgsl, atlas_radiance_detailed).
// `reflected`: a reflection is traced from the point (a specular face without tiles then shows
// its texels' diffuse share: they hold its specular light too, which the reflection traces;
// where no reflection follows, at a chain's end, they stand for both).
fn surface_radiance(f: Face, s: Surface, reflected: bool) -> vec3<f32> {
    let shown = flat_radiance(f, s, reflected);
    if NORMAL_MAPS != 0u && s.seen > 0.0 && all(emitted(f) == vec3<f32>(0.0)) {
        let n = shading_normal(f, s);
        if any(n != f.normal) {
            let light = light_direction(f, s.point);
            return shown * tilted_irradiance(f.normal, n, light[0], light[1]);
        }
    }
    return shown;
}

// The normal surface `s` (on face f) shades with: its normal map's at the point, else the
// face's (common/normal_map.wgsl).
fn shading_normal(f: Face, s: Surface) -> vec3<f32> {
    if NORMAL_MAPS == 0u || s.seen <= 0.0 {
        return f.normal;
    }
    let record = normal_record(s.face);
    if record.x == NO_FACE {
        return f.normal;
    }
    return mapped_normal(f.normal, triangles[s.triangle], record.x, bitcast<f32>(record.y), surface_uv(s));
}

// The texture coordinates of the point surface `s` (a light field with texture detail: its
// triangles carry them).
fn surface_uv(s: Surface) -> vec2<f32> {
    let map = ray_triangles[s.triangle];
    let u = dot(map.u.xyz, s.point) + map.u.w;
    let v = dot(map.v.xyz, s.point) + map.v.w;
    let tri = triangles[s.triangle];
    return corners_uv(tri.uv01, tri.uv2.xy, u, v);
}

// The specular part at the point surface `s` (on face f): its reflectance (rgb) and GGX alpha
// (w), the material's, or on a face with a specular texture (a metal that varies over its
// surface, src/scene/gltf/metal_rough.rs) the material's mirror colour times the texture at the
// point, with the texture's alpha there.
fn specular_at(f: Face, s: Surface) -> vec4<f32> {
    let m = material_of(f);
    if SURFACE_TEXTURES != 0u && s.seen > 0.0 {
        let texture = specular_record(s.face);
        if texture != NO_FACE {
            let t = texture_rgba_at(texture, surface_uv(s));
            return vec4<f32>(mirror_reflectance(m) * t.xyz, t.w);
        }
    }
    return vec4<f32>(mirror_reflectance(m), m.roughness);
}

// surface_radiance before the normal map.
fn flat_radiance(f: Face, s: Surface, reflected: bool) -> vec3<f32> {
    if reflected {
        return shown_texel_radiance(f, surface_texel_radiance(f, s));
    }
    return surface_texel_radiance(f, s);
}

// The light field's radiance at the point surface `s` (flat_radiance).
fn surface_texel_radiance(f: Face, s: Surface) -> vec3<f32> {
    if SURFACE_TEXTURES != 0u {
        let texture = face_textures[s.face].x;
        if texture != NO_FACE && s.seen > 0.0 && all(emitted(f) == vec3<f32>(0.0)) {
            return atlas_radiance_detailed(f, s.point, texture_at(texture, surface_uv(s)));
        }
    }
    return atlas_radiance(f, s.point);
}

// What each of a pair of eye rays shows where it first meets the scene (s0 on face f0, s1 on
// f1): the light field's radiance, less the direct light moving objects take from
// it (none without them: evaluated once per pair, at the first ray's point, or the second's
// where the first meets no face, and taken from the ray that meets that face), or what a ray
// that met no face shows. Surfaces seen in mirrors keep the light field's radiance.
fn pair_shown(s0: Surface, f0: Face, s1: Surface, f1: Face, seed: u32) -> array<vec3<f32>, 2> {
    var r0 = surface_radiance(f0, s0, view.mirror_bounces > 0u);
    var r1 = surface_radiance(f1, s1, view.mirror_bounces > 0u);
    if MOVING_OBJECTS != 0u && view.moving_root != NO_NODE && (view.moving_flags & 1u) != 0u && s0.seen + s1.seen > 0.0 {
        let first = s0.seen > 0.0;
        let face = select(s1.face, s0.face, first);
        let shadow = moving_shadow(face, select(s1.point, s0.point, first), seed);
        r0 = select(r0, max(r0 - shadow, vec3<f32>(0.0)), s0.face == face);
        r1 = select(r1, max(r1 - shadow, vec3<f32>(0.0)), s1.face == face);
    }
    return array<vec3<f32>, 2>(r0 * s0.seen + s0.background, r1 * s1.seen + s1.background);
}

// One eye ray's radiance through up to view.mirror_bounces mirror reflections, and where the
// chain ends: the last surface, its direction of travel and the weight still carried (for the
// tiles, in pair_mixed).
struct Path {
    radiance: vec3<f32>,
    // the weight carried to the last surface (its own mirror reflectance not included: the
    // tiles hold reflected radiance)
    throughput: vec3<f32>,
    face: u32,
    point: vec3<f32>,
    ray: vec3<f32>,
}

// The reflections that follow surface `first` (met along `ray_in`, its lobe's GGX alpha
// `first_alpha`: specular_at's, which the caller has): view.mirror_bounces of them,
// every one traced whatever it carries, with the weights relative to the light leaving `first`
// by its specular part (the caller multiplies by that part's reflectance). Off an ideal mirror a
// reflection follows the mirror direction; off a glossy lobe, a direction sampled from it with
// `u` (the first reflection; later ones with `u` shifted by a hash of the bounce), weighted by
// the sample's weight (common/bsdf.wgsl, reflect_sampled).
fn mirror_chain(first: Surface, ray_in: vec3<f32>, first_alpha: f32, u: vec2<f32>) -> Path {
    var s = first;
    var ray = ray_in;
    var f = faces[s.face];
    var weight = vec3<f32>(1.0);
    // the lobe's alpha at the point (a specular texture's, else the material's), each bounce's
    // from the specular_at that weighs the one before
    var alpha = first_alpha;
    var path: Path;
    path.radiance = vec3<f32>(0.0);
    path.throughput = vec3<f32>(1.0);
    for (var b = 0u; b < view.mirror_bounces; b++) {
        let m = material_of(f);
        // a normal map turns the reflection (NORMAL_MAPS 0: the face's normal)
        let normal = shading_normal(f, s);
        // a reflection off a glossy lobe takes the emitters' light by shadow rays
        // (glossy_emitter_light) and leaves out the emission its sampled ray meets: at every
        // glossy bounce, so that a lobe seen in another lobe or in a mirror (a metal column on
        // a metal floor) does not sparkle where its sampled ray meets a small emitter; one
        // shadow ray after the first bounce (the view's count on the first), which keeps a
        // mirror-and-glossy chain within what a frame can spend
        var emitters_sampled = false;
        if is_glossy(m) {
            let shift = vec2<f32>(unit_float(hash(b)), unit_float(hash(b + 17u)));
            let n = select(normal, -normal, dot(ray, normal) > 0.0);
            if view.glossy_light_samples > 0u && probe_grid.emitter_count > 0u {
                let count = select(1u, view.glossy_light_samples, b == 0u);
                let light = glossy_emitter_light(s.point + f.normal * select(1e-5, -1e-5, dot(ray, f.normal) > 0.0), n, -ray, alpha, fract(u + shift * f32(b)), count);
                path.radiance += weight * light;
                emitters_sampled = true;
            }
            let sampled = reflect_sampled(ray, n, alpha, fract(u + shift * f32(b)));
            ray = sampled.xyz;
            weight *= sampled.w;
        } else {
            ray = mirror_direction(ray, normal);
        }
        s = cast_ray(s.point + f.normal * 1e-5, ray, (view.moving_flags & 2u) != 0u);
        f = faces[s.face];
        let leaving = surface_radiance(f, s, b + 1u < view.mirror_bounces) - select(vec3<f32>(0.0), emitted(f), emitters_sampled);
        path.radiance += weight * (max(leaving, vec3<f32>(0.0)) * s.seen + s.background);
        path.throughput = weight * s.seen;
        let specular = specular_at(f, s);
        weight *= specular.xyz * s.seen;
        alpha = specular.w;
    }
    path.face = s.face;
    path.point = s.point;
    path.ray = ray;
    return path;
}

// The emitters' direct light that a glossy lobe at point p (normal n, toward the viewer along
// wo) reflects toward the viewer, per unit of its reflectance (mirror_chain's weights): the
// lobe's BRDF (common/bsdf.wgsl, ggx_brdf) over `count` shadow rays, each to a
// point on an emitting triangle picked by its share of the power through the alias table that
// the moving objects' shadows use (common/moving_surface.wgsl, pick_emitter: the same cost
// whatever the number of lights), on a Hammersley set rotated by the chain's lobe sample `u`.
// The chain's sampled ray then leaves out the emission it meets: a small emitter seen through a
// sampled lobe is a rare, bright hit (a sparkle on a rough metal), which these rays replace by its
// expected value. A map_Ke emitter is taken at its face's mean radiance.
fn glossy_emitter_light(p: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, alpha: f32, u: vec2<f32>, count: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        let v = hammersley(k, count, u);
        let picked = pick_emitter(v.x);
        let em = emitters[bitcast<u32>(picked.x)];
        let across = cross(em.e1, em.e2);
        let area = 0.5 * length(across);
        let r = sqrt(clamp(picked.y, 0.0, 1.0));
        let d = em.v0 + em.e1 * (1.0 - r) + em.e2 * (v.y * r) - p;
        let dist = length(d);
        let wi = d / dist;
        let cos_e = -dot(across, wi) / (2.0 * area);
        let f = ggx_brdf(n, wo, wi, alpha);
        if f <= 0.0 || cos_e <= 0.0 || em.chance <= 0.0 {
            continue;
        }
        if blocks(p, wi, dist * (1.0 - 1e-4), 0u) {
            continue;
        }
        sum += em.radiance.xyz * (f * dot(n, wi) * cos_e * area / (dist * dist * em.chance));
    }
    return sum / f32(max(count, 1u));
}

// Sample `i` of `total` of the glossy lobes a pixel's chains meet: the pixel's chains take the
// points of a Hammersley set rotated by a hash of the pixel, so each pixel stratifies the lobe
// and neighbours do not repeat its pattern.
fn lobe_sample(pixel: vec2<u32>, i: u32, total: u32) -> vec2<f32> {
    let h = hash(pixel.x ^ hash(pixel.y ^ 0x9e3779b9u));
    let shift = vec2<f32>(unit_float(h), unit_float(hash(h)));
    return hammersley(i, total, shift);
}

// How many chains eye-ray pair meeting surface `s` traces: view.lobe_samples where the surface
// is glossy, one where it is an ideal mirror (or no mirror: a stand-in).
fn chains_of(s: Surface) -> u32 {
    return select(1u, max(view.lobe_samples, 1u), is_glossy(material_of(faces[s.face])));
}

// The eye ray through point `offset` (0..1 each way) of pixel `pixel`.
fn eye_ray(pixel: vec2<u32>, offset: vec2<f32>, size: vec2<u32>) -> array<vec3<f32>, 2> {
    let ndc = vec2<f32>((f32(pixel.x) + offset.x) / f32(size.x) * 2.0 - 1.0, 1.0 - (f32(pixel.y) + offset.y) / f32(size.y) * 2.0);
    let near = view.inv_view_proj * vec4<f32>(ndc, 0.0, 1.0);
    let far = view.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let origin = near.xyz / near.w;
    return array<vec3<f32>, 2>(origin, normalize(far.xyz / far.w - origin));
}

// Sample k of n: the Hammersley set of n points, shifted half a stratum. For a power-of-two
// count it is a (0, m, 2)-net in base 2: one sample in every elementary box of area 1/n
// (n x 1, ..., 1 x n), so an edge of any slope is resolved in about 1/n steps.
fn sample_offset(k: u32, n: u32) -> vec2<f32> {
    let count = f32(n);
    return fract(vec2<f32>((f32(k) + 0.5) / count, f32(reverseBits(k) >> 8u) * (1.0 / 16777216.0) + 0.5 / count));
}

// The standard sample positions of 1, 2, 4, 8 and 16 MSAA samples (Vulkan's
// standardSampleLocations, Direct3D's standard patterns; 0..1 from the pixel's top-left corner):
// those of count c from entry c - 1.
const MSAA_POSITIONS: array<vec2<f32>, 31> = array<vec2<f32>, 31>(
    vec2<f32>(0.5, 0.5),
    vec2<f32>(0.75, 0.75), vec2<f32>(0.25, 0.25),
    vec2<f32>(0.375, 0.125), vec2<f32>(0.875, 0.375), vec2<f32>(0.125, 0.625), vec2<f32>(0.625, 0.875),
    vec2<f32>(0.5625, 0.3125), vec2<f32>(0.4375, 0.6875), vec2<f32>(0.8125, 0.5625), vec2<f32>(0.3125, 0.1875),
    vec2<f32>(0.1875, 0.8125), vec2<f32>(0.0625, 0.4375), vec2<f32>(0.6875, 0.9375), vec2<f32>(0.9375, 0.0625),
    vec2<f32>(0.5625, 0.5625), vec2<f32>(0.4375, 0.3125), vec2<f32>(0.3125, 0.625), vec2<f32>(0.75, 0.4375),
    vec2<f32>(0.1875, 0.375), vec2<f32>(0.625, 0.8125), vec2<f32>(0.8125, 0.6875), vec2<f32>(0.6875, 0.1875),
    vec2<f32>(0.375, 0.875), vec2<f32>(0.5, 0.0625), vec2<f32>(0.25, 0.125), vec2<f32>(0.125, 0.75),
    vec2<f32>(0.0, 0.5), vec2<f32>(0.9375, 0.25), vec2<f32>(0.875, 0.9375), vec2<f32>(0.0625, 0.0),
);

// The MSAA sample that eye ray k takes (view.msaa_samples of them): with 4, the diagonal pair
// first (0 and 3, centred on the pixel), so a paced tile that reads two of them is not lopsided.
fn msaa_sample(k: u32) -> u32 {
    let diagonal_first = array<u32, 4>(0u, 3u, 1u, 2u);
    return select(k, diagonal_first[k & 3u], view.msaa_samples == 4u);
}

// Where eye ray k of n goes through its pixel: the Hammersley set, or with view.msaa_samples
// the standard MSAA positions (n of them at most: see tile_samples).
fn sample_position(k: u32, n: u32) -> vec2<f32> {
    if view.msaa_samples > 0u {
        return MSAA_POSITIONS[view.msaa_samples - 1u + msaa_sample(k)];
    }
    if view.edge_samples > 0u {
        return progressive_position(k);
    }
    return sample_offset(k, n);
}

// Sample k of the 2D Sobol sequence shifted by half a pixel: every prefix of 2^m samples is a
// (0, m, 2)-net in base 2 (a shift by 1/2 maps elementary boxes onto elementary boxes), so a
// pixel's first eye ray goes through its centre and the eye rays edge antialiasing adds to an
// edge pixel complete a well spread set of view.edge_samples.
fn progressive_position(k: u32) -> vec2<f32> {
    var v = 0x80000000u;
    var y = 0u;
    for (var i = k; i != 0u; i >>= 1u) {
        y ^= select(0u, v, (i & 1u) != 0u);
        v ^= v >> 1u;
    }
    return fract(vec2<f32>(unit_float(reverseBits(k)), unit_float(y)) + 0.5);
}

// Eye rays per pixel of the 8x8 tile `tile`: samples_per_pixel, or paced_samples for the share
// paced_fraction of the tiles (frame pacing holds a view's time by that share). A tile's rank
// is its place in a rank-1 lattice (the R2 sequence's), so any share is spread evenly over the
// view, and a tile changes only when the share crosses its rank. On MSAA positions no more than
// there are samples (a paced tile reads fewer of them, never more).
fn tile_samples(tile: vec2<u32>) -> u32 {
    let rank = fract(f32(tile.x) * 0.7548776662 + f32(tile.y) * 0.5698402910);
    let n = select(view.samples_per_pixel, view.paced_samples, rank < view.paced_fraction);
    return min(max(n, 1u), select(0xffffffffu, view.msaa_samples, view.msaa_samples > 0u));
}

// Eye ray k of pixel `pixel` and the surface it meets first.
struct EyeHit {
    origin: vec3<f32>,
    ray: vec3<f32>,
    surface: Surface,
}

// Eye ray k of n of pixel `pixel` (of a view `size`) and what it meets first: cast through the
// scene, or with raster first hits read from the visibility buffer, the triangle's plane met
// where cast_ray would meet it (the same point, face and texels).
fn first_hit(pixel: vec2<u32>, k: u32, n: u32, size: vec2<u32>) -> EyeHit {
    let r = eye_ray(pixel, sample_position(k, n), size);
    if RASTER_FIRST_HITS == 0u {
        return EyeHit(r[0], r[1], cast_ray(r[0], r[1], true));
    }
    let halves = textureLoad(visibility, pixel, msaa_sample(k)).xy;
    let id = halves.x | (halves.y << 16u);
    var hit = Hit(1e30, NO_FACE, 0.0, 0.0);
    if id != 0u {
        let plane = ray_triangles[id - 1u].w;
        hit.t = -(dot(plane.xyz, r[0]) + plane.w) / dot(plane.xyz, r[1]);
        hit.tri = id - 1u;
    }
    return EyeHit(r[0], r[1], hit_surface(hit, r[0], r[1]));
}

// What an eye ray meets, for finding edges: the face (each side of a two-sided surface its own),
// SIGNATURE_SKY where it meets no face, SIGNATURE_OTHER where it meets a moving object or an
// absorbing back (their detail is left to the colour test).
fn edge_signature(h: EyeHit) -> u32 {
    if h.surface.seen > 0.0 {
        return h.surface.face;
    }
    return select(SIGNATURE_OTHER, SIGNATURE_SKY, all(h.surface.point == h.origin));
}

// Whether a pair of eye rays traces its reflection chain: always with view.fixed_work where the
// pass draws `stand_ins` (every pixel the same work, a pixel that sees no mirror tracing a
// stand-in times zero), else only where one of them meets a mirror (frame pacing holds the time
// instead, render/budget.rs).
fn reflection_traced(mirror: vec3<f32>, stand_ins: bool) -> bool {
    return (stand_ins && view.fixed_work != 0u) || max(mirror.x, max(mirror.y, mirror.z)) > 0.0;
}

// What a pair of eye rays (k and k + 1 of a pixel's n; the second weighted 0 past n) adds to
// the pixel's sum, the nearest clip depth they meet, and the signatures of what each meets
// (edge_signature).
struct PairLight {
    radiance: vec3<f32>,
    depth: f32,
    signatures: vec2<u32>,
}

// Which chains of a glossy lobe a pair of eye rays traces: the pair's place among the `count`
// pairs of its pixel that draw from one stratified set (a refined pixel's added eye rays draw
// from a set of their own), and whether a pair that meets no mirror traces a stand-in
// (view.fixed_work: every pixel the same work; the refine pass's work varies anyway).
struct ChainSet {
    index: u32,
    count: u32,
    stand_ins: bool,
}

// Which of a pair of eye rays (k and k + 1, the second weighted w1) traces the pair's reflection:
// the one that meets more mirror; where both meet as much, the first in even pairs and the
// second in odd ones. A pair's two eye rays lie in opposite halves of the pixel (the Hammersley
// set's y, the Sobol set's x): reflections always from the first would see a mirror's detail
// from one half of every pixel (measured on a mirror classroom's reflected lights: display MSE
// 1.7e-4 against 64 eye rays of one pixel each, 3e-6 with a reflection per eye ray).
fn traces_second(m0: vec3<f32>, m1: vec3<f32>, k: u32, w1: f32) -> bool {
    let first = max(m0.x, max(m0.y, m0.z));
    let second = max(m1.x, max(m1.y, m1.z));
    return second > first || (second == first && w1 > 0.0 && ((k / 2u) & 1u) == 1u);
}

// A pair of eye rays (k and k + 1 of n; an odd count's last pair repeats its ray with weight
// w1 = 0) as both ways of drawing meet it: where each ray lands, the mirror each meets, and
// the pair's light before any reflection (with its depth and what it met, for edges).
struct PairHits {
    h0: EyeHit,
    h1: EyeHit,
    sp0: vec4<f32>,
    sp1: vec4<f32>,
    m0: vec3<f32>,
    m1: vec3<f32>,
    w1: f32,
    shown: PairLight,
}

fn pair_hits(pixel: vec2<u32>, k: u32, n: u32) -> PairHits {
    let size = textureDimensions(image);
    let w1 = select(0.0, 1.0, k + 1u < n);
    let h0 = first_hit(pixel, k, n, size);
    // an odd count's last pair has one eye ray: h1 is h0 (no second cast: 1 eye ray per
    // pixel costs one cast and one reflection, not two casts)
    var h1 = h0;
    if k + 1u < n {
        h1 = first_hit(pixel, k + 1u, n, size);
    }
    let s0 = h0.surface;
    let s1 = h1.surface;
    let f0 = faces[s0.face];
    let f1 = faces[s1.face];
    let sp0 = specular_at(f0, s0);
    let sp1 = specular_at(f1, s1);
    let shown = pair_shown(s0, f0, s1, f1, hash(pixel.x ^ hash(pixel.y ^ hash(k))));
    let light = PairLight(shown[0] + shown[1] * w1, min(eye_depth(h0.origin, s0.point), eye_depth(h1.origin, s1.point)), vec2<u32>(edge_signature(h0), edge_signature(h1)));
    return PairHits(h0, h1, sp0, sp1, sp0.xyz * s0.seen, sp1.xyz * s1.seen * w1, w1, light);
}

// Without tiles (no facing mirrors) eye rays go in pairs, and each pair traces one reflection:
// from the ray of the two that meets more mirror, shared by both. Edges keep every eye ray;
// a reflection inside a mirror gets half as many, and the cost stays fixed: n eye rays and n/2
// reflections per pixel (the reflection is what a mirror makes expensive).
fn pair_diffuse(pixel: vec2<u32>, k: u32, n: u32, chain_set: ChainSet) -> PairLight {
    let p = pair_hits(pixel, k, n);
    var out = p.shown;
    if view.mirror_bounces > 0u && reflection_traced(p.m0 + p.m1, chain_set.stand_ins) {
        let use_second = traces_second(p.m0, p.m1, k, p.w1);
        var h = p.h0;
        if use_second {
            h = p.h1;
        }
        let chains = chains_of(h.surface);
        var reflected = vec3<f32>(0.0);
        for (var j = 0u; j < chains; j++) {
            let u = lobe_sample(pixel, chain_set.index * chains + j, chain_set.count * chains);
            reflected += mirror_chain(h.surface, h.ray, select(p.sp0.w, p.sp1.w, use_second), u).radiance;
        }
        out.radiance += (p.m0 + p.m1) * reflected / f32(chains);
    }
    return out;
}

// With tiles (mirrors facing each other) eye rays go in pairs as in pair_diffuse: the pair's
// chain of view.mirror_bounces reflections, from the ray that meets more mirror, is shared by
// both and ends in the tiles of the last surface: n eye rays, n/2 chains and n/2 tile lookups
// per pixel.
fn pair_mixed(pixel: vec2<u32>, k: u32, n: u32, chain_set: ChainSet) -> PairLight {
    let p = pair_hits(pixel, k, n);
    var out = p.shown;
    if reflection_traced(p.m0 + p.m1, chain_set.stand_ins) {
        let use_second = traces_second(p.m0, p.m1, k, p.w1);
        var h = p.h0;
        if use_second {
            h = p.h1;
        }
        // the tiles hold the radiance the mirror reflects toward where the ray came from (its
        // reflectance included): with no reflection traced they weigh by the eye rays that meet
        // a mirror, after one or more by the mirrors' reflectance along the chain
        let mirrored_rays = select(0.0, p.h0.surface.seen, max(p.m0.x, max(p.m0.y, p.m0.z)) > 0.0) + select(0.0, p.h1.surface.seen * p.w1, max(p.m1.x, max(p.m1.y, p.m1.z)) > 0.0);
        let weight = select(p.m0 + p.m1, vec3<f32>(mirrored_rays), view.mirror_bounces == 0u);
        let chains = chains_of(h.surface);
        var reflected = vec3<f32>(0.0);
        for (var j = 0u; j < chains; j++) {
            let u = lobe_sample(pixel, chain_set.index * chains + j, chain_set.count * chains);
            let chain = mirror_chain(h.surface, h.ray, select(p.sp0.w, p.sp1.w, use_second), u);
            let f = faces[chain.face];
            // a face without tiles looks up the first mirror face's (slot 0) and keeps none of it
            let carried = select(chain.throughput, vec3<f32>(0.0), f.tile_slot == NO_FACE);
            let slot = select(f.tile_slot, 0u, f.tile_slot == NO_FACE);
            reflected += chain.radiance + carried * tile_radiance_leaving(f, slot, chain.point, -chain.ray);
        }
        out.radiance += weight * reflected / f32(chains);
    }
    return out;
}

// Eye-ray pair k of n of `pixel`, drawn the light field's way (TILES: with its mirror tiles).
fn pair_light(pixel: vec2<u32>, k: u32, n: u32, chain_set: ChainSet) -> PairLight {
    if TILES != 0u {
        return pair_mixed(pixel, k, n, chain_set);
    }
    return pair_diffuse(pixel, k, n, chain_set);
}

// One thread per pixel: its tile's eye rays, in pairs. With edge antialiasing
// (view.edge_samples above them) the pixel also leaves its average and what its eye rays met
// for find_edges.
@compute @workgroup_size(8, 8)
fn resolve(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(workgroup_id) tile: vec3<u32>) {
    let size = textureDimensions(image);
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let n = tile_samples(tile.xy);
    var sum = vec3<f32>(0.0);
    var depth = 1.0;
    var signature = 0u;
    var mixed = 0u;
    for (var k = 0u; k < n; k += 2u) {
        let pair = pair_light(gid.xy, k, n, ChainSet(k / 2u, (n + 1u) / 2u, true));
        sum += pair.radiance;
        depth = min(depth, pair.depth);
        if k == 0u {
            signature = pair.signatures.x;
        }
        mixed |= select(0u, EDGE_MIXED, any(pair.signatures != vec2<u32>(signature)));
    }
    signature |= mixed;
    let colour = sum / f32(n);
    textureStore(image, gid.xy, vec4<f32>(colour, 1.0));
    textureStore(depth_image, gid.xy, vec4<f32>(depth, 0.0, 0.0, 0.0));
    if view.edge_samples > n {
        store_edge_pixel(gid.y * size.x + gid.x, EdgePixel(colour, signature));
    }
}

// What find_edges compares of a pixel's first pass: its signature and luminance.
struct EdgeKey {
    signature: u32,
    luminance: f32,
}

fn edge_key(p: EdgePixel) -> EdgeKey {
    return EdgeKey(p.signature, dot(p.colour, vec3<f32>(0.2126, 0.7152, 0.0722)));
}

// Whether pixel q's first pass differs from pixel p's enough to call p an edge: they met
// different things, or their luminances differ by more than view.edge_contrast of the larger.
fn differs(p: EdgeKey, q: EdgeKey) -> bool {
    if (p.signature & ~EDGE_MIXED) != (q.signature & ~EDGE_MIXED) {
        return true;
    }
    let a = p.luminance;
    let b = q.luminance;
    return abs(a - b) > view.edge_contrast * max(a, b) + 1e-6;
}

var<workgroup> tile_edges: atomic<u32>;
var<workgroup> tile_first: u32;
// the tile's pixels and the ring of pixels around it (10 x 10, row by row; clamped to the view)
var<workgroup> tile_keys: array<EdgeKey, 100>;

// The pixels edge antialiasing refines: those whose eye rays met more than one thing, or whose
// 3x3 neighbourhood differs from them (differs), in every tile, or paced in the tiles the pacer
// gives 2 eye rays per pixel or more. The tile and the ring around it are read once
// into workgroup memory (100 reads for 64 pixels, not 576), and each tile appends its pixels
// with one global atomic (the list stays in tile order, near pixels together).
@compute @workgroup_size(8, 8)
fn find_edges(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lane: u32, @builtin(workgroup_id) tile: vec3<u32>) {
    let size = textureDimensions(image);
    let corner = vec2<i32>(tile.xy * 8u) - 1;
    for (var i = lane; i < 100u; i += 64u) {
        let at = clamp(corner + vec2<i32>(i32(i % 10u), i32(i / 10u)), vec2<i32>(0), vec2<i32>(size) - 1);
        tile_keys[i] = edge_key(edge_pixel(u32(at.y) * size.x + u32(at.x)));
    }
    workgroupBarrier();
    var edge = false;
    let n = tile_samples(tile.xy);
    // paced (view.fixed_work 0), a tile refines its edges where the pacer gives it 2 eye rays
    // per pixel or more: the refine pass's cost is in the share the pacer moves, not a floor
    // under it
    let refined = view.edge_samples > n && (view.fixed_work != 0u || n >= 2u);
    if gid.x < size.x && gid.y < size.y && refined {
        let local = vec2<u32>(lane % 8u, lane / 8u) + 1u;
        let me = tile_keys[local.y * 10u + local.x];
        edge = (me.signature & EDGE_MIXED) != 0u;
        for (var y = local.y - 1u; y <= local.y + 1u; y++) {
            for (var x = local.x - 1u; x <= local.x + 1u; x++) {
                edge = edge || differs(me, tile_keys[y * 10u + x]);
            }
        }
    }
    var slot = 0u;
    if edge {
        slot = atomicAdd(&tile_edges, 1u);
    }
    workgroupBarrier();
    if lane == 0u {
        let count = atomicLoad(&tile_edges);
        if count > 0u {
            tile_first = atomicAdd(&edges.count, count);
        }
    }
    let first = workgroupUniformLoad(&tile_first);
    if edge {
        edges.words[edge_listed(first + slot, size)] = gid.x | (gid.y << 16u);
    }
}

// How many threads share a refined pixel's added eye rays: view.edge_samples rounded up to a
// power of two, at most a workgroup.
fn refine_lanes() -> u32 {
    return min(1u << (32u - countLeadingZeros(max(view.edge_samples, 2u) - 1u)), REFINE_GROUP);
}

// The refine pass's workgroups for the pixels find_edges picked (one thread).
@compute @workgroup_size(1)
fn edge_dispatch() {
    let count = atomicLoad(&edges.count);
    let per_group = REFINE_GROUP / refine_lanes();
    edges.x = min((count + per_group - 1u) / per_group, MAX_GROUPS);
    edges.y = 1u;
    edges.z = 1u;
}

var<workgroup> refine_count: u32;
var<workgroup> lane_sums: array<vec3<f32>, 64>;

// Edge antialiasing's second pass: each picked pixel adds eye rays up to view.edge_samples (the
// next of the same progressive set) to the average its first eye rays left, each eye ray with
// its own reflection: the set's consecutive points lie in opposite halves of the pixel (a pair
// sharing the first's reflection would see a mirror's edges from one half only), and an edge
// pixel is where the reflection's detail is. A pixel's added eye rays are cast side by side by
// refine_lanes() threads and summed in workgroup memory (one thread casting them one after
// another made the pass as long as 7 or 15 casts however few pixels it had: a latency the
// pacer saw as a step each time a tile's edges came or went). The workgroups step through the
// list by the whole dispatch, which may hold fewer of them than the list needs.
@compute @workgroup_size(64)
fn refine(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32, @builtin(num_workgroups) groups: vec3<u32>) {
    let size = textureDimensions(image);
    if lane == 0u {
        refine_count = atomicLoad(&edges.count);
    }
    let count = workgroupUniformLoad(&refine_count);
    let total = view.edge_samples;
    let lanes = refine_lanes();
    let per_group = REFINE_GROUP / lanes;
    // which of the group's pixels this thread works on, and its first added eye ray
    let slot = lane / lanes;
    let first = lane % lanes;
    let stride = per_group * groups.x;
    for (var batch = group.x * per_group; batch < count; batch += stride) {
        let i = batch + slot;
        var sum = vec3<f32>(0.0);
        var pixel = vec2<u32>(0u);
        var n = 0u;
        if i < count {
            let packed = edges.words[edge_listed(i, size)];
            pixel = vec2<u32>(packed & 0xffffu, packed >> 16u);
            n = tile_samples(pixel / 8u);
            for (var j = first; n + j < total; j += lanes) {
                // a "pair" of one eye ray (its second weighted 0, not cast)
                sum += pair_light(pixel, n + j, n + j + 1u, ChainSet(j, total - n, false)).radiance;
            }
        }
        lane_sums[lane] = sum;
        workgroupBarrier();
        if i < count && first == 0u {
            sum = edge_pixel(pixel.y * size.x + pixel.x).colour * f32(n);
            for (var l = 0u; l < lanes; l++) {
                sum += lane_sums[slot * lanes + l];
            }
            textureStore(image, pixel, vec4<f32>(sum / f32(total), 1.0));
        }
        workgroupBarrier();
    }
}
