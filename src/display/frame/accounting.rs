//! A frame of views' accounting: which timestamp pairs a frame writes and what each times
//! (`Pass`), read back at once after the frame (`Clock::Serial`: headless and windows wait for
//! every frame, which is what their CPU+GPU frame time measures) or frames later without
//! stalling (`Clock::InFlight`: the headset); the times to the pacer and, for timed frames, to
//! the report (`FrameTimes`), with the latency from a pose's arrival to its frame's submission
//! and the time each frame took to encode and submit.

use super::in_flight::{DoneFrame, InFlight};
use super::times::{FrameSeries, FrameTimes, Pass};
use super::views::ViewLabel;
use crate::error::Result;
use crate::gpu::{GpuContext, Timestamps};
use crate::render::budget::Pacer;
use crate::stats::Distribution;
use std::time::Instant;

/// How a frame's GPU times come back.
pub enum Clock {
    /// one set of queries, read once the frame is done (None: no timestamps on this adapter)
    Serial(Option<Timestamps>),
    /// `depth` frames in flight, each read back once the GPU has finished it, one pair per view
    InFlight {
        depth: usize,
        frames: Option<InFlight>,
    },
}

/// Every frame's times, and the state of the frame being drawn.
pub struct Accounting {
    pub times: FrameTimes,
    clock: Clock,
    /// what this frame's timestamp pairs time, in order
    passes: Vec<Pass>,
    /// live tracking: milliseconds from a pose's arrival to the submission of its frame
    latency: Vec<f64>,
    /// of each timed frame's CPU time, the part spent encoding and submitting its passes
    submit_ms: Vec<f64>,
    started: Instant,
    timed: bool,
    /// whether this frame writes timestamps
    stamped: bool,
}

impl Accounting {
    pub fn new(labels: Vec<ViewLabel>, clock: Clock) -> Accounting {
        Accounting {
            times: FrameTimes::new(labels),
            clock,
            passes: Vec::new(),
            latency: Vec::new(),
            submit_ms: Vec::new(),
            started: Instant::now(),
            timed: false,
            stamped: false,
        }
    }

    /// Frames whose GPU times come back late (the pacer steps less for them).
    pub fn lag(&self) -> usize {
        match &self.clock {
            Clock::Serial(_) => 0,
            Clock::InFlight { depth, .. } => *depth,
        }
    }

    /// Start a frame: the CPU clock, and whether its timestamps are written (a timed frame's;
    /// serially also a paced one's, as the pacer needs every frame's view times). Frames in
    /// flight that the GPU has finished go to the pacer and the report.
    pub fn begin(
        &mut self,
        ctx: &GpuContext,
        timed: bool,
        mut pacer: Option<&mut Pacer>,
    ) -> Result<()> {
        self.started = Instant::now();
        self.timed = timed;
        self.passes.clear();
        self.stamped = match &mut self.clock {
            Clock::Serial(ts) => ts.is_some() && (timed || pacer.is_some()),
            Clock::InFlight { frames, .. } => {
                let done = match frames.as_mut().filter(|_| timed) {
                    Some(f) => f.begin(ctx)?,
                    None => Vec::new(),
                };
                for frame in done {
                    self.push_done(&frame, pacer.as_deref_mut());
                }
                self.in_flight().is_some() && timed
            }
        };
        Ok(())
    }

    /// Whether this frame writes timestamps (its passes are timed, for the pacer or the report).
    pub fn stamped(&self) -> bool {
        self.stamped
    }

    /// The queries of this frame's next passes (None when it is not stamped).
    pub fn timestamps(&mut self) -> Option<&mut Timestamps> {
        match (&mut self.clock, self.stamped) {
            (Clock::Serial(ts), true) => ts.as_mut(),
            (Clock::InFlight { frames, .. }, true) => frames.as_mut().map(|f| f.timestamps()),
            _ => None,
        }
    }

    /// The frame's next timestamp pair times `pass`.
    pub fn pass(&mut self, pass: Pass) {
        self.passes.push(pass);
    }

    /// Whether the frame's last encoder must resolve the timestamps of frames in flight.
    pub fn resolves(&self) -> bool {
        self.stamped && matches!(self.clock, Clock::InFlight { .. })
    }

