//! The light field a command draws from: loaded from a `.vlf` or propagated from a scene
//! (`light_field_for`), with a rough estimate of the propagation time on a software adapter.

use super::params::ParamArgs;
use super::print_warnings;
use super::progress::Bars;
use anyhow::Result;
use std::path::Path;
use vlf::gpu::GpuContext;
use vlf::lightfield::{file, LightField, ResidentLightField};
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

/// A light field from a .vlf file, or propagated from a scene (optionally loaded from a .vlf
/// made for that scene).
pub fn light_field_for(
    ctx: &std::sync::Arc<GpuContext>,
    input: &Path,
    lightfield: Option<&Path>,
    params: &ParamArgs,
) -> Result<(LightField, ResidentLightField)> {
    if file::is_vlf_path(input) {
        let lf = file::load(input)?;
        let resident = lf.upload(ctx.clone())?;
        return Ok((lf, resident));
    }
    let scene = Scene::load(input)?;
    light_field_of_scene(ctx, &scene, lightfield, params)
}

/// The light field of a loaded `scene`: read from `lightfield` (a .vlf made for it), or
/// propagated.
pub fn light_field_of_scene(
    ctx: &std::sync::Arc<GpuContext>,
    scene: &Scene,
    lightfield: Option<&Path>,
    params: &ParamArgs,
) -> Result<(LightField, ResidentLightField)> {
    print_warnings(&scene.warnings);
    if let Some(path) = lightfield {
        let lf = file::load(path)?;
        lf.check_scene(scene, path)?;
        let resident = lf.upload(ctx.clone())?;
        return Ok((lf, resident));
    }
    let params = params.for_adapter(ctx)?;
    estimate_time(ctx, scene, &params)?;
    let (lf, resident, report) =
        vlf::propagate::propagate(ctx.clone(), scene, &params, &Bars::default())?;
    eprintln!(
        "propagated in {:.2} s: {} iterations, residual {:.2e}",
        report.propagation_seconds + report.visibility_seconds + report.setup_seconds,
        report.iterations,
        report.final_residual
    );
    Ok((lf, resident))
}

/// Seconds per (direction x atlas texel x iteration) on lavapipe with 2 CPU cores: the Cornell
/// box at the software preset (981 directions, 22880 texels, 5 iterations) propagated in 20.5 s.
const SOFTWARE_SECONDS_PER_TEXEL_DIRECTION: f64 = 1.8e-7;
/// Iterations assumed by the estimate: the accelerated Cornell box and the furnaces take 3 to 5.
const ESTIMATE_ITERATIONS: f64 = 5.0;

/// On a software adapter, a rough estimate of the propagation time before starting it.
pub fn estimate_time(ctx: &GpuContext, scene: &Scene, params: &PropagationParams) -> Result<()> {
    if !ctx.summary.software {
        return Ok(());
    }
    let texels = vlf::prepare::PreparedScene::new(scene, params.texel_density)?
        .atlas
        .texel_count() as f64;
    let cores = std::thread::available_parallelism().map_or(2, |n| n.get()) as f64;
    let work =
        params.direction_count() as f64 * texels * ESTIMATE_ITERATIONS * params.perturb as f64;
    let seconds = work * SOFTWARE_SECONDS_PER_TEXEL_DIRECTION * 2.0 / cores;
    eprintln!(
        "estimate: propagating takes {} on {} ({} directions x {} texels x ~{ESTIMATE_ITERATIONS} iterations, {cores} CPU cores; a rough model, mirrors add more)",
        human_seconds(seconds),
        ctx.summary.name,
        params.direction_count(),
        texels
    );
    Ok(())
}

/// A duration as a sentence reads it after "takes": "under a second", "about 40 s",
/// "about 12 min", "about 2.5 h".
pub fn human_seconds(s: f64) -> String {
    match s {
        s if s < 1.0 => "under a second".into(),
        s if s < 120.0 => format!("about {s:.0} s"),
        s if s < 7200.0 => format!("about {:.0} min", s / 60.0),
        s => format!("about {:.1} h", s / 3600.0),
    }
}
