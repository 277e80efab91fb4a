// Diffuse, emission and coverage textures sampled at a point, the one sampler of the stages that read
// textures per point: the path tracer (reference.wgsl) and the renderer's texture detail
// (common/light_field.wgsl, src/lightfield/textures.rs builds the arrays). The including file
// binds `texture_info: array<vec4<u32>>` (per texture: first texel, width, height) and
// `texture_texels: array<vec4<f32>>` (linear rgb, coverage in w), and includes common/types.wgsl (NO_FACE).
// The CPU twin is scene::Texture::sample.

// Texture `texture` at `uv`, bilinear with wrapping; v = 0 is the image's bottom row (OBJ
// convention). 1 for NO_FACE (no texture).
fn texture_at(texture: u32, uv: vec2<f32>) -> vec3<f32> {
    if texture == NO_FACE {
        return vec3<f32>(1.0);
    }
    return texture_bilinear(texture, uv).xyz;
}

// Its coverage (w: the alpha src/lightfield/textures.rs stores, 1 for a texture without one),
// sampled as texture_at samples the colour; twin scene::Texture::coverage.
fn texture_alpha(texture: u32, uv: vec2<f32>) -> f32 {
    return texture_bilinear(texture, uv).w;
}

fn texture_bilinear(texture: u32, uv: vec2<f32>) -> vec4<f32> {
    let info = texture_info[texture];
    let size = vec2<f32>(f32(info.y), f32(info.z));
    let p = vec2<f32>(fract(uv.x), 1.0 - fract(uv.y)) * size - 0.5;
    let p0 = floor(p);
    let f = p - p0;
    let w = i32(info.y);
    let h = i32(info.z);
    let x0 = (i32(p0.x) % w + w) % w;
    let y0 = (i32(p0.y) % h + h) % h;
    let x1 = (x0 + 1) % w;
    let y1 = (y0 + 1) % h;
    let a = texture_texels[info.x + u32(y0 * w + x0)];
    let b = texture_texels[info.x + u32(y0 * w + x1)];
    let c = texture_texels[info.x + u32(y1 * w + x0)];
    let d = texture_texels[info.x + u32(y1 * w + x1)];
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

// The texture coordinates at barycentric (u, v) of a triangle whose corners have uv01.xy,
// uv01.zw and uv2.xy.
fn corners_uv(uv01: vec4<f32>, uv2: vec2<f32>, u: f32, v: f32) -> vec2<f32> {
    return uv01.xy * (1.0 - u - v) + uv01.zw * u + uv2 * v;
}
