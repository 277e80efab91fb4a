//! Fitting every frame into the display's frame time, at the same time every frame.
//!
//! What a pixel costs depends on what it sees: an eye ray through the empty half of a classroom
//! opens fewer nodes of the BVH than one through rows of chairs (on an H100 a 1920x1200 view of
//! the 100K-triangle classroom at 2 eye rays per pixel takes 0.54 ms facing the blackboard's
//! empty strip and 0.97 ms facing the class). Two steps hold the time constant anyway:
//! - the fit, once before the first frame: the frame's views are probed at 1 eye ray per pixel
//!   and at the configured count, from the configured mirror reflections down (fewer reflections
//!   before the tiles end a chain, down to none: the tiles alone, the paper's method), until the
//!   cheap setting leaves headroom in the refresh period;
//! - the pacer, every frame: each view draws twice the eye rays per pixel in a share of its
//!   8x8 tiles (`tile_samples` in render.wgsl), at a level of 1-2, 2-4, ... up to
//!   PACED_MAX_SAMPLES, and the share (and past its ends the level) follows the view's measured
//!   GPU time toward its part of FIT_HEADROOM of the period. A view that turns cheap gets more
//!   eye rays, one that turns expensive fewer: the time stays put and the surplus goes to the
//!   picture. Paced, a pixel that sees no mirror traces no stand-in reflection (`fixed_work`
//!   off): the pacer, not equal work per pixel, keeps the time.

use super::Renderer;
use crate::error::Result;
use crate::gpu::Timestamps;
use crate::stats::Distribution;
use glam::{Mat4, Vec3};
use serde::Serialize;

/// The share of the frame budget the views' GPU time is held at: the rest is for the CPU's
/// submission, the passes after rendering (warp, present) and what the pacer lags behind by.
pub const FIT_HEADROOM: f64 = 0.75;
/// How far the pacer moves a view's share toward its target each frame (1: all the way, by the
/// slope the fit measured).
const PACER_GAIN: f64 = 0.6;
/// The least change in a view's GPU time, as the probed slope predicts it from a change in its
/// eye rays, that the pacer learns the view's own slope from (as a share of the view's target:
/// smaller steps are lost in the frame-to-frame jitter of its time, 1-2% on an H200).
const SLOPE_STEP: f64 = 0.04;
/// How far a view's learnt slope moves toward one frame's measure (in its logarithm).
const SLOPE_LEARN: f64 = 0.5;
/// The most a view's learnt slope may exceed the probed one (and it never goes below it: the
/// pacer then steps as it did without learning).
const SLOPE_MAX_SCALE: f64 = 8.0;
/// What the reserve for the GPU work before the views (the moving objects' pass) keeps of itself
/// each frame that work takes less: a peak follower that forgets a peak over about 15 s at
/// 120 Hz, so the views make room for the work's peaks, not its median, and keep their times
/// while it varies (a reserve that followed it closely moved every view's time with it: views'
/// p99/p50 1.18 on an H200, the shadow atlas taking 1.3 to 2.2 ms along a walk).
const RESERVE_DECAY: f64 = 0.9995;
/// The reserve never falls below this many times the work's first time: the pass's cost follows
/// the static texels the objects can shadow, which change along a walk (1.05 to 2.3 ms on the
/// 100K classroom's walk, 1.2 to 2.8 ms on the 1M's, 1.4 to 3.3 ms with the 200K-triangle prop,
/// all on an H200): a reserve that rose with it as it came took the views' times down with it
/// (views' p99/p50 1.30), one made at once for the whole walk keeps them.
const RESERVE_FIRST_FACTOR: f64 = 2.5;
/// The frames whose least time for the work makes that first reserve (one frame's time may be a
/// hitch: a first reserve taken from it would hold the views low for the whole run); the
/// reserve falls to it as they come (views rising early leave the views' p99 alone).
const RESERVE_FIRST_FRAMES: usize = 8;
/// The reserve rises with the work's second longest time of this many frames: a single frame's
/// spike (4.7 ms against 1.0 to 2.2 along a walk on an H200) would otherwise hold every view
/// low for seconds after it; the spike itself overruns its one frame.
const RESERVE_RISE_FRAMES: usize = 8;
/// The most of the held time the reserve takes (the views keep a quarter).
const RESERVE_MAX: f64 = 0.75;

/// What a frame is drawn with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Quality {
    pub eye_rays_per_pixel: u32,
    /// eye rays per pixel in the tiles frame pacing picks (= eye_rays_per_pixel unpaced)
    pub paced_eye_rays_per_pixel: u32,
    pub mirror_bounces: u32,
    /// how eye rays find their first hits (left out of reports: rays)
    #[serde(skip_serializing_if = "super::raster::FirstHits::is_rays")]
    pub first_hits: super::raster::FirstHits,
    /// edge antialiasing's eye rays per edge pixel (left out of reports: 0, off)
    #[serde(skip_serializing_if = "is_zero")]
    pub edge_samples: u32,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

