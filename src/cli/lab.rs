//! The lab's subcommands (feature `lab`): `vlf sweep`, `vlf generate`, `vlf stress` and
//! `vlf bench`, over the library's `vlf::lab`.

use super::params::ParamArgs;
use super::progress::Bars;
use super::{parse_size, print_warnings, write_json};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use vlf::gpu::GpuContext;
use vlf::propagate::PropagationParams;
use vlf::render::image_io;
use vlf::scene::{Camera, Scene};

/// `vlf sweep`'s arguments.
#[derive(Args)]
pub struct SweepArgs {
    scene: PathBuf,
    /// The reference image (vlf reference ... -o ref.exr); its size is the comparison size
    #[arg(long, required_unless_present = "walkthrough")]
    reference: Option<PathBuf>,
    #[arg(long)]
    camera: Option<String>,
    #[arg(long, value_delimiter = ',', default_value = "181,501,981,2001")]
    directions: Vec<u32>,
    #[arg(long, value_delimiter = ',', default_value = "64,128,256")]
    grid: Vec<u32>,
    #[arg(long, value_delimiter = ',', default_value = "32,64,96")]
    texel_density: Vec<f64>,
    #[arg(long, value_delimiter = ',', default_value = "1e-3")]
    tolerance: Vec<f64>,
    #[arg(long, value_delimiter = ',', default_value = "1")]
    perturb: Vec<u32>,
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256")]
    spp: Vec<u32>,
    /// Light field supersampling per pixel side (the path tracer covers each pixel too)
    #[arg(long, default_value_t = 4)]
    ssaa: u32,
    /// Measure the walkthrough case: a fixed per-frame budget along a scripted camera path
    #[arg(long)]
    walkthrough: bool,
    /// Walkthrough: milliseconds per frame (11.1 = 90 Hz)
    #[arg(long, default_value_t = 11.1)]
    budget_ms: f64,
    #[arg(long, default_value_t = 8)]
    frames: u32,
    /// Walkthrough: samples per pixel of each frame's reference
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
    size: [u32; 2],
    #[arg(long, default_value = "sweep")]
    out: PathBuf,
    /// Walkthrough: the light field's settings (default: config/propagation/default.toml's)
    #[arg(long)]
    config: Option<PathBuf>,
}

/// `vlf generate`'s arguments.
#[derive(Args)]
pub struct GenerateArgs {
    kind: vlf::lab::generate::SceneKind,
    /// About this many triangles (classroom) or faces (gallery)
    #[arg(long, default_value_t = 10_000)]
    size: u64,
    /// The mirror variant (a mirror wall in the classroom, mirrors along the gallery)
    #[arg(long)]
    mirrors: bool,
    /// Glossy floors (varnished: diffuse plus a GGX lobe of alpha 0.05) and glossy metal
    /// (alpha 0.2) furniture legs and frames
    #[arg(long)]
    glossy: bool,
    /// The mesh as OBJ + MTL or as glTF 2.0 (.gltf + .bin)
    #[arg(long, value_enum, default_value = "obj")]
    format: vlf::lab::generate::MeshFormat,
    #[arg(short, long)]
    out: PathBuf,
}

/// `vlf stress`'s arguments.
#[derive(Args)]
pub struct StressArgs {
    /// Where the table goes (default: STABILITY.md; with --quick, none unless given)
    #[arg(long)]
    out: Option<PathBuf>,
    /// Only the quick cases (about a minute on lavapipe); the table marks the others "not run"
    #[arg(long)]
    quick: bool,
}

