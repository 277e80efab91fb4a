//! `vlf cave --headless`: every wall and eye of a display configuration rendered offscreen
//! from one light field, frame after frame along the configured tracking; the last frame's
//! images (and each projector's output: `<wall>-<eye>-<projector>.png`), an overview with the
//! walls unfolded as a cross, and a frame-time report (GPU time per wall and eye from timestamp
//! queries, of the output passes, and CPU time per frame). This is a driver of the frame of
//! views (`frame/`): it keeps the walk's poses (shared through a cluster's frame lock), the
//! waiting, the files and the report; the frame draws and accounts.

use super::conditions::Conditions;
use super::frame::{
    frame_limits, worst_ratio, FrameOfViews, Limit, Poses, Slots, ViewImages, WallView,
};
pub use super::frame::{ViewTiming, CONSTANT_FRAME_TIME};
use super::post::Draw;
use super::DisplayConfig;
use crate::error::{Result, VlfError};
use crate::framelock::{FrameLock, FrameState, StudyState};
use crate::lightfield::{LightField, ResidentLightField};
use crate::render::budget::{BudgetFit, PacerReport};
use crate::render::image_io::{display_image, write_image};
use crate::render::Frame;
use crate::stats::Distribution;
use crate::study::log::Drawn;
use crate::study::{ControlServer, FrameRecord, LslOutlets, Session, SessionLog};
use crate::tracking::source::{Pose, PoseSource};
use crate::tracking::{HeldPoses, RawPoses};
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
    /// GPU milliseconds per frame of the moving objects' update (skinning, triangles, refit, and
    /// the shadow atlas where their shadows come from it); None without objects or timestamps
    pub objects_gpu_ms: Option<Distribution>,
    /// the largest per-view p99/p50 of the GPU time, and whether it meets CONSTANT_FRAME_TIME
    pub worst_p99_over_p50: Option<f64>,
    pub constant_frame_time: Option<bool>,
    /// every limit the frames are judged by (per-view and frame p99/p50, max/median, the
    /// display's frame budget), met or not
    pub limits: Vec<Limit>,
    /// live tracking: milliseconds from a pose's arrival to the submission of the first frame
    /// drawn from it (timed frames; None without live tracking or without a new pose)
    pub tracking_latency_ms: Option<Distribution>,
    /// every timed frame's pose to submission and to predicted photons (`crate::study`)
    pub motion_to_photon: Option<crate::study::MotionToPhoton>,
    /// the settings every frame was drawn with, and with `fit_frame_time` what was probed
    pub quality: crate::render::budget::Quality,
    /// with edge antialiasing: the share of each view's pixels it refined in the last frame
    /// (each view drawn again and read back), and the eye rays per pixel that makes
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub refined_last_frame: Vec<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eye_rays_per_pixel_last_frame: Option<f64>,
    pub fit: Option<BudgetFit>,
    /// with a fit: the share of each view's tiles the pacer drew at the high eye-ray count
    pub pacer: Option<PacerReport>,
    pub images: Vec<String>,
    /// the slowest frames by CPU+GPU time (SLOWEST_FRAMES of them), each with what it waited on
    pub slowest_frames: Vec<super::frame::SlowFrame>,
    /// every timed frame in order
    pub series: super::frame::FrameSeries,
}

/// A headless run: `frames` frames, the last one's images into `out` (PNG, and EXR with `exr`),
/// with `log` every frame into a session log, and with `control` an experiment script's
/// commands (`crate::study`; its `stop` makes the frame it arrives in the last), and with `lsl`
/// every frame on LSL outlets (its frames then held to the display's refresh rate).
pub struct HeadlessRun<'p> {
    pub frames: u32,
    pub out: &'p Path,
    pub exr: bool,
    pub log: Option<&'p mut SessionLog>,
    pub control: Option<&'p ControlServer>,
    pub lsl: Option<LslOutlets>,
    /// the display's conditions with their light fields made (`super::conditions`), switched
    /// by the script's `condition` command
    pub conditions: Option<&'p Conditions>,
    /// every frame drawn view by view and read back (untimed), its images into
    /// `out/frame-<n>/` as `vlf replay` writes them, the last one into `out` as well: what the
    /// walls showed frame by frame, to compare with a replay
    pub read_back_every_frame: bool,
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
    let run = HeadlessRun {
        frames,
        out,
        exr,
        log: None,
        control: None,
        lsl: None,
        conditions: None,
        read_back_every_frame: false,
    };
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
    run: HeadlessRun<'_>,
    progress: &dyn crate::progress::Progress,
) -> Result<CaveReport> {
    run_locked(lf, resident, config, config_path, run, None, progress)
}

