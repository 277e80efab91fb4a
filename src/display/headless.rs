//! `vlf cave --headless`: every wall and eye of a display configuration rendered offscreen
//! from one light field, frame after frame along the configured tracking; the last frame's
//! images (and each projector's output: `<wall>-<eye>-<projector>.png`), an overview with the
//! walls unfolded as a cross, and a frame-time report (GPU time per wall and eye from timestamp
//! queries, of the output passes, and CPU time per frame).

use super::framelock::{FrameLock, FrameState};
use super::post::{Draw, Outputs};
use super::tracking::PoseSource;
use super::DisplayConfig;
use crate::error::{Result, VlfError};
use crate::gpu::MemoryLedger;
use crate::lightfield::{LightField, ResidentLightField};
use crate::render::image_io::{display_image, write_image};
use crate::render::{Frame, Renderer};
use crate::stats::Distribution;
use serde::Serialize;
use std::path::Path;

#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct ViewTiming {
    pub wall: String,
    pub eye: String,
    pub pixels: [u32; 2],
    /// GPU milliseconds per frame (timestamp queries); None without them
    pub gpu_ms: Option<Distribution>,
    /// p99 / p50 of the GPU time: 1.0 is a perfectly constant frame time
    pub p99_over_p50: Option<f64>,
}

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
    /// live tracking: milliseconds from a pose's arrival to the submission of the first frame
    /// drawn from it (timed frames; None without live tracking or without a new pose)
    pub tracking_latency_ms: Option<Distribution>,
    pub images: Vec<String>,
}

/// Per-eye GPU time p99/p50 at or under this counts as a constant frame time.
pub const CONSTANT_FRAME_TIME: f64 = 1.10;

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
    run_locked(lf, resident, config, config_path, (frames, out, exr), None)
}

