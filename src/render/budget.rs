//! Fitting a frame into the display's frame time. The renderer's cost per pixel is set by its
//! settings (eye rays per pixel, mirror reflections per chain), hardly by what a view sees, so
//! one probe of a frame's views at each rung of a ladder of settings tells which ones fit: a
//! display that must never miss a refresh (a CAVE, a headset) starts at its configured settings
//! and steps down until the probed GPU time leaves headroom in the budget, then keeps those
//! settings for the whole run, so every frame costs the same.

use super::Renderer;
use crate::error::Result;
use crate::gpu::Timestamps;
use glam::{Mat4, Vec3};
use serde::Serialize;

/// The share of the frame budget the probed GPU time may take: the rest is for what a walk's
/// views vary by (per-view p99/p50 up to about 1.1 on the shipped walks), the CPU's submission
/// and the passes after rendering (warp, present).
pub const FIT_HEADROOM: f64 = 0.75;

/// What a pixel costs: eye rays per pixel and mirror reflections traced per chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Quality {
    pub eye_rays_per_pixel: u32,
    pub mirror_bounces: u32,
}

impl std::fmt::Display for Quality {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} eye ray{} per pixel, {} mirror reflection{}",
            self.eye_rays_per_pixel,
            if self.eye_rays_per_pixel == 1 {
                ""
            } else {
                "s"
            },
            self.mirror_bounces,
            if self.mirror_bounces == 1 { "" } else { "s" }
        )
    }
}

/// One rung tried: the GPU time of the frame's views with these settings.
#[derive(Clone, Debug, Serialize)]
pub struct Probe {
    pub quality: Quality,
    pub frame_gpu_ms: f64,
}

/// What the fit tried and chose.
#[derive(Clone, Debug, Serialize)]
pub struct BudgetFit {
    pub budget_ms: f64,
    pub headroom: f64,
    pub probes: Vec<Probe>,
    pub chosen: Quality,
    /// whether the chosen settings' probe fits budget x headroom (false: the cheapest rung did
    /// not, and the run is drawn with it anyway)
    pub fits: bool,
    /// "GPU timestamps" or "wall clock" (an adapter without timestamp queries)
    pub timed_by: &'static str,
}

impl BudgetFit {
    /// One line for a report.
    pub fn summary(&self) -> String {
        let tried: Vec<String> = (self.probes.iter())
            .map(|p| {
                format!(
                    "{}/{} {:.2} ms",
                    p.quality.eye_rays_per_pixel, p.quality.mirror_bounces, p.frame_gpu_ms
                )
            })
            .collect();
        format!(
            "frame time fit: budget {:.2} ms x {:.2} headroom; probed (eye rays/reflections) {}; {} {}",
            self.budget_ms,
            self.headroom,
            tried.join(", "),
            if self.fits {
                "drawn with"
            } else {
                "NOTHING FITS, drawn with the cheapest:"
            },
            self.chosen
        )
    }
}

/// A view of the frame to probe: its view-projection and eye (the light field's normalised
/// space) and its size in pixels.
pub struct ProbeView {
    pub view_proj: Mat4,
    pub eye: Vec3,
    pub size: [u32; 2],
}

impl Renderer {
    pub fn quality(&self) -> Quality {
        Quality {
            eye_rays_per_pixel: self.view_template.samples_per_pixel,
            mirror_bounces: self.view_template.mirror_bounces,
        }
    }

    /// From the configured settings down: halving the eye rays per pixel to 1, then (only where
    /// mirror tiles end the chains, so that a mirror keeps its picture) one reflection fewer down
    /// to 1.
    pub fn quality_ladder(&self) -> Vec<Quality> {
        let mut rung = self.quality();
        let mut ladder = vec![rung];
        while rung.eye_rays_per_pixel > 1 {
            rung.eye_rays_per_pixel /= 2;
            ladder.push(rung);
        }
        while self.view_dependent() && rung.mirror_bounces > 1 {
            rung.mirror_bounces -= 1;
            ladder.push(rung);
        }
        ladder
    }

    fn set_quality(&mut self, quality: Quality) -> Result<()> {
        self.set_samples_per_pixel(quality.eye_rays_per_pixel)?;
        self.view_template.mirror_bounces = quality.mirror_bounces;
        Ok(())
    }

    /// Probe `views` down the quality ladder and keep the first settings whose frame fits
    /// `budget_ms` x FIT_HEADROOM (or the cheapest).
    pub fn fit_frame_time(&mut self, views: &[ProbeView], budget_ms: f64) -> Result<BudgetFit> {
        let ladder = self.quality_ladder();
        let mut probes = Vec::new();
        let mut timed_by = "GPU timestamps";
        for quality in &ladder {
            self.set_quality(*quality)?;
            let (ms, timestamps) = self.probe_frame_ms(views)?;
            if !timestamps {
                timed_by = "wall clock";
            }
            probes.push(Probe {
                quality: *quality,
                frame_gpu_ms: ms,
            });
            if ms <= budget_ms * FIT_HEADROOM {
                break;
            }
        }
        let last = probes.last().expect("the ladder has one rung at least");
        let fit = BudgetFit {
            budget_ms,
            headroom: FIT_HEADROOM,
            chosen: last.quality,
            fits: last.frame_gpu_ms <= budget_ms * FIT_HEADROOM,
            probes,
            timed_by,
        };
        self.set_quality(fit.chosen)?;
        Ok(fit)
    }

    /// The frame's views drawn offscreen three times, one submission each as a display does; the
    /// slower of the last two (the first warms up). Milliseconds, and whether from timestamps.
    fn probe_frame_ms(&mut self, views: &[ProbeView]) -> Result<(f64, bool)> {
        let targets: Vec<_> = (views.iter())
            .map(|v| self.view_targets(v.size[0], v.size[1]))
            .collect();
        let ctx = self.ctx.clone();
        let mut timestamps = Timestamps::new(&ctx, views.len() as u32);
        let mut slowest: f64 = 0.0;
        for round in 0..3 {
            let started = std::time::Instant::now();
            for (view, target) in views.iter().zip(&targets) {
                self.set_view_matrix(view.view_proj, view.eye);
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                self.encode_view(&mut encoder, target, timestamps.as_mut());
                ctx.queue.submit([encoder.finish()]);
            }
            ctx.wait()?;
            let ms = match timestamps.as_mut() {
                Some(t) => t.read_ms(&ctx)?.iter().sum(),
                None => started.elapsed().as_secs_f64() * 1e3,
            };
            if round > 0 {
                slowest = slowest.max(ms);
            }
        }
        Ok((slowest, timestamps.is_some()))
    }
}
