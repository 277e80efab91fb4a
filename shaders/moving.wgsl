// Moving objects, every frame, driven by src/render/moving.rs: skin their vertices (one thread
// each: linear blend of up to four joints' matrices, a rigid object has one joint), turn each
// triangle into the renderer's affine map and shading record (one thread each), then refit the
// tree built once over their rest pose (one dispatch per level of it, deepest first: each pair
// takes its children's boxes). The renderer casts through that tree after the scene's
// (common/scene_cast.wgsl), so the objects are seen, and seen in mirrors, the frame they move.
#include "common/types.wgsl"

// mirrors gpu::types::GpuMovingParams
struct MovingParams {
    vertex_count: u32,
    triangle_count: u32,
    // the first moving triangle and pair in the renderer's buffers
    first_triangle: u32,
    first_pair: u32,
}

// mirrors gpu::types::GpuMovingVertex: the rest pose (normalised space of the object's mesh,
// before its joints' matrices), up to four joints and their weights (summing to 1)
struct MovingVertex {
    position: vec4<f32>,
    normal: vec4<f32>,
    joints: vec4<u32>,
    weights: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: MovingParams;
@group(0) @binding(1) var<storage, read> rest: array<MovingVertex>;
// joint matrices into the light field's normalised space; a hidden object's are all zero
@group(0) @binding(2) var<storage, read> joints: array<mat4x4<f32>>;
// skinned positions (w: 1 where the vertex is shown) and normals
@group(0) @binding(3) var<storage, read_write> posed: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> posed_normals: array<vec4<f32>>;
// each moving triangle's corners (indices into `rest`) and material, in the tree's order
@group(0) @binding(5) var<storage, read> corners: array<vec4<u32>>;
@group(0) @binding(6) var<storage, read_write> ray_triangles: array<RayTriangle>;
@group(0) @binding(7) var<storage, read_write> moving_triangles: array<MovingTriangle>;
@group(0) @binding(8) var<storage, read_write> pairs: array<BvhPair>;
// the pairs of each level of the tree, deepest level first, and this dispatch's level:
// [first entry of refit_order, count]
@group(0) @binding(9) var<storage, read> refit_order: array<u32>;
@group(1) @binding(0) var<uniform> level: vec4<u32>;

@compute @workgroup_size(64)
fn skin(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params.vertex_count {
        return;
    }
    let r = rest[i];
    var m = mat4x4<f32>(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var k = 0u; k < 4u; k++) {
        m += joints[r.joints[k]] * r.weights[k];
    }
    let p = m * vec4<f32>(r.position.xyz, 1.0);
    // a hidden object's matrices are zero: w = 0 marks its vertices
    let shown = abs(p.w) > 1e-6;
    posed[i] = vec4<f32>(p.xyz, select(0.0, 1.0, shown));
    // normals by the matrices' linear part (rigid and near-rigid joints: no inverse transpose)
    let n = (m * vec4<f32>(r.normal.xyz, 0.0)).xyz;
    posed_normals[i] = vec4<f32>(select(vec3<f32>(0.0), normalize(n), dot(n, n) > 1e-20), 0.0);
}

// The affine map of triangle (a, b, c), as GpuRayTriangle::new makes it (in f32 here): the
// inverse of p = a + u (b - a) + v (c - a) + w n.
fn ray_triangle_map(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> RayTriangle {
    let e1 = b - a;
    let e2 = c - a;
    let n = normalize(cross(e1, e2));
    // rows of the inverse of [e1 e2 n]: the reciprocal basis
    let det = dot(e1, cross(e2, n));
    let r1 = cross(e2, n) / det;
    let r2 = cross(n, e1) / det;
    let r3 = cross(e1, e2) / det;
    return RayTriangle(vec4<f32>(r1, -dot(r1, a)), vec4<f32>(r2, -dot(r2, a)), vec4<f32>(r3, -dot(r3, a)));
}

// a triangle no ray meets: u is -1 everywhere
const NO_TRIANGLE: RayTriangle = RayTriangle(vec4<f32>(0.0, 0.0, 0.0, -1.0), vec4<f32>(0.0), vec4<f32>(0.0, 0.0, 0.0, 1.0));

@compute @workgroup_size(64)
fn triangles(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params.triangle_count {
        return;
    }
    let c = corners[i];
    let a = posed[c.x];
    let b = posed[c.y];
    let d = posed[c.z];
    let area = length(cross(b.xyz - a.xyz, d.xyz - a.xyz));
    let shown = a.w * b.w * d.w > 0.0 && area > 1e-14;
    var map = NO_TRIANGLE;
    if shown {
        map = ray_triangle_map(a.xyz, b.xyz, d.xyz);
    }
    ray_triangles[params.first_triangle + i] = map;
    moving_triangles[i] = MovingTriangle(
        vec4<f32>(posed_normals[c.x].xyz, bitcast<f32>(c.w)),
        posed_normals[c.y],
        posed_normals[c.z],
    );
}

// a box no ray enters (bvh::bvh_pairs' "never")
const NEVER: f32 = 1.7014117e38;

struct Box {
    lo: vec3<f32>,
    hi: vec3<f32>,
}

// The smallest box around both (a "never" box is empty).
fn box_union(a: Box, b: Box) -> Box {
    if a.lo.x >= NEVER {
        return b;
    }
    if b.lo.x >= NEVER {
        return a;
    }
    return Box(min(a.lo, b.lo), max(a.hi, b.hi));
}

// The box of child reference `child`: a leaf's shown triangles, or an internal child's two boxes.
fn child_box(child: u32) -> Box {
    var b = Box(vec3<f32>(NEVER), vec3<f32>(-NEVER));
    if (child & 31u) == 0u {
        let p = pairs[child >> 5u];
        return box_union(Box(p.lo_left, p.hi_left), Box(p.lo_right, p.hi_right));
    }
    let first = (child >> 5u) - params.first_triangle;
    for (var t = first; t < first + (child & 31u); t++) {
        let c = corners[t];
        let a = posed[c.x];
        let d = posed[c.y];
        let e = posed[c.z];
        if a.w * d.w * e.w > 0.0 {
            b.lo = min(b.lo, min(a.xyz, min(d.xyz, e.xyz)));
            b.hi = max(b.hi, max(a.xyz, max(d.xyz, e.xyz)));
        }
    }
    if b.lo.x >= NEVER {
        b.hi = vec3<f32>(NEVER);
    }
    return b;
}

@compute @workgroup_size(64)
fn refit(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= level.y {
        return;
    }
    let pair = refit_order[level.x + gid.x];
    let p = pairs[pair];
    let left = child_box(p.left);
    let right = child_box(p.right);
    pairs[pair].lo_left = left.lo;
    pairs[pair].hi_left = left.hi;
    pairs[pair].lo_right = right.lo;
    pairs[pair].hi_right = right.hi;
}
