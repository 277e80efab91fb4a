//! What a headset run measured (`vlf xr --json`), and its table: per-eye GPU time, missed
//! refreshes and late frames against their limits, frames in flight and the overlap they bought;
//! and the display account those counts come from (`display_account`): which refresh showed which
//! frame, given when the GPU finished each frame, as the runtime's compositor decides it.

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
    /// "array" (one swapchain, a layer per eye) or "per-eye"
    pub swapchains: String,
    /// both eyes went onto the array swapchain in one multiview pass
    pub multiview: bool,
    /// how the eyes reached the runtime, in words (and why per eye, if so)
    pub eye_layers: String,
    /// each projection view carried its depth (XR_KHR_composition_layer_depth)
    pub depth_submitted: bool,
    /// the depth layer in words, or why the runtime got none
    pub depth: String,
    pub interaction_profiles: Vec<String>,
    /// with `--objects`: the hands tracked and the last frame's body (`body::BodyReport`)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body: Option<super::body::BodyReport>,
    /// frames rendered and submitted
    pub frames: u32,
    /// frames the runtime said not to render (should_render false)
    pub frames_skipped: u32,
    /// display refreshes from the first timed frame's predicted display time to the last one's
    /// that did not show the frame predicted for them: no frame was meant for them
    /// (`prediction_gaps`), or it was not ready (`display_account`). Without the runtime's clock
    /// (XR_KHR_convert_timespec_time), only the gaps
    pub missed_frames: u64,
    /// the frames (1-based) after which refreshes were missed, the first 100
    pub missed_after_frames: Vec<u32>,
    /// refreshes between consecutive predicted display times that no frame was predicted for:
    /// what xrWaitFrame's predictions skipped
    pub prediction_gaps: u64,
    /// frames shown after their predicted display time: their GPU work finished after the
    /// compositor took the frame for that refresh (None: the runtime cannot convert the system
    /// clock to XrTime)
    pub late_frames: Option<u64>,
    /// frames never shown: a later frame was ready for the same refresh
    pub dropped_frames: Option<u64>,
    /// how long before a refresh the compositor takes the frames that are ready
    /// (`compositor_lead_ns`)
    pub compositor_lead_ms: Option<f64>,
    /// per timed frame: its predicted display time minus when its GPU work finished (negative:
    /// finished after it)
    pub gpu_done_before_display_ms: Option<Distribution>,
    /// the first timed frames (up to `FIRST_FRAMES`), one by one: where a run starts with a
    /// burst of late frames, whether they began late or their GPU work finished late
    /// (with the runtime's clock; empty without it)
    pub first_frames: Vec<FrameStart>,
    /// per timed frame: from its head pose (xrLocateViews, predicted by the runtime for the
    /// frame's display time) to that predicted display time: motion to photon as the runtime
    /// predicts it; negative where the pose was located after it, a prediction already past (a
    /// late frame). None: the runtime cannot convert the system clock to XrTime
    pub pose_to_photon_ms: Option<Distribution>,
    /// frames whose GPU work finished after their predicted display time: late for any
    /// compositor
    pub gpu_done_after_display: Option<u64>,
    /// the display's refresh period: the shortest the runtime predicted after the first timed
    /// frame (`refresh_period_ns`)
    pub display_period_ms: f64,
    /// per eye: GPU time of the eye's render pass (timestamp queries)
    pub eyes: Vec<ViewTiming>,
    /// per timed frame with moving objects: GPU time of their pass before the eyes (skin,
    /// refit, their direct light, shadow atlas)
    pub objects_gpu_ms: Option<Distribution>,
    /// per timed frame: GPU time of the pass that puts the eyes on the swapchains' images
    pub layers_gpu_ms: Option<Distribution>,
    /// per timed frame: on the GPU's clock, from its first pass's start to its last pass's end
    /// (the passes and whatever the GPU did between them)
    pub frame_gpu_span_ms: Option<Distribution>,
    /// per timed frame after the first: on the GPU's clock, from the frame before's last pass's
    /// end to its first pass's start (the GPU idle, or busy with work outside vlf's passes)
    pub gpu_between_frames_ms: Option<Distribution>,
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
    /// what the eyes were drawn with; with --fit-frame-time what the first frame probed, and
    /// how many eye rays per pixel the pacer gave each eye
    pub quality: crate::render::budget::Quality,
    pub fit: Option<crate::render::budget::BudgetFit>,
    pub pacer: Option<crate::render::budget::PacerReport>,
    /// the session states in the order the runtime reported them
    pub states: Vec<String>,
    pub ended: String,
    /// the runtime lost the session (headset unplugged, runtime gone) rather than ending it
    pub lost: bool,
    pub screenshot: Option<String>,
}

