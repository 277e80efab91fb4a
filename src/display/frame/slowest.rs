//! A run's slowest frames and what each waited on: a hitch a subject sees is one frame, and
//! its cause is in what that frame spent its time on, set beside what the run's frames spend
//! on it as a rule. A frame's CPU time (all its passes submitted, the GPU done) splits into the
//! GPU's time for its passes, the CPU's time encoding and submitting them, and the rest; where
//! the frame's span on the GPU's clock is known, the rest splits into the GPU idle between its
//! passes (the span less the passes) and the CPU's own delay (the thread not running, or late
//! to see the GPU finish). The part furthest above its own median names what the frame waited
//! on.

use super::times::FrameSeries;
use super::views::ViewLabel;
use serde::{Deserialize, Serialize};

/// How many of the slowest frames a report lists.
pub const SLOWEST_FRAMES: usize = 10;
/// An excess over the median smaller than this (ms) names nothing: frame-to-frame jitter.
const NOTHING_STANDS_OUT_MS: f64 = 0.05;

/// One of a run's slowest frames by its CPU+GPU time.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SlowFrame {
    /// the frame's place among the run's timed frames (0: the first)
    pub frame: usize,
    /// the frame's CPU time: every pass submitted and the GPU done (ms)
    pub cpu_gpu_ms: f64,
    /// the GPU's time for all of its passes (ms; None without timestamps)
    pub gpu_ms: Option<f64>,
    /// the CPU's time encoding and submitting them (ms; None where not measured)
    pub submit_ms: Option<f64>,
    /// the rest: cpu_gpu_ms less the two (ms)
    pub other_ms: Option<f64>,
    /// of the rest, the GPU idle between the frame's passes: its span on the GPU's clock less
    /// its passes' time (ms; None where the span is not measured)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_idle_ms: Option<f64>,
    /// its slowest view against that view's median: the view, its time, its median (ms)
    pub slowest_view: Option<(String, f64, f64)>,
    /// the moving objects' pass before the views, and its median (ms; None without objects)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub objects_ms: Option<(f64, f64)>,
    /// what the frame waited on, in words
    pub waited_on: String,
}

impl SlowFrame {
    /// One line of a report.
    pub fn line(&self) -> String {
        let part = |name: &str, ms: Option<f64>| {
            ms.map_or(String::new(), |ms| format!(", {name} {ms:.2}"))
        };
        format!(
            "    frame {:>5}: {:.2} ms{}{}{}{}: {}\n",
            self.frame,
            self.cpu_gpu_ms,
            part("GPU", self.gpu_ms),
            part("submit", self.submit_ms),
            part("other", self.other_ms),
            part("of it GPU idle", self.gpu_idle_ms),
            self.waited_on
        )
    }
}

/// The median of `values` as the reports compute it (0 for none).
fn median(values: &[f64]) -> f64 {
    match values.is_empty() {
        true => 0.0,
        false => crate::stats::Distribution::of(values).median,
    }
}

/// The `n` frames of `series` with the longest CPU+GPU time, slowest first, each with what it
/// waited on (`labels` name the views, in the series' order).
pub fn slowest_frames(series: &FrameSeries, labels: &[ViewLabel], n: usize) -> Vec<SlowFrame> {
    let cpu = &series.cpu_frame_ms;
    let parts: Vec<[Option<f64>; 4]> = (0..cpu.len()).map(|i| frame_parts(series, i)).collect();
    let medians: [f64; 4] =
        std::array::from_fn(|k| median(&parts.iter().filter_map(|p| p[k]).collect::<Vec<_>>()));
    let view_medians: Vec<f64> = series.view_gpu_ms.iter().map(|v| median(v)).collect();
    let objects_median = median(&series.objects_gpu_ms);
    let mut order: Vec<usize> = (0..cpu.len()).collect();
    order.sort_by(|&a, &b| cpu[b].total_cmp(&cpu[a]));
    order.truncate(n);
    let at = |v: &[f64], i: usize| v.get(i).copied();
    (order.into_iter())
        .map(|i| {
            let [gpu, submit, idle, late] = parts[i];
            let slowest_view = (series.view_gpu_ms.iter().enumerate())
                .filter_map(|(v, times)| Some((v, at(times, i)? - view_medians[v])))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(v, _)| {
                    let name = labels
                        .get(v)
                        .map_or(format!("view {v}"), |l| format!("{} {}", l.wall, l.eye));
                    (name, series.view_gpu_ms[v][i], view_medians[v])
                });
            let objects_ms = at(&series.objects_gpu_ms, i).map(|ms| (ms, objects_median));
            let gpu_part = GpuPart {
                view: slowest_view.as_ref(),
                objects: objects_ms,
            };
            SlowFrame {
                frame: i,
                cpu_gpu_ms: cpu[i],
                gpu_ms: gpu,
                submit_ms: submit,
                other_ms: gpu.zip(submit).map(|(g, s)| cpu[i] - g - s),
                gpu_idle_ms: idle,
                waited_on: waited_on([gpu, submit, idle, late], medians, gpu_part),
                slowest_view,
                objects_ms,
            }
        })
        .collect()
}