/// What the last frame leaves: every view's image, and each projector's output (named
/// `<wall>-<eye>-<projector>`).
pub(super) struct Kept {
    views: Vec<Frame>,
    projectors: Vec<(String, Frame)>,
    /// the PNGs' exposure (the condition's; the EXRs stay linear)
    pub(super) exposure: f32,
}

impl Default for Kept {
    fn default() -> Kept {
        Kept {
            views: Vec::new(),
            projectors: Vec::new(),
            exposure: 1.0,
        }
    }
}

impl Kept {
    /// Every view's image, in view order.
    pub(super) fn views(&self) -> &[Frame] {
        &self.views
    }

    /// The latency test's walls in place of the views (`flash`: Some(true) full white, Some(false)
    /// black), as the windows show them: every view's and projector's image one colour, white
    /// being full scale at the exposure of the PNGs.
    pub(super) fn flash(&mut self, flash: Option<bool>) {
        let Some(white) = flash else { return };
        let level = if white { 1.0 / self.exposure } else { 0.0 };
        let images = (self.views.iter_mut()).chain(self.projectors.iter_mut().map(|(_, i)| i));
        for p in images.flat_map(|image| image.pixels.iter_mut()) {
            p[..3].fill(level);
        }
    }

    /// The frame's views read back (`FrameOfViews::read_back`), their projectors' outputs named.
    pub(super) fn of(config: &DisplayConfig, views: &[WallView], images: Vec<ViewImages>) -> Kept {
        let mut kept = Kept::default();
        for (v, (frame, projectors)) in views.iter().zip(images) {
            let view = v.name(config);
            kept.views.push(frame);
            kept.projectors.extend(
                (projectors.into_iter()).map(|(name, image)| (format!("{view}-{name}"), image)),
            );
        }
        kept
    }
}

/// The display's conditions as the session takes them, where they were made (`conditions`); a
/// run without them (a cluster's rank, the library's plain `run`) draws its light field as is.
pub(super) fn studied(
    config: &DisplayConfig,
    conditions: Option<&Conditions>,
) -> Vec<(String, Option<(glam::Vec3, f32)>)> {
    match conditions {
        Some(_) => config.study_conditions(),
        None => Vec::new(),
    }
}

/// What frame `f` of `total` is drawn from: the pose (spread evenly over a scripted walk; where
/// the script placed the room), the held poses, the raw poses a live tracker sent (this rank's),
/// when a live pose arrived and when the pose was sampled, and the study's state. In a cluster
/// rank 0's are shared through the lock, its objects' time and study state with them, and every
/// other rank sets them on its frame.
struct FramePose {
    pose: Pose,
    held: HeldPoses,
    raw: RawPoses,
    fresh: Option<std::time::Instant>,
    sampled: std::time::Instant,
    study: StudyState,
}

fn frame_pose<'l>(
    (poses, config): (&PoseSource, &DisplayConfig),
    (f, total): (u32, u32),
    (session, frame): (&mut Session<'_>, &mut FrameOfViews<'_>),
    lock: Option<&mut (dyn FrameLock + 'l)>,
) -> Result<FramePose> {
    let duration = match poses {
        PoseSource::Scripted(s) => s.duration(),
        PoseSource::Static(_) | PoseSource::Live(_) => 0.0,
    };
    let t = if total > 1 {
        duration * f as f32 / (total - 1) as f32
    } else {
        0.0
    };
    let (pose, held, raw, fresh) = poses.frame_at(&config.tracking, t);
    // when the pose came in (live tracking), or was sampled
    let sampled = fresh.unwrap_or_else(std::time::Instant::now);
    let pose = session.pose(pose, sampled);
    let object_time_s = object_time(poses, config, (f, total));
    let study = frame.study_state(session.flash(), session.stop);
    let Some(l) = lock else {
        frame.set_object_time(object_time_s);
        return Ok(FramePose {
            pose,
            held,
            raw,
            fresh,
            sampled,
            study,
        });
    };
    let state = FrameState::new(f as u64, &pose, held, 1.0).with_study(object_time_s, study);
    let s = l.share(state)?;
    if !l.is_leader() {
        frame.follow_study(&s.study())?;
    }
    frame.set_object_time(s.object_time_s);
    Ok(FramePose {
        pose: s.pose(),
        held: s.held(),
        raw,
        fresh,
        sampled,
        study: s.study(),
    })
}