impl std::fmt::Display for Quality {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (n, paced, b) = (
            self.eye_rays_per_pixel,
            self.paced_eye_rays_per_pixel,
            self.mirror_bounces,
        );
        match paced == n {
            true => write!(f, "{n} eye ray(s) per pixel, {b} mirror reflection(s)")?,
            false => write!(
                f,
                "{n} to {paced} eye rays per pixel (paced by tile), {b} mirror reflection(s)"
            )?,
        }
        if self.edge_samples > 0 {
            write!(f, ", {} at edges", self.edge_samples)?;
        }
        match self.first_hits {
            super::raster::FirstHits::Rays => Ok(()),
            super::raster::FirstHits::Raster => write!(f, ", raster first hits"),
        }
    }
}

/// One probe: the frame's views with `mirror_bounces` reflections, every tile at
/// `eye_rays_per_pixel`.
#[derive(Clone, Debug, Serialize)]
pub struct Probe {
    pub eye_rays_per_pixel: u32,
    pub mirror_bounces: u32,
    pub view_gpu_ms: Vec<f64>,
    pub frame_gpu_ms: f64,
}

/// What the fit tried and chose.
#[derive(Clone, Debug, Serialize)]
pub struct BudgetFit {
    pub budget_ms: f64,
    pub headroom: f64,
    pub probes: Vec<Probe>,
    /// the reflections traced, and the eye rays per pixel a tile draws (the pacer picks which
    /// tiles draw `high`)
    pub mirror_bounces: u32,
    pub low: u32,
    pub high: u32,
    /// whether 1 eye ray per pixel fits budget x headroom (false: nothing did, and the run is
    /// drawn with the cheapest settings anyway)
    pub fits: bool,
    /// each view's pixels: the views share the held time, and the pacer's slope, by them
    pub view_pixels: Vec<u64>,
    /// "GPU timestamps" or "wall clock" (an adapter without timestamp queries)
    pub timed_by: &'static str,
    /// the moving objects' pass before the views, as posed at the fit: the least of its timed
    /// rounds (None: no moving objects, or no timestamps); the pacer's first reserve
    #[serde(skip_serializing_if = "Option::is_none")]
    pub objects_gpu_ms: Option<f64>,
}

