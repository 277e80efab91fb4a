//! What a frame of views measured, frame after frame: the GPU time of each view's passes from
//! timestamp queries and the CPU time of each frame (`FrameTimes`, `Pass`), each view's
//! distribution as the reports give it (`ViewTiming`), and the limits a report judges those
//! times by (`Limit`, `frame_limits`): a ratio above its limit is said in words, in the table
//! and in the JSON.

use super::views::ViewLabel;
use crate::stats::Distribution;
use serde::{Deserialize, Serialize};

/// Per-view GPU time p99/p50 at or under this counts as a constant frame time.
pub const CONSTANT_FRAME_TIME: f64 = 1.10;
/// The whole frame's CPU+GPU time p99/p50 at or under this counts as constant.
pub const CONSTANT_CPU_FRAME_TIME: f64 = 1.15;
/// No frame's CPU+GPU time above this many medians.
pub const MAX_OVER_MEDIAN: f64 = 1.5;

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
    /// the moving objects' skinning and refit, before the views
    Objects,
}

/// Every frame's times, per view and in all.
pub struct FrameTimes {
    pub labels: Vec<ViewLabel>,
    gpu: Vec<Vec<f64>>,
    output_gpu: Vec<f64>,
    objects_gpu: Vec<f64>,
    frame_gpu: Vec<f64>,
    /// frames in flight: each frame's first pass start to last pass end on the GPU's clock, and
    /// from the frame before's last pass end to its first pass start (the first frame's None)
    gpu_span: Vec<f64>,
    gpu_gap: Vec<Option<f64>>,
    last_end_tick: Option<u64>,
    cpu: Vec<f64>,
}

impl FrameTimes {
    pub fn new(labels: Vec<ViewLabel>) -> FrameTimes {
        FrameTimes {
            gpu: vec![Vec::new(); labels.len()],
            labels,
            output_gpu: Vec::new(),
            objects_gpu: Vec::new(),
            frame_gpu: Vec::new(),
            gpu_span: Vec::new(),
            gpu_gap: Vec::new(),
            last_end_tick: None,
            cpu: Vec::new(),
        }
    }

    /// A frame in flight's first pass start and last pass end on the GPU's clock, in ticks of
    /// `tick_ms` (subtracted as integers: the clock's counts are too large for an f64's ticks).
    pub fn push_span(&mut self, (start, end): (u64, u64), tick_ms: f64) {
        self.gpu_span.push(end.wrapping_sub(start) as f64 * tick_ms);
        (self.gpu_gap).push(
            self.last_end_tick
                .map(|e| start.wrapping_sub(e) as i64 as f64 * tick_ms),
        );
        self.last_end_tick = Some(end);
    }

    /// Per frame in flight, in order: the GPU time from its first pass's start to its last's end,
    /// and the GPU's time between the frame before and it (idle, or work outside vlf's passes).
    pub fn gpu_spans(&self) -> (&[f64], &[Option<f64>]) {
        (&self.gpu_span, &self.gpu_gap)
    }

    /// One frame's timestamp pairs in milliseconds, `passes[i]` saying what pair i timed.
    pub fn push_gpu(&mut self, ms: &[f64], passes: &[Pass]) {
        let mut output = None;
        for (&ms, &pass) in ms.iter().zip(passes) {
            match pass {
                Pass::View(v) => self.gpu[v].push(ms),
                Pass::Output => *output.get_or_insert(0.0) += ms,
                Pass::Objects => self.objects_gpu.push(ms),
            }
        }
        // every pass of the frame, views and outputs
        self.frame_gpu.push(ms.iter().take(passes.len()).sum());
        if let Some(o) = output {
            self.output_gpu.push(o);
        }
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

    /// GPU time of the moving objects' update per frame (None without objects)
    pub fn objects_gpu_ms(&self) -> Option<Distribution> {
        (!self.objects_gpu.is_empty()).then(|| Distribution::of(&self.objects_gpu))
    }

    pub fn output_gpu_ms(&self) -> Option<Distribution> {
        (!self.output_gpu.is_empty()).then(|| Distribution::of(&self.output_gpu))
    }

    /// The last timed frame's GPU time of all its passes, and its CPU time.
    pub fn last_frame_ms(&self) -> (Option<f64>, Option<f64>) {
        (self.frame_gpu.last().copied(), self.cpu.last().copied())
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
            objects_gpu_ms: self.objects_gpu.clone(),
            gpu_span_ms: self.gpu_span.clone(),
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
    /// of each frame's GPU time, the moving objects' pass before the views (empty without them)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub objects_gpu_ms: Vec<f64>,
    /// each frame's span on the GPU's clock, its first pass's start to its last pass's end:
    /// more than its passes' time where the GPU idled between them (empty where not measured)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub gpu_span_ms: Vec<f64>,
}

/// The largest p99/p50 among the views.
pub fn worst_ratio(views: &[ViewTiming]) -> Option<f64> {
    views
        .iter()
        .filter_map(|v| v.p99_over_p50)
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))))
}
