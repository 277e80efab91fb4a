// Ray casting through a bounding volume hierarchy (src/bvh.rs::build_bvh), shared
// by the reference path tracer (reference.wgsl) and the renderer's primary rays (render.wgsl).
// The including file binds `triangles: array<Triangle>` and `nodes: array<BvhNode>`.

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

// mirrors reference::GpuBvhNode: leaf when count > 0 (first triangle in `index`), else
// `index` is the right child and the left child follows the node
struct BvhNode {
    lo: vec3<f32>,
    index: u32,
    hi: vec3<f32>,
    count: u32,
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

// Closest hit (any_hit: stop at the first one, for shadow rays). Children are tested when
// their parent is opened and only those the ray enters are pushed, nearer on top, each with the
// distance at which the ray enters it: an entry that a hit found since has made too far is
// dropped when popped, without reading its node.
fn trace(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, any_hit: bool) -> Hit {
    return trace_skipping(origin, dir, t_max, any_hit, NO_FACE, 0.0);
}

// The same, ignoring the triangles of face `skip` (a shadow ray leaving a face that is not
// quite planar must not meet the face itself).
fn trace_skipping(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, any_hit: bool, skip: u32, grow: f32) -> Hit {
    var hit = Hit(t_max, NO_FACE, 0.0, 0.0);
    let safe = select(dir, vec3<f32>(1e-20), abs(dir) < vec3<f32>(1e-20));
    let inv_dir = 1.0 / safe;
    let root = box_entry(nodes[0].lo, nodes[0].hi, origin, inv_dir, hit.t * TIE);
    if root < 0.0 {
        return hit;
    }
    var stack: array<u32, 64>;
    var entry: array<f32, 64>;
    var top = 1u;
    stack[0] = 0u;
    entry[0] = root;
    while top > 0u {
        top -= 1u;
        if entry[top] >= hit.t * TIE {
            continue;
        }
        let index = stack[top];
        let node = nodes[index];
        if node.count > 0u {
            for (var i = node.index; i < node.index + node.count; i++) {
                if triangles[i].face == skip {
                    continue;
                }
                let r = intersect_grown(origin, dir, triangles[i], hit.t * TIE, grow);
                if closer(r.x, i, hit) {
                    hit = Hit(r.x, i, r.y, r.z);
                    if any_hit {
                        return hit;
                    }
                }
            }
            continue;
        }
        let left = nodes[index + 1u];
        let right = nodes[node.index];
        let t_left = box_entry(left.lo, left.hi, origin, inv_dir, hit.t * TIE);
        let t_right = box_entry(right.lo, right.hi, origin, inv_dir, hit.t * TIE);
        if t_left >= 0.0 && t_right >= 0.0 {
            if top + 2u <= 64u {
                let right_first = t_right < t_left;
                stack[top] = select(node.index, index + 1u, right_first);
                entry[top] = select(t_right, t_left, right_first);
                stack[top + 1u] = select(index + 1u, node.index, right_first);
                entry[top + 1u] = select(t_left, t_right, right_first);
                top += 2u;
            }
        } else if (t_left >= 0.0 || t_right >= 0.0) && top < 64u {
            stack[top] = select(node.index, index + 1u, t_left >= 0.0);
            entry[top] = max(t_left, t_right);
            top += 1u;
        }
    }
    return hit;
}
