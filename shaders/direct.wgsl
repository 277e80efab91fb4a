// Direct light, driven by src/propagate/direct.rs: the first bounce onto every diffuse texel,
// computed per texel instead of through the fixed directions. A small emitter seen through a
// handful of discrete directions aliases into a ripple on every wall (each point's share of it
// jumps as the directions' cells slide across it); here each texel integrates every emitter
// triangle exactly where nothing is in the way, and shadow rays only say how much of it is
// hidden:
// - emitters: the unoccluded irradiance of each emitter triangle, clipped to the texel's
//   hemisphere, in closed form (Lambert's polygon formula); visibility from stratified shadow
//   rays through the BVH as a ratio estimator (Heitz et al. 2018): E = E_unoccluded x
//   sum(g Le V / p) / sum(g Le_mean / p) over the same samples, exact whenever nothing occludes
//   (furnaces, form factors) and free of the discrete directions wherever something does;
// - the sky: cosine-weighted stratified shadow rays over the texel's hemisphere.
// Every sample pattern is fixed per texel (a hash of its index rotates it), so the result is
// bit-for-bit repeatable. It replaces the first iteration's gather for texels only; mirror tile
// cells still receive the emitters through the light field (they carry mirror -> mirror
// chains). With mirrors (mirror_direct), emitter -> mirror -> texel paths come in the second
// iteration from mirror_light, in closed form, instead of through the mirror tiles.
#include "common/sampling.wgsl"
#include "common/types.wgsl"
#include "common/bsdf.wgsl"
#include "common/atlas.wgsl"
#include "common/upstream.wgsl"
#include "common/bilinear.wgsl"
#include "common/packed_cutouts.wgsl"

// the cut-outs' coverage (common/packed_cutouts.wgsl), shared with direct.wgsl / propagate.wgsl
@group(0) @binding(13) var<storage, read> cutouts: array<u32>;

// the gather's hooks; unused here
fn sender_specular(s: Face, xs: vec3<f32>, dir_index: u32, travel: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}

fn texel_rim_rays() -> bool {
    return false;
}

// mirrors gpu::types::GpuDirectParams
struct DirectParams {
    emitter_count: u32,
    // shadow rays per texel toward the emitters, and toward the sky
    emitter_samples: u32,
    sky_samples: u32,
    // triangles of faces with a mirror part (emitters seen in them are virtual emitters)
    mirror_count: u32,
}

// mirrors gpu::types::GpuMirrorTriangle: a triangle of a face with a mirror part
struct MirrorTriangle {
    v0: vec3<f32>,
    face: u32,
    e1: vec3<f32>,
    _pad0: u32,
    e2: vec3<f32>,
    _pad1: u32,
}

@group(2) @binding(0) var<uniform> direct: DirectParams;
@group(2) @binding(1) var<storage, read> emitters: array<Emitter>;
@group(2) @binding(2) var<storage, read> mirrors: array<MirrorTriangle>;
// the scene's triangles and BVH, for the shadow rays: common/upstream.wgsl's group 0

// shadow rays start this far off the receiver and stop this short of the emitter
const RAY_OFFSET: f32 = 1e-4;
// shadow rays meet triangles grown by this much (common/bvh.wgsl, intersect_grown)
const SHADOW_GROW: f32 = 1e-4;

// A texel's seed from its face and its place in the face's chart, not from its index in the
// atlas: a texel gets the same shadow rays however the atlas is packed (the backs of two-sided
// surfaces, packed with the rest, must not change the noise of the fronts' direct light).
fn texel_seed(texel: u32, face_id: u32, f: Face) -> u32 {
    let local_x = texel % grid.atlas_width - f.atlas_x;
    let local_y = texel / grid.atlas_width - f.atlas_y;
    return hash(hash(face_id) ^ (local_x | (local_y << 16u)));
}

