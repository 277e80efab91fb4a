// What a moving object shows where a ray meets it (src/render/moving.rs): its own albedo and
// emission, lit by the converged static light field at the smooth normal of the triangle's
// skinned corners: the direct light of the emitters and the sky by shadow rays against the scene
// and the moving objects themselves (their own shadows on each other and on themselves), the
// rest through the irradiance probes (common/irradiance.wgsl, baked without that direct light).
// The direct light is read from the triangle's corners where moving_light.wgsl evaluated it once
// per frame (probe_grid.vertex_light), or sampled per eye ray. The renderer binds this group;
// cast_ray (common/scene_cast.wgsl) calls moving_radiance. The shadow atlas's pass
// (shadow_atlas.wgsl) and the vertices' light pass (moving_light.wgsl) bind it too, for
// direct_samples, with placeholders for the vertices' light. The includer declares
// `const SAMPLED_DIRECT: u32`: 1 keeps the shadow rays a point samples itself where the vertices
// carry no direct light (moving_radiance) and the per-pixel shadows (common/moving_shadow.wgsl);
// 0 compiles them out, for a renderer whose moving surfaces take their direct light from their
// vertices and whose shadows come from the shadow atlas (eye and mirror rays never meet a moving
// back: cast_ray passes them by), so its pipeline carries no second traversal.

// mirrors gpu::types::GpuMovingMaterial
struct MovingMaterial {
    albedo: vec4<f32>,
    emission: vec4<f32>,
}

@group(2) @binding(0) var<storage, read> moving_triangles: array<MovingTriangle>;
@group(2) @binding(1) var<storage, read> moving_materials: array<MovingMaterial>;
@group(2) @binding(2) var<uniform> probe_grid: ProbeGrid;
@group(2) @binding(3) var<storage, read> probes: array<vec4<f32>>;
// the scene's emitting triangles (probe_grid.emitter_count of them), which the shadows sample,
// and their alias table (render/probes.rs alias_table: [threshold, alias bits, 0, 0])
@group(2) @binding(4) var<storage, read> emitters: array<Emitter>;
@group(2) @binding(5) var<storage, read> emitter_alias: array<vec4<f32>>;
// per moving vertex two entries (moving_light.wgsl): at 2 i its direct irradiance on the side
// its normal faces, at 2 i + 1 what the objects themselves change of the probes' irradiance
// there (signed: the light they hide from it, less what they send it); and per moving triangle
// its corners (indices of vertices) and material: [a, b, c, material]
@group(2) @binding(6) var<storage, read> vertex_light: array<vec4<f32>>;
@group(2) @binding(7) var<storage, read> moving_corners: array<vec4<u32>>;

// Probe `probe`'s irradiance for the basis `b` (irradiance_basis), never negative (order 2
// rings where the light is sharp).
fn probe_irradiance(probe: u32, b: array<f32, 9>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    for (var i = 0u; i < PROBE_COEFFICIENTS; i++) {
        e += probes[probe * PROBE_COEFFICIENTS + i].xyz * b[i];
    }
    return max(e, vec3<f32>(0.0));
}

// The eight probes around p and their trilinear weights.
struct ProbeCorners {
    probe: array<u32, 8>,
    weight: array<f32, 8>,
}

