//! A glTF metallic-roughness material whose metal varies over its surface, split per texel.
//!
//! The rules of docs/guide/gltf.md decide each texel of the material's textures as they decide a
//! material without textures: metallic (factor x the texture's blue) at least 0.5 and roughness
//! (factor x green) at most 0.6 make the texel a metal, whose specular part reflects the base
//! colour (factor x texture) with GGX alpha roughness²; every other texel is diffuse of the base
//! colour. The split gives two textures on the base colour's texel grid (the metallic-roughness
//! texture sampled bilinearly there, or its own grid without a base colour texture):
//! - the diffuse part's: the base colour where the texel is not a metal, 0 where it is;
//! - the specular part's: the base colour where the texel is a metal (rgb) and the texel's GGX
//!   alpha (the coverage channel, `Texture::alpha`; a dielectric texel takes the metal's mean,
//!   so bilinear lookups at a border do not sharpen the lobe).
//!
//! The material's `diffuse` and `mirror` become the base colour factor times each texture's mean,
//! and the textures are divided by those means: the factors are the surface's mean reflectances,
//! what propagation carries where it cannot read a texture per point (the mirror tiles), and the
//! product factor x texture is the texel's own value. `roughness` becomes the alpha whose mean
//! albedo is the metal texels' reflectance-weighted mean albedo, so the specular light that
//! propagation carries is the surface's mean.
//!
//! A metal with a base colour texture and no metallic-roughness texture is the same split with
//! every texel a metal.

use crate::material::{ggx_mean_albedo, GLOSSY_ROUGHNESS, MIRROR_METALLIC, MIRROR_ROUGHNESS};
use crate::scene::Texture;
use std::path::PathBuf;

/// The smallest GGX alpha a texel of a glossy material takes: a metal texel smooth enough to be
/// an ideal mirror (roughness at most 0.2) in a material whose other metal texels are glossy is
/// shown as this narrow lobe, which no display resolves from a mirror.
pub const MIN_TEXEL_ALPHA: f32 = 1e-3;

/// The metallic and roughness factors and the metallic-roughness texture (raw values in
/// [0, 1]: roughness in green, metallic in blue), if the material has one.
pub struct MetalRough<'t> {
    pub metallic: f32,
    pub roughness: f32,
    pub texture: Option<&'t Texture>,
}

/// What a split material becomes (see the module's header).
#[derive(Debug)]
pub struct Split {
    /// the base colour factor times the diffuse texture's mean (0: no diffuse part)
    pub diffuse: [f32; 3],
    /// the base colour factor times the specular texture's mean (0: no specular part)
    pub mirror: [f32; 3],
    /// the GGX alpha of the specular part's mean albedo; 0 where every metal texel is an ideal
    /// mirror
    pub roughness: f32,
    /// the diffuse part's texture divided by its mean (None: no diffuse part)
    pub diffuse_texture: Option<Texture>,
    /// the specular part's texture divided by its mean, with each texel's alpha (None: no
    /// specular part)
    pub specular_texture: Option<Texture>,
}

/// The texture coordinates of texel (x, y)'s centre in a w x h texture (`Texture::sample`'s
/// convention: v = 0 is the bottom row).
fn texel_centre(x: u32, y: u32, w: u32, h: u32) -> [f32; 2] {
    [
        (x as f32 + 0.5) / w as f32,
        1.0 - (y as f32 + 0.5) / h as f32,
    ]
}

/// One texel decided by the rules: its metal weight (0 or 1) and GGX alpha.
fn texel_kind(metallic: f32, roughness: f32) -> (bool, f32) {
    let metal = metallic >= MIRROR_METALLIC && roughness <= GLOSSY_ROUGHNESS;
    let alpha = if roughness > MIRROR_ROUGHNESS {
        roughness * roughness
    } else {
        0.0
    };
    (metal, alpha)
}

