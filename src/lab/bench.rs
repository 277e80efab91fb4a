//! `vlf bench`: setup, visibility, propagation per iteration and in total, transport samples
//! per second, render time at a fixed size over many frames (GPU timestamps: median, p99),
//! memory. Printed as a table; JSON and Markdown for BENCHMARKS.md.

use crate::error::Result;
use crate::gpu::{human_bytes, GpuContext, MemoryLedger};
use crate::progress::Silent;
use crate::propagate::report::PropagationReport;
use crate::propagate::PropagationParams;
use crate::render::Renderer;
use crate::scene::Scene;
use serde::Serialize;
use std::sync::Arc;

use crate::display::frame::{Limit, CONSTANT_FRAME_TIME};
pub use crate::stats::Distribution;

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub vlf_version: String,
    pub commit: Option<String>,
    pub date_utc: String,
    pub propagation: PropagationReport,
    /// texel x direction gathers per second, over all iterations
    pub transport_samples_per_second: f64,
    pub iteration_gpu_ms: Option<Distribution>,
    pub render_size: [u32; 2],
    /// antialiasing of the timed view: eye rays per pixel, and mirror reflections per ray
    #[serde(default)]
    pub eye_rays_per_pixel: u32,
    #[serde(default)]
    pub mirror_bounces: u32,
    /// edge antialiasing of the timed view: eye rays per edge pixel (None: off) and the share of
    /// the view's pixels it refined
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge_samples: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_share: Option<f64>,
    pub render_frame_ms: Distribution,
    pub render_timing_source: String,
    /// the view's frame time against the constancy limit (p99/p50 <= 1.10), said in the table
    #[serde(default)]
    pub limits: Vec<Limit>,
}

/// How the timed view is drawn: eye rays per pixel and edge antialiasing (None: off).
#[derive(Clone, Copy, Debug)]
pub struct TimedView {
    pub size: [u32; 2],
    pub frames: u32,
    pub samples_per_pixel: u32,
    pub edges: Option<crate::render::edges::EdgeAntialiasing>,
}

pub fn run(
    ctx: Arc<GpuContext>,
    scene: &Scene,
    params: &PropagationParams,
    view: TimedView,
) -> Result<BenchReport> {
    let TimedView {
        size,
        frames,
        samples_per_pixel,
        edges,
    } = view;
    let (lf, resident, report) = crate::propagate::propagate(ctx.clone(), scene, params, &Silent)?;
    let ledger = MemoryLedger::default();
    let mut renderer = Renderer::new(&resident, &lf, &ledger)?;
    renderer.set_samples_per_pixel(samples_per_pixel)?;
    renderer.set_edge_antialiasing(edges)?;
    let camera = lf.camera(None)?.clone();
    // warm up, then measure
    renderer.time_frames(&camera, size[0], size[1], 10)?;
    let (frame_ms, gpu) = renderer.time_frames(&camera, size[0], size[1], frames.max(1))?;
    let iteration_ms: Vec<f64> = report
        .per_iteration
        .iter()
        .filter_map(|i| i.gpu_ms)
        .collect();
    let samples =
        report.diffuse_elements as f64 * report.directions as f64 * report.iterations as f64;
    Ok(BenchReport {
        vlf_version: env!("CARGO_PKG_VERSION").into(),
        commit: commit(),
        date_utc: utc_date(),
        transport_samples_per_second: samples / report.propagation_seconds.max(1e-12),
        iteration_gpu_ms: (!iteration_ms.is_empty()).then(|| Distribution::of(&iteration_ms)),
        render_size: size,
        eye_rays_per_pixel: samples_per_pixel,
        mirror_bounces: renderer.mirror_bounces(),
        edge_samples: edges.map(|e| e.samples),
        refined_share: renderer.refined_pixels()?.map(|r| r.share()),
        limits: render_limits(&Distribution::of(&frame_ms)),
        render_frame_ms: Distribution::of(&frame_ms),
        render_timing_source: if gpu {
            "GPU timestamp queries".into()
        } else {
            "wall clock (no timestamp queries)".into()
        },
        propagation: report,
    })
}

/// "Measured by `command` (vlf version, commit, date) on **GPU** (backend, driver)": the stamp
/// every generated benchmark section carries.
pub fn measured_by(
    command: &str,
    version: &str,
    commit: Option<&str>,
    date: &str,
    a: &crate::gpu::AdapterSummary,
) -> String {
    format!(
        "Measured by `{command}` (vlf {version}, commit {}, {date}) on **{}** ({} backend, driver {} {})",
        commit.unwrap_or("unknown"),
        a.name,
        a.backend,
        a.driver,
        a.driver_info
    )
}

/// The commit measured: VLF_COMMIT (set where the tree has no .git), else git's.
pub fn commit() -> Option<String> {
    std::env::var("VLF_COMMIT")
        .ok()
        .filter(|c| !c.is_empty())
        .or_else(git_commit)
}

