//! Textures resolved to texel density on the way in. The atlas samples a texture once per
//! diffuse texel, so a texture finer than the atlas at the highest density a run may use
//! ([`TEXTURE_TEXELS_PER_UNIT`], twice the `high` preset) only costs memory: each image is
//! decoded on its own and box-filtered (in linear light) to that resolution before the next one
//! is read, so a model with a hundred 4K images holds megabytes, not gigabytes.

use super::{Material, Texture, Triangle};
use std::path::PathBuf;

/// Texels per unit length of the normalised scene that imported textures keep at least (per
/// texture, averaged over the surfaces it covers): twice the `high` preset's atlas density.
pub const TEXTURE_TEXELS_PER_UNIT: f64 = 256.0;

/// How a texture is laid on the scene: summed over the triangles that use it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TextureUse {
    /// area in texture coordinates (1 = the whole image once)
    pub uv_area: f64,
    /// area in the normalised scene (the unit sphere prepare maps the scene into)
    pub surface_area: f64,
}

/// What the scene's textures cost on the host, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct TextureMemory {
    pub textures: u32,
    /// of those, how many were reduced to texel density
    pub reduced: u32,
    /// linear RGB f32 at the images' own resolution (what keeping them whole would take)
    pub full_bytes: u64,
    /// what is kept
    pub kept_bytes: u64,
}

impl TextureMemory {
    pub fn of(textures: &[Texture], full_bytes: u64, reduced: u32) -> TextureMemory {
        TextureMemory {
            textures: textures.len() as u32,
            reduced,
            full_bytes,
            kept_bytes: textures
                .iter()
                .map(|t| t.width as u64 * t.height as u64 * 12)
                .sum(),
        }
    }
}

/// The box-filter footprint (k x k image pixels per kept texel) for an image of `w` x `h` used
/// as `usage` says: the largest k that keeps at least [`TEXTURE_TEXELS_PER_UNIT`] texels per
/// unit length. 1 keeps the image whole (also when the use is unknown or degenerate).
pub fn reduction(w: u32, h: u32, usage: TextureUse) -> u32 {
    let d = TEXTURE_TEXELS_PER_UNIT;
    if !(usage.uv_area > 0.0 && usage.surface_area > 0.0) {
        return 1;
    }
    // image pixels per atlas texel (at density d), over the area the texture covers
    let pixels_per_texel = usage.uv_area * w as f64 * h as f64 / (usage.surface_area * d * d);
    let k = pixels_per_texel.sqrt().floor();
    if k.is_finite() && k >= 2.0 {
        (k as u32).min(w.max(h))
    } else {
        1
    }
}

/// Where a texture's coverage (`Texture::alpha`) comes from, for a texture a material cuts
/// holes with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlphaSource {
    /// the image's alpha channel, 1 where it has none (glTF's base colour texture)
    Channel,
    /// the alpha channel, else the grey level (MTL `map_d`, a scalar map often stored as grey)
    ChannelOrGrey,
}

/// Decode an sRGB PNG or JPEG to linear RGB, box-filtered by `k` ([`reduction`]), with its
/// coverage (box-filtered alike, linear) where `alpha` asks for it. Returns the texture and the
/// bytes it would have taken whole.
pub fn decode(
    bytes: &[u8],
    path: PathBuf,
    usage: TextureUse,
    alpha: Option<AlphaSource>,
) -> Result<(Texture, u64), image::ImageError> {
    let decoded = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(image::ImageError::IoError)?
        .decode()?;
    let has_alpha = decoded.color().has_alpha();
    let image = decoded.into_rgba8();
    let (w, h) = image.dimensions();
    let full = w as u64 * h as u64 * 12;
    let k = reduction(w, h, usage);
    let lut: [f32; 256] = std::array::from_fn(|i| crate::color::srgb_decode(i as u8));
    let (ow, oh) = (w.div_ceil(k), h.div_ceil(k));
    let mut texels = vec![[0.0f32; 3]; ow as usize * oh as usize];
    let mut coverage = vec![0.0f32; if alpha.is_some() { texels.len() } else { 0 }];
    let mut counts = vec![0u32; texels.len()];
    for (x, y, p) in image.enumerate_pixels() {
        let o = (y / k) as usize * ow as usize + (x / k) as usize;
        for c in 0..3 {
            texels[o][c] += lut[p[c] as usize];
        }
        if let Some(source) = alpha {
            coverage[o] += match (has_alpha, source) {
                (true, _) => p[3] as f32 / 255.0,
                (false, AlphaSource::Channel) => 1.0,
                (false, AlphaSource::ChannelOrGrey) => p[0] as f32 / 255.0,
            };
        }
        counts[o] += 1;
    }
    if k > 1 {
        for (t, &n) in texels.iter_mut().zip(&counts) {
            *t = t.map(|v| v / n as f32);
        }
        for (a, &n) in coverage.iter_mut().zip(&counts) {
            *a /= n as f32;
        }
    }
    Ok((
        Texture {
            path,
            width: ow,
            height: oh,
            texels,
            alpha: coverage,
        },
        full,
    ))
}