/// `vlf bench`'s arguments.
#[derive(Args)]
pub struct BenchArgs {
    #[arg(long, default_value = "scenes/cornell/scene.toml")]
    scene: PathBuf,
    /// The whole suite (Cornell, Cornell-mirror, classrooms of 1K..1M triangles, the mirror
    /// gallery, a memory-budget run) instead of one scene
    #[arg(long)]
    suite: bool,
    /// Suite: small scenes only (software adapters, quick checks)
    #[arg(long)]
    quick: bool,
    /// Suite: where generated scenes go
    #[arg(long, default_value = "target/suite-scenes")]
    work: PathBuf,
    /// Suite: the log-log scaling chart (PNG)
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Suite: do not measure; write --markdown / --plot from this earlier --json report
    #[arg(long)]
    from_json: Option<PathBuf>,
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write a Markdown section (for BENCHMARKS.md)
    #[arg(long)]
    markdown: Option<PathBuf>,
    #[arg(long, default_value_t = 200)]
    frames: u32,
    #[arg(long, value_parser = parse_size, default_value = "1024x768")]
    size: [u32; 2],
    /// Antialiasing of the timed view: N eye rays per pixel (default: the real-time one)
    #[arg(long, default_value_t = vlf::render::REALTIME_SAMPLES)]
    aa: u32,
    // edge antialiasing of the timed view (e.g. --aa 1 --edge-samples 8)
    #[command(flatten)]
    edges: super::edge_args::EdgeArgs,
    #[command(flatten)]
    params: ParamArgs,
}
/// `vlf sweep`: the grid of settings against a reference, or the walkthrough at a frame budget.
pub fn sweep(a: SweepArgs) -> Result<()> {
    let scene = Scene::load(&a.scene)?;
    print_warnings(&scene.warnings);
    let cam = scene.camera(a.camera.as_deref())?.clone();
    let ctx = GpuContext::new()?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    if a.walkthrough {
        return walkthrough(ctx, &scene, &cam, &a);
    }
    let grid = vlf::lab::sweep::SweepGrid {
        directions: a.directions,
        grid: a.grid,
        texel_density: a.texel_density,
        tolerance: a.tolerance,
        perturb: a.perturb,
        spp: a.spp,
        ssaa: a.ssaa.max(1),
    };
    let reference = image_io::read_image(a.reference.as_deref().expect("clap requires it"))?;
    let rows = vlf::lab::sweep::run(ctx, &scene, &cam, &reference, &grid, &Bars::default())?;
    let [csv, png] = vlf::lab::sweep::write(&rows, &scene.name, &a.out)?;
    println!("{}\n{}", csv.display(), png.display());
    Ok(())
}

/// `vlf sweep --walkthrough`: the light field and the path tracer at a fixed frame budget
/// along a scripted camera path.
fn walkthrough(
    ctx: std::sync::Arc<GpuContext>,
    scene: &Scene,
    cam: &Camera,
    a: &SweepArgs,
) -> Result<()> {
    let params = match &a.config {
        Some(path) => PropagationParams::from_toml_file(path)?,
        None => PropagationParams::default(),
    };
    let (size, budget_ms) = (a.size, a.budget_ms);
    let path = vlf::lab::sweep::walkthrough_path(cam, a.frames.max(2), 30.0);
    let (rows, propagation_s, pt_spp) = vlf::lab::sweep::walkthrough(
        ctx,
        scene,
        &params,
        &path,
        size,
        budget_ms,
        a.reference_spp,
        &Bars::default(),
    )?;
    let title = format!(
        "{}: walkthrough at {budget_ms} ms per frame (path tracer {pt_spp} spp)",
        scene.name
    );
    let [csv, png] = vlf::lab::sweep::write_walkthrough(&rows, &title, &a.out)?;
    let mean = |method| vlf::lab::sweep::mean_rel_mse(&rows, method);
    println!(
        "walkthrough, {} frames at {}x{}, budget {budget_ms} ms: light field (one propagation of {propagation_s:.3} s) mean relMSE {:.3e}; path tracer at {pt_spp} spp mean relMSE {:.3e}",
        path.len(), size[0], size[1], mean("light field"), mean("path tracer")
    );
    println!("{}\n{}", csv.display(), png.display());
    Ok(())
}

/// `vlf generate`: a procedural scene.
pub fn generate(a: GenerateArgs) -> Result<()> {
    let g = vlf::lab::generate::generate_as(
        &vlf::lab::generate::GenerateOptions {
            kind: a.kind,
            size: a.size,
            mirrors: a.mirrors,
            glossy: a.glossy,
        },
        &a.out,
        a.format,
    )?;
    println!(
        "{}: {} triangles, {} faces ({})",
        g.scene.display(),
        g.triangles,
        g.faces,
        g.description
    );
    Ok(())
}