impl BudgetFit {
    /// One line for a report.
    pub fn summary(&self) -> String {
        let tried: Vec<String> = (self.probes.iter())
            .map(|p| {
                let (n, b) = (p.eye_rays_per_pixel, p.mirror_bounces);
                format!("{n}/{b} {:.2} ms", p.frame_gpu_ms)
            })
            .collect();
        let objects = (self.objects_gpu_ms).map_or(String::new(), |ms| {
            format!(", the moving objects' pass {ms:.2} ms")
        });
        format!(
            "frame time fit: budget {:.2} ms x {:.2} headroom; probed (eye rays/reflections) {}{objects}; {} {} reflection(s), {} to {} eye rays per pixel by tile",
            self.budget_ms,
            self.headroom,
            tried.join(", "),
            if self.fits { "drawn with" } else { "NOTHING FITS, drawn with the cheapest:" },
            self.mirror_bounces,
            self.low,
            if self.fits { PACED_MAX_SAMPLES } else { self.low }
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
    /// What a run draws with: its pacer's range where it has one, else the current settings.
    pub fn run_quality(&self, pacer: Option<&Pacer>) -> Quality {
        match pacer {
            Some(p) => Quality {
                eye_rays_per_pixel: 1,
                paced_eye_rays_per_pixel: p.max_samples,
                mirror_bounces: self.view_template.mirror_bounces,
                first_hits: self.first_hits(),
                edge_samples: self.view_template.edge_samples,
            },
            None => self.quality(),
        }
    }

    /// The most eye rays per pixel the pacer may give a tile: PACED_MAX_SAMPLES, or with
    /// raster first hits the visibility buffer's MSAA samples (a tile reads no more).
    pub fn paced_max_samples(&self) -> u32 {
        match self.view_template.msaa_samples {
            0 => PACED_MAX_SAMPLES,
            samples => samples.min(PACED_MAX_SAMPLES),
        }
    }

    pub fn quality(&self) -> Quality {
        Quality {
            eye_rays_per_pixel: self.view_template.samples_per_pixel,
            paced_eye_rays_per_pixel: self.view_template.paced_samples,
            mirror_bounces: self.view_template.mirror_bounces,
            first_hits: self.first_hits(),
            edge_samples: self.view_template.edge_samples,
        }
    }

    /// Mirror reflections to try, from the configured count down: to none where the tiles end
    /// chains (they then show the mirrors on their own), none fewer without tiles (a mirror
    /// would go black).
    fn bounce_ladder(&self) -> Vec<u32> {
        let configured = self.view_template.mirror_bounces;
        match self.view_dependent() {
            true => (0..=configured).rev().collect(),
            false => vec![configured],
        }
    }

    /// The next views' tiles: `setting.high` eye rays per pixel in the share `setting.fraction`,
    /// `setting.low` in the rest.
    /// What the next view is drawn with besides its camera (a session log records it per view
    /// and frame; `vlf replay` restores it with `set_view_settings`).
    pub fn view_settings(&self) -> ViewSettings {
        let v = &self.view_template;
        ViewSettings {
            samples_per_pixel: v.samples_per_pixel,
            paced_samples: v.paced_samples,
            paced_fraction: v.paced_fraction,
            mirror_bounces: v.mirror_bounces,
            fixed_work: v.fixed_work,
        }
    }

    /// Draw the next views exactly as `s` says (a logged frame, replayed).
    pub fn set_view_settings(&mut self, s: ViewSettings) {
        let v = &mut self.view_template;
        v.samples_per_pixel = s.samples_per_pixel.clamp(1, super::MAX_SAMPLES);
        v.paced_samples = s.paced_samples.clamp(1, super::MAX_SAMPLES);
        v.paced_fraction = s.paced_fraction.clamp(0.0, 1.0);
        v.mirror_bounces = s.mirror_bounces;
        v.fixed_work = s.fixed_work;
    }

    pub fn set_pacing(&mut self, setting: PacedSetting) {
        self.view_template.samples_per_pixel = setting.low.clamp(1, super::MAX_SAMPLES);
        self.view_template.paced_samples = setting.high.clamp(1, super::MAX_SAMPLES);
        self.view_template.paced_fraction = setting.fraction.clamp(0.0, 1.0);
    }

    /// Probe `views` (see the module's notes) and leave the renderer at the chosen settings,
    /// every tile at 1 eye ray per pixel until the pacer says otherwise.
    pub fn fit_frame_time(&mut self, views: &[ProbeView], budget_ms: f64) -> Result<BudgetFit> {
        let high = self.view_template.samples_per_pixel;
        let ladder = self.bounce_ladder();
        // paced, a pixel that sees no mirror traces no stand-in reflection: the pacer spends
        // the time saved on more eye rays elsewhere (and with edge antialiasing, only the tiles
        // it gives 2 eye rays or more refine their edges: render.wgsl, find_edges)
        self.view_template.fixed_work = 0;
        let mut probes = Vec::new();
        let mut timestamps = true;
        let mut fits = false;
        let mut warm_up = !self.ctx.summary.software;
        for &bounces in &ladder {
            self.view_template.mirror_bounces = bounces;
            // 1 eye ray per pixel must fit; the configured count shows what the pacer can add
            let counts = if high > 1 { vec![1, high] } else { vec![1] };
            for n in counts {
                self.set_samples_per_pixel(n)?;
                // the first probe draws for PROBE_WARM_UP first (on a GPU)
                let (view_gpu_ms, timed) = self.probe_views(views, std::mem::take(&mut warm_up))?;
                timestamps &= timed;
                let frame_gpu_ms = view_gpu_ms.iter().sum();
                if n == 1 {
                    fits = frame_gpu_ms <= budget_ms * FIT_HEADROOM;
                }
                probes.push(Probe {
                    eye_rays_per_pixel: n,
                    mirror_bounces: bounces,
                    frame_gpu_ms,
                    view_gpu_ms,
                });
                if !fits {
                    break;
                }
            }
            if fits {
                break;
            }
        }
        self.set_samples_per_pixel(1)?;
        // nothing fits: no tile draws more than one eye ray
        self.view_template.paced_samples = if fits { high } else { 1 };
        Ok(BudgetFit {
            budget_ms,
            headroom: FIT_HEADROOM,
            mirror_bounces: self.view_template.mirror_bounces,
            low: 1,
            high,
            fits,
            probes,
            view_pixels: (views.iter())
                .map(|v| v.size[0] as u64 * v.size[1] as u64)
                .collect(),
            objects_gpu_ms: None,
            timed_by: if timestamps {
                "GPU timestamps"
            } else {
                "wall clock"
            },
        })
    }

    /// The views drawn offscreen round after round, one submission each as a display does,
    /// the first a warm-up, until two rounds in a row agree within PROBE_AGREE (a GPU idle while the light field
    /// loaded may take a few hundred milliseconds to come up to speed: on an H200 the first
    /// eight frames after loading the 1M classroom took 3x the rest), at most PROBE_ROUNDS; each
    /// view's slower time of those two rounds, in milliseconds, and whether they come from
    /// timestamps. With `warm_up`, the views are first drawn untimed for PROBE_WARM_UP.
    fn probe_views(&mut self, views: &[ProbeView], warm_up: bool) -> Result<(Vec<f64>, bool)> {
        let targets: Vec<_> = (views.iter())
            .map(|v| self.view_targets(v.size[0], v.size[1]))
            .collect();
        let ctx = self.ctx.clone();
        let started = std::time::Instant::now();
        while warm_up && started.elapsed() < PROBE_WARM_UP {
            for (view, target) in views.iter().zip(&targets) {
                self.submit_view(view, target, None);
            }
            ctx.wait()?;
        }
        let mut timestamps = Timestamps::new(&ctx, views.len() as u32);
        // the software adapter (the CPU: no clocks to come up) draws the three rounds it always
        // did, its first a warm-up: its times jitter by more than PROBE_AGREE between rounds,
        // and every paced test there would draw PROBE_ROUNDS
        let rounds = if ctx.summary.software {
            3
        } else {
            PROBE_ROUNDS
        };
        let mut last: Option<Vec<f64>> = None;
        let mut slowest_of_last_two = Vec::new();
        for round in 0..rounds {
            let mut wall = Vec::new();
            for (view, target) in views.iter().zip(&targets) {
                let started = std::time::Instant::now();
                self.submit_view(view, target, timestamps.as_mut());
                if timestamps.is_none() {
                    ctx.wait()?;
                }
                wall.push(started.elapsed().as_secs_f64() * 1e3);
            }
            ctx.wait()?;
            let ms = match timestamps.as_mut() {
                Some(t) => t.read_ms(&ctx)?,
                None => wall,
            };
            // the first round warms up and is never one of the two
            if let Some(before) = last.as_ref().filter(|_| round >= 2) {
                slowest_of_last_two = before.iter().zip(&ms).map(|(a, b)| a.max(*b)).collect();
                if rounds_agree(before, &ms) {
                    break;
                }
            }
            last = Some(ms);
        }
        Ok((slowest_of_last_two, timestamps.is_some()))
    }

    /// Draw `view` into `targets` in a submission of its own, as a display does.
    fn submit_view(
        &mut self,
        view: &ProbeView,
        targets: &super::ViewTargets,
        timestamps: Option<&mut Timestamps>,
    ) {
        self.set_view_matrix(view.view_proj, view.eye);
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_view(&mut encoder, targets, timestamps);
        self.ctx.queue.submit([encoder.finish()]);
    }
}

/// The most rounds a probe draws waiting for the GPU's times to settle, and how close two
/// rounds' totals must be to count as settled.
const PROBE_ROUNDS: usize = 32;
/// How long the views are drawn before a fit's first probe, on a GPU (not the software
/// adapter): a GPU left idle while the light field loaded runs at a low clock for a while,
/// steadily, so two rounds agree on a time several times the real one. Seen on an H200 with
/// the 100K classroom and a body: 1 eye ray per pixel probed at 16.6 ms (3.8 ms warm), and the
/// fit said nothing fits: the walk drew every tile at 1 eye ray, unpaced, its first frames 22 ms.
const PROBE_WARM_UP: std::time::Duration = std::time::Duration::from_millis(300);
const PROBE_AGREE: f64 = 0.05;

/// Whether two rounds of a probe took about the same time in all (within PROBE_AGREE).
fn rounds_agree(a: &[f64], b: &[f64]) -> bool {
    let (a, b): (f64, f64) = (a.iter().sum(), b.iter().sum());
    (a - b).abs() <= PROBE_AGREE * a.max(b)
}

/// The most eye rays per pixel the pacer gives a view that is cheap for its target.
pub const PACED_MAX_SAMPLES: u32 = 16;

/// The settings a view is drawn with besides its camera: the `GpuView` fields that frame
/// pacing and the frame-time fit change.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct ViewSettings {
    pub samples_per_pixel: u32,
    pub paced_samples: u32,
    pub paced_fraction: f32,
    pub mirror_bounces: u32,
    pub fixed_work: u32,
}

/// A view's tiles: `high` eye rays per pixel in the share `fraction`, `low` in the rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacedSetting {
    pub low: u32,
    pub high: u32,
    pub fraction: f32,
}