/// Frame `i`'s CPU time in parts: the GPU's passes, encoding and submitting, the GPU idle
/// between its passes, and the rest (the whole rest where the span is not measured: then the
/// idle part is None).
fn frame_parts(series: &FrameSeries, i: usize) -> [Option<f64>; 4] {
    let at = |v: &[f64]| v.get(i).copied();
    let (gpu, submit) = (at(&series.frame_gpu_ms), at(&series.submit_ms));
    let rest = gpu.zip(submit).map(|(g, s)| series.cpu_frame_ms[i] - g - s);
    let idle = at(&series.gpu_span_ms)
        .zip(gpu)
        .map(|(span, g)| (span - g).max(0.0));
    let late = match idle {
        Some(idle) => rest.map(|r| r - idle),
        None => rest,
    };
    [gpu, submit, idle, late]
}

/// Within a frame's GPU time: its slowest view against its median, and the moving objects'
/// pass against its median.
struct GpuPart<'a> {
    view: Option<&'a (String, f64, f64)>,
    objects: Option<(f64, f64)>,
}

impl GpuPart<'_> {
    /// Which of the two rose more over its median, in words.
    fn words(&self) -> String {
        let view_over = self.view.map_or(f64::MIN, |(_, ms, median)| ms - median);
        let objects_over = self.objects.map_or(f64::MIN, |(ms, median)| ms - median);
        match (self.view, self.objects) {
            (_, Some((ms, median))) if objects_over >= view_over => {
                format!("; the moving objects' pass {ms:.2} ms against its median {median:.2}")
            }
            (Some((name, ms, median)), _) => {
                format!("; {name} {ms:.2} ms against its median {median:.2}")
            }
            _ => String::new(),
        }
    }
}

