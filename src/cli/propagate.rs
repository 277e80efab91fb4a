//! `vlf propagate`.

use super::light_field::estimate_time;
use super::params::ParamArgs;
use super::progress::Bars;
use super::{print_warnings, write_json};
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use vlf::gpu::GpuContext;
use vlf::scene::Scene;

/// `vlf propagate`'s arguments.
#[derive(Args)]
pub struct PropagateArgs {
    /// scene.toml or a glTF model (.gltf/.glb)
    scene: PathBuf,
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the summary as JSON
    #[arg(long)]
    report: Option<PathBuf>,
    /// Save the state every N iterations to OUTPUT.checkpoint (removed when done)
    #[arg(long, default_value_t = 0)]
    checkpoint: u32,
    /// Continue from OUTPUT.checkpoint if it exists (same scene and settings)
    #[arg(long)]
    resume: bool,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf propagate`: a scene into a .vlf file, with checkpoints and a JSON report.
pub fn run(args: PropagateArgs) -> Result<()> {
    // before minutes of work: a light field that could not be written would be lost
    let folder = (args.output.parent())
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    if !folder.is_dir() {
        anyhow::bail!(
            "{}: the folder {} does not exist; create it, or give -o a path in a folder that does",
            args.output.display(),
            folder.display()
        );
    }
    // the GPU opens while the scene is read (a quarter to most of a second on a GPU host)
    let opening = std::thread::spawn(GpuContext::new);
    let read = std::time::Instant::now();
    let scene = Scene::load(&args.scene)?;
    let read_seconds = read.elapsed().as_secs_f64();
    print_warnings(&scene.warnings);
    let ctx = (opening.join()).map_err(|_| anyhow::anyhow!("opening the GPU panicked"))??;
    let params = args.params.for_adapter(&ctx)?;
    estimate_time(&ctx, &scene, &params)?;
    let output = args.output;
    let plan = vlf::propagate::checkpoint::CheckpointPlan {
        path: PathBuf::from(format!("{}.checkpoint", output.display())),
        every: args.checkpoint,
        resume: args.resume,
    };
    let outputs = vlf::propagate::Outputs {
        checkpoints: Some(&plan),
        light_field: Some(&output),
    };
    let (_lf, _resident, mut rep) =
        vlf::propagate::propagate_with(ctx, &scene, &params, &Bars::default(), outputs)?;
    print_warnings(&rep.warnings[scene.warnings.len()..]);
    rep.command_phases
        .insert(0, ("read the scene".into(), read_seconds));
    if plan.path.exists() {
        std::fs::remove_file(&plan.path)
            .with_context(|| format!("removing {}", plan.path.display()))?;
    }
    println!("{}", rep.table());
    if let Some(path) = args.report {
        write_json(&path, &rep)?;
        println!("report: {}", path.display());
    }
    println!("light field: {}", output.display());
    Ok(())
}
