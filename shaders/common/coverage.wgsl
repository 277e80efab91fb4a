// Cut-outs (glTF alphaMode MASK, MTL map_d; src/material.rs: Cutout): the one test of whether a
// surface is there at a point, which every stage that meets surfaces asks: propagation's cell
// lines (visibility.wgsl), the BVH casts of direct light's shadow rays, rim rays and the path
// tracer (common/bvh.wgsl), the renderer's eye, mirror and moving objects' shadow rays
// (common/scene_cast.wgsl). The including file binds `face_textures: array<vec4<u32>>` (per face:
// diffuse, emission, coverage texture, cutoff bits; src/lightfield/textures.rs) and the textures
// of common/textures.wgsl, and includes that file.
//
// `const ALPHA_MASKS: u32`: 0 (the default) compiles the test out, so a scene without cut-outs
// pays nothing for it; the drivers set 1 for a scene with one (gpu::shaders::module_with).
const ALPHA_MASKS: u32 = 0u;

// Whether face `face` is a hole at texture coordinates `uv`: its coverage, bilinear, below its
// cutoff. A face without a cut-out has cutoff 0 and is never one.
fn is_hole(face: u32, uv: vec2<f32>) -> bool {
    if ALPHA_MASKS == 0u {
        return false;
    }
    let t = face_textures[face];
    let cutoff = bitcast<f32>(t.w);
    return cutoff > 0.0 && texture_alpha(t.z, uv) < cutoff;
}
