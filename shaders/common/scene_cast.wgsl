// The renderer's ray casting, shared by the stages that cast rays into the scene as the viewer
// sees it (render.wgsl, probes.wgsl): the triangles as affine maps, the BVH as child pairs, and
// cast_ray, what a ray meets first. The scene's triangles and, after them, the moving objects'
// (src/render/dynamic.rs refits their tree every frame) share the buffers. The including file
// binds `view: View`, `faces`, `triangles`, `pairs`, `ray_triangles` and the light field
// (`field.sky`), and defines `moving_radiance(triangle, point, ray) -> vec3<f32>`: what a moving
// object's triangle shows (a stage without moving objects returns black), and
// `const MOVING_OBJECTS: u32`: 0 compiles the moving objects' code out of the pipeline (a scene
// without them pays nothing for it, not even registers), 1 keeps it. A hit in a cut-out's hole
// is passed by (common/coverage.wgsl, which this file includes: the includer binds the
// light field's texture detail and includes common/textures.wgsl).
#include "common/coverage.wgsl"

// Where the ray meets the triangle's plane, and whether inside it, by the triangle's affine map
// to the unit triangle (Baldwin & Weber 2016): four dot products and no branch.
fn ray_triangle(origin: vec3<f32>, ray: vec3<f32>, tri: RayTriangle) -> f32 {
    let t = -(dot(tri.w.xyz, origin) + tri.w.w) / dot(tri.w.xyz, ray);
    let h = origin + ray * t;
    let u = dot(tri.u.xyz, h) + tri.u.w;
    let v = dot(tri.v.xyz, h) + tri.v.w;
    return select(-1.0, t, u >= 0.0 && v >= 0.0 && u + v <= 1.0);
}

// Whether the ray meets triangle i (at distance t) in a cut-out's hole; the moving objects'
// triangles have none.
fn ray_hole(i: u32, origin: vec3<f32>, ray: vec3<f32>, t: f32) -> bool {
    if ALPHA_MASKS == 0u || (MOVING_OBJECTS != 0u && i >= view.moving_first) {
        return false;
    }
    let map = ray_triangles[i];
    let h = origin + ray * t;
    let u = dot(map.u.xyz, h) + map.u.w;
    let v = dot(map.v.xyz, h) + map.v.w;
    let tri = triangles[i];
    return is_hole(tri.face, corners_uv(tri.uv01, tri.uv2.xy, u, v));
}

// no node: the traversal is done
const NO_NODE: u32 = 0xffffffffu;
// entries of the traversal stack: one per level of the tree at most; src/render/mod.rs sets it
// to what the scene's tree needs (bvh::BvhPairs::depth), since every entry is local memory
const PAIR_STACK: u32 = 64u;

// Closest hit, nearer than `nearest`, through the tree whose root pair is `root` (the scene's at
// 0; NO_NODE: none) and then the one at `then` (the moving objects', after the scene's; NO_NODE:
// none): one traversal and one stack for both, `then` waiting on the stack from the start. With
// `cull_moving_backs`, moving triangles met from behind are passed by (the eyes sit inside the
// avatar's head). Internal nodes are walked in a loop of their own (into the nearer
// child the ray enters, the farther one onto the stack with its entry distance), leaves tested
// after it, so the threads of a warp stay in step through the internal levels; an entry a hit
// found since has made too far is dropped when popped without reading anything.
fn cast_bvh(origin: vec3<f32>, ray: vec3<f32>, root: u32, then: u32, nearest: Hit, cull_moving_backs: bool) -> Hit {
    var hit = nearest;
    let safe = select(ray, vec3<f32>(1e-20), abs(ray) < vec3<f32>(1e-20));
    let inv_dir = 1.0 / safe;
    var stack: array<u32, PAIR_STACK>;
    var entry: array<f32, PAIR_STACK>;
    var top = 0u;
    if MOVING_OBJECTS != 0u && then != NO_NODE {
        stack[0] = then << 5u;
        entry[0] = 0.0;
        top = 1u;
    }
    var node = select(root << 5u, NO_NODE, root == NO_NODE);
    loop {
        while node != NO_NODE && (node & 31u) == 0u {
            let p = pairs[node >> 5u];
            let reach = hit.t * TIE;
            let t_left = box_entry(p.lo_left, p.hi_left, origin, inv_dir, reach);
            let t_right = box_entry(p.lo_right, p.hi_right, origin, inv_dir, reach);
            if t_left >= 0.0 && t_right >= 0.0 {
                let right_first = t_right < t_left;
                node = select(p.left, p.right, right_first);
                if top < PAIR_STACK {
                    stack[top] = select(p.right, p.left, right_first);
                    entry[top] = max(t_left, t_right);
                    top += 1u;
                }
            } else if t_left >= 0.0 {
                node = p.left;
            } else if t_right >= 0.0 {
                node = p.right;
            } else {
                node = NO_NODE;
            }
        }
        if node != NO_NODE {
            let first = node >> 5u;
            let end = first + (node & 31u);
            for (var i = first; i < end; i++) {
                let tri = ray_triangles[i];
                let t = ray_triangle(origin, ray, tri);
                let culled = MOVING_OBJECTS != 0u && cull_moving_backs && i >= view.moving_first && dot(tri.w.xyz, ray) > 0.0;
                if t > 1e-5 && !culled && closer(t, i, hit) && !ray_hole(i, origin, ray, t) {
                    hit.t = t;
                    hit.tri = i;
                }
            }
        }
        node = NO_NODE;
        while top > 0u {
            top -= 1u;
            if entry[top] < hit.t * TIE {
                node = stack[top];
                break;
            }
        }
        if node == NO_NODE {
            break;
        }
    }
    return hit;
}

