// Ray casting through a bounding volume hierarchy (src/bvh.rs::build_bvh), shared by the
// reference path tracer (reference.wgsl) and the shadow rays of direct light (direct.wgsl); the
// renderer casts through the same tree stored as child pairs (render.wgsl, cast_bvh).
// The including file binds `triangles: array<Triangle>`, `nodes: array<BvhNode>` and
// `faces: array<Face>`, and what common/coverage.wgsl asks (cut-outs: a hit in a hole is passed
// by).
#include "common/ray.wgsl"
#include "common/coverage.wgsl"

// mirrors reference::GpuBvhNode: leaf when count > 0 (first triangle in `index`), else
// `index` is the right child and the left child follows the node
struct BvhNode {
    lo: vec3<f32>,
    index: u32,
    hi: vec3<f32>,
    count: u32,
}

// Closest hit (any_hit: stop at the first one, for shadow rays). Children are tested when
// their parent is opened and only those the ray enters are pushed, nearer on top, each with the
// distance at which the ray enters it: an entry that a hit found since has made too far is
// dropped when popped, without reading its node.
fn trace(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, any_hit: bool) -> Hit {
    return trace_skipping(origin, dir, t_max, any_hit, NO_FACE, 0.0);
}

// The same, ignoring the triangles of face `skip` and of its twin, the other side of a
// two-sided surface (a shadow ray leaving a face that is not quite planar must not meet the
// face itself: its texels lie on the face's mean plane, which runs behind part of the
// triangles, where a ray would meet the twin's front). The including file binds `faces`.
fn trace_skipping(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, any_hit: bool, skip: u32, grow: f32) -> Hit {
    var hit = Hit(t_max, NO_FACE, 0.0, 0.0);
    var skip_twin = NO_FACE;
    if skip < UNRESOLVED {
        skip_twin = faces[skip].twin;
    }
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
                if triangles[i].face == skip || triangles[i].face == skip_twin {
                    continue;
                }
                let r = intersect_grown(origin, dir, triangles[i], hit.t * TIE, grow);
                if closer(r.x, i, hit) && !triangle_hole(triangles[i], r.y, r.z) {
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

// Whether triangle `tri` is a hole at barycentric (u, v) (common/coverage.wgsl).
fn triangle_hole(tri: Triangle, u: f32, v: f32) -> bool {
    if ALPHA_MASKS == 0u {
        return false;
    }
    return is_hole(tri.face, corners_uv(tri.uv01, tri.uv2.xy, u, v));
}