fn probe_corners(p: vec3<f32>) -> ProbeCorners {
    let top = vec3<f32>(probe_grid.counts - vec3<u32>(1u));
    let g = clamp((p - probe_grid.origin) / probe_grid.spacing, vec3<f32>(0.0), top);
    let base = min(vec3<u32>(floor(g)), probe_grid.counts - vec3<u32>(2u));
    let f = g - vec3<f32>(base);
    var out: ProbeCorners;
    for (var c = 0u; c < 8u; c++) {
        let o = vec3<u32>(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
        let t = select(vec3<f32>(1.0) - f, f, o == vec3<u32>(1u));
        let at = base + o;
        out.probe[c] = at.x + probe_grid.counts.x * (at.y + probe_grid.counts.y * at.z);
        out.weight[c] = t.x * t.y * t.z;
    }
    return out;
}

// A probe's weight where its rays met one-sided backs (a probe inside a wall or a cupboard sees
// black and would darken what stands beside it): none from a quarter of its rays.
fn probe_validity(probe: u32) -> f32 {
    return clamp(1.0 - 4.0 * probes[probe * PROBE_COEFFICIENTS].w, 0.0, 1.0);
}

// Irradiance at point p on a surface facing n: the eight probes around p, trilinear, each
// weighted down by probe_validity; where all eight are inside, plain trilinear.
fn irradiance_at(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let corners = probe_corners(p);
    let b = irradiance_basis(n);
    var weighted = vec3<f32>(0.0);
    var weights = 0.0;
    var plain = vec3<f32>(0.0);
    for (var c = 0u; c < 8u; c++) {
        let probe = corners.probe[c];
        let w = corners.weight[c];
        let e = probe_irradiance(probe, b);
        let valid = w * probe_validity(probe);
        weighted += e * valid;
        weights += valid;
        plain += e * w;
    }
    return select(plain, weighted / weights, weights > 1e-4);
}

// The probes' radiance arriving at p, as its nine coefficients (sh_basis(d) dotted with them is
// the radiance from direction d), weighted as irradiance_at weights the probes' irradiance.
fn radiance_coefficients_at(p: vec3<f32>) -> array<vec3<f32>, 9> {
    let corners = probe_corners(p);
    var weighted: array<vec3<f32>, 9>;
    var plain: array<vec3<f32>, 9>;
    var weights = 0.0;
    for (var c = 0u; c < 8u; c++) {
        let probe = corners.probe[c];
        let w = corners.weight[c];
        let valid = w * probe_validity(probe);
        for (var i = 0u; i < PROBE_COEFFICIENTS; i++) {
            let x = probes[probe * PROBE_COEFFICIENTS + i].xyz;
            weighted[i] += x * valid;
            plain[i] += x * w;
        }
        weights += valid;
    }
    if weights > 1e-4 {
        for (var i = 0u; i < PROBE_COEFFICIENTS; i++) {
            weighted[i] /= weights;
        }
        return weighted;
    }
    return plain;
}

// The radiance from direction d (arriving along -d) that `coefficients` hold, never negative.
fn sh_radiance(coefficients: array<vec3<f32>, 9>, d: vec3<f32>) -> vec3<f32> {
    let y = sh_basis(d);
    var l = vec3<f32>(0.0);
    for (var i = 0u; i < PROBE_COEFFICIENTS; i++) {
        l += coefficients[i] * y[i];
    }
    return max(l, vec3<f32>(0.0));
}

// Face f's chart in the shadow atlas: its own texels only (corner 0, 0), probe_grid.shadow_subdivision
// of them along each side of a light-field texel (the atlas's pass, shadow_atlas.wgsl, and its
// lookup, common/moving_shadow.wgsl).
fn shadow_chart(f: Face) -> Face {
    let s = max(probe_grid.shadow_subdivision, 1u);
    var chart = f;
    chart.atlas_x = 0u;
    chart.atlas_y = 0u;
    chart.atlas_w = f.atlas_w * s;
    chart.atlas_h = f.atlas_h * s;
    chart.texel_density = f.texel_density * f32(s);
    return chart;
}

// Where a ray along `ray` meets moving triangle `index` (counted from view.moving_first) at
// `point`: its barycentrics (u, v), the smooth normal of its skinned corners turned to the side
// the ray sees, whether that side is the triangle's front, and its material.
struct MovingPoint {
    n: vec3<f32>,
    u: f32,
    v: f32,
    front: bool,
    material: MovingMaterial,
}

fn moving_point(index: u32, point: vec3<f32>, ray: vec3<f32>) -> MovingPoint {
    let tri = ray_triangles[view.moving_first + index];
    var out: MovingPoint;
    out.u = dot(tri.u.xyz, point) + tri.u.w;
    out.v = dot(tri.v.xyz, point) + tri.v.w;
    let m = moving_triangles[index];
    var n = m.n0.xyz * (1.0 - out.u - out.v) + m.n1.xyz * out.u + m.n2.xyz * out.v;
    n = select(tri.w.xyz, n, dot(n, n) > 1e-12);
    // the side the ray sees, by the triangle's own normal (tri.w: eye rays pass the same backs
    // by); the smooth normal turned to it. (By the smooth normal, the silhouettes of a body
    // seen from above turned to backs and took shadow rays per eye ray.)
    out.front = dot(tri.w.xyz, ray) <= 0.0;
    out.n = normalize(select(-n, n, dot(n, tri.w.xyz) >= 0.0 == out.front));
    out.material = moving_materials[bitcast<u32>(m.n0.w)];
    return out;
}

// Entry `slot` of the vertices' light (vertex_light's layout) of moving triangle `index`'s
// corners, interpolated at barycentrics (u, v).
fn corners_light(index: u32, u: f32, v: f32, slot: u32) -> vec3<f32> {
    let c = moving_corners[index] * 2u + vec4<u32>(slot);
    return vertex_light[c.x].xyz * (1.0 - u - v) + vertex_light[c.y].xyz * u + vertex_light[c.z].xyz * v;
}

// The radiance leaving moving triangle `index` (counted from view.moving_first) at `point`
// toward the ray's origin. The direct light: on the front, where the vertices carry it, their
// light interpolated over the triangle (what the corners' normals face; shadows and light across
// a triangle are as smooth as its corners), and with it the vertices' correction of the probes'
// light for what the objects hide of it and send themselves; on a back (an open mesh seen from
// behind, rare: eye rays pass moving backs by) or without it, shadow rays from the point and
// the probes' light as it is.
fn moving_radiance(index: u32, point: vec3<f32>, ray: vec3<f32>) -> vec3<f32> {
    let at = moving_point(index, point, ray);
    var e = irradiance_at(point, at.n);
    if probe_grid.vertex_light != 0u && at.front {
        e = max(e + corners_light(index, at.u, at.v, 0u) + corners_light(index, at.u, at.v, 1u), vec3<f32>(0.0));
    } else if SAMPLED_DIRECT != 0u {
        let seed = hash(bitcast<u32>(point.x) ^ hash(bitcast<u32>(point.y) ^ hash(bitcast<u32>(point.z))));
        e += direct_samples(point + at.n * 1e-3, at.n, seed, false, vec2<u32>(probe_grid.shadow_samples, probe_grid.sky_shadow_samples));
    }
    return at.material.albedo.xyz / PI * e + at.material.emission.xyz;
}

// Whether the tree at `root` (the scene's, 0, or the moving objects') blocks the segment from
// `origin` along `ray` (unit) before `reach`.
fn blocks(origin: vec3<f32>, ray: vec3<f32>, reach: f32, root: u32) -> bool {
    let hit = cast_bvh(origin, ray, root, NO_NODE, Hit(reach, NO_FACE, 0.0, 0.0), false);
    return hit.tri != NO_FACE && hit.t < reach;
}

// The emitting triangle for `u` (0..1), picked with its share of the power in one step through
// the alias table, and `u` stretched back over 0..1 within that pick (the sample set stays
// stratified on every triangle).
fn pick_emitter(u: f32) -> vec2<f32> {
    let n = probe_grid.emitter_count;
    let x = u * f32(n);
    let i = min(u32(x), n - 1u);
    let frac = clamp(x - f32(i), 0.0, 1.0);
    let entry = emitter_alias[i];
    let threshold = entry.x;
    if frac < threshold {
        return vec2<f32>(bitcast<f32>(i), frac / threshold);
    }
    return vec2<f32>(entry.y, (frac - threshold) / max(1.0 - threshold, 1e-30));
}

// An orthonormal frame around unit `normal` (columns: two tangents and the normal) for the
// cosine-distributed rays of a moving surface's sky samples and its vertices' occlusion rays
// (moving_light.wgsl).
fn moving_frame(normal: vec3<f32>) -> mat3x3<f32> {
    let t = normalize(select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(normal.x) > 0.9));
    let a = normalize(cross(normal, t));
    return mat3x3<f32>(a, cross(normal, a), normal);
}