// The ray meets nothing: the sky.
const SKY: u32 = 0xfffffffdu;
// The face id of the moving objects' triangles (src/render/dynamic.rs): after every face of
// the scene, so a static face wins a tie.
const MOVING_FACE: u32 = 0xfffffff0u;

// What a ray meets first.
struct Surface {
    // the face to look up (a stand-in, face 0, where the ray meets none)
    face: u32,
    // 1 where the ray meets a face, 0 where it meets the sky, an absorbing back or a moving
    // object
    seen: f32,
    // what the ray shows instead when it meets no face: the sky, black, or the moving object's
    // radiance (moving_radiance)
    background: vec3<f32>,
    point: vec3<f32>,
    // the triangle met (in `triangles` and `ray_triangles`; 0 where none), for the texture at
    // the point
    triangle: u32,
}

// `with_moving`: the moving objects are there to be met (eye rays; reflections where the view
// shows them in mirrors).
fn cast_ray(origin: vec3<f32>, ray: vec3<f32>, with_moving: bool) -> Surface {
    var hit = Hit(1e30, NO_FACE, 0.0, 0.0);
    if view.exhaustive_triangles > 0u {
        // a small mesh: every ray tests every triangle, the same work for every ray
        // two triangles a step: their tests are independent, which keeps the GPU's pipes full
        let n = view.exhaustive_triangles;
        for (var i = 0u; i < n; i += 2u) {
            let j = min(i + 1u, n - 1u);
            let ti = ray_triangle(origin, ray, ray_triangles[i]);
            let tj = ray_triangle(origin, ray, ray_triangles[j]);
            let found_i = ti > 1e-5 && closer(ti, i, hit) && !ray_hole(i, origin, ray, ti);
            hit.t = select(hit.t, ti, found_i);
            hit.tri = select(hit.tri, i, found_i);
            let found_j = tj > 1e-5 && closer(tj, j, hit) && !ray_hole(j, origin, ray, tj);
            hit.t = select(hit.t, tj, found_j);
            hit.tri = select(hit.tri, j, found_j);
        }
    }
    // the scene's tree (a small mesh was tested above), then the moving objects', refitted every
    // frame (none: NO_NODE), whose backs are not seen (from inside a body, the world)
    let root = select(0u, NO_NODE, view.exhaustive_triangles > 0u);
    let then = select(NO_NODE, view.moving_root, MOVING_OBJECTS != 0u && with_moving);
    if root != NO_NODE || then != NO_NODE {
        hit = cast_bvh(origin, ray, root, then, hit, true);
    }
    return hit_surface(hit, origin, ray);
}

// The surface a ray from `origin` along `ray` meets at `hit` (hit.tri NO_FACE: none), as
// cast_ray finds it, or as the visibility buffer names it (render.wgsl, raster_first_hit).
fn hit_surface(hit: Hit, origin: vec3<f32>, ray: vec3<f32>) -> Surface {
    var out: Surface;
    var id = SKY;
    var moving = false;
    if hit.tri != NO_FACE {
        let face = triangles[hit.tri].face;
        moving = MOVING_OBJECTS != 0u && face == MOVING_FACE;
        let f = select(face, 0u, moving);
        // the back of a one-sided face absorbs: its twin is NO_FACE, black
        id = select(faces[f].twin, f, dot(faces[f].normal, ray) < 0.0);
    }
    let none = id == NO_FACE || id == SKY || moving;
    out.seen = select(1.0, 0.0, none);
    out.face = select(id, 0u, none);
    // a stand-in point where the ray meets nothing: lookups stay finite, and are dropped
    out.point = select(origin + ray * hit.t, origin, hit.tri == NO_FACE);
    out.background = select(vec3<f32>(0.0), field.sky.xyz, id == SKY);
    out.triangle = select(hit.tri, 0u, hit.tri == NO_FACE);
    if MOVING_OBJECTS != 0u && moving {
        out.background = moving_radiance(hit.tri - view.moving_first, out.point, ray);
    }
    return out;
}