/// How a normal map's image is read: its raw values (no sRGB curve) at full resolution, as
/// the tangent-space normals 2 rgb - 1 (`Material::normal_map`); `Height(bm)`: a grey height
/// map (MTL `bump`, its `-bm` multiplier) turned into those normals by central differences
/// (n = normalize(-bm dh/dx, -bm dh/dy, 1), x right and y up in the image, texel units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NormalSource {
    Normals,
    Height(f32),
}

/// Decode a normal map (PNG or JPEG) as `source` says, texels 0.5 + 0.5 n.
pub fn decode_normals(
    bytes: &[u8],
    path: PathBuf,
    source: NormalSource,
) -> Result<Texture, image::ImageError> {
    let image = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(image::ImageError::IoError)?
        .decode()?
        .into_rgb32f();
    let (w, h) = image.dimensions();
    let raw: Vec<[f32; 3]> = image.pixels().map(|p| p.0).collect();
    let texels = match source {
        NormalSource::Normals => raw,
        NormalSource::Height(bm) => height_normals(&raw, w as usize, h as usize, bm),
    };
    Ok(Texture {
        path,
        width: w,
        height: h,
        texels,
        alpha: Vec::new(),
    })
}

/// A height map's normals (its red channel the height), wrapping at the edges as the
/// texture lookups do, encoded 0.5 + 0.5 n.
fn height_normals(raw: &[[f32; 3]], w: usize, h: usize, bm: f32) -> Vec<[f32; 3]> {
    let at = |x: usize, y: usize| raw[y * w + x][0];
    let mut out = Vec::with_capacity(raw.len());
    for y in 0..h {
        for x in 0..w {
            let dx = (at((x + 1) % w, y) - at((x + w - 1) % w, y)) * 0.5;
            // rows run down the image: up is the previous row
            let dy = (at(x, (y + h - 1) % h) - at(x, (y + 1) % h)) * 0.5;
            let n = glam::Vec3::new(-bm * dx, -bm * dy, 1.0).normalize();
            out.push((n * 0.5 + 0.5).to_array());
        }
    }
    out
}

/// The mean of a texture's texels, per channel (a part of a split metal, gltf/metal_rough.rs).
pub fn mean(texels: &[[f32; 3]]) -> [f32; 3] {
    let mut sum = [0.0f64; 3];
    for p in texels {
        for c in 0..3 {
            sum[c] += p[c] as f64;
        }
    }
    let n = texels.len().max(1) as f64;
    sum.map(|s| (s / n) as f32)
}

/// Per texture (of `count`), the area it covers, from the triangles whose material names it as
/// diffuse, emission or coverage texture.
pub fn uses(
    positions: &[[f32; 3]],
    triangles: &[Triangle],
    materials: &[Material],
    count: usize,
) -> Vec<TextureUse> {
    let scale = crate::scene::normalise::normalise(positions).scale;
    let mut out = vec![TextureUse::default(); count];
    for t in triangles {
        let (Some(uv), Some(m)) = (t.uv, materials.get(t.material as usize)) else {
            continue;
        };
        let [a, b, c] = t
            .vertices
            .map(|i| glam::DVec3::from(positions[i as usize].map(|x| x as f64)));
        let surface = (b - a).cross(c - a).length() * 0.5 * scale * scale;
        let (e1, e2) = (
            [uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]],
            [uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]],
        );
        let uv_area = ((e1[0] * e2[1] - e1[1] * e2[0]) as f64).abs() * 0.5;
        for i in [
            m.diffuse_texture,
            m.emission_texture,
            m.cutout.map(|c| c.texture),
            m.normal_map.map(|n| n.texture),
            m.specular_texture,
        ]
        .into_iter()
        .flatten()
        {
            if let Some(u) = out.get_mut(i as usize) {
                u.surface_area += surface;
                u.uv_area += uv_area;
            }
        }
    }
    out
}