/// `vlf stress`: the stability cases, and their table.
pub fn stress(a: StressArgs) -> Result<()> {
    let StressArgs { out, quick } = a;
    let ctx = GpuContext::new()?;
    let adapter = format!("{} ({})", ctx.summary.name, ctx.summary.backend);
    let cases = vlf::lab::stress::run(ctx, quick, true)?;
    let out = out.or_else(|| (!quick).then(|| PathBuf::from("STABILITY.md")));
    if let Some(out) = out {
        std::fs::write(&out, vlf::lab::stress::markdown(&cases, &adapter))
            .with_context(|| format!("writing {}", out.display()))?;
        println!("{}", out.display());
    }
    let failed: Vec<&str> = cases
        .iter()
        .filter(|c| !c.pass)
        .map(|c| c.name.as_str())
        .collect();
    if !failed.is_empty() {
        bail!(
            "{} stability case(s) failed: {}",
            failed.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// `vlf bench`: one scene, the suite (`--suite`), or the tables of an earlier suite report
/// (`--from-json`).
pub fn bench(a: BenchArgs) -> Result<()> {
    if let Some(input) = &a.from_json {
        return suite_from_json(input, &a);
    }
    let ctx = GpuContext::new()?;
    if ctx.summary.software {
        eprintln!(
            "note: {} is a software adapter: these timings say nothing about GPU speed",
            ctx.summary.name
        );
    }
    match a.suite {
        true => suite(ctx, &a),
        false => bench_scene(ctx, &a),
    }
}

/// `vlf bench --from-json`: the Markdown and the chart of an earlier suite report.
fn suite_from_json(input: &Path, a: &BenchArgs) -> Result<()> {
    let report = vlf::lab::suite::SuiteReport::load(input)?;
    let md = report.markdown();
    match &a.markdown {
        Some(path) => {
            std::fs::write(path, &md).with_context(|| format!("writing {}", path.display()))?
        }
        None => print!("{md}"),
    }
    if let Some(path) = &a.plot {
        report.plot(path)?;
    }
    Ok(())
}

/// `vlf bench --suite`: the benchmark suite, as Markdown, JSON and a chart.
fn suite(ctx: std::sync::Arc<GpuContext>, a: &BenchArgs) -> Result<()> {
    let root = std::env::current_dir().context("the current folder")?;
    let report = vlf::lab::suite::run(
        ctx,
        &root,
        &a.work,
        a.quick,
        a.frames.min(100),
        &Bars::default(),
    )?;
    let md = report.markdown();
    print!("{md}");
    if let Some(path) = &a.json {
        write_json(path, &report)?;
        println!("json: {}", path.display());
    }
    if let Some(path) = &a.markdown {
        std::fs::write(path, &md).with_context(|| format!("writing {}", path.display()))?;
        println!("markdown: {}", path.display());
    }
    if let Some(path) = &a.plot {
        report.plot(path)?;
        println!("chart: {}", path.display());
    }
    Ok(())
}

/// `vlf bench`: one scene.
fn bench_scene(ctx: std::sync::Arc<GpuContext>, a: &BenchArgs) -> Result<()> {
    let scene = Scene::load(&a.scene)?;
    let params = a.params.for_adapter(&ctx)?;
    let view = vlf::lab::bench::TimedView {
        size: a.size,
        frames: a.frames,
        samples_per_pixel: a.aa,
        edges: a.edges.edge_antialiasing()?,
    };
    let report = vlf::lab::bench::run(ctx, &scene, &params, view)?;
    print!("{}", report.table());
    if let Some(path) = &a.json {
        write_json(path, &report)?;
        println!("json: {}", path.display());
    }
    if let Some(path) = &a.markdown {
        std::fs::write(path, report.markdown())
            .with_context(|| format!("writing {}", path.display()))?;
        println!("markdown: {}", path.display());
    }
    Ok(())
}