/// Holds each view's GPU time at its target by how many of its tiles draw more eye rays (see
/// the module's notes). A view's level is a pair of counts, 1 and 2, 2 and 4, ... up to
/// PACED_MAX_SAMPLES; its share moves within the level, and past either end to the next level:
/// a view too cheap at the configured count for its target gets more eye rays still.
pub struct Pacer {
    target_ms: Vec<f64>,
    /// the GPU time the views and the work before them are held at, and each view's share of it
    held_ms: f64,
    share: Vec<f64>,
    /// what the work before the views takes of the held time (`observe_before_views`), the
    /// least it takes (`RESERVE_FIRST_FACTOR` times the work's first time), and the frames
    /// left that make that least (none where the fit probed the work)
    reserved_ms: f64,
    reserved_floor_ms: f64,
    first_frames_left: usize,
    /// the work's last RESERVE_RISE_FRAMES times
    recent_before_views: Vec<f64>,
    /// the GPU time one more eye ray per pixel adds to a view, as probed
    per_ray_ms: Vec<f64>,
    /// how many times the probed cost an eye ray turns out to add to each view, learnt from
    /// its times (1 to SLOPE_MAX_SCALE): with edge antialiasing a tile given more eye rays also
    /// refines its edges, at a cost the probes did not see and that follows the tiles' edges
    /// (stepping by the probed slope alone, a view's time swung frame to frame, 0.6 to 0.96 ms
    /// around a 0.78 ms target on an H200)
    slope_scale: Vec<f64>,
    /// each view's eye rays per pixel and GPU time of the last frame timed
    last_timed: Vec<Option<(f64, f64)>>,
    /// frames between drawing with a setting and its time arriving (`lagged`)
    lag: usize,
    low: Vec<u32>,
    fraction: Vec<f32>,
    /// eye rays per pixel each frame, averaged over the view's tiles
    history: Vec<Vec<f32>>,
    reserved_history: Vec<f32>,
    gain: f64,
    /// the most eye rays per pixel a tile gets (`Renderer::paced_max_samples`)
    max_samples: u32,
}
/// What the pacer did over a run, per view: eye rays per pixel, averaged over its tiles.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct PacerReport {
    pub target_ms: Vec<f64>,
    pub eye_rays_per_pixel: Vec<Distribution>,
    /// the views' held time given to the GPU work before them each frame (the moving objects'
    /// pass; absent without it)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reserved_ms: Option<Distribution>,
    /// each view's cost of an eye ray at the run's end as learnt from its times, over the
    /// probed cost (1: as probed; absent in reports made before it was learnt)
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub slope_over_probed: Vec<f64>,
}

