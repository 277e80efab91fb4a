// Normal maps (src/material.rs, NormalMap): the shading normal at a point of a triangle, and
// what it does to a diffuse texel's irradiance. Included by render.wgsl and reference.wgsl after
// common/ray.wgsl (Triangle) and common/textures.wgsl (texture_at); the includer's driver sets
// NORMAL_MAPS (0 compiles the normal maps out of a scene without them). CPU twins:
// src/lightfield/normal_map.rs.

// The shading normal at texture coordinates `uv` of triangle `tri` (face normal n): the normal
// texture's 2 rgb - 1, x and y times `scale`, in the frame (T, B, n) of the triangle's texture
// coordinates: T the direction of growing u in the plane, B = n x T, turned to the side of
// growing v (mirrored coordinates). n itself where the coordinates are degenerate.
fn mapped_normal(n: vec3<f32>, tri: Triangle, texture: u32, scale: f32, uv: vec2<f32>) -> vec3<f32> {
    let d1 = tri.uv01.zw - tri.uv01.xy;
    let d2 = tri.uv2.xy - tri.uv01.xy;
    let det = d1.x * d2.y - d2.x * d1.y;
    if abs(det) < 1e-20 {
        return n;
    }
    let dpdu = (tri.e1 * d2.y - tri.e2 * d1.y) / det;
    let dpdv = (tri.e2 * d1.x - tri.e1 * d2.x) / det;
    let tangent = dpdu - n * dot(n, dpdu);
    if dot(tangent, tangent) < 1e-30 {
        return n;
    }
    let t = normalize(tangent);
    let b = cross(n, t) * select(1.0, -1.0, dot(cross(n, t), dpdv) < 0.0);
    let c = texture_at(texture, uv) * 2.0 - 1.0;
    let m = vec3<f32>(c.xy * scale, c.z);
    if dot(m, m) < 1e-12 {
        return n;
    }
    return normalize(t * m.x + b * m.y + n * m.z);
}

// A texel's irradiance at the tilted normal n2 relative to that at its face's normal n, from
// its light direction v and rest moment m (src/lightfield/textures.rs, texel_directions): v is
// the irradiance vector of its emitters' light over its whole irradiance, so v . n is their
// share of it. The emitters' light keeps its direction (max(0, v . n2): exact for a small
// emitter, the irradiance vector's rule for a large one); the rest (sky, every bounce) is
// taken as uniform over the hemisphere above the surface, of which a plane tilted to n2 sees
// (1 + n . n2) / 2, plus m . n2, m the tangential first moment of that rest over the whole
// irradiance (the first-order change for light a + b . w). n2 = n gives 1.
fn tilted_irradiance(n: vec3<f32>, n2: vec3<f32>, v: vec3<f32>, m: vec3<f32>) -> f32 {
    let direct = clamp(dot(v, n), 0.0, 1.0);
    let rest = 1.0 - direct;
    let at_n = max(dot(v, n), 0.0) + rest;
    let at_n2 = max(dot(v, n2), 0.0) + max(rest * 0.5 * (1.0 + dot(n, n2)) + dot(m, n2), 0.0);
    return select(1.0, at_n2 / at_n, at_n > 1e-6);
}
