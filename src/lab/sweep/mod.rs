//! `vlf sweep`: error against run time for the light field over a grid of settings and for the
//! path tracer over a range of samples per pixel, both against one reference image; CSV and a
//! log-log chart with the Pareto front (`plot.rs`). `--walkthrough` measures the walkthrough
//! case instead: a fixed per-frame budget along a scripted camera path.

pub mod plot;

use crate::error::{Result, VlfError};
use crate::gpu::{GpuContext, MemoryLedger};
use crate::lightfield::file::write_atomic;
use crate::metrics::{compare, Comparison};
use crate::progress::{Progress, Silent};
use crate::propagate::PropagationParams;
use crate::render::{Frame, Renderer};
use crate::scene::{Camera, Scene};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What the sweep varies. The light field runs every combination.
#[derive(Clone, Debug)]
pub struct SweepGrid {
    pub directions: Vec<u32>,
    pub grid: Vec<u32>,
    pub texel_density: Vec<f64>,
    pub tolerance: Vec<f64>,
    pub perturb: Vec<u32>,
    pub spp: Vec<u32>,
    pub ssaa: u32,
}

#[derive(Clone, Debug, Serialize)]
pub struct SweepRow {
    pub method: String,
    pub directions: u32,
    pub grid: u32,
    pub texel_density: f64,
    pub tolerance: f64,
    pub perturb: u32,
    pub spp: u32,
    /// the one-off part: for the light field setup + visibility + propagation, for the path
    /// tracer its preparation (scene, BVH, buffers, pipeline)
    pub propagation_s: f64,
    /// light field: one frame at the comparison size; path tracer: the whole image
    pub render_s: f64,
    pub total_s: f64,
    pub mse: f64,
    pub rel_mse: f64,
    pub display_mse: f64,
    pub flip: f64,
}

impl SweepRow {
    pub const CSV_HEADER: &'static str =
        "method,directions,grid,texel_density,tolerance,perturb,spp,propagation_s,render_s,total_s,mse,rel_mse,display_mse,flip";
    pub fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:e},{},{},{:.6},{:.6},{:.6},{:.6e},{:.6e},{:.6e},{:.6}",
            self.method,
            self.directions,
            self.grid,
            self.texel_density,
            self.tolerance,
            self.perturb,
            self.spp,
            self.propagation_s,
            self.render_s,
            self.total_s,
            self.mse,
            self.rel_mse,
            self.display_mse,
            self.flip
        )
    }
}

fn frame_seconds(
    renderer: &mut Renderer,
    camera: &Camera,
    w: u32,
    h: u32,
    ssaa: u32,
) -> Result<f64> {
    let (ms, _) = renderer.time_frames(camera, w * ssaa, h * ssaa, 20)?;
    Ok(crate::stats::Distribution::of(&ms).median / 1e3)
}

/// Run the sweep; each run's result is a `progress` note.
pub fn run(
    ctx: Arc<GpuContext>,
    scene: &Scene,
    camera: &Camera,
    reference: &Frame,
    grid: &SweepGrid,
    progress: &dyn Progress,
) -> Result<Vec<SweepRow>> {
    let (w, h) = (reference.width, reference.height);
    let mut rows = Vec::new();
    let combos: Vec<(u32, u32, f64, f64, u32)> = grid
        .directions
        .iter()
        .flat_map(|&d| grid.grid.iter().map(move |&g| (d, g)))
        .flat_map(|(d, g)| grid.texel_density.iter().map(move |&t| (d, g, t)))
        .flat_map(|(d, g, t)| grid.tolerance.iter().map(move |&tol| (d, g, t, tol)))
        .flat_map(|(d, g, t, tol)| grid.perturb.iter().map(move |&k| (d, g, t, tol, k)))
        .collect();
    let total_runs = combos.len() + grid.spp.len();
    for (i, &(directions, grid_res, density, tolerance, perturb)) in combos.iter().enumerate() {
        let params = PropagationParams {
            geodesic_frequency: PropagationParams::frequency_for_directions(directions),
            grid_resolution: grid_res,
            texel_density: density,
            tolerance,
            perturb,
            ..PropagationParams::default()
        };
        let result = crate::propagate::propagate(ctx.clone(), scene, &params, &Silent);
        let (lf, resident, report) = match result {
            Ok(r) => r,
            Err(e @ VlfError::GpuBudget(_)) => {
                progress.note(&format!("[{}/{total_runs}] light field {directions} dirs, grid {grid_res}: skipped, {e}", i + 1));
                continue;
            }
            Err(e) => return Err(e),
        };
        let mut renderer = Renderer::new(&resident, &lf, &MemoryLedger::default())?;
        let image = renderer.render_antialiased(camera, w, h, grid.ssaa)?;
        let c = compare(&image, reference)?;
        let render_s = frame_seconds(&mut renderer, camera, w, h, grid.ssaa)?;
        let propagation_s =
            report.setup_seconds + report.visibility_seconds + report.propagation_seconds;
        progress.note(&format!(
            "[{}/{total_runs}] light field {} dirs, grid {grid_res}, {density} texels/unit, tol {tolerance:.0e}, perturb {perturb}: {:.3} s, relMSE {:.3e}",
            i + 1, report.directions, propagation_s + render_s, c.rel_mse
        ));
        rows.push(row(
            "light field",
            report.directions,
            grid_res,
            density,
            tolerance,
            perturb,
            0,
            propagation_s,
            render_s,
            &c,
        ));
    }
    for (i, &spp) in grid.spp.iter().enumerate() {
        // a seed other than the reference's: independent noise
        let r =
            crate::reference::render(ctx.clone(), scene, camera, [w, h], spp, 1000 + spp, &Silent)?;
        let c = compare(&r.mean, reference)?;
        progress.note(&format!(
            "[{}/{total_runs}] path tracer {} spp: {:.3} s (+ {:.3} s setup), relMSE {:.3e}",
            combos.len() + i + 1,
            r.spp,
            r.seconds,
            r.setup_seconds,
            c.rel_mse
        ));
        rows.push(row(
            "path tracer",
            0,
            0,
            0.0,
            0.0,
            0,
            r.spp,
            r.setup_seconds,
            r.seconds,
            &c,
        ));
    }
    Ok(rows)
}

