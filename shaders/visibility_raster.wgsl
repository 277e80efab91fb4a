// Raster first hits, driven by src/render/raster.rs: the hardware rasteriser draws the
// renderer's triangles (vertex pulling from the ray-casting buffers: the scene's in BVH order,
// then the moving objects') with the view's view_proj and a depth test, into a multisampled
// visibility buffer holding, per MSAA sample, the triangle met plus one (0: nothing, the sky).
// render.wgsl then reads each sample's triangle instead of casting its eye ray (first_hit).
// What is drawn is what cast_ray meets:
// - no face culling: the back of a one-sided face occludes (it shows black, as cast_ray's does);
// - the moving objects' backs are not drawn (cast_bvh's cull_moving_backs: the eyes sit inside
//   the avatar's head), and a hidden object's triangles (a map with no area) are not drawn.
#include "common/types.wgsl"
#include "common/ray.wgsl"

// 1: the renderer draws moving objects (src/render/raster.rs sets 0 for one without them)
const MOVING_OBJECTS: u32 = 1u;

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;
// the triangles as affine maps (common/scene_cast.wgsl); the moving objects' are refitted every
// frame (moving.wgsl), their records in `triangles` are not
@group(0) @binding(2) var<storage, read> ray_triangles: array<RayTriangle>;

struct Corner {
    @builtin(position) position: vec4<f32>,
    // the triangle plus one
    @location(0) @interpolate(flat) id: u32,
}

// Where nothing is drawn: all three corners here make a triangle of no area beyond the far plane.
const NOT_DRAWN: vec4<f32> = vec4<f32>(0.0, 0.0, 2.0, 1.0);

// Corner `vertex % 3` of triangle `vertex / 3`.
@vertex
fn triangle_corner(@builtin(vertex_index) vertex: u32) -> Corner {
    let i = vertex / 3u;
    let corner = vertex % 3u;
    var out: Corner;
    out.id = i + 1u;
    if MOVING_OBJECTS != 0u && i >= view.moving_first {
        // a moving triangle's corners from its map's inverse (the map's rows are the inverse
        // of [e1 e2 n] with the corner a in its last column)
        let map = ray_triangles[i];
        let det = dot(map.u.xyz, cross(map.v.xyz, map.w.xyz));
        let e1 = cross(map.v.xyz, map.w.xyz) / det;
        let e2 = cross(map.w.xyz, map.u.xyz) / det;
        let n = cross(map.u.xyz, map.v.xyz) / det;
        let a = -(map.u.w * e1 + map.v.w * e2 + map.w.w * n);
        let p = a + select(vec3<f32>(0.0), e1, corner == 1u) + select(vec3<f32>(0.0), e2, corner == 2u);
        // seen from behind (the eye on the plane's negative side) it is not seen, as an eye ray
        // along which dot(w, ray) > 0 passes it by
        let front = dot(map.w.xyz, view.eye) + map.w.w >= 0.0;
        out.position = select(NOT_DRAWN, view.view_proj * vec4<f32>(p, 1.0), det != 0.0 && front);
        return out;
    }
    let t = triangles[i];
    let p = t.v0 + select(vec3<f32>(0.0), t.e1, corner == 1u) + select(vec3<f32>(0.0), t.e2, corner == 2u);
    out.position = view.view_proj * vec4<f32>(p, 1.0);
    return out;
}

// The triangle in two 16-bit halves (an Rg16Uint target: 4x MSAA on every adapter, which R32Uint
// is not).
@fragment
fn mark_triangle(@location(0) @interpolate(flat) id: u32) -> @location(0) vec2<u32> {
    return vec2<u32>(id & 0xffffu, id >> 16u);
}
