// View rendering from the resident light field, driven by src/render/mod.rs: one compute
// pass, one thread per pixel, and every pixel does the same fixed work whatever it sees:
// - antialiasing: view.samples_per_side^2 eye rays per pixel on a Hammersley set (one sample in
//   every elementary box of the pixel), averaged with a box filter: an edge pixel shows the
//   covered fraction;
// - each eye ray finds the face it meets (the twin for the back of a two-sided surface, none for
//   an absorbing back or the sky) and the exact point: against every triangle of a small mesh
//   (the same work for every ray), through the BVH of a large one (common/bvh.wgsl, nearer
//   child first: logarithmic, though no longer exactly equal per pixel). No rasteriser: its
//   cost grows with how many surfaces overlap a pixel, and it is scarce on compute GPUs such
//   as the H100/H200;
// - one bilinear lookup in the diffuse atlas for the diffuse part (and emission);
// - mirrors by ray tracing, the paper's rendering method (ii): the ray reflects off a mirror
//   (or a mixed surface's mirror part) view.mirror_bounces times and reads the converged
//   radiance where it lands, with the geometric sharpness of a path tracer. Every sample makes
//   every bounce: one that sees no mirror traces a stand-in and multiplies it by zero. Where a
//   chain of mirrors can be longer than that (facing mirrors), resolve_mixed ends it with the
//   mirror tiles: the three fixed directions around the reflected ray, looked up in the face's
//   tiles (a diffuse or sky sample does the same lookups on a stand-in, times zero).
// Output is linear radiance; tonemapping happens at display (present.wgsl) or on the CPU.
#include "common/types.wgsl"
#include "common/atlas.wgsl"
#include "common/directions.wgsl"
#include "common/tile_pages.wgsl"
#include "common/tiles.wgsl"
#include "common/bvh.wgsl"

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(4) var image: texture_storage_2d<rgba32float, write>;
// the converged radiance atlas, in pages of view.texel_page_cells texels
@group(0) @binding(5) var<storage, read> radiance_0: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> radiance_1: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> radiance_2: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> radiance_3: array<vec4<f32>>;

fn radiance(texel: u32) -> vec4<f32> {
    let i = texel % view.texel_page_cells;
    switch texel / view.texel_page_cells {
        case 0u: { return radiance_0[i]; }
        case 1u: { return radiance_1[i]; }
        case 2u: { return radiance_2[i]; }
        default: { return radiance_3[i]; }
    }
}
// view-dependent part, bound only for scenes with mirrors (resolve_mixed)
@group(1) @binding(0) var<storage, read> directions: array<Direction>;
@group(1) @binding(1) var<storage, read> geodesic_points: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> geodesic_index: array<u32>;
@group(1) @binding(3) var<storage, read> tile_rects: array<vec4<u32>>;
@group(1) @binding(4) var<storage, read> tile_index: array<u32>;
@group(1) @binding(5) var<storage, read> tile_radiance_0: array<vec4<f32>>;
@group(1) @binding(6) var<storage, read> tile_radiance_1: array<vec4<f32>>;
@group(1) @binding(7) var<storage, read> tile_radiance_2: array<vec4<f32>>;
@group(1) @binding(8) var<storage, read> tile_radiance_3: array<vec4<f32>>;

fn tile_page_cells() -> u32 {
    return view.tile_page_cells;
}

fn tile_cells_total() -> u32 {
    return view.tile_cell_count;
}

fn diffuse_part(f: Face, p: vec3<f32>) -> vec3<f32> {
    let taps = atlas_taps(f, p, view.atlas_width);
    return radiance(taps.index.x).xyz * taps.weight.x + radiance(taps.index.y).xyz * taps.weight.y
        + radiance(taps.index.z).xyz * taps.weight.z + radiance(taps.index.w).xyz * taps.weight.w;
}

// The mirror part leaving p along out_dir: three fixed directions around it, from the tiles.
fn view_dependent_part(f: Face, slot: u32, p: vec3<f32>, out_dir: vec3<f32>) -> vec3<f32> {
    let taps = lookup_direction(out_dir, view.geodesic_frequency);
    var sum = vec3<f32>(0.0);
    var found = 0.0;
    for (var k = 0u; k < 3u; k++) {
        let d = directions[taps.index[k]];
        // tiles hold the radiance leaving the front; a tap behind the face drops out
        let front = select(0.0, 1.0, dot(d.w * taps.sign[k], f.normal) > 0.0);
        let v = tile_bilinear(taps.index[k], d, slot, p, view.cell_size, view.tile_size, view.tile_face_count, true);
        let w = taps.weight[k] * min(v.w, 1.0) * front;
        sum += v.xyz * w;
        found += w;
    }
    return select(vec3<f32>(0.0), sum / found, found > 0.0);
}

