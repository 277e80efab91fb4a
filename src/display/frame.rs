//! The frame as the three display loops share it (offscreen `headless.rs`, windows `window/`,
//! headset `crate::xr`): which views a frame draws (`ViewLabel`), the GPU time of each view's passes
//! from timestamp queries (`FrameTimes`), read back either at once (headless and windows wait
//! for every frame, which is what their CPU+GPU frame time measures) or without stalling the
//! next frame (`InFlight`: the headset records frame N+1 while the GPU draws frame N), and the
//! limits a report judges those times by (`Limit`): a ratio above its limit is said in words, in
//! the table and in the JSON.

use crate::error::Result;
use crate::gpu::{GpuContext, Timestamps};
use crate::stats::Distribution;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

/// Per-view GPU time p99/p50 at or under this counts as a constant frame time.
pub const CONSTANT_FRAME_TIME: f64 = 1.10;
/// The whole frame's CPU+GPU time p99/p50 at or under this counts as constant.
pub const CONSTANT_CPU_FRAME_TIME: f64 = 1.15;
/// No frame's CPU+GPU time above this many medians.
pub const MAX_OVER_MEDIAN: f64 = 1.5;

/// A wall seen by one eye: what the CAVE's loops (headless and windows) draw once a frame.
#[derive(Clone, Copy, Debug)]
pub struct WallView {
    pub wall: usize,
    pub eye: &'static str,
    /// the eye's offset along the eye axis (-1/2 left, +1/2 right, 0 mono: `Wall::eyes`)
    pub side: f32,
}

/// Every wall's eyes, in wall order.
pub fn wall_views(config: &super::DisplayConfig) -> Vec<WallView> {
    (config.walls.iter().enumerate())
        .flat_map(|(wall, w)| {
            (w.eyes().into_iter()).map(move |(eye, side)| WallView { wall, eye, side })
        })
        .collect()
}

/// The reports' names of the views.
pub fn labels(config: &super::DisplayConfig, views: &[WallView]) -> Vec<ViewLabel> {
    (views.iter())
        .map(|v| ViewLabel {
            wall: config.walls[v.wall].name.clone(),
            eye: v.eye,
            pixels: config.walls[v.wall].eye_pixels(),
        })
        .collect()
}

/// One view of a frame, as the reports name it.
#[derive(Clone, Debug)]
pub struct ViewLabel {
    pub wall: String,
    pub eye: &'static str,
    pub pixels: [u32; 2],
}

/// One view's GPU time over the run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ViewTiming {
    pub wall: String,
    pub eye: String,
    pub pixels: [u32; 2],
    /// GPU milliseconds per frame (timestamp queries); None without them
    pub gpu_ms: Option<Distribution>,
    /// p99 / p50 of the GPU time: 1.0 is a perfectly constant frame time
    pub p99_over_p50: Option<f64>,
    /// p99/p50 above CONSTANT_FRAME_TIME (None without timestamps)
    #[serde(default)]
    pub above_limit: Option<bool>,
}

impl ViewTiming {
    pub fn of(label: &ViewLabel, series: &[f64]) -> ViewTiming {
        let d = (!series.is_empty()).then(|| Distribution::of(series));
        let ratio = d.as_ref().map(|d| d.p99 / d.median.max(1e-12));
        ViewTiming {
            wall: label.wall.clone(),
            eye: label.eye.into(),
            pixels: label.pixels,
            gpu_ms: d,
            p99_over_p50: ratio,
            above_limit: ratio.map(|r| r > CONSTANT_FRAME_TIME),
        }
    }

    /// The report's row: `  front  left  1920x1200  GPU p50 ...`, flagged when above the limit.
    pub fn row(&self) -> String {
        match &self.gpu_ms {
            Some(d) => format!(
                "  {:<10} {:<6} {}x{}  GPU p50 {:.3} ms  p95 {:.3}  p99 {:.3}  max {:.3}  (p99/p50 {:.3}){}\n",
                self.wall, self.eye, self.pixels[0], self.pixels[1], d.median, d.p95, d.p99, d.max,
                self.p99_over_p50.unwrap_or(0.0),
                if self.above_limit == Some(true) { format!("  ABOVE THE LIMIT {CONSTANT_FRAME_TIME:.2}") } else { String::new() }
            ),
            None => format!(
                "  {:<10} {:<6} {}x{}  (no GPU timestamps on this adapter)\n",
                self.wall, self.eye, self.pixels[0], self.pixels[1]
            ),
        }
    }
}