/// Frame `f`'s time for keyframed objects: the scripted walk's time where the poses are
/// scripted (objects move with the walk), else frame `f` of the refresh rate (60 Hz unless
/// given), so that a headless run draws the same frames every time.
fn object_time(poses: &PoseSource, config: &DisplayConfig, (f, total): (u32, u32)) -> f64 {
    match poses {
        PoseSource::Scripted(s) if total > 1 => {
            (s.duration() * f as f32 / (total - 1) as f32) as f64
        }
        _ => f as f64 / config.refresh_hz.unwrap_or(60.0) as f64,
    }
}

/// The frame of views a headless run draws (an image per wall, each view read back before the
/// next is drawn), with `conditions` bound, and the poses it draws from.
fn headless_frame<'a>(
    fields: (&'a LightField, &ResidentLightField),
    config: &'a DisplayConfig,
    config_path: &Path,
    conditions: Option<&'a Conditions>,
) -> Result<(PoseSource, FrameOfViews<'a>)> {
    let poses = config.pose_source(config_path)?;
    let slots = Slots::PerWall;
    let frame = FrameOfViews::cave(fields, config, config_path, &poses, slots, conditions)?;
    Ok((poses, frame))
}

/// `run` as one rank of a cluster (`crate::cluster`): each frame's pose comes from `lock.share`,
/// and `lock.swap` waits for every rank once the frame is drawn.
pub fn run_locked(
    lf: &LightField,
    resident: &ResidentLightField,
    config: &DisplayConfig,
    config_path: &Path,
    run: HeadlessRun<'_>,
    mut lock: Option<&mut dyn FrameLock>,
    progress: &dyn crate::progress::Progress,
) -> Result<CaveReport> {
    let (frames, out, exr, conditions) = (run.frames, run.out, run.exr, run.conditions);
    let mut session = (Session::new(run.log, run.control).with_display(config.refresh_hz, run.lsl))
        .with_objects(config.object_names())
        .with_conditions(studied(config, conditions));
    std::fs::create_dir_all(out).map_err(|e| VlfError::io(out, e))?;
    let (poses, mut frame) = headless_frame((lf, resident), config, config_path, conditions)?;
    let total = frames.max(1);
    let mut kept = Kept::default();
    let software = resident.ctx.summary.software;
    let began = std::time::Instant::now();
    progress.begin(total as u64, "frames", "drawing every wall and eye");
    let mut drawn_frames = total;
    for f in 0..total {
        report_frame(progress, (f, total), began, software);
        session.begin_frame();
        frame.take_study_changes(&mut session)?;
        let FramePose {
            pose,
            held,
            raw,
            fresh,
            sampled,
            study,
        } = frame_pose(
            (&poses, config),
            (f, total),
            (&mut session, &mut frame),
            lock.as_deref_mut(),
        )?;
        session.follow(&study, frame.condition());
        let object_time_s = frame.object_time_s();
        let tracked = Poses::Tracked {
            pose: &pose,
            held: &held,
            arrived: fresh,
        };
        let time_s = session.time_s();
        let record = |frame: &FrameOfViews, drawn: Drawn| FrameRecord {
            frame: f as u64,
            time_s,
            drawn,
            pose,
            wand: held.wand,
            left_hand: held.left_hand,
            targets: held.targets,
            gpu_ms: None,
            cpu_ms: None,
            block: 0,
            trial: 0,
            pose_to_submit_ms: None,
            pose_to_photon_ms: None,
            object_time_s: Some(object_time_s),
            raw,
            views: frame.drawn().to_vec(),
            events: String::new(),
            condition: String::new(),
            objects: Some(frame.object_switches()),
            flash: None,
            eyes: Vec::new(),
        };
        let last = f + 1 == total || study.stop;
        if last || run.read_back_every_frame {
            let folder = out.join(format!("frame-{f:06}"));
            let into = if run.read_back_every_frame {
                &folder
            } else {
                out
            };
            let each = (run.read_back_every_frame).then_some((into, exr));
            kept = read_back_kept(&mut frame, config, (tracked, study.flash), each)?;
            let note = format!("read back into {}", into.display());
            session.end_frame(record(&frame, Drawn::ReadBack), Some(note))?;
            if let Some(l) = lock.as_deref_mut() {
                l.swap_untimed()?;
            }
            if last {
                drawn_frames = f + 1;
                break;
            }
            continue;
        }
        let [pose_to_submit_ms, gpu_ms, cpu_ms] = timed_frame(
            &mut frame,
            (tracked, sampled),
            &resident.ctx,
            lock.as_deref_mut(),
        )?;
        let row = FrameRecord {
            gpu_ms,
            cpu_ms,
            pose_to_submit_ms,
            ..record(&frame, Drawn::Timed)
        };
        session.end_frame(row, None)?;
    }
    report_frame(progress, (drawn_frames, drawn_frames), began, software);
    progress.finish();
    if frame.frames_timed() == 0 {
        frame.times_mut().push_cpu(0.0);
    }
    let images = write_kept(config, frame.wall_views(), &kept, out, exr)?;
    let adapter = resident.ctx.summary.name.clone();
    let motion_to_photon = session.motion_to_photon();
    Ok(cave_report(
        config,
        &frame,
        (adapter, drawn_frames, images),
        motion_to_photon,
    ))
}

