//! `vlf cave --headless`: every wall and eye of a display configuration rendered offscreen
//! from one light field, frame after frame along the configured tracking; the last frame's
//! images (and each projector's output: `<wall>-<eye>-<projector>.png`), an overview with the
//! walls unfolded as a cross, and a frame-time report (GPU time per wall and eye from timestamp
//! queries, of the output passes, and CPU time per frame).

use super::frame::{
    frame_limits, labels, wall_views, worst_ratio, FrameTimes, Limit, Pass, WallView,
};
pub use super::frame::{ViewTiming, CONSTANT_FRAME_TIME};
use super::post::{Draw, Outputs};
use super::DisplayConfig;
use crate::error::{Result, VlfError};
use crate::framelock::{FrameLock, FrameState};
use crate::gpu::{MemoryLedger, Timestamps};
use crate::lightfield::{LightField, ResidentLightField};
use crate::render::budget::{BudgetFit, Pacer, PacerReport};
use crate::render::image_io::{display_image, write_image};
use crate::render::{Frame, Renderer};
use crate::stats::Distribution;
use crate::tracking::live::WandPose;
use crate::tracking::source::{Pose, PoseSource};
use serde::Serialize;
use std::path::Path;

#[derive(Clone, Debug, Serialize)]
pub struct CaveReport {
    pub display: String,
    pub adapter: String,
    pub frames: u32,
    pub views_per_frame: usize,
    pub views: Vec<ViewTiming>,
    /// GPU milliseconds for all views of one frame
    pub all_views_gpu_ms: Option<Distribution>,
    /// wall-clock milliseconds per frame on the CPU (all views submitted, GPU finished)
    pub cpu_frame_ms: Distribution,
    /// GPU milliseconds per frame of the passes after rendering (warp, blend, wand ray: one per
    /// projector, or per wall without projectors); None when there are none or no timestamps
    pub outputs_gpu_ms: Option<Distribution>,
    /// the largest per-view p99/p50 of the GPU time, and whether it meets CONSTANT_FRAME_TIME
    pub worst_p99_over_p50: Option<f64>,
    pub constant_frame_time: Option<bool>,
    /// every limit the frames are judged by (per-view and frame p99/p50, max/median, the
    /// display's frame budget), met or not
    pub limits: Vec<Limit>,
    /// live tracking: milliseconds from a pose's arrival to the submission of the first frame
    /// drawn from it (timed frames; None without live tracking or without a new pose)
    pub tracking_latency_ms: Option<Distribution>,
    /// the settings every frame was drawn with, and with `fit_frame_time` what was probed
    pub quality: crate::render::budget::Quality,
    pub fit: Option<BudgetFit>,
    /// with a fit: the share of each view's tiles the pacer drew at the high eye-ray count
    pub pacer: Option<PacerReport>,
    pub images: Vec<String>,
    /// every timed frame in order
    pub series: super::frame::FrameSeries,
}

/// Render `frames` frames: all views of a frame are submitted back to back and timed; the
/// last frame is drawn again view by view and read back, its images going to `out`.
pub fn run(
    lf: &LightField,
    resident: &ResidentLightField,
    config: &DisplayConfig,
    config_path: &Path,
    frames: u32,
    out: &Path,
    exr: bool,
) -> Result<CaveReport> {
    let run = (frames, out, exr);
    run_locked(
        lf,
        resident,
        config,
        config_path,
        run,
        None,
        &crate::progress::Silent,
    )
}

/// `run`, reporting each frame drawn to `progress` (the binary's bar; on a software adapter,
/// where a frame of a full-size CAVE takes minutes, a line per frame as well).
pub fn run_reporting(
    lf: &LightField,
    resident: &ResidentLightField,
    config: &DisplayConfig,
    config_path: &Path,
    (frames, out, exr): (u32, &Path, bool),
    progress: &dyn crate::progress::Progress,
) -> Result<CaveReport> {
    let run = (frames, out, exr);
    run_locked(lf, resident, config, config_path, run, None, progress)
}

