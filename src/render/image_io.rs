//! Writing frames: EXR holds linear radiance (the measured output), PNG a tonemapped view
//! (exposure, clamp, sRGB encoding). Both are written atomically, like `.vlf` files.

use super::Frame;
use crate::error::{Result, VlfError};
use std::path::Path;

pub use crate::color::{srgb_decode, srgb_encode};

/// The display image of a frame: exposure, clamp, sRGB encoding, 8 bits per channel.
pub fn display_image(frame: &Frame, exposure: f32) -> image::RgbImage {
    let c = |v: f32| (srgb_encode(v * exposure) * 255.0 + 0.5) as u8;
    let bytes = frame
        .pixels
        .iter()
        .flat_map(|p| [c(p[0]), c(p[1]), c(p[2])])
        .collect();
    image::RgbImage::from_raw(frame.width, frame.height, bytes)
        .expect("one pixel per texel of the frame")
}

fn temporary_beside(path: &Path) -> std::path::PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_string())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}.{ext}", std::process::id()))
}

fn finish_atomic(tmp: &Path, path: &Path) -> Result<()> {
    std::fs::rename(tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(tmp);
        VlfError::io(path, e)
    })
}

/// Whether `path` names an EXR file (linear radiance), by its extension.
pub fn is_exr(path: &Path) -> bool {
    (path.extension().and_then(|e| e.to_str())).is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// An image as displayed (e.g. with text drawn over it) into the PNG `path`, atomically.
pub fn save_png(rgb: &image::RgbImage, path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| VlfError::io(dir, e))?;
    }
    let tmp = temporary_beside(path);
    if let Err(e) = rgb.save_with_format(&tmp, image::ImageFormat::Png) {
        let _ = std::fs::remove_file(&tmp);
        return Err(VlfError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        });
    }
    finish_atomic(&tmp, path)
}

/// Write `.exr` (linear) or `.png` (tonemapped with `exposure`), by extension.
pub fn write_image(frame: &Frame, path: &Path, exposure: f32) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| VlfError::io(dir, e))?;
    }
    let tmp = temporary_beside(path);
    let image_err = |message: String| {
        let _ = std::fs::remove_file(&tmp);
        VlfError::Image {
            path: path.to_path_buf(),
            message,
        }
    };
    match ext.as_str() {
        "exr" => {
            let (w, h) = (frame.width as usize, frame.height as usize);
            exr::prelude::write_rgb_file(&tmp, w, h, |x, y| {
                let p = frame.pixels[y * w + x];
                (p[0], p[1], p[2])
            })
            .map_err(|e| image_err(e.to_string()))?;
        }
        "png" => return save_png(&display_image(frame, exposure), path),
        other => {
            return Err(VlfError::Image {
                path: path.to_path_buf(),
                message: format!(
                    "unknown image type {other:?}: use .exr (linear radiance) or .png (tonemapped)"
                ),
            })
        }
    }
    finish_atomic(&tmp, path)
}

/// Read a linear RGB EXR (for comparisons and tests).
pub fn read_exr(path: &Path) -> Result<Frame> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            (
                resolution.width(),
                vec![[0.0f32; 4]; resolution.width() * resolution.height()],
            )
        },
        |(w, pixels): &mut (usize, Vec<[f32; 4]>), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            pixels[pos.y() * *w + pos.x()] = [r, g, b, a];
        },
    )
    .map_err(|e| VlfError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let size = image.layer_data.size;
    Ok(Frame {
        width: size.width() as u32,
        height: size.height() as u32,
        pixels: image.layer_data.channel_data.pixels.1,
    })
}

/// Read an image for comparison: EXR as linear radiance; PNG is decoded from sRGB to linear.
pub fn read_image(path: &Path) -> Result<Frame> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "exr" {
        return read_exr(path);
    }
    let img = image::open(path)
        .map_err(|e| VlfError::Image {
            path: path.to_path_buf(),
            message: format!("cannot read: {e}"),
        })?
        .to_rgb8();
    let pixels = img
        .pixels()
        .map(|p| [srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2]), 1.0])
        .collect();
    Ok(Frame {
        width: img.width(),
        height: img.height(),
        pixels,
    })
}
