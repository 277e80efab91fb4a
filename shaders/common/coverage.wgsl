// Cut-outs (glTF alphaMode MASK, MTL map_d; src/material.rs: Cutout): the one test of whether a
// surface is there at a point, which every stage that meets surfaces asks: propagation's cell
// lines (visibility.wgsl), the BVH casts of direct light's shadow rays, rim rays and the path
// tracer (common/bvh.wgsl), the renderer's eye, mirror and moving objects' shadow rays
// (common/scene_cast.wgsl). Needs common/textures.wgsl (bilinear_taps) and three functions of
// the includer, which say where its copy of the coverage lies:
//   cutout_of(face) -> vec2<u32>: the face's coverage texture and cutoff bits (0, 0: none);
//   coverage_info(texture) -> vec4<u32>: the texture's first texel, width, height;
//   coverage_texel(index) -> f32: a texel's coverage.
// common/texture_cutouts.wgsl reads them from the surface textures (renderer, path tracer),
// common/packed_cutouts.wgsl from propagation's one packed array (src/lightfield/textures.rs:
// SurfaceTextures::packed_cutouts); a stage that never cuts returns none.
//
// `const ALPHA_MASKS: u32`: 0 (the default) compiles the test out, so a scene without cut-outs
// pays nothing for it; the drivers set 1 for a scene with one (gpu::shaders::module_with).
const ALPHA_MASKS: u32 = 0u;

// Whether face `face` is a hole at texture coordinates `uv`: its coverage, bilinear (as
// texture_at samples colour), below its cutoff. A face without a cut-out has cutoff 0 and is
// never one. Twin: scene::Texture::coverage.
fn is_hole(face: u32, uv: vec2<f32>) -> bool {
    if ALPHA_MASKS == 0u {
        return false;
    }
    let cut = cutout_of(face);
    let cutoff = bitcast<f32>(cut.y);
    if cutoff <= 0.0 {
        return false;
    }
    let taps = bilinear_taps(coverage_info(cut.x), uv);
    let top = mix(coverage_texel(taps.index.x), coverage_texel(taps.index.y), taps.f.x);
    let bottom = mix(coverage_texel(taps.index.z), coverage_texel(taps.index.w), taps.f.x);
    return mix(top, bottom, taps.f.y) < cutoff;
}