// The direct irradiance at `origin` (facing `normal`) over counts.x shadow rays to the emitters,
// each to a point on a triangle picked by its share of their power (one rotated Hammersley set
// over all of them: the same cost whatever the number of lights), and counts.y cosine-weighted
// directions to the sky, counting the samples a moving object blocks and the scene does not
// (`blocked_only`: what the objects take from a static surface, common/moving_shadow.wgsl and
// shadow_atlas.wgsl) or those neither blocks (what reaches a moving surface). Each sample casts
// its ray against the moving objects first, and against the scene only where that decided it
// counts.
fn direct_samples(origin: vec3<f32>, normal: vec3<f32>, seed: u32, blocked_only: bool, counts: vec2<u32>) -> vec3<f32> {
    return direct_samples_part(origin, normal, seed, blocked_only, counts, vec2<u32>(0u, 1u));
}

// The part of direct_samples that samples part.x, part.x + part.y, ... of the set take (the
// emitters' first, then the sky's): part.y threads, one for each part.x, share one estimate
// (moving_light.wgsl) and their parts sum to it.
fn direct_samples_part(origin: vec3<f32>, normal: vec3<f32>, seed: u32, blocked_only: bool, counts: vec2<u32>, part: vec2<u32>) -> vec3<f32> {
    // the moving objects' two top boxes (one load, the same for every pixel): a point they are
    // wholly below the horizon of gets no shadow, and a shadow ray that enters neither is not cast
    let top = pairs[view.moving_root];
    let lo = min(top.lo_left, top.lo_right);
    // an empty side is a "never" box (moving.wgsl): the other side's corner stands for it
    let left_empty = top.lo_left.x >= 1e37;
    let right_empty = top.lo_right.x >= 1e37;
    let hi = max(select(top.hi_left, top.hi_right, left_empty), select(top.hi_right, top.hi_left, right_empty));
    let reach_corner = select(lo, hi, normal > vec3<f32>(0.0));
    if blocked_only && ((left_empty && right_empty) || dot(reach_corner - origin, normal) <= 0.0) {
        return vec3<f32>(0.0);
    }
    let shift = vec2<f32>(unit_float(hash(seed ^ 0x9e3779b9u)), unit_float(hash(seed + 0x632be5abu)));
    let n = select(counts.x, 0u, probe_grid.emitter_count == 0u);
    let sky = field.sky.xyz;
    let m = select(0u, counts.y, max(sky.x, max(sky.y, sky.z)) > 0.0);
    // a frame around the normal for the sky's cosine-weighted directions
    let frame = moving_frame(normal);
    var counted = vec3<f32>(0.0);
    // one ray cast in the loop (its code once in the pipeline): each sample's ray first against
    // the moving objects, and where they block it, again against the scene
    var k = part.x;
    var against_scene = false;
    loop {
        if k >= n + m {
            break;
        }
        var ray: vec3<f32>;
        var reach = 1e30;
        var carried = vec3<f32>(0.0);
        if k < n {
            // the sample's first coordinate picks the triangle and, stretched back, places the
            // point on it
            let u = hammersley(k, n, shift);
            let picked = pick_emitter(u.x);
            let em = emitters[bitcast<u32>(picked.x)];
            let chance = em.chance;
            let across = cross(em.e1, em.e2);
            let area = 0.5 * length(across);
            let r = sqrt(clamp(picked.y, 0.0, 1.0));
            let d = em.v0 + em.e1 * (1.0 - r) + em.e2 * (u.y * r) - origin;
            let dist = length(d);
            ray = d / dist;
            reach = dist * (1.0 - 1e-4);
            let cos_p = dot(normal, ray);
            let cos_e = -dot(across, ray) / (2.0 * area);
            let usable = cos_p > 0.0 && cos_e > 0.0 && chance > 0.0;
            carried = select(vec3<f32>(0.0), em.radiance.xyz * (cos_p * cos_e * area / (dist * dist * chance * f32(n))), usable);
        } else {
            ray = cosine_direction(frame, hammersley(k - n, m, shift.yx));
            carried = sky * (PI / f32(m));
        }
        let inv = 1.0 / select(ray, vec3<f32>(1e-20), abs(ray) < vec3<f32>(1e-20));
        let enters = box_entry(top.lo_left, top.hi_left, origin, inv, reach) >= 0.0 || box_entry(top.lo_right, top.hi_right, origin, inv, reach) >= 0.0;
        if max(carried.x, max(carried.y, carried.z)) <= 0.0 || (blocked_only && !against_scene && !enters) {
            k += part.y;
            continue;
        }
        // one cast a step: against the scene once the objects decided, else against the objects
        // (a ray that misses their boxes is not cast; WGSL's select would evaluate both casts)
        let hit = (against_scene || enters) && blocks(origin, ray, reach, select(view.moving_root, 0u, against_scene));
        if !against_scene && hit == blocked_only {
            against_scene = true;
            continue;
        }
        if against_scene && !hit {
            counted += carried;
        }
        against_scene = false;
        k += part.y;
    }
    return counted;
}
