//! What a headset run measured (`vlf xr --json`), and its table: per-eye GPU time, missed
//! refreshes and late frames against their limits, frames in flight and the overlap they bought.

use crate::display::frame::{Limit, ViewTiming};
use crate::stats::Distribution;

/// What a headset run measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct XrReport {
    pub runtime: String,
    pub system: String,
    pub adapter: String,
    pub reference_space: String,
    pub swapchain_format: String,
    pub interaction_profiles: Vec<String>,
    /// frames rendered and submitted
    pub frames: u32,
    /// frames the runtime said not to render (should_render false)
    pub frames_skipped: u32,
    /// display refreshes between consecutive predicted display times that no frame was
    /// submitted for
    pub missed_frames: u64,
    /// the frames (1-based) after which refreshes were missed, the first 100
    pub missed_after_frames: Vec<u32>,
    /// frames whose xrEndFrame came after their predicted display time (None: the runtime
    /// cannot convert the system clock to XrTime)
    pub late_frames: Option<u64>,
    pub display_period_ms: f64,
    /// per eye: GPU time of the eye's render pass (timestamp queries)
    pub eyes: Vec<ViewTiming>,
    /// CPU time from xrBeginFrame to xrEndFrame
    pub cpu_frame_ms: Option<Distribution>,
    /// frames the CPU may record before the GPU has drawn the previous ones
    pub frames_in_flight: u32,
    /// timed frames whose recording began while the GPU still drew the frame before (the
    /// overlap frames in flight buy), and those that began with the GPU idle
    pub overlapped_frames: u64,
    pub serial_frames: u64,
    /// timed frames that waited for the GPU to finish a frame `frames_in_flight` back
    pub waited_for_gpu: u64,
    /// per-eye GPU p99/p50, missed refreshes and late frames against their limits
    pub limits: Vec<Limit>,
    /// the session states in the order the runtime reported them
    pub states: Vec<String>,
    pub ended: String,
    /// the runtime lost the session (headset unplugged, runtime gone) rather than ending it
    pub lost: bool,
    pub screenshot: Option<String>,
}

impl XrReport {
    pub fn table(&self) -> String {
        let mut s = format!(
            "OpenXR runtime {} | headset {} | GPU {} | {} space | swapchain {}\n",
            self.runtime, self.system, self.adapter, self.reference_space, self.swapchain_format
        );
        s.push_str(&format!(
            "{} frames rendered, {} skipped by the runtime, {} missed display refreshes (period {:.2} ms)\n",
            self.frames, self.frames_skipped, self.missed_frames, self.display_period_ms
        ));
        if let Some(late) = self.late_frames {
            s.push_str(&format!(
                "{late} frames submitted after their predicted display time\n"
            ));
        }
        if !self.missed_after_frames.is_empty() {
            let list: Vec<String> = self
                .missed_after_frames
                .iter()
                .map(|f| f.to_string())
                .collect();
            s.push_str(&format!("missed after frame(s): {}\n", list.join(", ")));
        }
        s.push_str("eye    pixels      GPU p50 ms  p99 ms   max ms   p99/p50\n");
        for e in &self.eyes {
            match &e.gpu_ms {
                Some(d) => s.push_str(&format!(
                    "{:<6} {:>4}x{:<6} {:>9.3} {:>8.3} {:>8.3} {:>8.3}{}\n",
                    e.eye,
                    e.pixels[0],
                    e.pixels[1],
                    d.median,
                    d.p99,
                    d.max,
                    d.p99 / d.median.max(1e-12),
                    if e.above_limit == Some(true) {
                        "  ABOVE THE LIMIT"
                    } else {
                        ""
                    }
                )),
                None => s.push_str(&format!(
                    "{:<6} {:>4}x{:<6} (no GPU timestamps on this adapter)\n",
                    e.eye, e.pixels[0], e.pixels[1]
                )),
            }
        }
        if let Some(c) = &self.cpu_frame_ms {
            s.push_str(&format!(
                "CPU frame (begin to end): p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms\n",
                c.median, c.p99, c.max
            ));
        }
        s.push_str(&format!(
            "frames in flight: up to {}; the CPU began {} frames while the GPU still drew the one before, {} with the GPU idle; waited for the GPU {} times\n",
            self.frames_in_flight, self.overlapped_frames, self.serial_frames, self.waited_for_gpu
        ));
        for line in Limit::lines(&self.limits).lines() {
            s.push_str(line.trim_start());
            s.push('\n');
        }
        s.push_str(&format!(
            "session states: {}\nended: {}\n",
            self.states.join(" -> "),
            self.ended
        ));
        if let Some(p) = &self.screenshot {
            s.push_str(&format!("screenshot (left eye): {p}\n"));
        }
        s
    }
}
