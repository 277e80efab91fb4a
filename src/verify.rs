//! `vlf verify`: how right the light field is on a user's own model. Each camera is rendered
//! from the light field (the still's eye rays per pixel) and path-traced by `vlf reference`
//! (`crate::reference`, which shares only the scene import and the BVH with the light field's
//! pipeline) at a stated sample count; the two are compared (mean ratio, display MSE, relMSE,
//! FLIP), next to the reference's own noise estimated from its per-pixel variance, and judged
//! against stated targets. Error maps go to files; the verdict is said in words.

use crate::color::srgb_encode;
use crate::error::{Result, VlfError};
use crate::gpu::GpuContext;
use crate::lightfield::{LightField, ResidentLightField};
use crate::metrics::Comparison;
use crate::progress::Progress;
use crate::render::{image_io, Frame, Renderer};
use crate::scene::{Camera, Scene};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What a view must meet to count as right (issue-tracker targets for real models): the image
/// mean within 1% of the reference's, display MSE at most 1e-4, relMSE at most 2e-3.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Targets {
    pub mean_ratio_off: f64,
    pub display_mse: f64,
    pub rel_mse: f64,
}

pub const TARGETS: Targets = Targets {
    mean_ratio_off: 0.01,
    display_mse: 1e-4,
    rel_mse: 2e-3,
};

/// How a verification runs.
pub struct VerifyOptions {
    /// cameras to check (empty: every camera of the scene)
    pub cameras: Vec<String>,
    /// image size (None: each camera's own)
    pub size: Option<[u32; 2]>,
    /// the reference's samples per pixel
    pub spp: u32,
    pub seed: u32,
    /// where the images and error maps go
    pub out: PathBuf,
}

/// One camera's verdict.
#[derive(Clone, Debug, Serialize)]
pub struct ViewCheck {
    pub camera: String,
    pub size: [u32; 2],
    /// mean of the light field's image over the reference's (all channels)
    pub mean_ratio: f64,
    pub comparison: Comparison,
    /// what the reference's own noise alone gives: relMSE and display MSE of an exact image
    /// against it (they add to what the comparison measures)
    pub reference_noise_rel_mse: f64,
    pub reference_noise_display_mse: f64,
    /// the targets this view misses, in words (empty: every target met)
    pub missed: Vec<String>,
    pub light_field_image: String,
    pub reference_image: String,
    /// FLIP per pixel (magma) and the signed relative error of the luminance (blue: darker
    /// than the reference, red: brighter)
    pub error_maps: Vec<String>,
    pub reference_seconds: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct VerifyReport {
    pub scene: String,
    pub adapter: String,
    pub spp: u32,
    pub targets: Targets,
    pub views: Vec<ViewCheck>,
}

impl VerifyReport {
    /// Every view meets every target.
    pub fn right(&self) -> bool {
        self.views.iter().all(|v| v.missed.is_empty())
    }

