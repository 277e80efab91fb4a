//! Normal maps in the light field: what a texel keeps so that a view can shade it with a
//! tilted normal, and the CPU twins of `shaders/common/normal_map.wgsl`.
//!
//! A texel holds one radiance, albedo x E(n) / pi, the irradiance at its face's normal n. A
//! normal map asks, per pixel, for E(n') at the mapped normal n'. A light field with normal maps
//! keeps per texel its *light direction* v: the irradiance vector of the direct
//! light from the emitters (`direct_vector` in shaders/direct.wgsl, shadowed as the direct light
//! is) divided by the texel's whole irradiance (luminance). v . n is the direct share of the
//! irradiance; the view scales the texel's radiance by
//! E(n') / E(n) = max(0, v . n') + max(0, (1 - v . n) (1 + n . n') / 2 + m . n')
//! ([`tilted_irradiance`], m below): the emitters keep their direction, the rest (the sky,
//! every bounce) gets the share a plane tilted to n' sees of uniform light over the hemisphere
//! above the surface, (1 + n . n') / 2, and m . n' for its own direction. Where
//! n' = n the factor is 1: a flat normal map shows exactly the texel. The rest is not quite
//! uniform (a wall beside a lit floor gets its indirect light from below): each texel keeps
//! a second vector m, the tangential first moment of the rest of its light,
//! the integral of L(w) (w - n (n . w)) over the hemisphere (`rest_vector` in
//! shaders/direct.wgsl, rays reading the converged radiance), over the whole irradiance, and a
//! plane tilted to n' receives m . n' more: for light L = a + b . w that is the first-order
//! change exactly. Colour is not split by direction: the factor multiplies all three channels.

use crate::gpu::types::{GpuFace, GpuMaterial, NO_FACE};
use crate::prepare::PreparedScene;
use glam::Vec3;

/// Per texel (one record each) the emitters' irradiance vector and the rest's moment, as the
/// two passes of shaders/direct.wgsl leave them (`Propagator::light_vectors`).
pub type LightVectors = (Vec<[f32; 4]>, Vec<[f32; 4]>);

/// Rec. 709 luminance, as shaders/direct.wgsl weighs the emitters.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// normal_map.wgsl's `tilted_irradiance`: a texel's irradiance at normal `n2` relative to that
/// at its face's normal `n`, from its light direction `v` and the rest's moment `m`.
pub fn tilted_irradiance(n: Vec3, n2: Vec3, v: Vec3, m: Vec3) -> f32 {
    let direct = v.dot(n).clamp(0.0, 1.0);
    let rest = 1.0 - direct;
    let at_n = v.dot(n).max(0.0) + rest;
    let at_n2 = v.dot(n2).max(0.0) + (rest * 0.5 * (1.0 + n.dot(n2)) + m.dot(n2)).max(0.0);
    if at_n > 1e-6 {
        at_n2 / at_n
    } else {
        1.0
    }
}

/// The texels' light directions and rest moments (`SurfaceDetail::texel_directions`, half
/// floats, two records per texel) from their emitter irradiance vectors and rest moments
/// (`vectors`, None without direct light: every texel then takes its light as uniform) and the
/// converged radiance `total`: v = vector / E and m = moment / E, where E is the
/// irradiance the texel's radiance says (pi x radiance / albedo, luminance over the channels
/// its albedo does not leave black). Emitting faces and texels without light keep v = 0.
pub fn texel_directions(
    vectors: Option<&LightVectors>,
    total: &[[f32; 4]],
    prepared: &PreparedScene,
    faces: &[GpuFace],
    materials: &[GpuMaterial],
) -> Vec<[u32; 2]> {
    let factors = prepared.atlas.texture_albedo.as_ref();
    // E per texel (0: none, an emitter, no light)
    let irradiance = |i: usize| -> f32 {
        let face = prepared.atlas.points[i][3].to_bits();
        if face == NO_FACE {
            return 0.0;
        }
        let f = &faces[face as usize];
        if crate::material::emitted(materials, f) != Vec3::ZERO {
            return 0.0;
        }
        let factor = factors.map_or(Vec3::ONE, |a| Vec3::from_slice(&a[i][..3]));
        let albedo = crate::material::material_of(materials, f).diffuse_reflectance() * factor;
        // the irradiance over the channels the albedo does not leave black
        let lit = albedo.cmpgt(Vec3::splat(1e-3));
        let radiance = Vec3::from_slice(&total[i][..3]);
        let e = Vec3::select(lit, radiance * std::f32::consts::PI / albedo, Vec3::ZERO);
        luminance(e) / luminance(Vec3::select(lit, Vec3::ONE, Vec3::ZERO)).max(1e-6)
    };
    let over = |e: f32, x: Option<&[f32; 4]>| match (e > 0.0, x) {
        (true, Some(x)) => [x[0] / e, x[1] / e, x[2] / e, 0.0],
        _ => [0.0; 4],
    };
    (0..total.len())
        .flat_map(|i| {
            let e = irradiance(i);
            let v = over(e, vectors.and_then(|(v, _)| v.get(i)));
            let m = over(e, vectors.and_then(|(_, m)| m.get(i)));
            [
                super::textures::pack_half_rgb(v),
                super::textures::pack_half_rgb(m),
            ]
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
            let m = Vec3::new(v.y, 0.2, 0.0);
            assert_eq!(tilted_irradiance(n, n, v, m), 1.0);
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
        assert!((tilted_irradiance(n, n2, v, Vec3::ZERO) - expected).abs() < 1e-5);
        // uniform light: the tilted plane sees (1 + cos) / 2 of it
        let uniform = tilted_irradiance(n, n2, Vec3::ZERO, Vec3::ZERO);
        assert!((uniform - 0.5 * (1.0 + tilt.cos())).abs() < 1e-6);
        // light from the tilt's side: more
        let m = Vec3::new(0.1, 0.0, 0.0);
        assert!(tilted_irradiance(n, n2, Vec3::ZERO, m) > uniform);
    }
}