impl PacerReport {
    /// One line for a report: the targets and the range of shares over all views.
    pub fn line(&self) -> String {
        let (lo, hi) = (self.eye_rays_per_pixel.iter())
            .fold((f64::MAX, f64::MIN), |(lo, hi), d| {
                (lo.min(d.min), hi.max(d.max))
            });
        let total: f64 = self.target_ms.iter().sum();
        let reserved = (self.reserved_ms.as_ref()).map_or(String::new(), |r| {
            format!(
                " (the moving objects' pass reserved: median {:.2} ms, max {:.2} ms, given to the views' part of it)",
                r.median, r.max
            )
        });
        let steepest = self.slope_over_probed.iter().copied().fold(1.0, f64::max);
        let learnt = match steepest > 1.01 {
            true => format!("; an eye ray costs up to {steepest:.2}x what the fit probed"),
            false => String::new(),
        };
        format!(
            "  frame pacing: views held at {total:.2} ms in all{reserved}; eye rays per pixel (over a view's tiles) {lo:.2} to {hi:.2}, median per view {}{learnt}\n",
            (self.eye_rays_per_pixel.iter())
                .map(|d| format!("{:.2}", d.median))
                .collect::<Vec<_>>()
                .join(" ")
        )
    }
}

impl Pacer {
    /// For a fit that fits with more than one eye ray per pixel to give. Views share the held
    /// time, and the cost of an eye ray, by their pixels (one view's own probe time is not to be
    /// trusted: a software adapter's timestamps put a frame's work on its last pass).
    pub fn from_fit(fit: &BudgetFit) -> Option<Pacer> {
        if !fit.fits || fit.high <= fit.low {
            return None;
        }
        let low = fit
            .probes
            .iter()
            .rev()
            .find(|p| p.eye_rays_per_pixel == fit.low)?;
        let high = (fit.probes.iter().rev()).find(|p| p.eye_rays_per_pixel == fit.high)?;
        let held = fit.budget_ms * fit.headroom;
        let total = fit.view_pixels.iter().sum::<u64>().max(1) as f64;
        let share: Vec<f64> = (fit.view_pixels.iter())
            .map(|&p| p as f64 / total)
            .collect();
        let target_ms: Vec<f64> = share.iter().map(|s| held * s).collect();
        let per_ray = (high.frame_gpu_ms - low.frame_gpu_ms) / (fit.high - fit.low) as f64;
        let per_ray_ms = (share.iter().zip(&target_ms))
            .map(|(s, t)| (per_ray * s).max(0.01 * t))
            .collect();
        let views = share.len();
        Some(Pacer {
            target_ms,
            held_ms: held,
            share,
            reserved_ms: 0.0,
            reserved_floor_ms: 0.0,
            first_frames_left: RESERVE_FIRST_FRAMES,
            recent_before_views: Vec::new(),
            reserved_history: Vec::new(),
            per_ray_ms,
            slope_scale: vec![1.0; views],
            last_timed: vec![None; views],
            lag: 0,
            low: vec![fit.low; views],
            fraction: vec![0.0; views],
            history: vec![Vec::new(); views],
            gain: PACER_GAIN,
            max_samples: PACED_MAX_SAMPLES,
        })
        .map(|mut pacer| {
            // the moving objects' pass as the fit probed it makes the first reserve: the views
            // are held from the first frame where they stay (the first frames' own times, GPU
            // clocks still rising, would make too large a one)
            if let Some(ms) = fit.objects_gpu_ms {
                pacer.reserved_floor_ms = ms * RESERVE_FIRST_FACTOR;
                pacer.first_frames_left = 0;
                pacer.set_reserve(pacer.reserved_floor_ms);
            }
            pacer
        })
    }