    /// In the frame's last encoder: the timestamps of a frame in flight to its read-back buffer.
    pub fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder) {
        if let (
            Clock::InFlight {
                frames: Some(f), ..
            },
            true,
        ) = (&mut self.clock, self.stamped)
        {
            f.resolve(encoder, &self.passes);
        }
    }

    /// Every pass of the frame is submitted (its pose arrived at `arrived`, live tracking).
    pub fn submitted(&mut self, arrived: Option<Instant>) {
        if self.timed {
            self.submit_ms.push(self.elapsed_ms());
            if let Some(arrived) = arrived {
                self.latency.push(arrived.elapsed().as_secs_f64() * 1e3);
            }
        }
        if let (
            Clock::InFlight {
                frames: Some(f), ..
            },
            true,
        ) = (&mut self.clock, self.stamped)
        {
            f.submitted();
        }
    }

    /// Milliseconds since the frame began.
    pub fn elapsed_ms(&self) -> f64 {
        self.started.elapsed().as_secs_f64() * 1e3
    }

    /// After the frame: read serial timestamps back, their view times to the pacer and, when the
    /// frame is timed, to the report with its CPU time `cpu_ms`.
    pub fn account(
        &mut self,
        ctx: &GpuContext,
        cpu_ms: f64,
        pacer: Option<&mut Pacer>,
    ) -> Result<()> {
        if let (Clock::Serial(Some(ts)), true) = (&mut self.clock, self.stamped) {
            let ticks = ts.read_ticks(ctx)?;
            let ms = crate::gpu::pairs_ms(&ticks, ctx.timestamp_period_ns);
            if let Some(p) = pacer {
                pace(p, &ms, &self.passes);
            }
            if self.timed && !ms.is_empty() {
                self.times.push_gpu(&ms, &self.passes);
                // the passes run in order: the frame's span on the GPU, its idle time included
                let tick_ms = ctx.timestamp_period_ns as f64 * 1e-6;
                (self.times).push_span((ticks[0], ticks[ticks.len() - 1]), tick_ms);
            }
        }
        if self.timed {
            self.times.push_cpu(cpu_ms);
        }
        Ok(())
    }

    /// At the end of a run: the times of the frames still in flight (waiting for the GPU).
    pub fn finish(&mut self, ctx: &GpuContext, mut pacer: Option<&mut Pacer>) -> Result<()> {
        if let Clock::InFlight {
            frames: Some(f), ..
        } = &mut self.clock
        {
            for frame in f.finish(ctx)? {
                self.push_done(&frame, pacer.as_deref_mut());
            }
        }
        Ok(())
    }

    /// A finished frame in flight's times (its views', the moving objects' pass before them, the
    /// swapchain layers' after) to the pacer and the report, and its span on the GPU's clock.
    fn push_done(&mut self, frame: &DoneFrame, pacer: Option<&mut Pacer>) {
        if let Some(p) = pacer {
            pace(p, &frame.ms, &frame.passes);
        }
        self.times.push_gpu(&frame.ms, &frame.passes);
        if let Some((start, end)) = frame.span_ticks {
            self.times.push_span((start, end), frame.tick_ms);
        }
    }

    /// The frames in flight's counts (overlapped, serial, waited for the GPU).
    pub fn in_flight(&self) -> Option<&InFlight> {
        match &self.clock {
            Clock::InFlight { frames, .. } => frames.as_ref(),
            Clock::Serial(_) => None,
        }
    }

    pub fn latency_ms(&self) -> Option<Distribution> {
        (!self.latency.is_empty()).then(|| Distribution::of(&self.latency))
    }

    /// Every timed frame in order, with the part of its CPU time spent submitting.
    pub fn series(&self) -> FrameSeries {
        FrameSeries {
            submit_ms: self.submit_ms.clone(),
            ..self.times.series()
        }
    }
}

/// One frame's timestamp pairs (`passes[i]` saying what pair i timed) to the pacer: each view's
/// GPU time, and the moving objects' pass before them (the views make room for it).
fn pace(pacer: &mut Pacer, ms: &[f64], passes: &[Pass]) {
    for (&m, pass) in ms.iter().zip(passes) {
        match pass {
            Pass::View(v) => pacer.observe(*v, m),
            Pass::Objects => pacer.observe_before_views(m),
            Pass::Output => {}
        }
    }
}
