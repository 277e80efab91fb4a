//! GPU timestamps of frames in flight (`InFlight`), read back without stalling the next frame:
//! the headset records frame N+1 while the GPU draws frame N (headless and windows wait for
//! every frame instead, which is what their CPU+GPU frame time measures).

use super::times::Pass;
use crate::error::Result;
use crate::gpu::{GpuContext, Timestamps};
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

const IDLE: u8 = 0;
const PENDING: u8 = 1;
const MAPPED: u8 = 2;

/// One frame in flight: its timestamp queries, the buffer they come back in and what each pair
/// timed.
struct Slot {
    timestamps: Timestamps,
    readback: wgpu::Buffer,
    state: Arc<AtomicU8>,
    pairs: u32,
    passes: Vec<Pass>,
}

/// A finished frame's GPU times: pair i's milliseconds, and what it timed; and the GPU's clock
/// (ticks of `tick_ms`) when its first pass began and its last ended (one queue: its frames'
/// passes are in order), for the frame's span and the GPU's time between frames.
pub struct DoneFrame {
    pub ms: Vec<f64>,
    pub passes: Vec<Pass>,
    pub span_ticks: Option<(u64, u64)>,
    pub tick_ms: f64,
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
    /// `pairs_per_frame`: the most timestamp pairs one frame writes (its views, the moving
    /// objects' pass, the headset's swapchain layers). None where the adapter has no timestamp
    /// queries.
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
                    passes: Vec::new(),
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
    pub fn begin(&mut self, ctx: &GpuContext) -> Result<Vec<DoneFrame>> {
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

    /// After the frame's last pass: copy its timestamps to the slot's read-back buffer;
    /// `passes[i]` says what pair i timed.
    pub fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder, passes: &[Pass]) {
        let slot = &mut self.slots[self.next];
        slot.pairs = slot.timestamps.resolve_into(encoder, &slot.readback);
        slot.passes = passes.to_vec();
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
    pub fn finish(&mut self, ctx: &GpuContext) -> Result<Vec<DoneFrame>> {
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
    fn collect(&mut self, ctx: &GpuContext) -> Vec<DoneFrame> {
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
                done.push(DoneFrame {
                    ms: (ticks.chunks(2))
                        .map(|p| p[1].wrapping_sub(p[0]) as f64 * period)
                        .collect(),
                    passes: std::mem::take(&mut slot.passes),
                    span_ticks: ticks.first().copied().zip(ticks.last().copied()),
                    tick_ms: period,
                });
            }
            slot.readback.unmap();
            slot.state.store(IDLE, Ordering::Release);
        }
        done
    }
}