/// A kept view's image and its projectors' outputs (named `<wall>-<eye>-<projector>`).
type ViewImages = (Frame, Vec<(String, Frame)>);

/// What the last frame leaves: every view's image, and each projector's output.
#[derive(Default)]
struct Kept {
    views: Vec<Frame>,
    projectors: Vec<(String, Frame)>,
}

/// The renderer and the passes after it, drawing the views of one frame.
struct Drawer<'a> {
    config: &'a DisplayConfig,
    lf: &'a LightField,
    renderer: Renderer,
    post: Option<Outputs>,
    views: Vec<WallView>,
    /// with a fit: how many eye rays each view draws in which tiles, frame by frame
    pacer: Option<Pacer>,
}

impl Drawer<'_> {
    /// What the frame's timestamp pairs time, in order: each view's render, then (with
    /// outputs) each of its outputs' passes.
    fn passes(&self) -> Vec<Pass> {
        let mut passes = Vec::new();
        for (v, view) in self.views.iter().enumerate() {
            passes.push(Pass::View(v));
            let outputs = self.post.as_ref().map_or(0, |p| p.timed_outputs(view.wall));
            passes.extend(std::iter::repeat_n(Pass::Output, outputs));
        }
        passes
    }

    /// Draw one view: submitted and timed (`keep` false), or drawn again untimed and read back
    /// with its projectors' outputs (`keep` true: the last frame's images).
    fn draw_view(
        &mut self,
        v: WallView,
        (pose, wand): (&Pose, Option<&WandPose>),
        ts: Option<&mut Timestamps>,
        keep: bool,
    ) -> Result<Option<ViewImages>> {
        let wall = &self.config.walls[v.wall];
        let norm = &self.lf.meta.normalisation;
        let view = super::wall_view(self.config, wall, v.side, pose, norm);
        let [w, h] = wall.eye_pixels();
        let Some(p) = self.post.as_ref() else {
            if keep {
                let frame = self.renderer.render_matrix(view.0, view.1, w, h)?.0;
                return Ok(Some((frame, Vec::new())));
            }
            self.renderer.submit_matrix(view.0, view.1, w, h, ts);
            return Ok(None);
        };
        let overlay = super::post::wand_overlay(self.config, wall, v.side, pose, wand, norm);
        let draw = if keep { Draw::Everything } else { Draw::Timed };
        p.encode(&mut self.renderer, v.wall, view, overlay.as_ref(), ts, draw);
        if !keep {
            return Ok(None);
        }
        let (frame, projectors) = p.read(v.wall)?;
        let named = (projectors.into_iter())
            .map(|(name, image)| (format!("{}-{}-{name}", wall.name, v.eye), image))
            .collect();
        Ok(Some((frame, named)))
    }

    /// Submit every view of a timed frame, back to back.
    fn submit_timed(
        &mut self,
        pose: &Pose,
        wand: Option<&WandPose>,
        mut ts: Option<&mut Timestamps>,
    ) -> Result<()> {
        for i in 0..self.views.len() {
            if let Some(p) = &self.pacer {
                self.renderer.set_pacing(p.setting(i));
            }
            self.draw_view(self.views[i], (pose, wand), ts.as_deref_mut(), false)?;
        }
        Ok(())
    }

    /// Draw every view of the last frame again, one by one, and read the images back (not
    /// timed).
    fn draw_kept(&mut self, pose: &Pose, wand: Option<&WandPose>) -> Result<Kept> {
        let mut kept = Kept::default();
        for i in 0..self.views.len() {
            if let Some((frame, projectors)) =
                self.draw_view(self.views[i], (pose, wand), None, true)?
            {
                kept.views.push(frame);
                kept.projectors.extend(projectors);
            }
        }
        Ok(kept)
    }
}