    /// No tile above `max_samples` eye rays per pixel (raster first hits: the MSAA samples).
    pub fn capped(mut self, max_samples: u32) -> Pacer {
        self.max_samples = max_samples.clamp(1, PACED_MAX_SAMPLES);
        self
    }

    /// For a loop whose GPU times arrive `frames` frames after the frame was drawn (frames in
    /// flight): a smaller step per frame keeps the share from overshooting while it waits.
    pub fn lagged(mut self, frames: u32) -> Pacer {
        self.gain = PACER_GAIN / (1.0 + frames as f64);
        self.lag = frames as usize;
        self
    }

    /// What view `view` draws this frame.
    pub fn setting(&self, view: usize) -> PacedSetting {
        PacedSetting {
            low: self.low[view],
            high: self.low[view] * 2,
            fraction: self.fraction[view],
        }
    }

    /// View `view` took `gpu_ms` with the setting it was given: move toward its target, by the
    /// cost of the eye rays a share of one level adds (the probed cost, times what the view's
    /// times have taught).
    pub fn observe(&mut self, view: usize, gpu_ms: f64) {
        let (low, given) = (self.low[view], self.fraction[view] as f64);
        self.history[view].push((low as f64 * (1.0 + given)) as f32);
        self.learn_slope(view, gpu_ms);
        let level_ms = self.per_ray_ms[view] * self.slope_scale[view] * low as f64;
        let mut fraction = given + self.gain * (self.target_ms[view] - gpu_ms) / level_ms;
        if fraction > 1.0 && low * 2 < self.max_samples {
            // up a level, whose share costs twice as much
            self.low[view] = low * 2;
            fraction = (fraction - 1.0) / 2.0;
        } else if fraction < 0.0 && low > 1 {
            self.low[view] = low / 2;
            fraction = 1.0 + fraction * 2.0;
        }
        self.fraction[view] = fraction.clamp(0.0, 1.0) as f32;
    }

    /// Learn view `view`'s slope from its time `gpu_ms` and the last frame's: where the eye rays
    /// it was drawn with changed by enough to show above the jitter (SLOPE_STEP), the change in
    /// time over what the probed slope predicts, taken part of the way (SLOPE_LEARN).
    fn learn_slope(&mut self, view: usize, gpu_ms: f64) {
        let history = &self.history[view];
        let Some(&rays) = history.len().checked_sub(1 + self.lag).map(|i| &history[i]) else {
            return;
        };
        let now = (rays as f64, gpu_ms);
        if let Some((rays_before, ms_before)) = self.last_timed[view] {
            let predicted = self.per_ray_ms[view] * (now.0 - rays_before);
            if predicted.abs() > SLOPE_STEP * self.target_ms[view] {
                let measured = ((gpu_ms - ms_before) / predicted).clamp(1.0, SLOPE_MAX_SCALE);
                let scale = &mut self.slope_scale[view];
                *scale = (scale.ln() + SLOPE_LEARN * (measured.ln() - scale.ln())).exp();
            }
        }
        self.last_timed[view] = Some(now);
    }