/// Split a material of base colour `base_factor` with base colour texture `base` (linear rgb)
/// and metallic-roughness `mr` per texel. `name`: the path the derived textures are named after.
pub fn split(base_factor: [f32; 3], base: Option<&Texture>, mr: &MetalRough, name: &str) -> Split {
    let (w, h) = match (base, mr.texture) {
        (Some(b), _) => (b.width, b.height),
        (None, Some(t)) => (t.width, t.height),
        (None, None) => (1, 1),
    };
    let n = (w as usize) * (h as usize);
    let mut diffuse = Vec::with_capacity(n);
    let mut specular = Vec::with_capacity(n);
    let mut alpha = Vec::with_capacity(n);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let colour = base.map_or([1.0; 3], |b| b.texels[i]);
            let [_, g, b] = (mr.texture).map_or([1.0; 3], |t| t.sample(texel_centre(x, y, w, h)));
            let (metal, a) = texel_kind(mr.metallic * b, mr.roughness * g);
            diffuse.push(if metal { [0.0; 3] } else { colour });
            specular.push(if metal { colour } else { [0.0; 3] });
            alpha.push(if metal { a } else { f32::NAN });
        }
    }
    let glossy = (alpha.iter()).any(|&a| a > 0.0);
    let table = albedo_table();
    let albedo_of = |a: f32| table.albedo(a.max(MIN_TEXEL_ALPHA));
    // the metal texels' reflectance-weighted mean albedo, and the alpha that has it
    let (mut weighted, mut weights) = (0.0f64, 0.0f64);
    for (s, &a) in specular.iter().zip(&alpha).filter(|(_, a)| !a.is_nan()) {
        let lum = (0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2]) as f64;
        weighted += lum * albedo_of(a) as f64;
        weights += lum;
    }
    // one alpha over every metal texel (a uniform texture, the factors alone) is kept exactly
    let metal_alphas = alpha.iter().filter(|a| !a.is_nan());
    let (lo, hi) = metal_alphas.fold((f32::MAX, f32::MIN), |(l, h), &a| (l.min(a), h.max(a)));
    let roughness = match (glossy && weights > 0.0, lo == hi) {
        (true, true) => hi.max(MIN_TEXEL_ALPHA),
        (true, false) => table.alpha((weighted / weights) as f32),
        (false, _) => 0.0,
    };
    let fill = if glossy { roughness } else { 0.0 };
    for a in &mut alpha {
        *a = match (a.is_nan(), glossy) {
            (true, _) => fill,
            (false, true) => a.max(MIN_TEXEL_ALPHA),
            (false, false) => 0.0,
        };
    }
    let (diffuse_mean, diffuse_texture) = normalised(diffuse, Vec::new(), (w, h), name, "diffuse");
    let (mirror_mean, specular_texture) = normalised(specular, alpha, (w, h), name, "specular");
    Split {
        diffuse: std::array::from_fn(|c| base_factor[c] * diffuse_mean[c]),
        mirror: std::array::from_fn(|c| base_factor[c] * mirror_mean[c]),
        roughness: if mirror_mean.iter().any(|&m| m > 0.0) {
            roughness
        } else {
            0.0
        },
        diffuse_texture,
        specular_texture,
    }
}

/// A texture's per-channel mean, and the texture divided by it (None where every channel's mean
/// is 0: the part is absent; a channel whose mean is 0 stays 0).
fn normalised(
    mut texels: Vec<[f32; 3]>,
    alpha: Vec<f32>,
    (width, height): (u32, u32),
    name: &str,
    part: &str,
) -> ([f32; 3], Option<Texture>) {
    let mean = crate::scene::texels::mean(&texels);
    if mean.iter().all(|&m| m <= 0.0) {
        return ([0.0; 3], None);
    }
    for t in &mut texels {
        for c in 0..3 {
            t[c] = if mean[c] > 0.0 { t[c] / mean[c] } else { 0.0 };
        }
    }
    let texture = Texture {
        path: PathBuf::from(format!("{name} ({part} part)")),
        width,
        height,
        texels,
        alpha,
    };
    (mean, Some(texture))
}

/// `material::ggx_mean_albedo` at alphas from [`MIN_TEXEL_ALPHA`] to the roughest metal texel's
/// (roughness 0.6), densest where it bends (small alphas), computed once: each value takes tens
/// of milliseconds, and a texture has millions of texels.
struct AlbedoTable {
    nodes: Vec<(f32, f32)>,
}

const ALBEDO_NODES: usize = 24;

fn albedo_table() -> &'static AlbedoTable {
    static TABLE: std::sync::OnceLock<AlbedoTable> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let top = GLOSSY_ROUGHNESS * GLOSSY_ROUGHNESS;
        let nodes = (0..ALBEDO_NODES)
            .map(|k| {
                let t = k as f32 / (ALBEDO_NODES - 1) as f32;
                let a = MIN_TEXEL_ALPHA + (top - MIN_TEXEL_ALPHA) * t * t;
                (a, ggx_mean_albedo(a))
            })
            .collect();
        AlbedoTable { nodes }
    })
}

impl AlbedoTable {
    /// The mean albedo at `alpha`, linear between the nodes (held at the ends).
    fn albedo(&self, alpha: f32) -> f32 {
        let n = &self.nodes;
        let k = n.partition_point(|&(a, _)| a < alpha).clamp(1, n.len() - 1);
        let ((a0, e0), (a1, e1)) = (n[k - 1], n[k]);
        let t = ((alpha - a0) / (a1 - a0)).clamp(0.0, 1.0);
        e0 + (e1 - e0) * t
    }