// The ray meets nothing: the sky.
const SKY: u32 = 0xfffffffdu;

// What a ray meets first.
struct Surface {
    // the face to look up (a stand-in, face 0, where the ray meets none)
    face: u32,
    // 1 where the ray meets a face, 0 where it meets the sky or an absorbing back
    seen: f32,
    // what the ray shows instead when it meets no face: the sky, or black
    background: vec3<f32>,
    point: vec3<f32>,
}

fn surface_of(hit: Hit, origin: vec3<f32>, ray: vec3<f32>) -> Surface {
    var out: Surface;
    var id = SKY;
    if hit.tri != NO_FACE {
        let face = triangles[hit.tri].face;
        // the back of a one-sided face absorbs: its twin is NO_FACE, black
        id = select(faces[face].twin, face, dot(faces[face].normal, ray) < 0.0);
    }
    let none = id == NO_FACE || id == SKY;
    out.seen = select(1.0, 0.0, none);
    out.face = select(id, 0u, none);
    out.background = select(vec3<f32>(0.0), view.sky.xyz, id == SKY);
    // a stand-in point where the ray meets nothing: lookups stay finite, and are dropped
    out.point = select(origin + ray * hit.t, origin, hit.tri == NO_FACE);
    return out;
}

// Rays go in packets of PACKET: a small mesh is tested triangle by triangle against all of
// them, so each triangle is read once per packet rather than once per ray.
const PACKET: u32 = 4u;

struct Rays {
    origin: array<vec3<f32>, 4>,
    dir: array<vec3<f32>, 4>,
}

fn cast_rays(rays: Rays) -> array<Surface, 4> {
    var hits: array<Hit, 4>;
    for (var k = 0u; k < PACKET; k++) {
        hits[k] = Hit(1e30, NO_FACE, 0.0, 0.0);
    }
    if view.exhaustive_triangles > 0u {
        // a small mesh: every ray tests every triangle, the same work for every ray
        for (var i = 0u; i < view.exhaustive_triangles; i++) {
            let tri = triangles[i];
            for (var k = 0u; k < PACKET; k++) {
                let r = intersect(rays.origin[k], rays.dir[k], tri, hits[k].t * TIE);
                if closer(r.x, i, hits[k]) {
                    hits[k].t = r.x;
                    hits[k].tri = i;
                }
            }
        }
    } else {
        for (var k = 0u; k < PACKET; k++) {
            hits[k] = trace(rays.origin[k], rays.dir[k], 1e30, false);
        }
    }
    var out: array<Surface, 4>;
    for (var k = 0u; k < PACKET; k++) {
        out[k] = surface_of(hits[k], rays.origin[k], rays.dir[k]);
    }
    return out;
}

// A packet of eye rays' radiance through up to view.mirror_bounces mirror reflections each, and
// where each chain ends: the last surface, its direction of travel and the weight still carried
// (for the tiles, in resolve_mixed).
struct Paths {
    radiance: array<vec3<f32>, 4>,
    throughput: array<vec3<f32>, 4>,
    face: array<u32, 4>,
    point: array<vec3<f32>, 4>,
    ray: array<vec3<f32>, 4>,
}

