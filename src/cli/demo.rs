//! `vlf demo` (also what `vlf` alone runs).

use super::print_warnings;
use super::progress::Bars;
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use vlf::gpu::GpuContext;
use vlf::lightfield::file;
use vlf::propagate::PropagationParams;
use vlf::render::{image_io, Renderer};
use vlf::scene::Scene;

/// `vlf demo`'s arguments.
#[derive(Args)]
pub struct DemoArgs {
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
}

pub fn run(out: &Path) -> Result<()> {
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell/scene.toml");
    let scene_path = if Path::new("scenes/cornell/scene.toml").exists() {
        PathBuf::from("scenes/cornell/scene.toml")
    } else {
        scene_path
    };
    let scene = Scene::load(&scene_path)?;
    print_warnings(&scene.warnings);
    let ctx = GpuContext::new()?;
    let params = if ctx.summary.software {
        println!(
            "{} is a software adapter (no GPU found): using lighter settings ({} directions, {}^2 grid, {} texels/unit) so the demo finishes in a few minutes",
            ctx.summary.name,
            PropagationParams::software().direction_count(),
            PropagationParams::software().grid_resolution,
            PropagationParams::software().texel_density
        );
        PropagationParams::software()
    } else {
        println!("adapter: {} ({})", ctx.summary.name, ctx.summary.backend);
        PropagationParams::default()
    };
    let (lf, resident, report) = vlf::propagate::propagate(ctx, &scene, &params, &Bars::default())?;
    println!("{}", report.table());
    if report.final_residual >= params.tolerance && report.iterations >= params.max_iterations {
        bail!("the demo did not converge");
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut renderer = Renderer::new(&resident, &lf, &resident.ledger)?;
    let cam = lf.camera(Some("front"))?.clone();
    let frame = renderer.render(&cam, cam.size[0], cam.size[1])?;
    let png = out.join("cornell.png");
    let exr = out.join("cornell.exr");
    let vlf_path = out.join("cornell.vlf");
    image_io::write_image(&frame, &png, 1.0)?;
    image_io::write_image(&frame, &exr, 1.0)?;
    file::save(&lf, &vlf_path)?;
    println!(
        "wrote {}\nwrote {}\nwrote {}",
        png.display(),
        exr.display(),
        vlf_path.display()
    );
    Ok(())
}