// A convex polygon relative to the receiver: a triangle clipped by up to five planes (the
// receiver's hemisphere; for a virtual emitter also the mirror's plane and the three sides of
// the window through the mirror triangle) has at most 8 corners.
struct Polygon {
    p: array<vec3<f32>, 8>,
    count: u32,
}

// The triangle (a, b, c) clipped to the side of the plane through `at` that n points to.
fn clip_triangle(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, n: vec3<f32>, at: vec3<f32>) -> Polygon {
    var poly: Polygon;
    poly.p[0] = a;
    poly.p[1] = b;
    poly.p[2] = c;
    poly.count = 3u;
    return clip_polygon(poly, n, at);
}

// Keep the part of the polygon on the side of the plane (through `at`) that n points to
// (Sutherland-Hodgman); fewer than 3 corners left: empty.
fn clip_polygon(poly: Polygon, n: vec3<f32>, at: vec3<f32>) -> Polygon {
    var out: Polygon;
    out.count = 0u;
    for (var k = 0u; k < poly.count; k++) {
        let p = poly.p[k];
        let q = poly.p[(k + 1u) % poly.count];
        let dp = dot(n, p - at);
        let dq = dot(n, q - at);
        if dp > 0.0 && out.count < 8u {
            out.p[out.count] = p;
            out.count += 1u;
        }
        if (dp > 0.0) != (dq > 0.0) && out.count < 8u {
            out.p[out.count] = p + (q - p) * (dp / (dp - dq));
            out.count += 1u;
        }
    }
    if out.count < 3u {
        out.count = 0u;
    }
    return out;
}

// Irradiance at the origin (normal n) from a polygon of unit radiance above its horizon:
// Lambert's formula, half the sum over edges of the edge's angle times n . the edge's normal.
fn polygon_irradiance(poly: Polygon, n: vec3<f32>) -> f32 {
    var sum = 0.0;
    for (var k = 0u; k < poly.count; k++) {
        let a = normalize(poly.p[k]);
        let b = normalize(poly.p[(k + 1u) % poly.count]);
        let c = cross(a, b);
        let len = length(c);
        if len > 1e-12 {
            sum += atan2(len, dot(a, b)) * dot(n, c / len);
        }
    }
    return abs(sum) * 0.5;
}

// Twice the area of the fan triangle (p0, pk, pk+1).
fn fan_area2(poly: Polygon, k: u32) -> f32 {
    return length(cross(poly.p[k] - poly.p[0], poly.p[k + 1u] - poly.p[0]));
}

fn polygon_area(poly: Polygon) -> f32 {
    var total = 0.0;
    for (var k = 1u; k + 1u < poly.count; k++) {
        total += fan_area2(poly, k);
    }
    return 0.5 * total;
}

// A point of the convex polygon, uniform in area for uniform u: a fan triangle by area (u.x
// picks it and, rescaled, the point in it), then uniform in that triangle.
fn polygon_point(poly: Polygon, u: vec2<f32>) -> vec3<f32> {
    var target_area = u.x * 2.0 * polygon_area(poly);
    var s = 0.0;
    var k = 1u;
    for (; k + 2u < poly.count; k++) {
        let area = fan_area2(poly, k);
        if target_area < area {
            s = target_area / max(area, 1e-20);
            break;
        }
        target_area -= area;
    }
    if k + 2u >= poly.count {
        s = clamp(target_area / max(fan_area2(poly, k), 1e-20), 0.0, 1.0);
    }
    let r = sqrt(s);
    return poly.p[0] * (1.0 - r) + poly.p[k] * (r * (1.0 - u.y)) + poly.p[k + 1u] * (r * u.y);
}

