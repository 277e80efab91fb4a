// Sample patterns shared by the stages that sample emitters and directions (direct.wgsl, the
// moving objects' shadows in common/moving_surface.wgsl): an integer hash, floats from its bits,
// and the Hammersley set with a Cranley-Patterson rotation.

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

fn unit_float(bits: u32) -> f32 {
    return f32(bits >> 8u) * (1.0 / 16777216.0);
}

fn radical_inverse(k: u32) -> f32 {
    return unit_float(reverseBits(k));
}

// Point `k` of an `n`-point Hammersley set, rotated (Cranley-Patterson) by `shift`.
fn hammersley(k: u32, n: u32, shift: vec2<f32>) -> vec2<f32> {
    return fract(vec2<f32>((f32(k) + 0.5) / f32(n), radical_inverse(k)) + shift);
}
