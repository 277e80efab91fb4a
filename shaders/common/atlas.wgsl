// Bilinear lookup in the diffuse texel atlas. Mirrored on the CPU by
// src/lightfield/atlas_lookup.rs::atlas_taps.

struct AtlasTaps {
    index: vec4<u32>,
    weight: vec4<f32>,
}

// The four texels around point p on face f, and their bilinear weights. Points outside the
// chart clamp to its outermost texels, which the padding keeps valid.
fn atlas_taps(f: Face, p: vec3<f32>, atlas_width: u32) -> AtlasTaps {
    let d = p - f.origin;
    let s = clamp(dot(d, f.axis_a) * f.texel_density - 0.5, 0.0, f32(f.atlas_w - 1u));
    let t = clamp(dot(d, f.axis_b) * f.texel_density - 0.5, 0.0, f32(f.atlas_h - 1u));
    let s0 = floor(s);
    let t0 = floor(t);
    let fs = s - s0;
    let ft = t - t0;
    let x0 = u32(s0);
    let y0 = u32(t0);
    let x1 = min(x0 + 1u, f.atlas_w - 1u);
    let y1 = min(y0 + 1u, f.atlas_h - 1u);
    let row0 = (f.atlas_y + y0) * atlas_width + f.atlas_x;
    let row1 = (f.atlas_y + y1) * atlas_width + f.atlas_x;
    var taps: AtlasTaps;
    taps.index = vec4<u32>(row0 + x0, row0 + x1, row1 + x0, row1 + x1);
    taps.weight = vec4<f32>((1.0 - fs) * (1.0 - ft), fs * (1.0 - ft), (1.0 - fs) * ft, fs * ft);
    return taps;
}