/// A line on the first frames that finished on the GPU less than the compositor's lead `lead_ms`
/// before their display (a start-up burst), if any did: how many, and for the first of them
/// when xrWaitFrame returned and when its GPU work finished, before its display.
pub fn start_burst(first: &[FrameStart], lead_ms: f64) -> Option<String> {
    let late: Vec<(usize, &FrameStart)> = (first.iter().enumerate())
        .filter(|(_, f)| f.gpu_done_before_display_ms < lead_ms)
        .collect();
    let (k, f) = *late.first()?;
    Some(format!(
        "first frames: {} of the first {} finished on the GPU inside the compositor's lead; the first, frame {k}: xrWaitFrame returned {:.2} ms and its GPU work finished {:.2} ms before its display\n",
        late.len(),
        first.len(),
        f.woke_before_display_ms,
        f.gpu_done_before_display_ms
    ))
}

/// How many of the first timed frames a report lists one by one (`XrReport::first_frames`).
pub const FIRST_FRAMES: usize = 64;

/// One of the first timed frames, on the runtime's clock.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FrameStart {
    /// its predicted display time after the first timed frame's, ms
    pub display_ms: f64,
    /// from when xrWaitFrame returned for it to its predicted display time, ms
    pub woke_before_display_ms: f64,
    /// from when its GPU work finished to its predicted display time, ms (negative: after it)
    pub gpu_done_before_display_ms: f64,
    /// on the GPU's clock: its first pass's start to its last pass's end, ms
    pub gpu_span_ms: Option<f64>,
    /// on the GPU's clock: the frame before's last pass's end to its first pass's start, ms
    pub gpu_before_ms: Option<f64>,
}

