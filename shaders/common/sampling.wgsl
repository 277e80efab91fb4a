// Sample patterns shared by the stages that sample emitters and directions (direct.wgsl, the
// moving objects' shadows in common/moving_surface.wgsl): an integer hash, floats from its bits,
// the Hammersley set with a Cranley-Patterson rotation, and cosine-distributed directions.

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

// The cosine-distributed direction of the unit square's point u in `frame` (columns: two
// tangents and the normal).
fn cosine_direction(frame: mat3x3<f32>, u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    return frame[0] * (r * cos(phi)) + frame[1] * (r * sin(phi)) + frame[2] * sqrt(max(1.0 - u.x, 0.0));
}