fn git_commit() -> Option<String> {
    let out = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

pub fn utc_date() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    // civil date from days since 1970-01-01 (Howard Hinnant's algorithm)
    let z = (secs / 86400) as i64 + 719468;
    let era = z.div_euclid(146097);
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    format!("{y:04}-{m:02}-{d:02}")
}

/// The view's frame time p99/p50 against the constant-frame-time limit.
fn render_limits(frame_ms: &Distribution) -> Vec<Limit> {
    let ratio = frame_ms.p99 / frame_ms.median.max(1e-12);
    vec![Limit::check("render p99/p50", ratio, CONSTANT_FRAME_TIME)]
}

impl BenchReport {
    pub fn table(&self) -> String {
        let p = &self.propagation;
        let mut s = p.table();
        s.push_str(&format!(
            "  transport samples/s       {:.3e}\n",
            self.transport_samples_per_second
        ));
        if let Some(d) = &self.iteration_gpu_ms {
            s.push_str(&format!(
                "  iteration (GPU)           median {:.3} ms, p99 {:.3} ms, over {}\n",
                d.median, d.p99, d.samples
            ));
        }
        let r = &self.render_frame_ms;
        s.push_str(&format!(
            "  render {}x{}            median {:.4} ms, p99 {:.4} ms, max {:.4} ms over {} frames ({})\n",
            self.render_size[0], self.render_size[1], r.median, r.p99, r.max, r.samples, self.render_timing_source
        ));
        if let Some((samples, share)) = self.edge_samples.zip(self.refined_share) {
            s.push_str(&format!(
                "  edge antialiasing         {samples} eye rays on {:.1}% of the pixels, {} on the rest\n",
                share * 100.0,
                self.eye_rays_per_pixel
            ));
        }
        s.push_str(&Limit::lines(&self.limits));
        s
    }

    /// A Markdown section for BENCHMARKS.md, beside the paper's Cornell row.
    pub fn markdown(&self) -> String {
        let p = &self.propagation;
        let a = &p.adapter;
        let r = &self.render_frame_ms;
        let fps = 1000.0 / r.median;
        let mut s = String::new();
        s.push_str(&format!(
            "## {} — {}\n\n{}.\n\n",
            p.scene,
            self.date_utc,
            measured_by(
                "vlf bench",
                &self.vlf_version,
                self.commit.as_deref(),
                &self.date_utc,
                a
            )
        ));
        s.push_str("| | paper (GeForce 8800 GTX) | vlf |\n|---|---|---|\n");
        let rows = [
            (
                "directions",
                "512".to_string(),
                format!(
                    "{} (geodesic n={})",
                    p.directions, p.params.geodesic_frequency
                ),
            ),
            (
                "grid / tile",
                "—".into(),
                format!(
                    "{0}x{0}, {1}x{1} tiles",
                    p.params.grid_resolution, p.params.tile_size
                ),
            ),
            ("faces", "19".into(), p.faces.to_string()),
            (
                "diffuse elements",
                "34,816".into(),
                p.diffuse_elements.to_string(),
            ),
            (
                "non-diffuse elements",
                "931,136".into(),
                p.non_diffuse_elements.to_string(),
            ),
            ("setup", "—".into(), format!("{:.3} s", p.setup_seconds)),
            (
                "visibility",
                "—".into(),
                format!(
                    "{:.1} ms ({} layers{})",
                    p.visibility_seconds * 1e3,
                    p.layers,
                    p.visibility_gpu_ms
                        .map(|g| format!(", {g:.2} ms GPU"))
                        .unwrap_or_default()
                ),
            ),
            (
                "iterations",
                "3".into(),
                format!("{} (residual {:.2e})", p.iterations, p.final_residual),
            ),
            (
                "propagation per iteration (GPU)",
                "—".into(),
                self.iteration_gpu_ms
                    .as_ref()
                    .map(|d| format!("median {:.3} ms, p99 {:.3} ms", d.median, d.p99))
                    .unwrap_or("—".into()),
            ),
            (
                "propagation total",
                "4.07 s".into(),
                format!("{:.1} ms", p.propagation_seconds * 1e3),
            ),
            (
                "transport samples/s",
                "—".into(),
                format!("{:.3e}", self.transport_samples_per_second),
            ),
            (
                "memory while propagating",
                "23.2 MB".into(),
                human_bytes(p.propagation_memory_bytes),
            ),
            (
                "memory for rendering",
                "2.9 MB".into(),
                human_bytes(p.render_memory_bytes),
            ),
            (
                "frame time (1024x768 in the paper)",
                "8.3 ms (122 fps)".into(),
                format!(
                    "{}x{}: median {:.4} ms, p99 {:.4} ms ({fps:.0} fps)",
                    self.render_size[0], self.render_size[1], r.median, r.p99
                ),
            ),
        ];
        for (k, a, b) in rows {
            s.push_str(&format!("| {k} | {a} | {b} |\n"));
        }
        s
    }
}
