// The reference path tracer, driven by src/reference/mod.rs: same scene semantics as the light
// field (ARCHITECTURE.md, "Scene files: the contract"): one-sided faces unless two-sided (the back
// of a one-sided face absorbs), diffuse / mirror / mixed, area emitters from the front side,
// uniform sky, textures. Next-event estimation on the emitters with multiple importance sampling
// (power heuristic) against cosine sampling, unbounded depth with Russian roulette, seeded per
// pixel and sample so that a run repeats bit for bit. Each pass adds `samples_per_pass` samples per
// pixel to running sums of radiance and of its square.
#include "common/types.wgsl"
#include "common/bsdf.wgsl"
#include "common/bvh.wgsl"
#include "common/textures.wgsl"
#include "common/texture_cutouts.wgsl"
#include "common/normal_map.wgsl"

// 1: some face has a normal map (src/reference/mod.rs sets 0 without one)
const NORMAL_MAPS: u32 = 1u;

// mirrors reference::GpuTraceParams
struct TraceParams {
    inv_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    width: u32,
    sky: vec3<f32>,
    height: u32,
    samples_per_pass: u32,
    pass_index: u32,
    seed: u32,
    light_count: u32,
    light_weight_total: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: TraceParams;
@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(2) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(3) var<storage, read> faces: array<Face>;
// per face: (diffuse texture, emission texture, coverage texture, cutoff bits), NO_FACE for no
// texture
@group(0) @binding(4) var<storage, read> face_textures: array<vec4<u32>>;
// per texture: (first texel, width, height, -)
@group(0) @binding(5) var<storage, read> texture_info: array<vec4<u32>>;
@group(0) @binding(6) var<storage, read> texture_texels: array<vec4<f32>>;
// per emitting triangle: (triangle index as bits, cumulative weight)
@group(0) @binding(7) var<storage, read> lights: array<vec2<f32>>;
// per pixel: sum of radiance, then sum of its square
@group(0) @binding(8) var<storage, read_write> sums: array<vec4<f32>>;
// the material table the faces index (common/bsdf.wgsl)
@group(0) @binding(9) var<storage, read> materials: array<Material>;
// per face: its normal texture (NO_FACE for none) and the scale's bits (common/normal_map.wgsl)
@group(0) @binding(10) var<storage, read> face_normal_maps: array<vec2<u32>>;
// per face: its specular texture (NO_FACE for none; rgb a multiple of the mirror colour, w the
// GGX alpha: src/scene/gltf/metal_rough.rs); one NO_FACE where no face has one
@group(0) @binding(11) var<storage, read> face_specular: array<u32>;

var<private> rng_state: u32;

fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn random() -> f32 {
    rng_state = pcg(rng_state);
    return f32(rng_state >> 8u) / 16777216.0;
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

fn triangle_uv(tri: Triangle, u: f32, v: f32) -> vec2<f32> {
    return corners_uv(tri.uv01, tri.uv2.xy, u, v);
}

// Face `face_id`'s specular part at texture coordinates uv: reflectance (rgb) and GGX alpha (w),
// its material's, times its specular texture where it has one (the renderer's specular_at).
fn specular_here(face_id: u32, m: Material, uv: vec2<f32>) -> vec4<f32> {
    if arrayLength(&face_specular) > face_id {
        let texture = face_specular[face_id];
        if texture != NO_FACE {
            let t = texture_rgba_at(texture, uv);
            return vec4<f32>(mirror_reflectance(m) * t.xyz, t.w);
        }
    }
    return vec4<f32>(mirror_reflectance(m), m.roughness);
}

// Emitted radiance of the hit's front side, with the triangle's light-sampling pdf (area).
fn emission(tri: Triangle, u: f32, v: f32) -> vec3<f32> {
    return emitted(faces[tri.face]) * texture_at(face_textures[tri.face].y, triangle_uv(tri, u, v));
}

fn light_pdf_area(tri: Triangle) -> f32 {
    let le = luminance(emitted(faces[tri.face]));
    return le / params.light_weight_total;
}

fn sample_light() -> u32 {
    let target_weight = random() * params.light_weight_total;
    var lo = 0u;
    var hi = params.light_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if lights[mid].y < target_weight {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return bitcast<u32>(lights[lo].x);
}

fn power_heuristic(a: f32, b: f32) -> f32 {
    return a * a / max(a * a + b * b, 1e-30);
}

fn cosine_direction(n: vec3<f32>) -> vec3<f32> {
    let r1 = random();
    let r2 = random();
    let phi = 2.0 * PI * r1;
    let s = sqrt(r2);
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.6);
    let t = normalize(cross(helper, n));
    let b = cross(n, t);
    return normalize(t * (cos(phi) * s) + b * (sin(phi) * s) + n * sqrt(max(0.0, 1.0 - r2)));
}

fn radiance(origin_in: vec3<f32>, dir_in: vec3<f32>) -> vec3<f32> {
    var origin = origin_in;
    var dir = dir_in;
    var throughput = vec3<f32>(1.0);
    var result = vec3<f32>(0.0);
    var specular = true;
    var last_pdf = 1.0;
    for (var depth = 0u; depth < 1024u; depth++) {
        let hit = trace(origin, dir, 1e30, false);
        if hit.tri == NO_FACE {
            result += throughput * params.sky;
            break;
        }
        let tri = triangles[hit.tri];
        let x = origin + dir * hit.t;
        let n_tri = normalize(cross(tri.e1, tri.e2));
        var face_id = tri.face;
        var n = n_tri;
        if dot(dir, n_tri) > 0.0 {
            // the back: black unless the surface is two-sided (then its twin face)
            face_id = faces[tri.face].twin;
            n = -n_tri;
            if face_id == NO_FACE {
                break;
            }
        }
        let f = faces[face_id];
        let uv = triangle_uv(tri, hit.u, hit.v);
        if face_id == tri.face && any(emitted(f) > vec3<f32>(0.0)) {
            let le = emission(tri, hit.u, hit.v);
            if specular {
                result += throughput * le;
            } else {
                let cos_l = max(-dot(dir, n), 1e-8);
                let light_pdf = light_pdf_area(tri) * hit.t * hit.t / cos_l;
                result += throughput * le * power_heuristic(last_pdf, light_pdf);
            }
        }
        let m = material_of(f);
        let albedo = diffuse_reflectance(m) * texture_at(face_textures[face_id].x, uv);
        let p_diffuse = luminance(albedo);
        let specular_part = specular_here(face_id, m, uv);
        let p_mirror = luminance(specular_part.xyz);
        if p_diffuse + p_mirror <= 0.0 {
            break;
        }
        let origin_next = x + n * 1e-4;
        // the shading normal (a normal map's; n without one): the BSDF turns with it, and
        // light from below the surface itself (n) stays blocked, as Mitsuba's normalmap does
        var ns = n;
        if NORMAL_MAPS != 0u {
            let record = face_normal_maps[face_id];
            if record.x != NO_FACE {
                ns = mapped_normal(n, tri, record.x, bitcast<f32>(record.y), uv);
            }
        }
        if random() * (p_diffuse + p_mirror) < p_mirror {
            // an ideal mirror reflects; a glossy lobe is sampled (its emitters are met, not
            // sampled: no next-event estimation through it)
            var u = vec2<f32>(0.0);
            if is_glossy(m) {
                u = vec2<f32>(random(), random());
            }
            let sampled = reflect_sampled(dir, ns, specular_part.w, u);
            throughput *= specular_part.xyz * sampled.w * ((p_diffuse + p_mirror) / p_mirror);
            dir = sampled.xyz;
            if dot(dir, n) <= 0.0 {
                break;
            }
            specular = true;
        } else {
            let lobe = (p_diffuse + p_mirror) / p_diffuse;
            // next-event estimation
            if params.light_count > 0u {
                let lt = triangles[sample_light()];
                var a = random();
                var b = random();
                if a + b > 1.0 {
                    a = 1.0 - a;
                    b = 1.0 - b;
                }
                let y = lt.v0 + lt.e1 * a + lt.e2 * b;
                let to_light = y - origin_next;
                let dist = length(to_light);
                let l = to_light / dist;
                let n_l = normalize(cross(lt.e1, lt.e2));
                let cos_l = -dot(l, n_l);
                let cos_x = dot(l, ns);
                if cos_l > 0.0 && cos_x > 0.0 && dot(l, n) > 0.0 {
                    let shadow = trace(origin_next, l, dist * (1.0 - 1e-4), true);
                    if shadow.tri == NO_FACE {
                        let light_pdf = light_pdf_area(lt) * dist * dist / cos_l;
                        let bsdf_pdf = cos_x / PI;
                        let le = emission(lt, a, b);
                        result += throughput * lobe * albedo / PI * cos_x * le / light_pdf * power_heuristic(light_pdf, bsdf_pdf);
                    }
                }
            }
            dir = cosine_direction(ns);
            last_pdf = max(dot(dir, ns), 1e-8) / PI;
            throughput *= albedo * lobe;
            specular = false;
            if dot(dir, n) <= 0.0 {
                break;
            }
        }
        origin = origin_next;
        // Russian roulette after three bounces
        if depth >= 3u {
            let q = min(max(throughput.x, max(throughput.y, throughput.z)), 0.95);
            if random() >= q {
                break;
            }
            throughput /= q;
        }
    }
    return result;
}

@compute @workgroup_size(8, 8)
fn trace_pass(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    let pixel = gid.y * params.width + gid.x;
    var sum = vec3<f32>(0.0);
    var sum_sq = vec3<f32>(0.0);
    for (var s = 0u; s < params.samples_per_pass; s++) {
        let sample = params.pass_index * params.samples_per_pass + s;
        rng_state = pcg(pcg(pcg(pixel) ^ sample * 0x9e3779b9u) ^ params.seed);
        // box filter over the pixel
        let px = (f32(gid.x) + random()) / f32(params.width) * 2.0 - 1.0;
        let py = 1.0 - (f32(gid.y) + random()) / f32(params.height) * 2.0;
        let far = params.inv_view_proj * vec4<f32>(px, py, 1.0, 1.0);
        let dir = normalize(far.xyz / far.w - params.eye);
        let l = radiance(params.eye, dir);
        sum += l;
        sum_sq += l * l;
    }
    sums[2u * pixel] += vec4<f32>(sum, 0.0);
    sums[2u * pixel + 1u] += vec4<f32>(sum_sq, 0.0);
}