/// A measured quantity against the limit it must stay at or under.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Limit {
    pub what: String,
    pub measured: f64,
    pub limit: f64,
    pub met: bool,
}

impl Limit {
    pub fn check(what: impl Into<String>, measured: f64, limit: f64) -> Limit {
        Limit {
            what: what.into(),
            measured,
            limit,
            met: measured <= limit,
        }
    }

    /// `  limit met: ...` or `  ABOVE THE LIMIT: ...`, one line each.
    pub fn lines(limits: &[Limit]) -> String {
        limits
            .iter()
            .map(|l| {
                format!(
                    "  {}: {} {:.3} (limit {:.3})\n",
                    if l.met {
                        "limit met"
                    } else {
                        "ABOVE THE LIMIT"
                    },
                    l.what,
                    l.measured,
                    l.limit
                )
            })
            .collect()
    }
}

/// The limits of a run's frames: every view's GPU p99/p50 (the worst one), the frame's
/// CPU+GPU p99/p50, its maximum against the median, and each frame under `frame_budget_ms`
/// where the display has one.
pub fn frame_limits(
    views: &[ViewTiming],
    cpu_frame_ms: Option<&Distribution>,
    frame_budget_ms: Option<f64>,
) -> Vec<Limit> {
    let mut limits = Vec::new();
    let worst = views
        .iter()
        .filter_map(|v| v.p99_over_p50.map(|r| (r, v)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((r, v)) = worst {
        let what = format!("per-view GPU p99/p50 (worst: {} {})", v.wall, v.eye);
        limits.push(Limit::check(what, r, CONSTANT_FRAME_TIME));
    }
    if let Some(c) = cpu_frame_ms.filter(|c| c.samples > 1) {
        let median = c.median.max(1e-12);
        limits.push(Limit::check(
            "frame CPU+GPU p99/p50",
            c.p99 / median,
            CONSTANT_CPU_FRAME_TIME,
        ));
        limits.push(Limit::check(
            "frame CPU+GPU max/median",
            c.max / median,
            MAX_OVER_MEDIAN,
        ));
        if let Some(budget) = frame_budget_ms {
            limits.push(Limit::check("frame CPU+GPU max (ms)", c.max, budget));
        }
    }
    limits
}

/// What one timestamp pair of a frame measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// the render of view i
    View(usize),
    /// a pass after rendering (warp, blend, wand ray, present)
    Output,
}

/// Every frame's times, per view and in all.
pub struct FrameTimes {
    pub labels: Vec<ViewLabel>,
    gpu: Vec<Vec<f64>>,
    output_gpu: Vec<f64>,
    frame_gpu: Vec<f64>,
    cpu: Vec<f64>,
}

impl FrameTimes {
    pub fn new(labels: Vec<ViewLabel>) -> FrameTimes {
        FrameTimes {
            gpu: vec![Vec::new(); labels.len()],
            labels,
            output_gpu: Vec::new(),
            frame_gpu: Vec::new(),
            cpu: Vec::new(),
        }
    }

    /// One frame's timestamp pairs in milliseconds, `passes[i]` saying what pair i timed.
    pub fn push_gpu(&mut self, ms: &[f64], passes: &[Pass]) {
        let mut output = None;
        for (&ms, &pass) in ms.iter().zip(passes) {
            match pass {
                Pass::View(v) => self.gpu[v].push(ms),
                Pass::Output => *output.get_or_insert(0.0) += ms,
            }
        }
        // every pass of the frame, views and outputs
        self.frame_gpu.push(ms.iter().take(passes.len()).sum());
        if let Some(o) = output {
            self.output_gpu.push(o);
        }
    }

    /// One frame's timestamp pairs when each view has exactly one, in view order.
    pub fn push_view_gpu(&mut self, ms: &[f64]) {
        let passes: Vec<Pass> = (0..self.labels.len()).map(Pass::View).collect();
        self.push_gpu(ms, &passes);
    }

    pub fn push_cpu(&mut self, ms: f64) {
        self.cpu.push(ms);
    }

    pub fn frames_timed(&self) -> usize {
        self.cpu.len()
    }

    pub fn views(&self) -> Vec<ViewTiming> {
        self.labels
            .iter()
            .zip(&self.gpu)
            .map(|(label, series)| ViewTiming::of(label, series))
            .collect()
    }

    /// GPU time of all of a frame's passes
    pub fn frame_gpu_ms(&self) -> Option<Distribution> {
        (!self.frame_gpu.is_empty()).then(|| Distribution::of(&self.frame_gpu))
    }

    pub fn output_gpu_ms(&self) -> Option<Distribution> {
        (!self.output_gpu.is_empty()).then(|| Distribution::of(&self.output_gpu))
    }

    pub fn cpu_ms(&self) -> Option<Distribution> {
        (!self.cpu.is_empty()).then(|| Distribution::of(&self.cpu))
    }

    /// Every timed frame in order: each view's GPU milliseconds, all views', the CPU's (for
    /// plotting a walk frame by frame).
    pub fn series(&self) -> FrameSeries {
        FrameSeries {
            view_gpu_ms: self.gpu.clone(),
            frame_gpu_ms: self.frame_gpu.clone(),
            cpu_frame_ms: self.cpu.clone(),
            submit_ms: Vec::new(),
        }
    }
}

/// The frames of a run in order (`FrameTimes::series`), views in the report's order.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameSeries {
    pub view_gpu_ms: Vec<Vec<f64>>,
    pub frame_gpu_ms: Vec<f64>,
    pub cpu_frame_ms: Vec<f64>,
    /// of each frame's CPU time, the part spent encoding and submitting its passes (headless;
    /// the rest is waiting for the GPU)
    pub submit_ms: Vec<f64>,
}