#[allow(clippy::too_many_arguments)]
fn row(
    method: &str,
    directions: u32,
    grid: u32,
    texel_density: f64,
    tolerance: f64,
    perturb: u32,
    spp: u32,
    propagation_s: f64,
    render_s: f64,
    c: &Comparison,
) -> SweepRow {
    SweepRow {
        method: method.into(),
        directions,
        grid,
        texel_density,
        tolerance,
        perturb,
        spp,
        propagation_s,
        render_s,
        total_s: propagation_s + render_s,
        mse: c.mse,
        rel_mse: c.rel_mse,
        display_mse: c.display_mse,
        flip: c.flip_mean,
    }
}

/// The light field (red) and the path tracer (blue), each with its rows' `points`.
fn method_series(points: impl Fn(&str) -> Vec<(f64, f64)>) -> [plot::Series<'static>; 2] {
    use plotters::style::RGBColor;
    [
        ("light field", RGBColor(200, 60, 40)),
        ("path tracer", RGBColor(40, 90, 200)),
    ]
    .map(|(name, color)| plot::Series {
        name,
        color,
        points: points(name),
    })
}

/// The chart of a sweep: relMSE against total time, both methods, Pareto front.
pub fn chart(rows: &[SweepRow], scene: &str, path: &Path) -> Result<()> {
    plot::error_vs_time(
        path,
        &format!("{scene}: error against run time"),
        "relMSE against the reference",
        &method_series(|method| {
            rows.iter()
                .filter(|r| r.method == method)
                .map(|r| (r.total_s, r.rel_mse))
                .collect()
        }),
    )
}

/// A CSV file: the header, then one line a row.
fn write_csv(path: &Path, header: &str, lines: impl Iterator<Item = String>) -> Result<()> {
    let mut text = format!("{header}\n");
    for line in lines {
        text.push_str(&line);
        text.push('\n');
    }
    write_atomic(path, text.as_bytes())
}

/// The sweep as OUT/sweep.csv and its chart as OUT/sweep.png; returns both paths.
pub fn write(rows: &[SweepRow], scene: &str, out: &Path) -> Result<[PathBuf; 2]> {
    let csv = out.join("sweep.csv");
    write_csv(&csv, SweepRow::CSV_HEADER, rows.iter().map(SweepRow::csv))?;
    let png = out.join("sweep.png");
    chart(rows, scene, &png)?;
    Ok([csv, png])
}

/// A scripted camera path: from the scene's first camera, `frames` views turning about the
/// camera's target by up to `degrees` (and back), like a visitor looking around.
pub fn walkthrough_path(camera: &Camera, frames: u32, degrees: f32) -> Vec<Camera> {
    let target = glam::Vec3::from(camera.target);
    let eye = glam::Vec3::from(camera.eye);
    let up = glam::Vec3::from(camera.up).normalize();
    (0..frames)
        .map(|i| {
            let s = (i as f32 / (frames.max(2) - 1) as f32 * std::f32::consts::PI).sin();
            let angle = (degrees * s).to_radians();
            let offset = glam::Quat::from_axis_angle(up, angle) * (eye - target);
            let mut c = camera.clone();
            c.name = format!("walk{i}");
            c.eye = (target + offset * (1.0 - 0.25 * s)).into();
            c
        })
        .collect()
}

