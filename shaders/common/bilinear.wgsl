// The texel lookup of textures and a triangle's texture coordinates, which read no binding:
// included by common/textures.wgsl, and by the stages that test cut-outs without sampling
// colour (common/coverage.wgsl in propagation).

// The four texels around `uv` of a texture with record `info` (first texel, width, height), in
// the order (x0 y0, x1 y0, x0 y1, x1 y1), wrapping, and the weights between them: the one
// lookup texture_at and the cut-outs' coverage (common/coverage.wgsl) share. Reads no binding.
struct BilinearTaps {
    index: vec4<u32>,
    f: vec2<f32>,
}

fn bilinear_taps(info: vec4<u32>, uv: vec2<f32>) -> BilinearTaps {
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
    let index = vec4<u32>(u32(y0 * w + x0), u32(y0 * w + x1), u32(y1 * w + x0), u32(y1 * w + x1));
    return BilinearTaps(vec4<u32>(info.x) + index, f);
}

// The texture coordinates at barycentric (u, v) of a triangle whose corners have uv01.xy,
// uv01.zw and uv2.xy.
fn corners_uv(uv01: vec4<f32>, uv2: vec2<f32>, u: f32, v: f32) -> vec2<f32> {
    return uv01.xy * (1.0 - u - v) + uv01.zw * u + uv2 * v;
}