/// The pose of frame `f` of `total` (spread evenly over a scripted walk), shared through the
/// cluster's lock when there is one; and when a live pose arrived.
fn frame_pose<'l>(
    poses: &PoseSource,
    config: &DisplayConfig,
    (f, total): (u32, u32),
    lock: Option<&mut (dyn FrameLock + 'l)>,
) -> Result<(Pose, Option<WandPose>, Option<std::time::Instant>)> {
    let duration = match poses {
        PoseSource::Scripted(s) => s.duration(),
        PoseSource::Static(_) | PoseSource::Live(_) => 0.0,
    };
    let t = if total > 1 {
        duration * f as f32 / (total - 1) as f32
    } else {
        0.0
    };
    let (pose, fresh) = poses.at_fresh(t);
    let wand = poses.wand_at(&config.tracking, t);
    Ok(match lock {
        Some(l) => {
            let s = l.share(FrameState::new(f as u64, &pose, wand.as_ref(), 1.0))?;
            (s.pose(), s.wand(), fresh)
        }
        None => (pose, wand, fresh),
    })
}

/// `run` as one rank of a cluster (`crate::cluster`): each frame's pose comes from `lock.share`,
/// and `lock.swap` waits for every rank once the frame is drawn.
pub fn run_locked(
    lf: &LightField,
    resident: &ResidentLightField,
    config: &DisplayConfig,
    config_path: &Path,
    (frames, out, exr): (u32, &Path, bool),
    mut lock: Option<&mut dyn FrameLock>,
    progress: &dyn crate::progress::Progress,
) -> Result<CaveReport> {
    std::fs::create_dir_all(out).map_err(|e| VlfError::io(out, e))?;
    let poses = config.pose_source(config_path)?;
    let mut renderer = Renderer::new(resident, lf, &MemoryLedger::default())?;
    renderer.set_samples_per_pixel(config.antialiasing)?;
    let views = wall_views(config);
    let fit = super::frame::fit_frame_time(&mut renderer, config, &views, &poses, lf)?;
    let specs = super::warp::load_outputs(config, config_path)?;
    // the pass after rendering (`post.rs`), when needed: one wall image per wall
    let wand = poses.may_have_wand(&config.tracking);
    let walls: Vec<usize> = (0..config.walls.len()).collect();
    let post = Outputs::needed(config, &specs, wand)
        .then(|| Outputs::new(&resident.ctx, &renderer, config, &specs, &walls, true))
        .transpose()?;
    let mut drawer = Drawer {
        config,
        lf,
        renderer,
        post,
        views,
        pacer: fit.as_ref().and_then(Pacer::from_fit),
    };
    let passes = drawer.passes();
    let mut times = FrameTimes::new(labels(config, &drawer.views));
    // live tracking: milliseconds from a pose's arrival to the submission of its frame
    let mut latency = Vec::new();
    let mut submit_ms = Vec::new();
    let mut timestamps = crate::gpu::Timestamps::new(&resident.ctx, passes.len() as u32);
    let total = frames.max(1);
    let mut kept = Kept::default();
    let software = resident.ctx.summary.software;
    let began = std::time::Instant::now();
    progress.begin(total as u64, "frames", "drawing every wall and eye");
    for f in 0..total {
        report_frame(progress, (f, total), began, software);
        let (pose, wand, fresh) = frame_pose(&poses, config, (f, total), lock.as_deref_mut())?;
        if f + 1 == total {
            kept = drawer.draw_kept(&pose, wand.as_ref())?;
            if let Some(l) = lock.as_deref_mut() {
                l.swap_untimed()?;
            }
            break;
        }
        let started = std::time::Instant::now();
        drawer.submit_timed(&pose, wand.as_ref(), timestamps.as_mut())?;
        submit_ms.push(started.elapsed().as_secs_f64() * 1e3);
        if let Some(arrived) = fresh {
            latency.push(arrived.elapsed().as_secs_f64() * 1e3);
        }
        resident.ctx.wait_spinning()?;
        times.push_cpu(started.elapsed().as_secs_f64() * 1e3);
        if let Some(l) = lock.as_deref_mut() {
            l.swap()?;
        }
        if let Some(ts) = timestamps.as_mut() {
            let ms = ts.read_ms(&resident.ctx)?;
            times.push_gpu(&ms, &passes);
            if let Some(p) = drawer.pacer.as_mut() {
                super::frame::pace_views(p, &ms, &passes);
            }
        }
    }
    report_frame(progress, (total, total), began, software);
    progress.finish();
    if times.frames_timed() == 0 {
        times.push_cpu(0.0);
    }
    let images = write_kept(config, &drawer.views, &kept, out, exr)?;
    let views = times.views();
    let worst = worst_ratio(&views);
    let cpu_frame_ms = times.cpu_ms().expect("one frame at least");
    let limits = frame_limits(&views, Some(&cpu_frame_ms), config.frame_budget_ms());
    Ok(CaveReport {
        worst_p99_over_p50: worst,
        constant_frame_time: worst.map(|w| w <= CONSTANT_FRAME_TIME),
        limits,
        display: config.name.clone(),
        adapter: resident.ctx.summary.name.clone(),
        frames: total,
        views_per_frame: drawer.views.len(),
        views,
        all_views_gpu_ms: times.frame_gpu_ms(),
        cpu_frame_ms,
        outputs_gpu_ms: times.output_gpu_ms(),
        tracking_latency_ms: (!latency.is_empty()).then(|| Distribution::of(&latency)),
        quality: drawer.renderer.run_quality(drawer.pacer.as_ref()),
        fit,
        pacer: drawer.pacer.as_ref().map(Pacer::report),
        images,
        series: super::frame::FrameSeries {
            submit_ms,
            ..times.series()
        },
    })
}

