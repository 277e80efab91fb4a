//! The sRGB transfer curve, both ways: textures are decoded with it on the way in (scene) and
//! images encoded with it on the way out (render, displays).

/// sRGB encoding of a linear value in [0, 1].
pub fn srgb_encode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear value of an 8-bit sRGB-encoded component.
pub fn srgb_decode(c: u8) -> f32 {
    let x = c as f32 / 255.0;
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}
