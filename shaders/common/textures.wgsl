// Diffuse and emission textures sampled at a point, the one sampler of the stages that read
// textures per point: the path tracer (reference.wgsl) and the renderer's texture detail
// (common/light_field.wgsl, src/lightfield/textures.rs builds the arrays). The including file
// binds `texture_info: array<vec4<u32>>` (per texture: first texel, width, height) and
// `texture_texels: array<vec4<f32>>` (linear rgb, a cut-out's coverage in w), and includes common/types.wgsl (NO_FACE).
// The CPU twin is scene::Texture::sample.
#include "common/bilinear.wgsl"

// Texture `texture` at `uv`, bilinear with wrapping; v = 0 is the image's bottom row (OBJ
// convention). 1 for NO_FACE (no texture).
fn texture_at(texture: u32, uv: vec2<f32>) -> vec3<f32> {
    return texture_rgba_at(texture, uv).xyz;
}

// The same with the fourth channel (a specular texture's GGX alpha, a coverage); 1 for NO_FACE.
fn texture_rgba_at(texture: u32, uv: vec2<f32>) -> vec4<f32> {
    if texture == NO_FACE {
        return vec4<f32>(1.0);
    }
    let taps = bilinear_taps(texture_info[texture], uv);
    let a = texture_texels[taps.index.x];
    let b = texture_texels[taps.index.y];
    let c = texture_texels[taps.index.z];
    let d = texture_texels[taps.index.w];
    return mix(mix(a, b, taps.f.x), mix(c, d, taps.f.x), taps.f.y);
}