// (`receiver`: the face x lies on. A face never lights itself or its own back: a texel of a
// two-sided emitter's back lies in the emitter's plane, and where rounding puts it a hair in
// front, the emitter's own triangle around it would fill its whole hemisphere, giving it pi Le
// that the emitter also sends into the room: +20% of the Space Ship Hallway's emitted power.)
fn emitter_polygon(e: Emitter, x: vec3<f32>, n: vec3<f32>, receiver: u32) -> Polygon {
    var none: Polygon;
    none.count = 0u;
    if receiver < UNRESOLVED && (e.face == receiver || e.face == faces[receiver].twin) {
        return none;
    }
    let normal = faces[e.face].normal;
    // emitters shine from their front only
    if dot(normal, x - e.v0) <= 0.0 {
        return none;
    }
    let a = e.v0 - x;
    return clip_triangle(a, a + e.e1, a + e.e2, n, vec3<f32>(0.0));
}

fn emitted_radiance(e: Emitter, point: vec3<f32>) -> vec3<f32> {
    if e.textured == 0u {
        return e.radiance.xyz;
    }
    let taps = atlas_taps(faces[e.face], point, grid.atlas_width);
    let b = unshot_load(taps.index.x).xyz * taps.weight.x + unshot_load(taps.index.y).xyz * taps.weight.y
        + unshot_load(taps.index.z).xyz * taps.weight.z + unshot_load(taps.index.w).xyz * taps.weight.w;
    return b / PI;
}

fn visible(start: vec3<f32>, end: vec3<f32>, skip: u32) -> f32 {
    let d = end - start;
    let dist = length(d);
    let hit = trace_skipping(start, d / dist, dist - RAY_OFFSET, true, skip, SHADOW_GROW);
    return select(1.0, 0.0, hit.tri != NO_FACE);
}

// Irradiance from every emitter at x (normal n), rgb. Each emitter's unoccluded irradiance is
// exact; its visibility is the ratio over its own shadow rays. The rays go half by each
// emitter's unoccluded share and half evenly, so that a dim emitter next to a bright one that
// is hidden from x still gets rays of its own; an emitter left without one (more emitters
// than rays) takes the visibility of all the rays together.
fn emitter_irradiance(x: vec3<f32>, n: vec3<f32>, seed: u32, skip: u32) -> vec3<f32> {
    var weight_total = 0.0;
    var lit_emitters = 0.0;
    for (var i = 0u; i < direct.emitter_count; i++) {
        let e = emitters[i];
        let w = polygon_irradiance(emitter_polygon(e, x, n, skip), n) * e.radiance.w;
        weight_total += w;
        lit_emitters += select(0.0, 1.0, w > 0.0);
    }
    if weight_total <= 0.0 {
        return vec3<f32>(0.0);
    }
    let samples = direct.emitter_samples;
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x9e3779b9u)), unit_float(hash(seed + 0x632be5abu)));
    let select_shift = unit_float(hash(seed));
    let origin = x + n * RAY_OFFSET;
    var irradiance = vec3<f32>(0.0);
    // emitters without a ray of their own, and the visibility of all rays together
    var unsampled = vec3<f32>(0.0);
    var seen_all = vec3<f32>(0.0);
    var expected_all = vec3<f32>(0.0);
    var cumulative = 0.0;
    for (var i = 0u; i < direct.emitter_count; i++) {
        let e = emitters[i];
        let poly = emitter_polygon(e, x, n, skip);
        let f = polygon_irradiance(poly, n);
        let w = f * e.radiance.w;
        if w <= 0.0 {
            continue;
        }
        // stratified: ray j goes to the emitter whose share holds (j + shift) / N
        let share = 0.5 * w / weight_total + 0.5 / lit_emitters;
        let before = ceil(cumulative * f32(samples) - select_shift);
        cumulative += share;
        let after = ceil(cumulative * f32(samples) - select_shift);
        let count = u32(max(after - before, 0.0));
        let unoccluded = f * e.radiance.xyz;
        if count == 0u {
            unsampled += unoccluded;
            continue;
        }
        let area = polygon_area(poly);
        let normal = faces[e.face].normal;
        var seen = vec3<f32>(0.0);
        var expected = vec3<f32>(0.0);
        for (var k = 0u; k < count; k++) {
            let p = polygon_point(poly, hammersley(k, count, shift));
            let r2 = dot(p, p);
            let dir = p / sqrt(r2);
            let g = max(dot(n, dir), 0.0) * max(-dot(normal, dir), 0.0) / r2;
            expected += g * e.radiance.xyz;
            seen += g * emitted_radiance(e, x + p) * visible(origin, x + p, skip);
        }
        let ratio = select(vec3<f32>(0.0), seen / expected, expected > vec3<f32>(0.0));
        irradiance += unoccluded * ratio;
        // over all rays: weighted by area per ray, so that emitters count by their irradiance
        let scale = area / f32(count);
        seen_all += seen * scale;
        expected_all += expected * scale;
    }
    let ratio_all = select(vec3<f32>(0.0), seen_all / expected_all, expected_all > vec3<f32>(0.0));
    return irradiance + unsampled * ratio_all;
}