/// The largest p99/p50 among the views.
pub fn worst_ratio(views: &[ViewTiming]) -> Option<f64> {
    views
        .iter()
        .filter_map(|v| v.p99_over_p50)
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))))
}

const IDLE: u8 = 0;
const PENDING: u8 = 1;
const MAPPED: u8 = 2;

/// One frame in flight: its timestamp queries and the buffer they come back in.
struct Slot {
    timestamps: Timestamps,
    readback: wgpu::Buffer,
    state: Arc<AtomicU8>,
    pairs: u32,
}

/// GPU timestamps of frames in flight, read back without waiting for the GPU: each frame takes
/// the next of `depth` slots; a slot is read once the GPU has finished its frame (checked
/// without blocking), and only a slot still busy `depth` frames later makes the CPU wait.
pub struct InFlight {
    slots: Vec<Slot>,
    next: usize,
    /// frames whose recording began while the GPU still drew the one before
    pub overlapped: u64,
    /// frames whose recording began with the GPU idle
    pub serial: u64,
    /// frames that had to wait for a slot (the GPU `depth` frames behind)
    pub waited: u64,
}

impl InFlight {
    /// None where the adapter has no timestamp queries.
    pub fn new(ctx: &GpuContext, pairs_per_frame: u32, depth: usize) -> Option<InFlight> {
        let slots = (0..depth.max(1))
            .map(|_| {
                let timestamps = Timestamps::new(ctx, pairs_per_frame)?;
                let readback = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps in flight"),
                    size: pairs_per_frame as u64 * 16,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                Some(Slot {
                    timestamps,
                    readback,
                    state: Arc::new(AtomicU8::new(IDLE)),
                    pairs: 0,
                })
            })
            .collect::<Option<Vec<_>>>()?;
        Some(InFlight {
            slots,
            next: 0,
            overlapped: 0,
            serial: 0,
            waited: 0,
        })
    }

    /// Start a frame: the times of the frames the GPU has finished, oldest first (this frame's
    /// queries are `timestamps`). Notes whether the previous frame was still on the GPU.
    pub fn begin(&mut self, ctx: &GpuContext) -> Result<Vec<Vec<f64>>> {
        let _ = ctx.device.poll(wgpu::PollType::Poll);
        let previous = (self.next + self.slots.len() - 1) % self.slots.len();
        match self.slots[previous].state.load(Ordering::Acquire) {
            PENDING => self.overlapped += 1,
            _ => self.serial += 1,
        }
        if self.slots[self.next].state.load(Ordering::Acquire) == PENDING {
            self.waited += 1;
            while self.slots[self.next].state.load(Ordering::Acquire) == PENDING {
                ctx.wait()?;
            }
        }
        Ok(self.collect(ctx))
    }

