//! Normal maps in the light field: what a texel keeps so that a view can shade it with a
//! tilted normal, and the CPU twins of `shaders/common/normal_map.wgsl`.
//!
//! A texel holds one radiance, albedo x E(n) / pi, the irradiance at its face's normal n. A
//! normal map asks, per pixel, for E(n') at the mapped normal n'. A light field with normal maps
//! keeps per texel one more vector, its *light direction* v: the irradiance vector of the direct
//! light from the emitters (`direct_vector` in shaders/direct.wgsl, shadowed as the direct light
//! is) divided by the texel's whole irradiance (luminance). v . n is the direct share of the
//! irradiance; the view scales the texel's radiance by
//! E(n') / E(n) = max(0, v . n') + (1 - v . n) (1 + n . n') / 2 ([`tilted_irradiance`]): the
//! emitters keep their direction, the rest (the sky, every bounce) is taken as uniform over
//! the hemisphere above the surface, of which a plane tilted to n' sees (1 + n . n') / 2. Where
//! n' = n the factor is 1: a flat normal map shows exactly the texel. Colour is not split by
//! direction: the factor multiplies all three channels.

use crate::gpu::types::{GpuFace, GpuMaterial, NO_FACE};
use crate::prepare::PreparedScene;
use glam::Vec3;

/// Rec. 709 luminance, as shaders/direct.wgsl weighs the emitters.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// normal_map.wgsl's `tilted_irradiance`: a texel's irradiance at normal `n2` relative to that
/// at its face's normal `n`, from its light direction `v`.
pub fn tilted_irradiance(n: Vec3, n2: Vec3, v: Vec3) -> f32 {
    let direct = v.dot(n).clamp(0.0, 1.0);
    let rest = 1.0 - direct;
    let at_n = v.dot(n).max(0.0) + rest;
    let at_n2 = v.dot(n2).max(0.0) + rest * 0.5 * (1.0 + n.dot(n2));
    if at_n > 1e-6 {
        at_n2 / at_n
    } else {
        1.0
    }
}

/// The texels' light directions (`SurfaceDetail::texel_directions`, half floats) from their
/// emitter irradiance vectors (`vectors`, None without direct light: every texel then takes
/// its light as uniform) and the converged radiance `total`: v = vector / E, where E is the
/// irradiance the texel's radiance says (pi x radiance / albedo, luminance over the channels
/// its albedo does not leave black). Emitting faces and texels without light keep v = 0.
pub fn texel_directions(
    vectors: Option<&[[f32; 4]]>,
    total: &[[f32; 4]],
    prepared: &PreparedScene,
    faces: &[GpuFace],
    materials: &[GpuMaterial],
) -> Vec<[u32; 2]> {
    let factors = prepared.atlas.texture_albedo.as_ref();
    let texel = |i: usize, vector: &[f32; 4]| -> Vec3 {
        let face = prepared.atlas.points[i][3].to_bits();
        if face == NO_FACE {
            return Vec3::ZERO;
        }
        let f = &faces[face as usize];
        if crate::material::emitted(materials, f) != Vec3::ZERO {
            return Vec3::ZERO;
        }
        let factor = factors.map_or(Vec3::ONE, |a| Vec3::from_slice(&a[i][..3]));
        let albedo = crate::material::material_of(materials, f).diffuse_reflectance() * factor;
        // the irradiance over the channels the albedo does not leave black
        let lit = albedo.cmpgt(Vec3::splat(1e-3));
        let radiance = Vec3::from_slice(&total[i][..3]);
        let e = Vec3::select(lit, radiance * std::f32::consts::PI / albedo, Vec3::ZERO);
        let e = luminance(e) / luminance(Vec3::select(lit, Vec3::ONE, Vec3::ZERO)).max(1e-6);
        match e > 0.0 {
            true => Vec3::from_slice(&vector[..3]) / e,
            false => Vec3::ZERO,
        }
    };
    (0..total.len())
        .map(|i| {
            let v = match vectors.and_then(|v| v.get(i)) {
                Some(vector) => texel(i, vector),
                None => Vec3::ZERO,
            };
            super::textures::pack_half_rgb([v.x, v.y, v.z, 0.0])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_normal_keeps_the_texel() {
        let n = Vec3::Z;
        for v in [
            Vec3::ZERO,
            Vec3::new(0.3, 0.0, 0.5),
            Vec3::new(0.0, 0.9, 0.2),
        ] {
            assert_eq!(tilted_irradiance(n, n, v), 1.0);
        }
    }

    #[test]
    fn a_small_emitter_follows_the_cosine_and_uniform_light_the_visible_hemisphere() {
        let n = Vec3::Z;
        // all light from one direction 70 degrees off the normal
        let d = Vec3::new(70f32.to_radians().sin(), 0.0, 70f32.to_radians().cos());
        let v = d / d.dot(n);
        let tilt = 20f32.to_radians();
        let n2 = Vec3::new(tilt.sin(), 0.0, tilt.cos());
        let expected = d.dot(n2) / d.dot(n);
        assert!((tilted_irradiance(n, n2, v) - expected).abs() < 1e-5);
        // uniform light: the tilted plane sees (1 + cos) / 2 of it
        let uniform = tilted_irradiance(n, n2, Vec3::ZERO);
        assert!((uniform - 0.5 * (1.0 + tilt.cos())).abs() < 1e-6);
    }
}