// An orthonormal frame around n: columns (a, b, n), a and b spanning the tangent plane.
fn hemisphere_frame(n: vec3<f32>) -> mat3x3<f32> {
    let t = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.5);
    let a = normalize(cross(n, t));
    return mat3x3<f32>(a, cross(n, a), n);
}

// Irradiance from the sky at x (normal n), as a fraction of pi x the sky's radiance (rgb: a ray
// that meets a mirror first goes on, reflected, with the mirror's reflectance).
fn sky_fraction(x: vec3<f32>, n: vec3<f32>, seed: u32, skip: u32) -> vec3<f32> {
    let samples = direct.sky_samples;
    if samples == 0u {
        return vec3<f32>(0.0);
    }
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x85ebca6bu)), unit_float(hash(seed + 0xc2b2ae35u)));
    let frame = hemisphere_frame(n);
    let origin = x + n * RAY_OFFSET;
    let follow_mirrors = direct.mirror_count > 0u;
    var open = vec3<f32>(0.0);
    for (var k = 0u; k < samples; k++) {
        let u = hammersley(k, samples, shift);
        let dir = cosine_direction(frame, u);
        // the scene lies in the unit sphere: a ray that leaves it sees the sky
        let hit = trace_skipping(origin, dir, 4.0, !follow_mirrors, skip, SHADOW_GROW);
        if hit.tri == NO_FACE {
            open += vec3<f32>(1.0);
        } else if follow_mirrors {
            let face = triangles[hit.tri].face;
            let f = faces[face];
            let m = material_of(f);
            // an ideal mirror with tiles (a glossy lobe's sky comes through its tiles, a tile-less
            // mirror's as diffuse light)
            if is_delta(m) && !is_glossy(m) && f.tile_slot != NO_FACE && dot(f.normal, dir) < 0.0 {
                let p = origin + dir * hit.t;
                let reflected = mirror_direction(dir, f.normal);
                let again = trace_skipping(p + f.normal * RAY_OFFSET, reflected, 4.0, true, face, SHADOW_GROW);
                open += select(vec3<f32>(0.0), carried_reflectance(m), again.tri == NO_FACE);
            }
        }
    }
    return open / f32(samples);
}