/// `done` of `total` frames drawn, to the bar; on a software adapter also as a line with the
/// time so far and the time left at that rate (a bar is hidden where stderr is no terminal).
fn report_frame(
    progress: &dyn crate::progress::Progress,
    (done, total): (u32, u32),
    began: std::time::Instant,
    software: bool,
) {
    let elapsed = began.elapsed().as_secs_f64();
    let left = elapsed / done.max(1) as f64 * (total - done) as f64;
    let message = format!("frame {done} of {total}");
    progress.advance_to(done as u64, &message);
    if software && done == total {
        progress.note(&format!("all {total} frames drawn in {elapsed:.0} s"));
    } else if software && done > 0 {
        progress.note(&format!(
            "{message} drawn after {elapsed:.0} s (software adapter; about {left:.0} s to go)"
        ));
    }
}

/// The last frame's images (`<wall>-<eye>.png`, each projector's output) and the overview.
fn write_kept(
    config: &DisplayConfig,
    views: &[WallView],
    kept: &Kept,
    out: &Path,
    exr: bool,
) -> Result<Vec<String>> {
    let named = kept.views.iter().zip(views).map(
        |(
            image,
            &WallView {
                wall: wall_index,
                eye,
                ..
            },
        )| { (format!("{}-{eye}", config.walls[wall_index].name), image) },
    );
    let projectors = kept
        .projectors
        .iter()
        .map(|(name, image)| (name.clone(), image));
    let mut images = write_images(named.chain(projectors), out, exr)?;
    let overview = out.join("overview.png");
    write_overview(config, views, &kept.views, &overview)?;
    images.push(overview.display().to_string());
    Ok(images)
}

/// Write each named image as `out/<name>.png` (and `.exr`); the paths written.
fn write_images<'a>(
    named: impl Iterator<Item = (String, &'a Frame)>,
    out: &Path,
    exr: bool,
) -> Result<Vec<String>> {
    let mut images = Vec::new();
    for (name, image) in named {
        for ext in ["png", "exr"].into_iter().filter(|e| *e == "png" || exr) {
            let path = out.join(format!("{name}.{ext}"));
            write_image(image, &path, 1.0)?;
            images.push(path.display().to_string());
        }
    }
    Ok(images)
}