    /// The GPU work before the views (the moving objects' skinning, refit, light and shadow
    /// atlas) took `gpu_ms` this frame: the views' targets make room for it within the held time,
    /// by a reserve made in the first frames for the work's variation along a walk
    /// (`RESERVE_FIRST_FACTOR` times its least time in `RESERVE_FIRST_FRAMES`, or as the fit
    /// probed it) that then rises to a higher time kept two frames of `RESERVE_RISE_FRAMES` at
    /// once and forgets it slowly (`RESERVE_DECAY`), down to that first reserve.
    pub fn observe_before_views(&mut self, gpu_ms: f64) {
        let first = gpu_ms * RESERVE_FIRST_FACTOR;
        if self.recent_before_views.len() == RESERVE_RISE_FRAMES {
            self.recent_before_views.remove(0);
        }
        self.recent_before_views.push(gpu_ms);
        let mut recent = self.recent_before_views.clone();
        recent.sort_by(f64::total_cmp);
        let sustained = recent.iter().rev().nth(1).copied().unwrap_or(0.0);
        let peak = match self.first_frames_left {
            RESERVE_FIRST_FRAMES => first,
            0 => (sustained.max(self.reserved_ms * RESERVE_DECAY)).max(self.reserved_floor_ms),
            _ => self.reserved_floor_ms.min(first),
        };
        if self.first_frames_left > 0 {
            self.reserved_floor_ms = peak;
            self.first_frames_left -= 1;
        }
        self.set_reserve(peak);
        self.reserved_history.push(self.reserved_ms as f32);
    }

    /// The views' targets share the held time less `reserved_ms` (at most RESERVE_MAX of it).
    fn set_reserve(&mut self, reserved_ms: f64) {
        self.reserved_ms = reserved_ms.min(self.held_ms * RESERVE_MAX);
        let left = self.held_ms - self.reserved_ms;
        for (target, share) in self.target_ms.iter_mut().zip(&self.share) {
            *target = left * share;
        }
    }

