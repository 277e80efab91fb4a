// The sRGB encoding, for targets that do not encode themselves: present.wgsl's windows and the
// headset's eyes (common/eye_colour.wgsl).

fn encode_srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}