    /// The queries of the frame begun.
    pub fn timestamps(&mut self) -> &mut Timestamps {
        &mut self.slots[self.next].timestamps
    }

    /// After the frame's last pass: copy its timestamps to the slot's read-back buffer.
    pub fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder) {
        let slot = &mut self.slots[self.next];
        slot.pairs = slot.timestamps.resolve_into(encoder, &slot.readback);
    }

    /// After the frame is submitted: ask for its timestamps, and move to the next slot.
    pub fn submitted(&mut self) {
        let slot = &mut self.slots[self.next];
        if slot.pairs > 0 {
            slot.state.store(PENDING, Ordering::Release);
            let state = slot.state.clone();
            slot.readback
                .slice(..slot.pairs as u64 * 16)
                .map_async(wgpu::MapMode::Read, move |r| {
                    state.store(if r.is_ok() { MAPPED } else { IDLE }, Ordering::Release)
                });
        }
        self.next = (self.next + 1) % self.slots.len();
    }

    /// The times of every frame still in flight, waiting for the GPU (at the end of a run).
    pub fn finish(&mut self, ctx: &GpuContext) -> Result<Vec<Vec<f64>>> {
        while self
            .slots
            .iter()
            .any(|s| s.state.load(Ordering::Acquire) == PENDING)
        {
            ctx.wait()?;
        }
        Ok(self.collect(ctx))
    }

    /// Read every mapped slot, oldest first.
    fn collect(&mut self, ctx: &GpuContext) -> Vec<Vec<f64>> {
        let n = self.slots.len();
        let mut done = Vec::new();
        for k in 0..n {
            let slot = &mut self.slots[(self.next + k) % n];
            if slot.state.load(Ordering::Acquire) != MAPPED {
                continue;
            }
            let range = slot.readback.slice(..slot.pairs as u64 * 16);
            if let Ok(bytes) = range.get_mapped_range() {
                let ticks: &[u64] = bytemuck::cast_slice(&bytes);
                let period = ctx.timestamp_period_ns as f64 * 1e-6;
                done.push(
                    (ticks.chunks(2))
                        .map(|p| p[1].wrapping_sub(p[0]) as f64 * period)
                        .collect(),
                );
            }
            slot.readback.unmap();
            slot.state.store(IDLE, Ordering::Release);
        }
        done
    }
}

/// With `fit_frame_time`, the settings whose frame fits the refresh period, probed on the
/// views of the walk's first pose (`render/budget.rs`).
pub fn fit_frame_time(
    renderer: &mut crate::render::Renderer,
    config: &super::DisplayConfig,
    views: &[WallView],
    poses: &crate::tracking::source::PoseSource,
    lf: &crate::lightfield::LightField,
) -> crate::error::Result<Option<crate::render::budget::BudgetFit>> {
    let Some(budget) = config.frame_budget_ms().filter(|_| config.fit_frame_time) else {
        return Ok(None);
    };
    let (pose, _) = poses.at_fresh(0.0);
    let probes: Vec<crate::render::budget::ProbeView> = (views.iter())
        .map(|v| {
            let wall = &config.walls[v.wall];
            let (view_proj, eye) =
                super::wall_view(config, wall, v.side, &pose, &lf.meta.normalisation);
            let [w, h] = wall.eye_pixels();
            crate::render::budget::ProbeView {
                view_proj,
                eye,
                size: [w, h],
            }
        })
        .collect();
    renderer.fit_frame_time(&probes, budget).map(Some)
}

/// One frame's timestamp pairs (`passes[i]` saying what pair i timed) to the pacer: each
/// view's GPU time.
pub fn pace_views(pacer: &mut crate::render::budget::Pacer, ms: &[f64], passes: &[Pass]) {
    for (&m, pass) in ms.iter().zip(passes) {
        if let Pass::View(v) = pass {
            pacer.observe(*v, m);
        }
    }
}