// The emitters seen in the mirrors: a planar mirror shows each emitter as a virtual emitter, its
// mirror image, seen through the mirror's outline. Irradiance at x from emitter E through mirror
// triangle M equals that at x' (x mirrored, normal mirrored) from E itself through M (M lies in
// the plane that mirrors): E clipped to the front of M's plane, to x''s hemisphere, and to the
// cone from x' through M's edges, in closed form; visibility from shadow rays along both legs
// (x -> the point on the mirror -> the emitter), per pair. These paths would otherwise reach the
// texels through the mirror tiles' fixed directions (a caustic that aliases like direct light
// did); mirror_light adds them in the second iteration, whose gather leaves mirror senders out.
fn mirror_irradiance(x: vec3<f32>, n: vec3<f32>, seed: u32, skip: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x27d4eb2fu)), unit_float(hash(seed + 0x165667b1u)));
    let pairs = direct.mirror_count * direct.emitter_count;
    let count = max(1u, direct.emitter_samples / max(pairs, 1u));
    for (var m = 0u; m < direct.mirror_count; m++) {
        let mt = mirrors[m];
        let mf = faces[mt.face];
        let nm = mf.normal;
        // x must see the mirror's front
        let side = dot(nm, x - mt.v0);
        if side <= 0.0 || mt.face == skip {
            continue;
        }
        let xr = x - 2.0 * side * nm;
        let nr = n - 2.0 * dot(n, nm) * nm;
        let c0 = mt.v0 - xr;
        let c1 = c0 + mt.e1;
        let c2 = c0 + mt.e2;
        // the window's three planes through x' (normals pointing into the cone)
        // inside the cone, dot(cross(c0, c1), p) has the sign of the triple product [c0, c1, c2]
        let orient = select(-1.0, 1.0, dot(cross(c1 - c0, c2 - c0), c0) > 0.0);
        let w0 = normalize(cross(c0, c1)) * orient;
        let w1 = normalize(cross(c1, c2)) * orient;
        let w2 = normalize(cross(c2, c0)) * orient;
        for (var i = 0u; i < direct.emitter_count; i++) {
            let e = emitters[i];
            let en = faces[e.face].normal;
            if dot(en, xr - e.v0) <= 0.0 {
                continue;
            }
            var poly = clip_triangle(e.v0 - xr, e.v0 + e.e1 - xr, e.v0 + e.e2 - xr, nr, vec3<f32>(0.0));
            poly = clip_polygon(poly, nm, mt.v0 - xr);
            poly = clip_polygon(poly, w0, vec3<f32>(0.0));
            poly = clip_polygon(poly, w1, vec3<f32>(0.0));
            poly = clip_polygon(poly, w2, vec3<f32>(0.0));
            let f = polygon_irradiance(poly, nr);
            if f <= 0.0 {
                continue;
            }
            // visibility over the two legs, from `count` points of the clipped emitter
            var seen = 0.0;
            var expected = 0.0;
            for (var k = 0u; k < count; k++) {
                let p = polygon_point(poly, hammersley(k, count, shift));
                let r2 = dot(p, p);
                let dir = p / sqrt(r2);
                let g = max(dot(nr, dir), 0.0) * max(-dot(en, dir), 0.0) / r2;
                // where x' -> p crosses the mirror's plane, and that point seen from x
                let t = dot(nm, mt.v0 - xr) / dot(nm, dir);
                let on_mirror = xr + dir * t;
                let real = xr + p;
                let v = visible(x + n * RAY_OFFSET, on_mirror, skip) * visible(on_mirror + nm * RAY_OFFSET, real, mt.face);
                expected += g;
                seen += g * v;
            }
            let ratio = select(0.0, seen / expected, expected > 0.0);
            sum += f * ratio * e.radiance.xyz * carried_reflectance(material_of(mf));
        }
    }
    return sum;
}

// The texel a thread of a pass over the page takes: its place in the page, its atlas index,
// its face and sample point; face NO_FACE past the page or for an unused texel (whose `next`
// is set to 0 here).
struct PageTexel {
    in_page: u32,
    texel: u32,
    face: u32,
    point: vec3<f32>,
}

fn page_texel(gid: vec3<u32>, groups: vec3<u32>) -> PageTexel {
    var t: PageTexel;
    t.in_page = gid.x + gid.y * groups.x * 64u;
    t.face = NO_FACE;
    if t.in_page >= texel_page.cells {
        return t;
    }
    t.texel = texel_page.base + t.in_page;
    let point = texel_point(t.texel);
    t.point = point.xyz;
    t.face = bitcast<u32>(point.w);
    if t.face == NO_FACE {
        next[t.in_page] = vec4<f32>(0.0);
    }
    return t;
}

