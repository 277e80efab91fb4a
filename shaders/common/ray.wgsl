// What every ray cast shares (the BVH traversal of common/bvh.wgsl and the renderer's own in
// render.wgsl): the triangle as stored in BVH order, the closest hit, the ray-triangle and
// ray-box tests and the tie rule. The including file binds `triangles: array<Triangle>`.

// mirrors reference::GpuTriangle: corner, edges, face, and the corners' texture coordinates
struct Triangle {
    v0: vec3<f32>,
    face: u32,
    e1: vec3<f32>,
    _pad0: u32,
    e2: vec3<f32>,
    _pad1: u32,
    uv01: vec4<f32>,
    uv2: vec4<f32>,
}

struct Hit {
    t: f32,
    tri: u32,
    u: f32,
    v: f32,
}

fn intersect(origin: vec3<f32>, dir: vec3<f32>, tri: Triangle, t_max: f32) -> vec3<f32> {
    return intersect_grown(origin, dir, tri, t_max, 0.0);
}

// The same, with the triangle grown by `grow` in barycentric terms: shadow rays use it so that
// none slips through the crack between two triangles that share an edge (Moller-Trumbore is not
// watertight), which an emitter a million times brighter behind a wall would amplify.
fn intersect_grown(origin: vec3<f32>, dir: vec3<f32>, tri: Triangle, t_max: f32, grow: f32) -> vec3<f32> {
    let p = cross(dir, tri.e2);
    let det = dot(tri.e1, p);
    if abs(det) < 1e-12 {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let inv = 1.0 / det;
    let s = origin - tri.v0;
    let u = dot(s, p) * inv;
    if u < -grow || u > 1.0 + grow {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let q = cross(s, tri.e1);
    let v = dot(dir, q) * inv;
    if v < -grow || u + v > 1.0 + grow {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let t = dot(tri.e2, q) * inv;
    if t <= 1e-5 || t >= t_max {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    return vec3<f32>(t, u, v);
}

fn box_entry(lo: vec3<f32>, hi: vec3<f32>, origin: vec3<f32>, inv_dir: vec3<f32>, t_max: f32) -> f32 {
    let a = (lo - origin) * inv_dir;
    let b = (hi - origin) * inv_dir;
    let t0 = max(max(min(a.x, b.x), min(a.y, b.y)), min(a.z, b.z));
    let t1 = min(min(max(a.x, b.x), max(a.y, b.y)), max(a.z, b.z));
    if t1 >= max(t0, 0.0) && t0 < t_max {
        return max(t0, 0.0);
    }
    return -1.0;
}

// Hits this close (relative) count as a tie: coplanar duplicated faces. The lower face id wins
// a tie (then the lower triangle), so one whole face shows, the same from every viewpoint and
// in every run: no patchwork, no flicker.
const TIE: f32 = 1.000001;

fn closer(t: f32, tri: u32, hit: Hit) -> bool {
    if t <= 0.0 {
        return false;
    }
    if hit.tri == NO_FACE || t * TIE < hit.t {
        return true;
    }
    if t > hit.t * TIE {
        return false;
    }
    let face = triangles[tri].face;
    let other = triangles[hit.tri].face;
    return face < other || (face == other && tri < hit.tri);
}