/// The part of a frame furthest above its median, in words.
fn waited_on(parts: [Option<f64>; 4], medians: [f64; 4], gpu_part: GpuPart<'_>) -> String {
    let excess: Vec<(usize, f64)> = (parts.iter().enumerate())
        .filter_map(|(k, p)| Some((k, (*p)? - medians[k])))
        .collect();
    let Some(&(k, over)) = excess.iter().max_by(|a, b| a.1.total_cmp(&b.1)) else {
        return "not known (no GPU timestamps)".into();
    };
    if over < NOTHING_STANDS_OUT_MS {
        return format!(
            "nothing stands out (each part within {NOTHING_STANDS_OUT_MS} ms of its median)"
        );
    }
    let span_known = parts[2].is_some();
    match k {
        0 => format!(
            "the GPU: its passes {over:.2} ms over their median{}",
            gpu_part.words()
        ),
        1 => format!("the CPU encoding and submitting: {over:.2} ms over its median"),
        2 => format!(
            "the GPU idle between its passes: {over:.2} ms more than the median (its span on \
             the GPU's clock longer than its passes)"
        ),
        _ if span_known => format!(
            "the CPU: {over:.2} ms more than the median outside the GPU's span and submitting \
             (the thread waiting on the GPU not running, or late to see it finish)"
        ),
        _ => format!(
            "neither the GPU's passes nor submitting: {over:.2} ms more between them than the \
             median (the GPU idle between passes, or the CPU late to see it finish)"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Twelve frames of two views: one with a slow view, one slow to submit, one where the
    /// GPU finished early but the frame ended late; each is named for what it waited on, and
    /// the even frames (nothing above the medians) say nothing stands out; then with a moving
    /// objects' pass, a frame whose pass rose is named for it; then with the frames' GPU spans,
    /// the late frame is named for the GPU idle between its passes where its span grew, and for
    /// the CPU where it did not.
    #[test]
    fn each_slow_frame_is_named_for_what_it_waited_on() {
        let mut series = FrameSeries {
            view_gpu_ms: vec![vec![1.0; 12], vec![1.0; 12]],
            frame_gpu_ms: vec![2.0; 12],
            cpu_frame_ms: vec![3.0; 12],
            submit_ms: vec![0.5; 12],
            objects_gpu_ms: Vec::new(),
            gpu_span_ms: Vec::new(),
        };
        // frame 3: the second view took 1.8 ms more
        series.view_gpu_ms[1][3] = 2.8;
        series.frame_gpu_ms[3] = 3.8;
        series.cpu_frame_ms[3] = 4.8;
        // frame 7: submitting took 1 ms more
        series.submit_ms[7] = 1.5;
        series.cpu_frame_ms[7] = 4.0;
        // frame 9: the GPU as usual, the frame 0.7 ms longer
        series.cpu_frame_ms[9] = 3.7;
        let labels = vec![
            ViewLabel {
                wall: "front".into(),
                eye: "left",
                pixels: [8, 8],
            },
            ViewLabel {
                wall: "front".into(),
                eye: "right",
                pixels: [8, 8],
            },
        ];
        let said =
            |f: &SlowFrame, words: &str| assert!(f.waited_on.contains(words), "{}", f.waited_on);
        let slow = slowest_frames(&series, &labels, 4);
        let frames: Vec<usize> = slow.iter().map(|f| f.frame).collect();
        assert_eq!(frames[..3], [3, 7, 9]);
        said(&slow[0], "the GPU: its passes 1.80 ms");
        said(&slow[0], "front right 2.80 ms");
        said(&slow[1], "the CPU encoding and submitting: 1.00");
        said(&slow[2], "neither");
        assert!((slow[2].other_ms.unwrap() - 1.2).abs() < 1e-9);
        said(&slow[3], "nothing stands out");
        let line = slow[0].line();
        assert!(line.contains("frame     3: 4.80 ms, GPU 3.80, submit 0.50, other 0.50"));
        // with a moving objects' pass: a frame whose pass took 1.5 ms more is named for it
        series.objects_gpu_ms = vec![1.0; 12];
        series.objects_gpu_ms[5] = 2.5;
        series.frame_gpu_ms[5] = 3.5;
        series.cpu_frame_ms[5] = 4.5;
        let slow = slowest_frames(&series, &labels, 2);
        assert_eq!(slow[1].frame, 5);
        said(
            &slow[1],
            "the moving objects' pass 2.50 ms against its median 1.00",
        );
        said(&slow[0], "front right 2.80 ms");
        // with the frames' GPU spans: frame 9's 0.7 ms is the GPU idle between its passes, and
        // where the span is as usual the CPU's own delay
        series.gpu_span_ms = series.frame_gpu_ms.clone();
        series.gpu_span_ms[9] += 0.7;
        let slow = slowest_frames(&series, &labels, 4);
        let nine = slow.iter().find(|f| f.frame == 9).unwrap();
        said(nine, "the GPU idle between its passes: 0.70 ms");
        assert!((nine.gpu_idle_ms.unwrap() - 0.7).abs() < 1e-9);
        assert!(nine.line().contains("other 1.20, of it GPU idle 0.70"));
        series.gpu_span_ms[9] -= 0.7;
        let slow = slowest_frames(&series, &labels, 4);
        said(
            slow.iter().find(|f| f.frame == 9).unwrap(),
            "the CPU: 0.70 ms more",
        );
    }
}