// Next unshot radiosity of one texel from direct light (rgb), and the sky's share of its
// irradiance (w): the same as the first iteration's gather would give without aliasing.
@compute @workgroup_size(64)
fn direct_light(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = page_texel(gid, groups);
    if t.face == NO_FACE {
        return;
    }
    let f = faces[t.face];
    let seed = texel_seed(t.texel, t.face, f);
    let e = emitter_irradiance(t.point, f.normal, seed, t.face);
    var sky = vec3<f32>(0.0);
    if (grid.flags & GRID_FLAG_SKY) != 0u {
        sky = grid.sky * (PI * sky_fraction(t.point, f.normal, seed, t.face));
    }
    next[t.in_page] = vec4<f32>(propagated_diffuse(f, material_of(f)) * (e + sky), sky.x + sky.y + sky.z);
}

// The irradiance vector of the emitters at x (normal n), luminance: per emitter triangle its
// unoccluded vector (Lambert's formula without the dot product with n: half the sum over edges
// of the edge's angle times the edge's normal, turned to n's side) times its luminance and the
// share of its shadow rays that reach it. Its dot product with n is the emitters' irradiance;
// with a tilted normal, what a normal map's point receives from them (common/normal_map.wgsl).
fn emitter_vector(x: vec3<f32>, n: vec3<f32>, seed: u32, skip: u32) -> vec3<f32> {
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x9e3779b9u)), unit_float(hash(seed + 0x632be5abu)));
    let origin = x + n * RAY_OFFSET;
    let count = max(direct.emitter_samples / max(direct.emitter_count, 1u), 4u);
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < direct.emitter_count; i++) {
        let e = emitters[i];
        let poly = emitter_polygon(e, x, n, skip);
        if poly.count < 3u {
            continue;
        }
        var vector = vec3<f32>(0.0);
        for (var k = 0u; k < poly.count; k++) {
            let a = normalize(poly.p[k]);
            let b = normalize(poly.p[(k + 1u) % poly.count]);
            let c = cross(a, b);
            let len = length(c);
            if len > 1e-12 {
                vector += c / len * (atan2(len, dot(a, b)) * 0.5);
            }
        }
        vector *= select(1.0, -1.0, dot(vector, n) < 0.0);
        var seen = 0.0;
        for (var k = 0u; k < count; k++) {
            let p = polygon_point(poly, hammersley(k, count, shift));
            seen += visible(origin, x + p, skip);
        }
        let luminance = dot(e.radiance.xyz, vec3<f32>(0.2126, 0.7152, 0.0722));
        sum += vector * (luminance * seen / f32(count));
    }
    return sum;
}

// The tangential first moment of the rest of the light at x (normal n): every bounce and the
// sky, luminance, once propagation has converged (the texels' pages then hold the converged
// radiance where the unshot radiosity was: Propagator::light_vectors): the integral over the
// hemisphere of L(w) (w - n (n . w)), from uniformly distributed rays that read the radiance
// of the face they meet (its emission left out: emitter_vector has it) or the sky. A plane
// tilted to n' receives m . n' more than the uniform share (common/normal_map.wgsl).
fn rest_moment(x: vec3<f32>, n: vec3<f32>, seed: u32, skip: u32) -> vec3<f32> {
    let samples = max(direct.emitter_samples, 16u);
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x68e31da4u)), unit_float(hash(seed + 0xb5297a4du)));
    let frame = hemisphere_frame(n);
    let origin = x + n * RAY_OFFSET;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < samples; k++) {
        let u = hammersley(k, samples, shift);
        // uniform over the hemisphere: cos theta = u.x
        let r = sqrt(max(1.0 - u.x * u.x, 0.0));
        let phi = 2.0 * PI * u.y;
        let dir = frame[0] * (r * cos(phi)) + frame[1] * (r * sin(phi)) + frame[2] * u.x;
        let hit = trace_skipping(origin, dir, 4.0, false, skip, 0.0);
        var radiance = grid.sky;
        if hit.tri != NO_FACE {
            let side = facing_side(triangles[hit.tri].face, -dir);
            let f = faces[side];
            radiance = vec3<f32>(0.0);
            if dot(f.normal, dir) < 0.0 {
                let taps = atlas_taps(f, origin + dir * hit.t, grid.atlas_width);
                let total = unshot_load(taps.index.x).xyz * taps.weight.x + unshot_load(taps.index.y).xyz * taps.weight.y
                    + unshot_load(taps.index.z).xyz * taps.weight.z + unshot_load(taps.index.w).xyz * taps.weight.w;
                radiance = max(total - emitted(f), vec3<f32>(0.0));
            }
        }
        let luminance = dot(radiance, vec3<f32>(0.2126, 0.7152, 0.0722));
        sum += (dir - n * u.x) * luminance;
    }
    return sum * (2.0 * PI / f32(samples));
}