fn trace_paths(eye: Rays) -> Paths {
    var rays = eye;
    var s = cast_rays(rays);
    var paths: Paths;
    for (var k = 0u; k < PACKET; k++) {
        let f = faces[s[k].face];
        paths.radiance[k] = diffuse_part(f, s[k].point) * s[k].seen + s[k].background;
        paths.throughput[k] = f.mirror * s[k].seen;
    }
    for (var b = 0u; b < view.mirror_bounces; b++) {
        // every bounce is traced; one that carries nothing (no mirror) is multiplied by zero
        for (var k = 0u; k < PACKET; k++) {
            let n = faces[s[k].face].normal;
            rays.dir[k] = rays.dir[k] - 2.0 * dot(rays.dir[k], n) * n;
            rays.origin[k] = s[k].point + n * 1e-5;
        }
        s = cast_rays(rays);
        for (var k = 0u; k < PACKET; k++) {
            let f = faces[s[k].face];
            paths.radiance[k] += paths.throughput[k] * (diffuse_part(f, s[k].point) * s[k].seen + s[k].background);
            paths.throughput[k] *= f.mirror * s[k].seen;
        }
    }
    for (var k = 0u; k < PACKET; k++) {
        paths.face[k] = s[k].face;
        paths.point[k] = s[k].point;
        paths.ray[k] = rays.dir[k];
    }
    return paths;
}

// The eye ray through point `offset` (0..1 each way) of pixel `pixel`.
fn eye_ray(pixel: vec2<u32>, offset: vec2<f32>, size: vec2<u32>) -> array<vec3<f32>, 2> {
    let ndc = vec2<f32>((f32(pixel.x) + offset.x) / f32(size.x) * 2.0 - 1.0, 1.0 - (f32(pixel.y) + offset.y) / f32(size.y) * 2.0);
    let near = view.inv_view_proj * vec4<f32>(ndc, 0.0, 1.0);
    let far = view.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let origin = near.xyz / near.w;
    return array<vec3<f32>, 2>(origin, normalize(far.xyz / far.w - origin));
}

// Sample k of n x n: the Hammersley set of n^2 points, centred in its strata. For a power-of-two
// count it is a (0, m, 2)-net in base 2: one sample in every elementary box of area 1/n^2
// (n^2 x 1, ..., n x n, ..., 1 x n^2), so an edge of any slope is resolved in about 1/n^2 steps.
fn sample_offset(k: u32, n: u32) -> vec2<f32> {
    let count = f32(n * n);
    return vec2<f32>((f32(k) + 0.5) / count, f32(reverseBits(k) >> 8u) * (1.0 / 16777216.0) * 0.999999 + 0.5 / count);
}

// Packet p of a pixel's n x n eye rays; slots past the last sample repeat it with weight 0.
fn eye_packet(pixel: vec2<u32>, size: vec2<u32>, p: u32, n: u32) -> Rays {
    var rays: Rays;
    for (var k = 0u; k < PACKET; k++) {
        let r = eye_ray(pixel, sample_offset(min(p * PACKET + k, n * n - 1u), n), size);
        rays.origin[k] = r[0];
        rays.dir[k] = r[1];
    }
    return rays;
}

fn slot_weight(p: u32, k: u32, n: u32) -> f32 {
    return select(0.0, 1.0 / f32(n * n), p * PACKET + k < n * n);
}

@compute @workgroup_size(8, 8)
fn resolve_diffuse(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = textureDimensions(image);
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let n = max(view.samples_per_side, 1u);
    var sum = vec3<f32>(0.0);
    for (var p = 0u; p * PACKET < n * n; p++) {
        let paths = trace_paths(eye_packet(gid.xy, size, p, n));
        for (var k = 0u; k < PACKET; k++) {
            sum += paths.radiance[k] * slot_weight(p, k, n);
        }
    }
    textureStore(image, gid.xy, vec4<f32>(sum, 1.0));
}

@compute @workgroup_size(8, 8)
fn resolve_mixed(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = textureDimensions(image);
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let n = max(view.samples_per_side, 1u);
    var sum = vec3<f32>(0.0);
    for (var p = 0u; p * PACKET < n * n; p++) {
        let paths = trace_paths(eye_packet(gid.xy, size, p, n));
        for (var k = 0u; k < PACKET; k++) {
            let f = faces[paths.face[k]];
            // a face without tiles looks up the first mirror face's (slot 0) and keeps none of it
            let carried = select(paths.throughput[k], vec3<f32>(0.0), f.tile_slot == NO_FACE);
            let slot = select(f.tile_slot, 0u, f.tile_slot == NO_FACE);
            let ray = paths.ray[k];
            let out_dir = ray - 2.0 * dot(ray, f.normal) * f.normal;
            let l = paths.radiance[k] + carried * view_dependent_part(f, slot, paths.point[k], out_dir);
            sum += l * slot_weight(p, k, n);
        }
    }
    textureStore(image, gid.xy, vec4<f32>(sum, 1.0));
}