/// The report of a run's frames: `frame`'s times and settings, the adapter, the frames drawn and
/// the images written, the motion to photon.
fn cave_report(
    config: &DisplayConfig,
    frame: &FrameOfViews<'_>,
    (adapter, drawn_frames, images): (String, u32, Vec<String>),
    motion_to_photon: Option<crate::study::MotionToPhoton>,
) -> CaveReport {
    let views = frame.times().views();
    let worst = worst_ratio(&views);
    let cpu_frame_ms = frame.times().cpu_ms().expect("one frame at least");
    let limits = frame_limits(&views, Some(&cpu_frame_ms), config.frame_budget_ms());
    let refined = frame.refined_shares().to_vec();
    let series = frame.series();
    let slowest =
        super::frame::slowest_frames(&series, frame.labels(), super::frame::SLOWEST_FRAMES);
    CaveReport {
        eye_rays_per_pixel_last_frame: edge_eye_rays(&frame.quality(), &refined),
        worst_p99_over_p50: worst,
        constant_frame_time: worst.map(|w| w <= CONSTANT_FRAME_TIME),
        limits,
        display: config.name.clone(),
        adapter,
        frames: drawn_frames,
        views_per_frame: frame.labels().len(),
        views,
        all_views_gpu_ms: frame.times().frame_gpu_ms(),
        cpu_frame_ms,
        outputs_gpu_ms: frame.times().output_gpu_ms(),
        objects_gpu_ms: frame.times().objects_gpu_ms(),
        tracking_latency_ms: frame.latency_ms(),
        motion_to_photon,
        quality: frame.quality(),
        refined_last_frame: refined,
        fit: frame.fit().cloned(),
        pacer: frame.pacer_report(),
        images,
        slowest_frames: slowest,
        series,
    }
}

/// The eye rays per pixel edge antialiasing drew, over the views whose refined shares are
/// `refined`: each pixel's own count, and the edge count on those refined (exact unpaced; paced,
/// as if every tile drew the low count). None without edge antialiasing.
fn edge_eye_rays(quality: &crate::render::budget::Quality, refined: &[f64]) -> Option<f64> {
    if quality.edge_samples == 0 || refined.is_empty() {
        return None;
    }
    let share = refined.iter().sum::<f64>() / refined.len() as f64;
    let own = quality.eye_rays_per_pixel as f64;
    Some(own + share * (quality.edge_samples as f64 - own).max(0.0))
}