// With normal maps, once propagation has converged (src/lightfield/normal_map.rs): each
// texel's emitter_vector (`direct_vector`), or its rest_moment (`rest_vector`), in xyz.
fn store_vector(gid: vec3<u32>, groups: vec3<u32>, rest: bool) {
    let t = page_texel(gid, groups);
    if t.face == NO_FACE {
        return;
    }
    let f = faces[t.face];
    let seed = texel_seed(t.texel, t.face, f);
    var v: vec3<f32>;
    if rest {
        v = rest_moment(t.point, f.normal, seed, t.face);
    } else {
        v = emitter_vector(t.point, f.normal, seed, t.face);
    }
    next[t.in_page] = vec4<f32>(v, 0.0);
}

@compute @workgroup_size(64)
fn direct_vector(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    store_vector(gid, groups, false);
}

@compute @workgroup_size(64)
fn rest_vector(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    store_vector(gid, groups, true);
}

// What x receives from the mirror fronts it sees, for the second iteration: rgb the irradiance
// from their diffuse parts' unshot radiance (mixed surfaces), w the irradiance that unit radiance
// on them would give (pi times their cosine-weighted share of x's hemisphere). Each mirror
// triangle clipped to the hemisphere in closed form, times the ratio over shadow rays to points
// on it of (visibility x radiance) and of visibility, as for emitters.
fn mirror_share(x: vec3<f32>, n: vec3<f32>, seed: u32, skip: u32) -> vec4<f32> {
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x3c6ef372u)), unit_float(hash(seed + 0x7f4a7c15u)));
    let count = max(1u, direct.emitter_samples / max(direct.mirror_count, 1u));
    let origin = x + n * RAY_OFFSET;
    var sum = vec4<f32>(0.0);
    for (var m = 0u; m < direct.mirror_count; m++) {
        let mt = mirrors[m];
        let mf = faces[mt.face];
        if mt.face == skip || dot(mf.normal, x - mt.v0) <= 0.0 {
            continue;
        }
        let a = mt.v0 - x;
        let poly = clip_triangle(a, a + mt.e1, a + mt.e2, n, vec3<f32>(0.0));
        let f = polygon_irradiance(poly, n);
        if f <= 0.0 {
            continue;
        }
        let diffuse = any(diffuse_reflectance(material_of(mf)) > vec3<f32>(0.0));
        var seen = vec4<f32>(0.0);
        var expected = 0.0;
        for (var k = 0u; k < count; k++) {
            let p = polygon_point(poly, hammersley(k, count, shift));
            let r2 = dot(p, p);
            let dir = p / sqrt(r2);
            let g = max(dot(n, dir), 0.0) * max(-dot(mf.normal, dir), 0.0) / r2;
            expected += g;
            let v = g * visible(origin, x + p, skip);
            var radiance = vec3<f32>(0.0);
            if diffuse && v > 0.0 {
                let taps = atlas_taps(mf, x + p, grid.atlas_width);
                radiance = (unshot_load(taps.index.x).xyz * taps.weight.x + unshot_load(taps.index.y).xyz * taps.weight.y
                    + unshot_load(taps.index.z).xyz * taps.weight.z + unshot_load(taps.index.w).xyz * taps.weight.w) / PI;
            }
            seen += vec4<f32>(radiance, 1.0) * v;
        }
        sum += f * select(vec4<f32>(0.0), seen / expected, expected > 0.0);
    }
    return sum;
}