    pub fn report(&self) -> PacerReport {
        let reserved: Vec<f64> = self.reserved_history.iter().map(|&r| r as f64).collect();
        PacerReport {
            reserved_ms: (!reserved.is_empty()).then(|| Distribution::of(&reserved)),
            target_ms: self.target_ms.clone(),
            slope_over_probed: self.slope_scale.clone(),
            eye_rays_per_pixel: (self.history.iter())
                .map(|h| Distribution::of(&h.iter().map(|&f| f as f64).collect::<Vec<_>>()))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{
        BudgetFit, Pacer, Probe, FIT_HEADROOM, RESERVE_DECAY, RESERVE_FIRST_FACTOR,
        RESERVE_FIRST_FRAMES, RESERVE_MAX, RESERVE_RISE_FRAMES,
    };

    /// A view whose eye rays cost `steeper` times what the fit probed (`fit`: 0.5 ms per eye
    /// ray per pixel a view) over 1 ms at one eye ray, its time jittering by up to `jitter`
    /// (a share, deterministic), drawn `frames` frames with times `lag` frames late; each
    /// frame's time over the view's target.
    fn paced_times(steeper: f64, jitter: f64, frames: usize, lag: u32) -> Vec<f64> {
        let mut pacer = Pacer::from_fit(&fit()).unwrap();
        if lag > 0 {
            pacer = pacer.lagged(lag);
        }
        let target = pacer.target_ms[0];
        let mut in_flight = std::collections::VecDeque::new();
        let mut times = Vec::new();
        for frame in 0..frames {
            let s = pacer.setting(0);
            let rays = s.low as f64 * (1.0 + s.fraction as f64);
            let wobble = jitter * ((frame as f64 * 2.39996).sin());
            let ms = (1.0 + 0.5 * steeper * (rays - 1.0)) * (1.0 + wobble);
            times.push(ms / target);
            in_flight.push_back(ms);
            if in_flight.len() > lag as usize {
                pacer.observe(0, in_flight.pop_front().unwrap());
            }
        }
        times
    }

    /// The worst of `times` after the first `settle` frames, as a distance from the target.
    fn worst_after(times: &[f64], settle: usize) -> f64 {
        times[settle..]
            .iter()
            .map(|t| (t - 1.0).abs())
            .fold(0.0, f64::max)
    }

    /// A view whose eye rays cost 3.5 times what the fit probed (edge antialiasing: a tile given
    /// more eye rays also refines its edges) settles on its target: the pacer learns the slope
    /// from its times. Stepping by the probed slope alone it swung between 0.32 and 1.75 of its
    /// target frame after frame (a loop gain of 0.6 x 3.5 = 2.1); measured: within 1e-3 from
    /// the 6th frame; with a 1.5% jitter, within 2.4% after 100 frames (1.4% with times a frame
    /// late; 2.0% where the probed slope is right).
    #[test]
    fn a_view_steeper_than_probed_settles_on_its_target() {
        let steep = paced_times(3.5, 0.0, 200, 0);
        let worst = worst_after(&steep, 40);
        eprintln!(
            "3.5x steeper: first frames {:.3?}, worst after 40 {worst:.2e}",
            &steep[..12]
        );
        assert!(worst < 0.01, "{worst}");
        for (steeper, jitter, lag) in [(3.5, 0.015, 0), (3.5, 0.015, 1), (1.0, 0.015, 0)] {
            let worst = worst_after(&paced_times(steeper, jitter, 400, lag), 100);
            eprintln!("{steeper}x, jitter {jitter}, lag {lag}: worst after 100 {worst:.3}");
            assert!(worst < 2.5 * jitter, "{worst}");
        }
    }

    /// A fit of two equal views at a 120 Hz budget whose 1 and 4 eye rays per pixel fit.
    fn fit() -> BudgetFit {
        let probe = |rays: u32, ms: f64| Probe {
            eye_rays_per_pixel: rays,
            mirror_bounces: 1,
            view_gpu_ms: vec![ms / 2.0; 2],
            frame_gpu_ms: ms,
        };
        BudgetFit {
            budget_ms: 1000.0 / 120.0,
            headroom: FIT_HEADROOM,
            probes: vec![probe(1, 2.0), probe(4, 5.0)],
            mirror_bounces: 1,
            low: 1,
            high: 4,
            fits: true,
            view_pixels: vec![100, 100],
            timed_by: "GPU timestamps",
            objects_gpu_ms: None,
        }
    }

    /// The views make room for the moving objects' pass before them: from the first frame by
    /// RESERVE_FIRST_FACTOR times its first time (its variation along a walk), their targets
    /// dropping by a higher time at once, keeping its peak while it takes less (forgetting it by
    /// RESERVE_DECAY a frame, back to the first reserve after a minute), and never giving it
    /// more than RESERVE_MAX of the held time; the report gives the reserve's distribution.
    #[test]
    fn the_views_make_room_for_the_work_before_them_by_its_peak() {
        let mut pacer = Pacer::from_fit(&fit()).unwrap();
        let total = |p: &Pacer| p.target_ms.iter().sum::<f64>();
        let held = total(&pacer);
        assert!((held - 6.25).abs() < 1e-9, "{held}");
        // the first frame a hitch: the first reserve is the least of the first frames' times
        pacer.observe_before_views(3.0);
        assert!((total(&pacer) - (held - held * RESERVE_MAX)).abs() < 1e-9);
        let first = 0.5 * RESERVE_FIRST_FACTOR;
        for _ in 1..RESERVE_FIRST_FRAMES {
            pacer.observe_before_views(0.5);
        }
        assert!((total(&pacer) - (held - first)).abs() < 1e-9);
        assert!((pacer.target_ms[0] - pacer.target_ms[1]).abs() < 1e-12);
        // within the first reserve the targets stay
        pacer.observe_before_views(1.0);
        assert!((total(&pacer) - (held - first)).abs() < 1e-9);
        // one frame's spike leaves the targets; a time kept two frames takes them down at once
        pacer.observe_before_views(2.0);
        assert!((total(&pacer) - (held - first)).abs() < 1e-9);
        pacer.observe_before_views(2.0);
        assert!((total(&pacer) - (held - 2.0)).abs() < 1e-9);
        pacer.observe_before_views(0.5);
        assert!((total(&pacer) - (held - 2.0)).abs() < 1e-9);
        for _ in 0..RESERVE_RISE_FRAMES {
            pacer.observe_before_views(0.5);
        }
        assert!(total(&pacer) < held - 2.0 * RESERVE_DECAY.powi(RESERVE_RISE_FRAMES as i32 - 2));
        for _ in 0..10_000 {
            pacer.observe_before_views(0.5);
        }
        assert!((total(&pacer) - (held - first)).abs() < 1e-9);
        pacer.observe_before_views(100.0);
        pacer.observe_before_views(100.0);
        assert!((total(&pacer) - held * (1.0 - RESERVE_MAX)).abs() < 1e-9);
        (0..2).for_each(|v| pacer.observe(v, 1.0));
        let reserved = pacer.report().reserved_ms.unwrap();
        assert!((reserved.max - held * RESERVE_MAX).abs() < 1e-5);
        assert!((reserved.median - first).abs() < 1e-5);
        // probed at the fit, the work's first reserve holds the views from the first frame
        let probed = BudgetFit {
            objects_gpu_ms: Some(0.4),
            ..fit()
        };
        let mut pacer = Pacer::from_fit(&probed).unwrap();
        let first = 0.4 * RESERVE_FIRST_FACTOR;
        assert!((total(&pacer) - (held - first)).abs() < 1e-9);
        pacer.observe_before_views(3.0);
        assert!((total(&pacer) - (held - first)).abs() < 1e-9);
        pacer.observe_before_views(3.0);
        assert!((total(&pacer) - (held - 3.0)).abs() < 1e-9);
        for _ in 0..10_000 {
            pacer.observe_before_views(0.1);
        }
        assert!((total(&pacer) - (held - first)).abs() < 1e-9);
        // without the work, no reserve in the report
        let mut plain = Pacer::from_fit(&fit()).unwrap();
        (0..2).for_each(|v| plain.observe(v, 3.0));
        assert!(plain.report().reserved_ms.is_none());
    }
}