/// `run` as one rank of a cluster (`cluster.rs`): each frame's pose comes from `lock.share`,
/// and `lock.swap` waits for every rank once the frame is drawn.
pub fn run_locked(
    lf: &LightField,
    resident: &ResidentLightField,
    config: &DisplayConfig,
    config_path: &Path,
    (frames, out, exr): (u32, &Path, bool),
    mut lock: Option<&mut dyn FrameLock>,
) -> Result<CaveReport> {
    std::fs::create_dir_all(out).map_err(|e| VlfError::io(out, e))?;
    let poses = PoseSource::from_config(config, config_path)?;
    let duration = match &poses {
        PoseSource::Scripted(s) => s.duration(),
        PoseSource::Static(_) | PoseSource::Live(_) => 0.0,
    };
    let mut renderer = Renderer::new(resident, lf, &MemoryLedger::default())?;
    renderer.set_samples_per_pixel(config.antialiasing)?;
    let views: Vec<(usize, &'static str, f32)> = config
        .walls
        .iter()
        .enumerate()
        .flat_map(|(i, w)| {
            w.eyes()
                .into_iter()
                .map(move |(name, side)| (i, name, side))
        })
        .collect();
    let mut gpu: Vec<Vec<f64>> = vec![Vec::new(); views.len()];
    let specs = super::warp::load_outputs(config, config_path)?;
    // the pass after rendering (`post.rs`), when needed: one wall image per wall
    let wand = poses.may_have_wand(&config.tracking);
    let walls: Vec<usize> = (0..config.walls.len()).collect();
    let post = Outputs::needed(config, &specs, wand)
        .then(|| Outputs::new(&resident.ctx, &renderer, config, &specs, &walls, true))
        .transpose()?;
    let mut post_gpu = Vec::new();

    let mut all_gpu = Vec::new();
    let mut cpu = Vec::new();
    // live tracking: milliseconds from a pose's arrival to the submission of its frame
    let mut latency = Vec::new();
    let mut last: Vec<Frame> = Vec::new();
    let mut projector_images: Vec<(String, Frame)> = Vec::new();
    let pairs = views.len()
        + post
            .as_ref()
            .map_or(0, |p| views.iter().map(|v| p.timed_outputs(v.0)).sum());
    let mut timestamps = crate::gpu::Timestamps::new(&resident.ctx, pairs as u32);
    let total_frames = frames.max(1);
    for f in 0..total_frames {
        let t = if total_frames > 1 {
            duration * f as f32 / (total_frames - 1) as f32
        } else {
            0.0
        };
        let (pose, fresh) = poses.at_fresh(t);
        let wand = poses.wand_at(&config.tracking, t);
        let (pose, wand) = match lock.as_deref_mut() {
            Some(l) => {
                let s = l.share(FrameState::new(f as u64, &pose, wand.as_ref(), 1.0))?;
                (s.pose(), s.wand())
            }
            None => (pose, wand),
        };
        let last_frame = f + 1 == total_frames;
        let started = std::time::Instant::now();
        last.clear();
        for &(wall_index, eye_name, side) in &views {
            let wall = &config.walls[wall_index];
            let (view_proj, eye) =
                super::wall_view(config, wall, side, &pose, &lf.meta.normalisation);
            let [w, h] = wall.eye_pixels();
            let overlay = super::post::wand_overlay(
                config,
                wall,
                side,
                &pose,
                wand.as_ref(),
                &lf.meta.normalisation,
            );
            match post.as_ref() {
                Some(p) if last_frame => {
                    let view = (view_proj, eye);
                    p.encode(
                        &mut renderer,
                        wall_index,
                        view,
                        overlay.as_ref(),
                        None,
                        Draw::Everything,
                    );
                    let (frame, projectors) = p.read(wall_index)?;
                    last.push(frame);
                    projector_images.extend(
                        projectors.into_iter().map(|(name, image)| {
                            (format!("{}-{eye_name}-{name}", wall.name), image)
                        }),
                    );
                }
                Some(p) => p.encode(
                    &mut renderer,
                    wall_index,
                    (view_proj, eye),
                    overlay.as_ref(),
                    timestamps.as_mut(),
                    Draw::Timed,
                ),
                // the images to keep: drawn and read back one by one (not timed)
                None if last_frame => last.push(renderer.render_matrix(view_proj, eye, w, h)?.0),
                None => renderer.submit_matrix(view_proj, eye, w, h, timestamps.as_mut()),
            }
        }
        if last_frame {
            if let Some(l) = lock.as_deref_mut() {
                l.swap()?;
            }
            break;
        }
        if let Some(arrived) = fresh {
            latency.push(arrived.elapsed().as_secs_f64() * 1e3);
        }
        resident.ctx.wait()?;
        cpu.push(started.elapsed().as_secs_f64() * 1e3);
        if let Some(l) = lock.as_deref_mut() {
            l.swap()?;
        }
        if let Some(ts) = timestamps.as_mut() {
            let ms = ts.read_ms(&resident.ctx)?;
            // per view: its render, then (with outputs) each output's pass
            let mut it = ms.into_iter();
            let mut post_ms = 0.0;
            for (v, view) in views.iter().enumerate() {
                gpu[v].push(it.next().unwrap_or(0.0));
                for _ in 0..post.as_ref().map_or(0, |p| p.timed_outputs(view.0)) {
                    post_ms += it.next().unwrap_or(0.0);
                }
            }
            all_gpu.push(gpu.iter().filter_map(|g| g.last()).sum::<f64>() + post_ms);
            if post.is_some() {
                post_gpu.push(post_ms);
            }
        }
    }
    if cpu.is_empty() {
        cpu.push(0.0);
    }
    let named = last
        .iter()
        .zip(&views)
        .map(|(image, &(wall_index, eye, _))| {
            (format!("{}-{eye}", config.walls[wall_index].name), image)
        });
    let mut images = write_images(
        named.chain(
            projector_images
                .iter()
                .map(|(name, image)| (name.clone(), image)),
        ),
        out,
        exr,
    )?;
    let overview = out.join("overview.png");
    write_overview(config, &views, &last, &overview)?;
    images.push(overview.display().to_string());
    let (timings, worst) = view_timings(config, &views, &gpu);
    Ok(CaveReport {
        worst_p99_over_p50: worst,
        constant_frame_time: worst.map(|w| w <= CONSTANT_FRAME_TIME),
        display: config.name.clone(),
        adapter: resident.ctx.summary.name.clone(),
        frames: frames.max(1),
        views_per_frame: views.len(),
        views: timings,
        all_views_gpu_ms: (!all_gpu.is_empty()).then(|| Distribution::of(&all_gpu)),
        cpu_frame_ms: Distribution::of(&cpu),
        outputs_gpu_ms: (!post_gpu.is_empty()).then(|| Distribution::of(&post_gpu)),
        tracking_latency_ms: (!latency.is_empty()).then(|| Distribution::of(&latency)),
        images,
    })
}

/// Each view's GPU time, and the largest p99/p50 among them.
fn view_timings(
    config: &DisplayConfig,
    views: &[(usize, &'static str, f32)],
    gpu: &[Vec<f64>],
) -> (Vec<ViewTiming>, Option<f64>) {
    let timings: Vec<ViewTiming> = views
        .iter()
        .enumerate()
        .map(|(v, &(wall_index, eye, _))| {
            let d = (!gpu[v].is_empty()).then(|| Distribution::of(&gpu[v]));
            ViewTiming {
                wall: config.walls[wall_index].name.clone(),
                eye: eye.into(),
                pixels: config.walls[wall_index].eye_pixels(),
                p99_over_p50: d.as_ref().map(|d| d.p99 / d.median.max(1e-12)),
                gpu_ms: d,
            }
        })
        .collect();
    let worst = timings
        .iter()
        .filter_map(|v: &ViewTiming| v.p99_over_p50)
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))));
    (timings, worst)
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
    views: &[(usize, &'static str, f32)],
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
    for (i, &(wall_index, eye, _)) in views.iter().enumerate() {
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
            "  display {} on {}: {} frames, {} views per frame\n",
            self.display, self.adapter, self.frames, self.views_per_frame
        );
        for v in &self.views {
            match &v.gpu_ms {
                Some(d) => s.push_str(&format!(
                    "  {:<10} {:<6} {}x{}  GPU p50 {:.3} ms  p95 {:.3}  p99 {:.3}  max {:.3}  (p99/p50 {:.3})\n",
                    v.wall, v.eye, v.pixels[0], v.pixels[1], d.median, d.p95, d.p99, d.max, v.p99_over_p50.unwrap_or(0.0)
                )),
                None => s.push_str(&format!("  {:<10} {:<6} {}x{}  (no GPU timestamps on this adapter)\n", v.wall, v.eye, v.pixels[0], v.pixels[1])),
            }
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
        s
    }
}