// The second iteration's texels, after their gather (which left mirror senders out and put pi x
// their share of the quadrature weight in w): what the emitters' first reflections in the
// mirrors deliver (virtual emitters, closed form), and the gathered rest rescaled from the
// discrete directions' share of the hemisphere to the exact share the mirrors leave. The two
// parts then split the hemisphere the same way, as the plain gather's do: a uniformly lit scene
// stays uniform (the closed box of emitting mirrors and walls comes out exact), where the
// directions' share alone would leave its aliasing in every later bounce. The diffuse part of
// mixed surfaces (mirror and diffuse parts) comes with the mirrors' share (mirror_share), not
// through the gather, which left those senders out whole.
@compute @workgroup_size(64)
fn mirror_light(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let in_page = gid.x + gid.y * groups.x * 64u;
    if in_page >= texel_page.cells {
        return;
    }
    let texel = texel_page.base + in_page;
    let point = texel_point(texel);
    let face_id = bitcast<u32>(point.w);
    if face_id == NO_FACE {
        next[in_page] = vec4<f32>(0.0);
        return;
    }
    let f = faces[face_id];
    let seed = texel_seed(texel, face_id, f);
    let gathered = next[in_page];
    let discrete = clamp(gathered.w / PI, 0.0, 1.0);
    let share = mirror_share(point.xyz, f.normal, seed, face_id);
    let exact = clamp(share.w / PI, 0.0, 1.0);
    // where the directions saw mirrors alone, the rest's mean radiance is unknown: keep it
    let scale = select(1.0, (1.0 - exact) / (1.0 - discrete), discrete < 0.999);
    let mirrored = mirror_irradiance(point.xyz, f.normal, seed, face_id);
    next[in_page] = vec4<f32>(gathered.xyz * scale + propagated_diffuse(f, material_of(f)) * (mirrored + share.xyz), 0.0);
}

// Which texels lie inside closed geometry, such as the part of a floor under a box that stands
// on it: from there most of the hemisphere meets the back of one-sided faces. Nothing can see
// such a texel, but the renderer's bilinear lookup next to the contact line would blend its
// darkness into the visible texels beside it (a dark, texel-stepped seam along the foot of
// every box, magnified in a mirror). Run once, with group 1's `next` bound to the page's total
// radiance: w = 1 for a texel the renderer may interpolate, 0 for one it leaves out. A fixed
// pattern of cosine-distributed rays, so the marks repeat bit for bit.
const VALIDITY_RAYS: u32 = 16u;

@compute @workgroup_size(64)
fn texel_validity(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let in_page = gid.x + gid.y * groups.x * 64u;
    if in_page >= texel_page.cells {
        return;
    }
    let point = texel_point(texel_page.base + in_page);
    let face_id = bitcast<u32>(point.w);
    if face_id == NO_FACE {
        return;
    }
    let n = faces[face_id].normal;
    let frame = hemisphere_frame(n);
    let origin = point.xyz + n * RAY_OFFSET;
    var inside = 0u;
    for (var k = 0u; k < VALIDITY_RAYS; k++) {
        let u = hammersley(k, VALIDITY_RAYS, vec2<f32>(0.5));
        let dir = cosine_direction(frame, u);
        let hit = trace_skipping(origin, dir, 4.0, false, face_id, 0.0);
        if hit.tri != NO_FACE {
            let f = faces[triangles[hit.tri].face];
            // the back of a one-sided face (a two-sided surface's back is its twin's front)
            if dot(f.normal, dir) > 0.0 && f.twin == NO_FACE {
                inside += 1u;
            }
        }
    }
    let valid = select(1.0, 0.0, inside * 4u >= VALIDITY_RAYS * 3u);
    next[in_page] = vec4<f32>(next[in_page].xyz, valid);
}