/// A timed frame: every view submitted back to back, then waited for (and every rank, with a
/// `lock`): from `sampled` to its submission, its GPU and its CPU time, ms.
fn timed_frame<'l>(
    frame: &mut FrameOfViews<'_>,
    (tracked, sampled): (Poses<'_>, std::time::Instant),
    ctx: &crate::gpu::GpuContext,
    lock: Option<&mut (dyn FrameLock + 'l)>,
) -> Result<[Option<f64>; 3]> {
    frame.begin(true)?;
    frame.draw(tracked, Draw::Timed, None)?;
    let pose_to_submit_ms = Some(sampled.elapsed().as_secs_f64() * 1e3);
    ctx.wait_spinning()?;
    let cpu_ms = frame.elapsed_ms();
    if let Some(l) = lock {
        l.swap()?;
    }
    frame.account(cpu_ms)?;
    let (gpu_ms, cpu_ms) = frame.times().last_frame_ms();
    Ok([pose_to_submit_ms, gpu_ms, cpu_ms])
}

/// A frame drawn again view by view and read back (not timed), as the walls showed it: at the
/// condition's exposure, the latency test's `flash` in place of the views; with `into`, its
/// images written there (with EXR where asked) as `vlf replay` writes a frame's.
fn read_back_kept(
    frame: &mut FrameOfViews<'_>,
    config: &DisplayConfig,
    (tracked, flash): (Poses<'_>, Option<bool>),
    into: Option<(&Path, bool)>,
) -> Result<Kept> {
    let images = frame.read_back(tracked)?;
    let mut kept = Kept::of(config, frame.wall_views(), images);
    kept.exposure = frame.exposure();
    kept.flash(flash);
    if let Some((dir, exr)) = into {
        std::fs::create_dir_all(dir).map_err(|e| VlfError::io(dir, e))?;
        write_kept(config, frame.wall_views(), &kept, dir, exr)?;
    }
    Ok(kept)
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
pub(super) fn write_kept(
    config: &DisplayConfig,
    views: &[WallView],
    kept: &Kept,
    out: &Path,
    exr: bool,
) -> Result<Vec<String>> {
    let named = (kept.views.iter().zip(views)).map(|(image, v)| (v.name(config), image));
    let projectors = kept
        .projectors
        .iter()
        .map(|(name, image)| (name.clone(), image));
    let mut images = write_images(named.chain(projectors), out, (exr, kept.exposure))?;
    let overview = out.join("overview.png");
    write_overview(config, views, (&kept.views, kept.exposure), &overview)?;
    images.push(overview.display().to_string());
    Ok(images)
}

/// Write each named image as `out/<name>.png` (and `.exr`); the paths written.
fn write_images<'a>(
    named: impl Iterator<Item = (String, &'a Frame)>,
    out: &Path,
    (exr, exposure): (bool, f32),
) -> Result<Vec<String>> {
    let mut images = Vec::new();
    for (name, image) in named {
        for ext in ["png", "exr"].into_iter().filter(|e| *e == "png" || exr) {
            let path = out.join(format!("{name}.{ext}"));
            write_image(image, &path, exposure)?;
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
    (images, exposure): (&[Frame], f32),
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
        let img = display_image(frame, exposure);
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
        if let Some(rays) = self.eye_rays_per_pixel_last_frame {
            let shares: Vec<String> = (self.refined_last_frame.iter())
                .map(|r| format!("{:.1}%", r * 100.0))
                .collect();
            s += &format!(
                "  edge antialiasing, last frame: {} of the views' pixels refined, {rays:.2} eye rays per pixel\n",
                shares.join(" ")
            );
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
        if let Some(d) = &self.objects_gpu_ms {
            s.push_str(&format!(
                "  moving objects' update (skin, refit, shadow atlas), GPU: median {:.3} ms, p99 {:.3} ms\n",
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
        if let Some(m) = &self.motion_to_photon {
            s.push_str(&m.line());
        }
        if let (Some(w), Some(ok)) = (self.worst_p99_over_p50, self.constant_frame_time) {
            s.push_str(&format!(
                "  constant per-eye frame time: {} (worst p99/p50 {w:.3}; limit {CONSTANT_FRAME_TIME:.2})\n",
                if ok { "yes" } else { "NO" }
            ));
        }
        s.push_str(&Limit::lines(&self.limits));
        if !self.slowest_frames.is_empty() {
            s.push_str("  slowest frames (CPU+GPU, ms) and what each waited on:\n");
            for f in &self.slowest_frames {
                s.push_str(&f.line());
            }
        }
        s
    }
}