    /// The table and the verdict in words.
    pub fn table(&self) -> String {
        let mut s = format!(
            "verify {} on {}: the light field against vlf reference at {} spp\n",
            self.scene, self.adapter, self.spp
        );
        s.push_str("  camera          size       mean ratio  display MSE (noise)    relMSE (noise)        FLIP\n");
        for v in &self.views {
            let c = &v.comparison;
            s.push_str(&format!(
                "  {:<15} {:<10} {:>10.4}  {:.2e} ({:.1e})    {:.2e} ({:.1e})    {:.4}\n",
                v.camera,
                format!("{}x{}", v.size[0], v.size[1]),
                v.mean_ratio,
                c.display_mse,
                v.reference_noise_display_mse,
                c.rel_mse,
                v.reference_noise_rel_mse,
                c.flip_mean
            ));
        }
        let t = &self.targets;
        s.push_str(&format!(
            "  targets: mean within {:.0}% of the reference, display MSE <= {:.0e}, relMSE <= {:.0e}\n",
            t.mean_ratio_off * 100.0,
            t.display_mse,
            t.rel_mse
        ));
        for v in &self.views {
            if v.missed.is_empty() {
                s.push_str(&format!("  {}: within every target\n", v.camera));
            } else {
                s.push_str(&format!(
                    "  {}: THE LIGHT FIELD IS OFF: {} (error maps: {})\n",
                    v.camera,
                    v.missed.join("; "),
                    v.error_maps.join(", ")
                ));
            }
        }
        s
    }
}

/// Check every requested camera of `scene` (already propagated into `lf`).
pub fn verify(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    (lf, resident): (&LightField, &ResidentLightField),
    options: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<VerifyReport> {
    std::fs::create_dir_all(&options.out).map_err(|e| VlfError::io(&options.out, e))?;
    let cameras: Vec<Camera> = if options.cameras.is_empty() {
        scene.cameras.clone()
    } else {
        (options.cameras.iter())
            .map(|name| scene.camera(Some(name)).cloned())
            .collect::<Result<_>>()?
    };
    if cameras.is_empty() {
        return Err(VlfError::Parameter {
            name: "camera",
            message: format!(
                "{} has no camera to verify: add a [[camera]] to its scene.toml",
                scene.name
            ),
        });
    }
    let mut renderer = Renderer::new(resident, lf, &resident.ledger)?;
    renderer.set_samples_per_pixel(crate::render::STILL_SAMPLES)?;
    renderer.set_lobe_samples(crate::render::STILL_LOBE_SAMPLES);
    let mut views = Vec::new();
    for cam in &cameras {
        views.push(check_view(
            ctx,
            scene,
            &mut renderer,
            cam,
            options,
            progress,
        )?);
    }
    Ok(VerifyReport {
        scene: scene.name.clone(),
        adapter: ctx.summary.name.clone(),
        spp: options.spp,
        targets: TARGETS,
        views,
    })
}

fn check_view(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    renderer: &mut Renderer,
    cam: &Camera,
    options: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<ViewCheck> {
    let [w, h] = options.size.unwrap_or(cam.size);
    let image = renderer.render_antialiased(cam, w, h, 1)?;
    let (spp, seed) = (options.spp, options.seed);
    let reference = crate::reference::render(ctx.clone(), scene, cam, [w, h], spp, seed, progress)?;
    let comparison = crate::metrics::compare(&image, &reference.mean)?;
    let mean_ratio = mean(&image) / mean(&reference.mean).max(1e-30);
    let (noise_rel, noise_display) = reference_noise(&reference.mean, &reference.variance);
    let file = |what: &str, ext: &str| options.out.join(format!("{}-{what}.{ext}", cam.name));
    let (lf_path, ref_path) = (file("lightfield", "exr"), file("reference", "exr"));
    image_io::write_image(&image, &lf_path, 1.0)?;
    image_io::write_image(&reference.mean, &ref_path, 1.0)?;
    let flip = file("flip", "png");
    crate::metrics::write_difference_png(&image, &reference.mean, &flip)?;
    let signed = file("relative-error", "png");
    write_signed_error(&image, &reference.mean, &signed)?;
    let t = TARGETS;
    let mut missed = Vec::new();
    if (mean_ratio - 1.0).abs() > t.mean_ratio_off {
        let how = if mean_ratio < 1.0 {
            "darker"
        } else {
            "brighter"
        };
        missed.push(format!(
            "{:.1}% {how} on average than the reference (target {:.0}%)",
            (mean_ratio - 1.0).abs() * 100.0,
            t.mean_ratio_off * 100.0
        ));
    }
    if comparison.display_mse > t.display_mse {
        missed.push(format!(
            "display MSE {:.2e} above {:.0e}",
            comparison.display_mse, t.display_mse
        ));
    }
    if comparison.rel_mse > t.rel_mse {
        missed.push(format!(
            "relMSE {:.2e} above {:.0e}",
            comparison.rel_mse, t.rel_mse
        ));
    }
    Ok(ViewCheck {
        camera: cam.name.clone(),
        size: [w, h],
        mean_ratio,
        comparison,
        reference_noise_rel_mse: noise_rel,
        reference_noise_display_mse: noise_display,
        missed,
        light_field_image: lf_path.display().to_string(),
        reference_image: ref_path.display().to_string(),
        error_maps: vec![flip.display().to_string(), signed.display().to_string()],
        reference_seconds: reference.seconds + reference.setup_seconds,
    })
}

fn mean(f: &Frame) -> f64 {
    let sum: f64 = (f.pixels.iter())
        .map(|p| p[0] as f64 + p[1] as f64 + p[2] as f64)
        .sum();
    sum / (3 * f.pixels.len().max(1)) as f64
}

/// The reference's own error, from its per-pixel variance of the mean: the expected relMSE
/// (the metric's own weighting, var / (ref^2 + 0.01)) and display MSE (through the sRGB
/// curve's slope at the reference) an exact image would show against it.
fn reference_noise(reference: &Frame, variance: &Frame) -> (f64, f64) {
    let (mut rel, mut display) = (0.0, 0.0);
    for (r, v) in reference.pixels.iter().zip(&variance.pixels) {
        for c in 0..3 {
            let (y, var) = (r[c] as f64, v[c].max(0.0) as f64);
            rel += var / (y * y + 0.01);
            let h = 1e-3f32.max(r[c] * 1e-3);
            let slope = (srgb_encode(r[c] + h) - srgb_encode((r[c] - h).max(0.0))) as f64
                / (r[c] + h - (r[c] - h).max(0.0)) as f64;
            display += slope * slope * var;
        }
    }
    let n = (3 * reference.pixels.len().max(1)) as f64;
    (rel / n, display / n)
}

/// The luminance's signed relative error per pixel as a PNG: white where equal, towards blue
/// where the light field is darker than the reference and red where brighter, full colour at
/// 10% (pixels darker than 1% of the image's mean are grey: their ratio means little).
fn write_signed_error(test: &Frame, reference: &Frame, path: &Path) -> Result<()> {
    let lum = |p: &[f32; 4]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    let floor = 0.01 * mean(reference);
    let mut img = image::RgbImage::new(test.width, test.height);
    for (i, (a, b)) in test.pixels.iter().zip(&reference.pixels).enumerate() {
        let (x, y) = (i as u32 % test.width, i as u32 / test.width);
        let (la, lb) = (lum(a), lum(b));
        let colour = if lb < floor {
            [128, 128, 128]
        } else {
            let e = ((la - lb) / lb / 0.1).clamp(-1.0, 1.0);
            let fade = (255.0 * (1.0 - e.abs())) as u8;
            if e < 0.0 {
                [fade, fade, 255]
            } else {
                [255, fade, fade]
            }
        };
        img.put_pixel(x, y, image::Rgb(colour));
    }
    img.save(path)
        .map_err(|e| VlfError::io(path, std::io::Error::other(e)))
}