#[derive(Clone, Debug, Serialize)]
pub struct WalkRow {
    pub frame: u32,
    pub method: String,
    pub spp: u32,
    /// the frame's own time: the light field's render, the path tracer's tracing (its one-off
    /// scene preparation and BVH build are not a per-frame cost and are left out)
    pub frame_ms: f64,
    pub rel_mse: f64,
    pub flip: f64,
}

impl WalkRow {
    pub const CSV_HEADER: &'static str = "frame,method,spp,frame_ms,rel_mse,flip";
    pub fn csv(&self) -> String {
        format!(
            "{},{},{},{:.4},{:.6e},{:.6}",
            self.frame, self.method, self.spp, self.frame_ms, self.rel_mse, self.flip
        )
    }
}

/// The walkthrough as OUT/walkthrough.csv and its relMSE per frame charted as
/// OUT/walkthrough.png under `title`; returns both paths.
pub fn write_walkthrough(rows: &[WalkRow], title: &str, out: &Path) -> Result<[PathBuf; 2]> {
    let csv = out.join("walkthrough.csv");
    write_csv(&csv, WalkRow::CSV_HEADER, rows.iter().map(WalkRow::csv))?;
    let png = out.join("walkthrough.png");
    plot::error_per_frame(
        &png,
        title,
        "relMSE against the frame's reference",
        &method_series(|method| {
            rows.iter()
                .filter(|r| r.method == method)
                .map(|r| (r.frame as f64, r.rel_mse))
                .collect()
        }),
    )?;
    Ok([csv, png])
}

/// The mean relMSE of one method's frames.
pub fn mean_rel_mse(rows: &[WalkRow], method: &str) -> f64 {
    let v: Vec<f64> = rows
        .iter()
        .filter(|r| r.method == method)
        .map(|r| r.rel_mse)
        .collect();
    v.iter().sum::<f64>() / v.len() as f64
}

/// The walkthrough at a fixed per-frame budget: the light field propagates once, then draws
/// every frame; the path tracer gets the samples per pixel that fit the budget for each frame.
/// Each frame is compared with a path-traced reference of that frame at `reference_spp`.
#[allow(clippy::too_many_arguments)]
pub fn walkthrough(
    ctx: Arc<GpuContext>,
    scene: &Scene,
    params: &PropagationParams,
    path: &[Camera],
    size: [u32; 2],
    budget_ms: f64,
    reference_spp: u32,
    progress: &dyn Progress,
) -> Result<(Vec<WalkRow>, f64, u32)> {
    let (lf, resident, report) = crate::propagate::propagate(ctx.clone(), scene, params, progress)?;
    let propagation_s =
        report.setup_seconds + report.visibility_seconds + report.propagation_seconds;
    let mut renderer = Renderer::new(&resident, &lf, &MemoryLedger::default())?;
    // path tracer speed: seconds per sample per pixel at this size
    let calibration =
        crate::reference::render(ctx.clone(), scene, &path[0], size, 16, 99, &Silent)?;
    let per_spp_ms = calibration.seconds * 1e3 / calibration.spp as f64;
    let spp = ((budget_ms / per_spp_ms).floor() as u32).max(1);
    let mut rows = Vec::new();
    for (i, cam) in path.iter().enumerate() {
        let reference = crate::reference::render(
            ctx.clone(),
            scene,
            cam,
            size,
            reference_spp,
            5000 + i as u32,
            &Silent,
        )?;
        let image = renderer.render(cam, size[0], size[1])?;
        let (ms, _) = renderer.time_frames(cam, size[0], size[1], 10)?;
        let c = compare(&image, &reference.mean)?;
        rows.push(WalkRow {
            frame: i as u32,
            method: "light field".into(),
            spp: 0,
            frame_ms: crate::stats::Distribution::of(&ms).median,
            rel_mse: c.rel_mse,
            flip: c.flip_mean,
        });
        let pt =
            crate::reference::render(ctx.clone(), scene, cam, size, spp, 7000 + i as u32, &Silent)?;
        let c = compare(&pt.mean, &reference.mean)?;
        rows.push(WalkRow {
            frame: i as u32,
            method: "path tracer".into(),
            spp: pt.spp,
            frame_ms: pt.seconds * 1e3,
            rel_mse: c.rel_mse,
            flip: c.flip_mean,
        });
        progress.note(&format!(
            "frame {}/{}: light field relMSE {:.3e}, path tracer ({} spp) relMSE {:.3e}",
            i + 1,
            path.len(),
            rows[rows.len() - 2].rel_mse,
            pt.spp,
            c.rel_mse
        ));
    }
    Ok((rows, propagation_s, spp))
}