/// The walls unfolded as a cross: front in the middle, left and right beside it, floor below,
/// ceiling above; any other wall follows in a row. Left (or mono) eye.
fn write_overview(
    config: &DisplayConfig,
    views: &[WallView],
    images: &[Frame],
    path: &Path,
) -> Result<()> {
    const CELL: u32 = 256;
    let slot = |name: &str| match name {
        "left" => Some((0, 1)),
        "front" => Some((1, 1)),
        "right" => Some((2, 1)),
        "floor" => Some((1, 2)),
        "ceiling" => Some((1, 0)),
        _ => None,
    };
    let mut placed = Vec::new();
    let mut extra = 0;
    for (
        i,
        &WallView {
            wall: wall_index,
            eye,
            ..
        },
    ) in views.iter().enumerate()
    {
        if eye == "right" {
            continue;
        }
        let name = &config.walls[wall_index].name;
        let (cx, cy) = slot(name).unwrap_or_else(|| {
            extra += 1;
            (2 + extra, 1)
        });
        placed.push((cx, cy, &images[i]));
    }
    let width = placed.iter().map(|p| p.0 + 1).max().unwrap_or(1) * CELL;
    let mut canvas = image::RgbImage::new(width, 3 * CELL);
    for (cx, cy, frame) in placed {
        let img = display_image(frame, 1.0);
        let scale = (CELL as f32 / frame.width as f32).min(CELL as f32 / frame.height as f32);
        let (w, h) = (
            ((frame.width as f32 * scale) as u32).max(1),
            ((frame.height as f32 * scale) as u32).max(1),
        );
        let small = image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle);
        image::imageops::overlay(
            &mut canvas,
            &small,
            (cx * CELL + (CELL - w) / 2) as i64,
            (cy * CELL + (CELL - h) / 2) as i64,
        );
    }
    canvas
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| VlfError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

impl CaveReport {
    pub fn table(&self) -> String {
        let mut s = format!(
            "  display {} on {}: {} frames, {} views per frame, {}\n",
            self.display, self.adapter, self.frames, self.views_per_frame, self.quality
        );
        if let Some(fit) = &self.fit {
            s += &format!("  {}\n", fit.summary());
        }
        if let Some(p) = &self.pacer {
            s += &p.line();
        }
        for v in &self.views {
            s.push_str(&v.row());
        }
        if let Some(d) = &self.all_views_gpu_ms {
            s.push_str(&format!(
                "  all views, GPU: median {:.3} ms, p99 {:.3} ms\n",
                d.median, d.p99
            ));
        }
        if let Some(d) = &self.outputs_gpu_ms {
            s.push_str(&format!(
                "  of which outputs (warp, blend, wand ray), GPU: median {:.3} ms, p99 {:.3} ms\n",
                d.median, d.p99
            ));
        }
        s.push_str(&format!(
            "  CPU frame time: median {:.3} ms, p99 {:.3} ms\n",
            self.cpu_frame_ms.median, self.cpu_frame_ms.p99
        ));
        if let Some(d) = &self.tracking_latency_ms {
            s.push_str(&format!("  tracking latency (pose received -> frame submitted): p50 {:.3} ms, p99 {:.3} ms ({} poses)\n", d.median, d.p99, d.samples));
        }
        if let (Some(w), Some(ok)) = (self.worst_p99_over_p50, self.constant_frame_time) {
            s.push_str(&format!(
                "  constant per-eye frame time: {} (worst p99/p50 {w:.3}; limit {CONSTANT_FRAME_TIME:.2})\n",
                if ok { "yes" } else { "NO" }
            ));
        }
        s.push_str(&Limit::lines(&self.limits));
        s
    }
}