impl XrReport {
    pub fn table(&self) -> String {
        let mut s = format!(
            "OpenXR runtime {} | headset {} | GPU {} | {} space | swapchain {}\n",
            self.runtime, self.system, self.adapter, self.reference_space, self.swapchain_format
        );
        s.push_str(&format!(
            "eyes: {}\ndepth: {}\n",
            self.eye_layers, self.depth
        ));
        s.push_str(&format!(
            "{} frames rendered, {} skipped by the runtime, {} missed display refreshes (period {:.2} ms; {} of them skipped by xrWaitFrame's predictions)\n",
            self.frames, self.frames_skipped, self.missed_frames, self.display_period_ms, self.prediction_gaps
        ));
        s.push_str(&format!("eyes drawn with {}\n", self.quality));
        if let Some(b) = &self.body {
            s.push_str(&format!(
                "objects: {}; left grip located in {} frames, right grip in {} of {}\n",
                b.objects.join(", "),
                b.frames_with_left_grip,
                b.frames_with_right_grip,
                self.frames
            ));
        }
        if let Some(fit) = &self.fit {
            s += &format!("{}\n", fit.summary());
        }
        if let Some(p) = &self.pacer {
            s += p.line().trim_start();
        }
        if let (Some(late), Some(dropped), Some(lead)) = (
            self.late_frames,
            self.dropped_frames,
            self.compositor_lead_ms,
        ) {
            s.push_str(&format!(
                "{late} frames shown after their predicted display time, {dropped} never shown (the compositor taking the frames ready {lead:.1} ms before each refresh)\n"
            ));
        }
        if let Some(line) =
            (self.compositor_lead_ms).and_then(|lead| start_burst(&self.first_frames, lead))
        {
            s.push_str(&line);
        }
        if let (Some(d), Some(after)) = (
            &self.gpu_done_before_display_ms,
            self.gpu_done_after_display,
        ) {
            s.push_str(&format!(
                "GPU done before the predicted display time: min {:.2} ms, p50 {:.2} ms, max {:.2} ms; {after} frames finished on the GPU after it\n",
                d.min, d.median, d.max
            ));
        }
        if let Some(d) = &self.pose_to_photon_ms {
            s.push_str(&format!(
                "motion to photon (head pose located -> predicted display time): p50 {:.2} ms, p99 {:.2} ms\n",
                d.median, d.p99
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
        s += &self.gpu_lines();
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

    /// The table's GPU lines: per eye, the moving objects' pass, and the frame's passes as one.
    fn gpu_lines(&self) -> String {
        let mut s = String::new();
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
        if let Some(d) = &self.objects_gpu_ms {
            s.push_str(&format!(
                "moving objects' pass before the eyes (skin, refit, direct light, shadow atlas), GPU: p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms\n",
                d.median, d.p99, d.max
            ));
        }
        // each part where it was measured (a run of one frame has no time between frames)
        let mut parts = Vec::new();
        if let Some(d) = &self.layers_gpu_ms {
            parts.push(format!("swapchain layers' pass p50 {:.3} ms", d.median));
        }
        if let Some(d) = &self.frame_gpu_span_ms {
            parts.push(format!(
                "first pass start to last pass end p50 {:.3} ms, max {:.3} ms",
                d.median, d.max
            ));
        }
        if let Some(d) = &self.gpu_between_frames_ms {
            parts.push(format!(
                "from one frame's end to the next's start p50 {:.3} ms, min {:.3} ms",
                d.median, d.min
            ));
        }
        if !parts.is_empty() {
            s.push_str(&format!("GPU per frame: {}\n", parts.join("; ")));
        }
        s
    }
}

/// One timed frame as the display account sees it, on the runtime's clock (XrTime, ns): its
/// predicted display time and period (xrWaitFrame) and when the GPU finished it.
#[derive(Clone, Copy, Debug)]
pub struct ShownFrame {
    pub display_ns: i64,
    pub period_ns: i64,
    pub gpu_done_ns: i64,
}

/// Which refresh showed which frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DisplayAccount {
    /// refreshes, from the first frame's predicted display time to the last one's, that did
    /// not show the frame predicted for them
    pub missed: u64,
    /// per missed refresh: how many frames were predicted before it (the first 100)
    pub missed_after: Vec<u32>,
    /// of `missed`: refreshes no frame was predicted for
    pub gaps: u64,
    /// frames shown after their predicted display time
    pub late: u64,
    /// frames never shown: a later one was ready for the same refresh
    pub dropped: u64,
}

/// Half a millisecond: display times this close are the same refresh (as Monado compares them).
const SAME_REFRESH_NS: i64 = 500_000;

/// How long before a refresh the compositor takes the frames that are ready: OpenXR does not
/// say, so this is Monado's pacing: 4 ms from present to display plus the compositor's time,
/// 20% of the period and at least 3 ms (14 ms at 20 Hz, its null compositor; 7 ms at 90 Hz).
/// VLF_XR_COMPOSITOR_LEAD_MS sets another runtime's.
pub fn compositor_lead_ns(period_ns: i64) -> i64 {
    let set = std::env::var("VLF_XR_COMPOSITOR_LEAD_MS")
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|ms| ms.is_finite() && *ms >= 0.0);
    match set {
        Some(ms) => (ms * 1e6) as i64,
        None => 4_000_000 + (period_ns / 5).max(3_000_000),
    }
}

/// The display period the account steps refreshes by: the longest that divides every period the
/// runtime predicted and every step between predicted display times, after the first frame
/// (Monado's first prediction comes before its compositor has run, and it gives a slow
/// application a multiple of the display's period: 100 and 150 ms at 20 Hz are 50 ms refreshes).
pub fn refresh_period_ns(frames: &[ShownFrame]) -> i64 {
    let later = frames.get(1..).filter(|f| !f.is_empty()).unwrap_or(frames);
    let lengths: Vec<i64> = (later.iter().map(|f| f.period_ns))
        .chain(later.windows(2).map(|w| w[1].display_ns - w[0].display_ns))
        .filter(|&d| d > SAME_REFRESH_NS)
        .collect();
    let Some(&shortest) = lengths.iter().min() else {
        return 1;
    };
    let divides = |q: i64| {
        (lengths.iter())
            .all(|&d| (d - (d as f64 / q as f64).round() as i64 * q).abs() <= SAME_REFRESH_NS)
    };
    (1..=8)
        .map(|k| shortest / k)
        .find(|&q| divides(q))
        .unwrap_or(shortest)
}

/// Every refresh from the first frame's predicted display time to the last one's, with the
/// frame predicted for it (None: a gap in the predictions).
fn refreshes(frames: &[ShownFrame], period: i64) -> Vec<(i64, Option<usize>)> {
    let mut out = Vec::with_capacity(frames.len());
    for (n, f) in frames.iter().enumerate() {
        if n > 0 {
            let before = frames[n - 1].display_ns + period / 2;
            let gaps = (1..)
                .map(|j| f.display_ns - j * period)
                .take_while(|&r| r > before);
            let mut gaps: Vec<_> = gaps.map(|r| (r, None)).collect();
            gaps.reverse();
            out.extend(gaps);
        }
        out.push((f.display_ns, Some(n)));
    }
    out
}

/// The runtime's account of the frames: at each refresh the compositor takes, `lead_ns` before
/// it, the newest frame that is predicted for this refresh or an earlier one and whose GPU work
/// has finished; a refresh that does not get its own frame is missed, a frame taken after its
/// predicted refresh is late, and one overtaken by a newer frame is dropped. Frames are in the
/// order they were submitted.
pub fn display_account(frames: &[ShownFrame], lead_ns: i64) -> DisplayAccount {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    let mut account = DisplayAccount::default();
    if frames.is_empty() {
        return account;
    }
    let period = refresh_period_ns(frames);
    // frames predicted up to the current refresh, not yet done: (GPU done, index)
    let mut waiting = BinaryHeap::new();
    let (mut predicted, mut newest_ready, mut shown) = (0usize, None::<usize>, None::<usize>);
    let mut take = |refresh: i64, account: &mut DisplayAccount| {
        while predicted < frames.len() && frames[predicted].display_ns <= refresh + SAME_REFRESH_NS
        {
            waiting.push(Reverse((frames[predicted].gpu_done_ns, predicted)));
            predicted += 1;
        }
        while let Some(&Reverse((done, n))) = waiting.peek() {
            if done > refresh - lead_ns {
                break;
            }
            waiting.pop();
            newest_ready = newest_ready.max(Some(n));
        }
        if let Some(n) = newest_ready.filter(|&n| shown.is_none_or(|s| n > s)) {
            account.dropped += (n - shown.map_or(0, |s| s + 1)) as u64;
            if refresh > frames[n].display_ns + SAME_REFRESH_NS {
                account.late += 1;
            }
            shown = Some(n);
        }
        shown
    };
    for (refresh, meant) in refreshes(frames, period) {
        let now = take(refresh, &mut account);
        let own = now.is_some_and(|n| (frames[n].display_ns - refresh).abs() <= SAME_REFRESH_NS);
        if !own {
            account.missed += 1;
            account.gaps += meant.is_none() as u64;
            if account.missed_after.len() < 100 {
                let before = frames.partition_point(|f| f.display_ns < refresh - SAME_REFRESH_NS);
                account.missed_after.push(before as u32);
            }
        }
    }
    // after the last predicted refresh: the frames still to come are shown late or dropped
    let last_done = frames.iter().map(|f| f.gpu_done_ns).max().unwrap_or(0);
    let mut refresh = frames[frames.len() - 1].display_ns;
    while take(refresh, &mut account).is_none_or(|s| s + 1 < frames.len()) {
        if refresh - lead_ns > last_done {
            break;
        }
        refresh += period;
    }
    account
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    /// Frames predicted every 50 ms from 1000 ms, done `done[n]` ms before their display time.
    fn frames(ahead_ms: &[i64]) -> Vec<ShownFrame> {
        (ahead_ms.iter().enumerate())
            .map(|(n, &a)| ShownFrame {
                display_ns: (1000 + 50 * n as i64) * MS,
                period_ns: 50 * MS,
                gpu_done_ns: (1000 + 50 * n as i64 - a) * MS,
            })
            .collect()
    }

    #[test]
    fn a_start_up_burst_is_named_by_its_first_late_frame() {
        let frame = |gpu: f64| FrameStart {
            display_ms: 0.0,
            woke_before_display_ms: 22.2,
            gpu_done_before_display_ms: gpu,
            gpu_span_ms: None,
            gpu_before_ms: None,
        };
        let on_time = [frame(10.9), frame(10.8)];
        assert_eq!(start_burst(&on_time, 7.0), None);
        let burst = [frame(10.9), frame(3.5), frame(-1.0), frame(10.8)];
        let line = start_burst(&burst, 7.0).expect("a burst");
        assert!(
            line.starts_with("first frames: 2 of the first 4 finished on the GPU inside the compositor's lead; the first, frame 1: xrWaitFrame returned 22.20 ms and its GPU work finished 3.50 ms"),
            "{line}"
        );
    }

    #[test]
    fn frames_done_before_the_lead_are_all_shown_on_time() {
        let a = display_account(&frames(&[20, 15, 30, 14]), 14 * MS);
        assert_eq!(a, DisplayAccount::default());
    }

    #[test]
    fn a_frame_done_inside_the_lead_misses_its_refresh_and_the_next_one_overtakes_it() {
        // frame 1 is done 5 ms before its refresh, after the compositor took the frames (14 ms);
        // by the next refresh frame 2 is ready too: frame 1 is never shown
        let a = display_account(&frames(&[20, 5, 20, 20]), 14 * MS);
        assert_eq!((a.missed, a.late, a.dropped, a.gaps), (1, 0, 1, 0));
        assert_eq!(a.missed_after, vec![1]);
        // with no lead it would have been on time: the count depends on the compositor
        assert_eq!(
            display_account(&frames(&[20, 5, 20, 20]), 0),
            DisplayAccount::default()
        );
    }

    #[test]
    fn late_frames_in_a_row_are_shown_late_until_one_catches_up() {
        // 1 and 2 both miss the lead: 1 is shown at 2's refresh, 2 is overtaken by 3
        let a = display_account(&frames(&[20, 5, 5, 20]), 14 * MS);
        assert_eq!((a.missed, a.late, a.dropped), (2, 1, 1), "{a:?}");
        assert_eq!(a.missed_after, vec![1, 2]);
    }

    #[test]
    fn gaps_in_the_predictions_are_missed_refreshes_without_late_frames() {
        let mut f = frames(&[20, 20, 20]);
        f[2].display_ns += 100 * MS; // xrWaitFrame skipped two refreshes before frame 2
        f[2].gpu_done_ns += 100 * MS;
        let a = display_account(&f, 14 * MS);
        assert_eq!((a.missed, a.gaps, a.late, a.dropped), (2, 2, 0, 0));
        assert_eq!(a.missed_after, vec![2, 2]);
    }

    #[test]
    fn the_last_frame_late_is_counted_after_the_last_refresh() {
        let a = display_account(&frames(&[20, 20, -30]), 14 * MS);
        assert_eq!((a.missed, a.late, a.dropped), (1, 1, 0));
    }

    #[test]
    fn the_refresh_period_ignores_the_first_prediction_and_longer_application_periods() {
        let mut f = frames(&[20, 20, 20, 20]);
        f[0].period_ns = 16 * MS;
        f[3].period_ns = 100 * MS;
        assert_eq!(refresh_period_ns(&f), 50 * MS);
        // a slow application paced at 100 and 150 ms: the display still refreshes every 50 ms
        let mut slow = frames(&[20, 20, 20, 20]);
        for (k, (display, period)) in [(1000, 16), (1100, 100), (1250, 150), (1350, 100)]
            .into_iter()
            .enumerate()
        {
            slow[k].display_ns = display * MS;
            slow[k].period_ns = period * MS;
        }
        assert_eq!(refresh_period_ns(&slow), 50 * MS);
    }

    #[test]
    fn the_lead_follows_monado_pacing() {
        if std::env::var_os("VLF_XR_COMPOSITOR_LEAD_MS").is_none() {
            assert_eq!(compositor_lead_ns(50 * MS), 14 * MS);
            assert_eq!(compositor_lead_ns(11_111_111), 7 * MS);
        }
    }
}
