//! Image comparison on linear radiance, as the accuracy studies of the field report it: MSE and
//! RMSE, relMSE (mean of (a-b)^2 / (b^2 + 0.01), b the reference), the largest absolute error,
//! MSE of display values (sRGB-encoded, clamped to [0, 1], as the paper reports), and the mean
//! of NVIDIA's FLIP (LDR FLIP on the sRGB display images, through the `nv-flip` crate). Means
//! are over pixels and the three channels.

use crate::error::{Result, VlfError};
use crate::render::image_io::srgb_encode;
use crate::render::Frame;
use serde::Serialize;

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Comparison {
    pub width: u32,
    pub height: u32,
    pub mse: f64,
    pub rmse: f64,
    pub rel_mse: f64,
    pub max_abs: f64,
    pub display_mse: f64,
    pub flip_mean: f64,
    /// pixels compared (all, or those a mask keeps)
    #[serde(default)]
    pub pixels: u64,
    /// the image's mean over the reference's (pixels compared, channels averaged): a light
    /// field too dark or too bright as a whole shows here first
    #[serde(default)]
    pub mean_ratio: f64,
}

fn display_bytes(frame: &Frame) -> Vec<u8> {
    crate::render::image_io::display_image(frame, 1.0).into_raw()
}

/// Compare `test` with `reference` (same size).
pub fn compare(test: &Frame, reference: &Frame) -> Result<Comparison> {
    compare_where(test, reference, None)
}

/// Compare over the pixels `keep` marks (all where None); FLIP is averaged over them too.
pub fn compare_where(test: &Frame, reference: &Frame, keep: Option<&[bool]>) -> Result<Comparison> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(VlfError::Parameter {
            name: "images",
            message: format!(
                "sizes differ: {}x{} against a {}x{} reference; render both at one size",
                test.width, test.height, reference.width, reference.height
            ),
        });
    }
    if keep.is_some_and(|k| k.len() != test.pixels.len()) {
        return Err(VlfError::Parameter {
            name: "mask",
            message: format!(
                "the mask is not {}x{}: use one of the images' size",
                test.width, test.height
            ),
        });
    }
    let kept = |i: usize| keep.is_none_or(|k| k[i]);
    let pixels = (0..test.pixels.len()).filter(|&i| kept(i)).count();
    if pixels == 0 {
        return Err(VlfError::Parameter {
            name: "mask",
            message: "the mask keeps no pixel".into(),
        });
    }
    let n = (pixels * 3) as f64;
    let (mut se, mut rel, mut max_abs, mut display) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let (mut sum, mut sum_reference) = (0.0f64, 0.0f64);
    for (i, (a, b)) in test.pixels.iter().zip(&reference.pixels).enumerate() {
        if !kept(i) {
            continue;
        }
        for c in 0..3 {
            let (x, y) = (a[c] as f64, b[c] as f64);
            if !x.is_finite() || !y.is_finite() {
                return Err(VlfError::Parameter {
                    name: "images",
                    message: "an image holds NaN or infinite values".into(),
                });
            }
            let d = x - y;
            sum += x;
            sum_reference += y;
            se += d * d;
            rel += d * d / (y * y + 0.01);
            max_abs = max_abs.max(d.abs());
            let dd = srgb_encode(a[c]) as f64 - srgb_encode(b[c]) as f64;
            display += dd * dd;
        }
    }
    let flip = flip_map(test, reference);
    let flip_mean = match keep {
        None => nv_flip::FlipPool::from_image(&flip).mean() as f64,
        Some(_) => {
            flip.to_vec()
                .iter()
                .enumerate()
                .filter(|(i, _)| kept(*i))
                .map(|(_, &v)| v as f64)
                .sum::<f64>()
                / pixels as f64
        }
    };
    Ok(Comparison {
        width: test.width,
        height: test.height,
        mse: se / n,
        rmse: (se / n).sqrt(),
        rel_mse: rel / n,
        max_abs,
        display_mse: display / n,
        flip_mean,
        pixels: pixels as u64,
        mean_ratio: sum / sum_reference.max(1e-30),
    })
}

fn flip_map(test: &Frame, reference: &Frame) -> nv_flip::FlipImageFloat {
    let r = nv_flip::FlipImageRgb8::with_data(
        reference.width,
        reference.height,
        &display_bytes(reference),
    );
    let t = nv_flip::FlipImageRgb8::with_data(test.width, test.height, &display_bytes(test));
    nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE)
}

/// A false-colour difference image: FLIP error per pixel through the magma colour map.
pub fn write_difference_png(test: &Frame, reference: &Frame, path: &std::path::Path) -> Result<()> {
    let map = flip_map(test, reference).apply_color_lut(&nv_flip::magma_lut());
    let img =
        image::RgbImage::from_raw(map.width(), map.height(), map.to_vec()).ok_or_else(|| {
            VlfError::Image {
                path: path.to_path_buf(),
                message: "difference image has the wrong size".into(),
            }
        })?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| VlfError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

impl Comparison {
    pub fn table(&self) -> String {
        format!(
            "  size         {}x{} ({} pixels compared)\n  mean ratio   {:.6}\n  MSE          {:.6e}\n  RMSE         {:.6e}\n  relMSE       {:.6e}\n  max |a-b|    {:.6e}\n  display MSE  {:.6e}\n  FLIP (mean)  {:.6}\n",
            self.width, self.height, self.pixels, self.mean_ratio, self.mse, self.rmse, self.rel_mse, self.max_abs, self.display_mse, self.flip_mean
        )
    }
}

/// A mask from a PNG of the images' size: pixels whose red channel is above half are kept.
pub fn read_mask(path: &std::path::Path) -> Result<(u32, u32, Vec<bool>)> {
    let img = image::open(path)
        .map_err(|e| VlfError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?
        .to_rgb8();
    Ok((
        img.width(),
        img.height(),
        img.pixels().map(|p| p[0] > 127).collect(),
    ))
}
