//! Normalisation: the centre and scale that map a scene's world units (metres) into the sphere
//! the light field lives in (its grids cover [-1, 1]^2). Part of the scene, which frames its
//! default camera with it; preparation applies it.

use glam::DVec3;

/// The scene is scaled so that it fits in a sphere of this radius (grids cover [-1, 1]^2).
pub const NORMALISED_RADIUS: f64 = 0.99;

/// Maps world (metres) to the normalised space the light field lives in.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Normalisation {
    pub center: [f64; 3],
    pub scale: f64,
}

impl Normalisation {
    pub fn to_unit(&self, p: [f32; 3]) -> DVec3 {
        (DVec3::from(p.map(|x| x as f64)) - DVec3::from(self.center)) * self.scale
    }
}

/// The centre and scale that fit the positions into the sphere of [`NORMALISED_RADIUS`].
pub fn normalise(positions: &[[f32; 3]]) -> Normalisation {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in positions {
        let p = DVec3::from(p.map(|x| x as f64));
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let center = (lo + hi) * 0.5;
    let radius = positions
        .iter()
        .map(|p| (DVec3::from(p.map(|x| x as f64)) - center).length())
        .fold(0.0, f64::max)
        .max(1e-12);
    Normalisation {
        center: center.into(),
        scale: NORMALISED_RADIUS / radius,
    }
}