    /// The alpha whose mean albedo is `albedo` (the albedo falls with alpha), linear between the
    /// nodes; held at the table's ends.
    fn alpha(&self, albedo: f32) -> f32 {
        let n = &self.nodes;
        let k = n
            .partition_point(|&(_, e)| e > albedo)
            .clamp(1, n.len() - 1);
        let ((a0, e0), (a1, e1)) = (n[k - 1], n[k]);
        let t = ((e0 - albedo) / (e0 - e1).max(1e-12)).clamp(0.0, 1.0);
        a0 + (a1 - a0) * t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(w: u32, h: u32, texels: Vec<[f32; 3]>) -> Texture {
        Texture {
            path: "t.png".into(),
            width: w,
            height: h,
            texels,
            alpha: Vec::new(),
        }
    }

    #[test]
    fn texel_centres_sample_a_texture_exactly() {
        let t = texture(3, 2, (0..6).map(|i| [i as f32, 0.0, 0.0]).collect());
        for y in 0..2 {
            for x in 0..3 {
                let got = t.sample(texel_centre(x, y, 3, 2))[0];
                assert_eq!(got, (y * 3 + x) as f32, "texel ({x}, {y})");
            }
        }
    }

    #[test]
    fn a_half_metal_checker_splits_into_two_parts_whose_sum_is_the_base_colour() {
        // columns: a glossy metal (roughness 0.4), a dielectric, a smooth metal (roughness 0.1),
        // a rough metal (0.8: diffuse by the rules)
        let base = texture(4, 1, vec![[0.8, 0.6, 0.4], [0.5; 3], [0.9; 3], [0.3; 3]]);
        let mr = texture(
            4,
            1,
            vec![
                [0.0, 0.4, 1.0],
                [0.0, 0.4, 0.0],
                [0.0, 0.1, 1.0],
                [0.0, 0.8, 1.0],
            ],
        );
        let rules = MetalRough {
            metallic: 1.0,
            roughness: 1.0,
            texture: Some(&mr),
        };
        let s = split([1.0, 0.5, 1.0], Some(&base), &rules, "m");
        let (d, sp) = (s.diffuse_texture.unwrap(), s.specular_texture.unwrap());
        for (i, b) in base.texels.iter().enumerate() {
            for c in 0..3 {
                let factor = [1.0, 0.5, 1.0][c];
                let sum = s.diffuse[c] * d.texels[i][c] + s.mirror[c] * sp.texels[i][c];
                assert!(
                    (sum - factor * b[c]).abs() < 1e-6,
                    "texel {i} channel {c}: {sum}"
                );
            }
        }
        assert_eq!(
            sp.texels[1], [0.0; 3],
            "the dielectric texel has no specular part"
        );
        assert_eq!(d.texels[0], [0.0; 3], "the metal texel has no diffuse part");
        assert!(
            (sp.alpha[0] - 0.16).abs() < 1e-6,
            "alpha = roughness²: {}",
            sp.alpha[0]
        );
        assert_eq!(
            sp.alpha[2], MIN_TEXEL_ALPHA,
            "a smooth metal texel in a glossy material"
        );
        assert_eq!(
            sp.alpha[1], s.roughness,
            "a dielectric texel takes the mean alpha"
        );
        // the mean alpha carries the metal texels' mean albedo
        let (a0, a2) = (ggx_mean_albedo(0.16), ggx_mean_albedo(MIN_TEXEL_ALPHA));
        let got = ggx_mean_albedo(s.roughness);
        assert!(
            got < a2 && got > a0,
            "mean albedo {got} between {a0} and {a2}"
        );
    }

    #[test]
    fn a_smooth_metal_texture_stays_an_ideal_mirror() {
        let mr = texture(2, 1, vec![[0.0, 0.1, 1.0], [0.0, 0.2, 0.0]]);
        let rules = MetalRough {
            metallic: 1.0,
            roughness: 1.0,
            texture: Some(&mr),
        };
        let s = split([0.5; 3], None, &rules, "m");
        assert_eq!(s.roughness, 0.0);
        assert_eq!(s.mirror, [0.25; 3]);
        assert_eq!(s.diffuse, [0.25; 3]);
        assert_eq!(s.specular_texture.unwrap().alpha, vec![0.0, 0.0]);
    }

    #[test]
    fn the_albedo_table_follows_the_mean_albedo_and_inverts_it() {
        let table = albedo_table();
        for a in [0.002f32, 0.01, 0.05, 0.13, 0.2, 0.33] {
            let exact = ggx_mean_albedo(a);
            let got = table.albedo(a);
            assert!(
                (got - exact).abs() < 2e-3,
                "alpha {a}: table {got}, exact {exact}"
            );
            let back = table.alpha(exact);
            assert!((back - a).abs() < 0.05 * a + 2e-3, "alpha {a} -> {back}");
        }
    }
}
