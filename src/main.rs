//! The `vlf` command line. Library errors are reported through anyhow here, and only here.

/// The binary's own modules (src/cli/): the progress bars, and the lab's subcommands.
mod cli {
    #[cfg(feature = "lab")]
    pub mod lab;
    pub mod progress;
}

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use cli::progress::Bars;
use std::path::{Path, PathBuf};
use vlf::gpu::GpuContext;
use vlf::lightfield::{file, LightField, ResidentLightField};
use vlf::propagate::PropagationParams;
use vlf::render::{image_io, Renderer};
use vlf::scene::Scene;

#[derive(Parser)]
#[command(
    name = "vlf",
    version,
    about = "Virtual light field: propagate global illumination on the GPU, render any view from it"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ExportFormat {
    /// Mitsuba 3 XML + PLY (tools/mitsuba/reference.py, which shares no code with vlf)
    Mitsuba,
}

#[derive(Subcommand)]
enum Command {
    /// Propagate a scene into a light field file (.vlf)
    Propagate(PropagateArgs),
    /// Render a view from a scene (propagating first) or from a .vlf file
    Render(RenderArgs),
    /// Path-trace a reference image with the same scene semantics (GPU, BVH, NEE + MIS)
    Reference(ReferenceArgs),
    /// Error against run time: the light field over a grid of settings and the path tracer over
    /// samples per pixel -> CSV + log-log chart with the Pareto front
    #[cfg(feature = "lab")]
    Sweep(cli::lab::SweepArgs),
    /// Draw every wall and eye of a display configuration (CAVE, power wall, window): one window
    /// per wall (W/A/S/D or arrows walk, Q/E turn, R/F rise/sink in fly mode, G toggles fly,
    /// left-drag turns, Home resets, gamepad sticks; Esc quits), or offscreen with --headless
    Cave(CaveArgs),
    /// Print a display configuration's live tracking as it arrives: head and wand poses in the
    /// room (after [tracking.calibration]), buttons and joystick
    Track(TrackArgs),
    /// An OpenXR headset: the runtime's Vulkan device, a swapchain per eye, thumbstick navigation
    Xr(XrArgs),
    /// Write a procedural scene (scene.toml + OBJ + MTL, or glTF) that scales to a million triangles
    #[cfg(feature = "lab")]
    Generate(cli::lab::GenerateArgs),
    /// Run the stability cases and write their table (STABILITY.md)
    #[cfg(feature = "lab")]
    Stress(cli::lab::StressArgs),
    /// Compare a linear image with a reference: MSE, RMSE, relMSE, max error, display MSE, FLIP
    Compare(CompareArgs),
    /// Write the scene for another renderer, e.g. `vlf export mitsuba scene.toml -o DIR`: a
    /// standalone Mitsuba 3 scene (DIR/<camera>.xml per camera), for an independent ground truth
    Export(ExportArgs),
    /// Propagate the built-in Cornell box and write PNG + EXR into out/
    Demo(DemoArgs),
    /// Check the light field on your own model: every camera rendered from it and path-traced
    /// by `vlf reference`, compared, with error maps and the verdict in words
    Verify(VerifyArgs),
    /// Measure setup, visibility, propagation and rendering
    #[cfg(feature = "lab")]
    Bench(cli::lab::BenchArgs),
}

/// `vlf propagate`'s arguments.
#[derive(Args)]
struct PropagateArgs {
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

/// `vlf render`'s arguments.
#[derive(Args)]
struct RenderArgs {
    /// scene.toml, a glTF model (.gltf/.glb) or file.vlf
    input: PathBuf,
    #[arg(long)]
    camera: Option<String>,
    /// Image size WxH (default: the camera's)
    #[arg(long, value_parser = parse_size)]
    size: Option<[u32; 2]>,
    /// With a scene.toml: load this light field instead of propagating (must match the scene)
    #[arg(long)]
    lightfield: Option<PathBuf>,
    /// Exposure multiplier for PNG output
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Supersampling on top of --aa: render N x N times the pixels and box-filter them
    #[arg(long, default_value_t = 1)]
    ssaa: u32,
    /// Antialiasing: N eye rays per pixel (a Hammersley set), box-filtered; 1 = off
    #[arg(long, default_value_t = vlf::render::STILL_SAMPLES)]
    aa: u32,
    /// out.exr (linear radiance) or out.png (tonemapped)
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf reference`'s arguments.
#[derive(Args)]
struct ReferenceArgs {
    scene: PathBuf,
    #[arg(long)]
    camera: Option<String>,
    #[arg(long, value_parser = parse_size)]
    size: Option<[u32; 2]>,
    /// Samples per pixel
    #[arg(long, default_value_t = 1024)]
    spp: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Also write the per-pixel variance of the estimate (EXR)
    #[arg(long)]
    variance: Option<PathBuf>,
    /// ref.exr (linear radiance) or ref.png
    #[arg(short, long)]
    output: PathBuf,
}

/// `vlf verify`'s arguments.
#[derive(Args)]
struct VerifyArgs {
    /// scene.toml or a glTF model (.gltf/.glb)
    scene: PathBuf,
    /// Cameras to check (default: every camera of the scene); repeat for several
    #[arg(long)]
    camera: Vec<String>,
    /// Image size WxH (default: each camera's)
    #[arg(long, value_parser = parse_size)]
    size: Option<[u32; 2]>,
    /// The reference's samples per pixel (its noise is listed beside every figure)
    #[arg(long, default_value_t = 4096)]
    spp: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// With a scene.toml: check this light field instead of propagating (must match the scene)
    #[arg(long)]
    lightfield: Option<PathBuf>,
    /// Where the images and error maps go
    #[arg(long, default_value = "verify-out")]
    out: PathBuf,
    /// Also write the figures as JSON
    #[arg(long)]
    json: Option<PathBuf>,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf cave`'s arguments.
#[derive(Args)]
struct CaveArgs {
    config: PathBuf,
    /// scene.toml (propagated first) or file.vlf
    #[arg(long)]
    scene: PathBuf,
    /// Render offscreen to files instead of windows
    #[arg(long)]
    headless: bool,
    /// Frames to draw (headless: default 60; windowed: until Esc unless given)
    #[arg(long)]
    frames: Option<u32>,
    /// Windowed with --frames: keep the windows up this many seconds afterwards
    #[arg(long, default_value_t = 0.0)]
    hold_seconds: f64,
    /// Windowed: exposure applied before display
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    #[arg(long, default_value = "cave-out")]
    out: PathBuf,
    /// Also write EXR (linear radiance) per wall and eye
    #[arg(long)]
    exr: bool,
    /// Write the frame-time report as JSON
    #[arg(long)]
    json: Option<PathBuf>,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf track`'s arguments.
#[derive(Args)]
struct TrackArgs {
    config: PathBuf,
    /// Stop after this many seconds (default: until Ctrl-C)
    #[arg(long)]
    seconds: Option<f64>,
}

/// `vlf xr`'s arguments.
#[derive(Args)]
struct XrArgs {
    /// scene.toml (propagated first) or file.vlf
    #[arg(long)]
    scene: PathBuf,
    /// End the session after this many frames (default: when the runtime or the user ends it)
    #[arg(long)]
    frames: Option<u32>,
    /// Write the left eye's image of frame --screenshot-frame as PNG
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Which frame --screenshot captures (1 is the first rendered frame)
    #[arg(long, default_value_t = 30)]
    screenshot_frame: u32,
    /// The scene camera the viewer starts at (default: the scene's first)
    #[arg(long)]
    camera: Option<String>,
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Per-eye resolution relative to the runtime's recommendation (e.g. 1.4 supersamples;
    /// clamped to the runtime's maximum)
    #[arg(long, default_value_t = 1.0)]
    resolution_scale: f32,
    /// Antialiasing: N eye rays per pixel (1 = off)
    #[arg(long, default_value_t = vlf::render::REALTIME_SAMPLES)]
    aa: u32,
    /// Fit every frame into the headset's refresh period: the first frame probes the eyes from
    /// --aa down (fewer eye rays, then fewer mirror reflections) and shows nothing; then each
    /// eye's eye rays per pixel follow its GPU time (frame pacing)
    #[arg(long)]
    fit_frame_time: bool,
    /// The eyes' swapchains: one array swapchain with a layer per eye where the runtime takes it
    /// (auto, else one per eye), insist on the array (array), or one per eye (per-eye)
    #[arg(long, value_enum, default_value = "auto")]
    swapchains: vlf::display::xr::Swapchains,
    /// Write the frame-time report as JSON
    #[arg(long)]
    json: Option<PathBuf>,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf compare`'s arguments.
#[derive(Args)]
struct CompareArgs {
    image: PathBuf,
    reference: PathBuf,
    #[arg(long)]
    json: bool,
    /// Write a false-colour difference image (FLIP error, magma colour map)
    #[arg(long)]
    diff: Option<PathBuf>,
    /// Compare only where this PNG (same size) is white, e.g. away from geometric edges
    /// (tools/mitsuba/edges.py writes such a mask)
    #[arg(long)]
    mask: Option<PathBuf>,
}

/// `vlf export`'s arguments.
#[derive(Args)]
struct ExportArgs {
    /// The renderer: mitsuba
    #[arg(value_enum)]
    format: ExportFormat,
    scene: PathBuf,
    /// The folder to write (created if missing)
    #[arg(short, long)]
    output: PathBuf,
    /// The Python that runs the exporter (needs numpy and mitsuba: `pip install mitsuba numpy`)
    #[arg(long, default_value = "python3")]
    python: String,
}

/// `vlf demo`'s arguments.
#[derive(Args)]
struct DemoArgs {
    #[arg(long, default_value = "out")]
    out: PathBuf,
}

/// `--quality`: the propagation presets, shipped as config/propagation/<name>.toml.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Quality {
    /// a quick look: coarse, seconds on a software adapter
    Draft,
    /// the default settings (what a GPU gets when no preset is given)
    Default,
    /// finer and tighter than the default: for a GPU
    High,
}

/// The shipped presets: (name, file, text). Parsed like any --config file, so an error names it.
const PRESETS: [(&str, &str, &str); 4] = [
    (
        "draft",
        "config/propagation/draft.toml",
        include_str!("../config/propagation/draft.toml"),
    ),
    (
        "default",
        "config/propagation/default.toml",
        include_str!("../config/propagation/default.toml"),
    ),
    (
        "high",
        "config/propagation/high.toml",
        include_str!("../config/propagation/high.toml"),
    ),
    (
        "software",
        "config/propagation/software.toml",
        include_str!("../config/propagation/software.toml"),
    ),
];

fn preset(name: &str) -> Result<PropagationParams> {
    let (_, file, text) = PRESETS
        .iter()
        .find(|p| p.0 == name)
        .with_context(|| format!("no preset {name:?}"))?;
    let params: PropagationParams =
        toml::from_str(text).with_context(|| format!("{file} (built in)"))?;
    params
        .validate()
        .with_context(|| format!("{file} (built in)"))?;
    Ok(params)
}

#[derive(Args, Clone, Default)]
struct ParamArgs {
    /// Start from the settings in this TOML file (see config/propagation/); flags override it
    #[arg(long, conflicts_with = "quality")]
    config: Option<PathBuf>,
    /// Start from a preset (config/propagation/<name>.toml); flags override it. Without it (and
    /// without --config): default on a GPU, lighter settings on a software adapter
    #[arg(long, value_enum)]
    quality: Option<Quality>,
    /// Number of directions over the hemisphere (rounded up to a geodesic set, 5n^2+1)
    #[arg(long)]
    directions: Option<u32>,
    /// Grid cells per side for each direction
    #[arg(long)]
    grid: Option<u32>,
    /// Tile size in cells (must divide the grid)
    #[arg(long)]
    tile: Option<u32>,
    /// Diffuse texels per unit length of the normalised scene
    #[arg(long)]
    texel_density: Option<f64>,
    /// Stop when unshot power / emitted power falls below this
    #[arg(long)]
    tolerance: Option<f64>,
    #[arg(long)]
    max_iterations: Option<u32>,
    /// K perturbed ("virtual") direction sets used during transport: memory unchanged, time x K
    #[arg(long)]
    perturb: Option<u32>,
    /// Plain shooting to the tolerance: no geometric-tail acceleration
    #[arg(long)]
    no_accelerate: bool,
    /// GPU memory the propagation may use (e.g. 512MiB, 2GiB; a bare number is MiB). Directions
    /// whose visibility does not fit are processed in batches, rebuilt every iteration
    #[arg(long, value_parser = parse_mebibytes)]
    memory_budget: Option<u64>,
    /// Shadow rays per texel for direct light from the emitters (and again from the sky);
    /// 0 sends direct light through the fixed directions as the paper does
    #[arg(long)]
    direct_samples: Option<u32>,
    /// Direct light also through planar mirrors: emitters seen in them as virtual emitters (on
    /// by default where direct light is on; for settings files that turn it off)
    #[arg(long, conflicts_with = "no_mirror_direct")]
    mirror_direct: bool,
    /// Mirrors' first reflections of the emitters through the mirror tiles' fixed directions
    /// instead of as virtual emitters
    #[arg(long)]
    no_mirror_direct: bool,
}

impl ParamArgs {
    /// The settings for this adapter: --config, else --quality, else the default on a GPU and
    /// the software preset on a software adapter (said on stderr); then the flags.
    fn for_adapter(&self, ctx: &GpuContext) -> Result<PropagationParams> {
        let base = match (&self.config, self.quality) {
            (Some(path), _) => PropagationParams::from_toml_file(path)?,
            (None, Some(q)) => preset(&format!("{q:?}").to_lowercase())?,
            (None, None) if ctx.summary.software => {
                let p = preset("software")?;
                eprintln!(
                    "note: {} is a software adapter (no GPU found): using lighter settings ({} directions, {}^2 grid, {} texels/unit, config/propagation/software.toml); --quality default|high or --config for others",
                    ctx.summary.name,
                    p.direction_count(),
                    p.grid_resolution,
                    p.texel_density
                );
                p
            }
            (None, None) => PropagationParams::default(),
        };
        self.apply(base)
    }

    /// The flags over `base`.
    fn apply(&self, base: PropagationParams) -> Result<PropagationParams> {
        let mut p = base;
        if let Some(d) = self.directions {
            p.geodesic_frequency = PropagationParams::frequency_for_directions(d);
        }
        if let Some(g) = self.grid {
            p.grid_resolution = g;
        }
        if let Some(t) = self.tile {
            p.tile_size = t;
        }
        if let Some(t) = self.texel_density {
            p.texel_density = t;
        }
        if let Some(t) = self.tolerance {
            p.tolerance = t;
        }
        if let Some(m) = self.max_iterations {
            p.max_iterations = m;
        }
        if let Some(k) = self.perturb {
            p.perturb = k;
        }
        if self.no_accelerate {
            p.accelerate = false;
        }
        if let Some(m) = self.memory_budget {
            p.memory_budget_mib = Some(m);
        }
        if let Some(d) = self.direct_samples {
            p.direct_samples = d;
        }
        if self.mirror_direct || self.no_mirror_direct {
            p.mirror_direct = self.mirror_direct;
        }
        Ok(p)
    }
}

/// "512MiB", "2GiB", "1.5G", "800M" or a bare number of MiB, as MiB.
fn parse_mebibytes(s: &str) -> std::result::Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("{s:?}: expected a size such as 512MiB or 2GiB"))?;
    let mib = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "m" | "mb" | "mib" => value,
        "g" | "gb" | "gib" => value * 1024.0,
        "t" | "tb" | "tib" => value * 1024.0 * 1024.0,
        other => return Err(format!("{s:?}: unknown unit {other:?}; use MiB or GiB")),
    };
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must be refused too
    if !(mib >= 1.0) {
        return Err(format!("{s:?}: a memory budget must be at least 1 MiB"));
    }
    Ok(mib.round() as u64)
}

fn parse_size(s: &str) -> std::result::Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?}: expected WxH, e.g. 1024x768"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("{s:?}: width is not a number"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("{s:?}: height is not a number"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("{s:?}: width and height must be 1..16384"));
    }
    Ok([w, h])
}

fn main() {
    quiet_vulkan_device_select();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    if !cfg!(feature = "lab") {
        refuse_lab_commands();
    }
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {}", error_text(&e));
        std::process::exit(1);
    }
}

/// The lab's subcommands, which a core build (`--no-default-features`) leaves out.
const LAB_COMMANDS: [&str; 4] = ["bench", "generate", "stress", "sweep"];

/// In a build without the lab, `vlf bench` (or another lab command) says how to get it rather
/// than clap's bare "unrecognized subcommand".
fn refuse_lab_commands() {
    let asked = std::env::args().nth(1);
    if let Some(name) = asked.filter(|a| LAB_COMMANDS.contains(&a.as_str())) {
        eprintln!(
            "error: `vlf {name}` is part of the lab, which this vlf was built without \
             (--no-default-features): build it with `cargo build --release --features lab` \
             (the lab is a default feature)"
        );
        std::process::exit(2);
    }
}

/// Mesa's implicit Vulkan layer VK_LAYER_MESA_device_select asks the Wayland compositor for
/// the default GPU whenever physical devices are enumerated (wgpu enables the Wayland surface
/// extension); without a session, libwayland prints "error: XDG_RUNTIME_DIR is invalid or not
/// set in the environment." twice before every command. Where libwayland cannot connect
/// anyway (no WAYLAND_SOCKET, no absolute WAYLAND_DISPLAY, no absolute XDG_RUNTIME_DIR), the
/// layer has nothing to ask: switch it off with its own variable, unless the user set one of
/// its variables (NODEVICE_SELECT, MESA_VK_DEVICE_SELECT, DRI_PRIME). vlf chooses its adapter
/// itself (WGPU_ADAPTER_NAME); this runs first, before any thread exists.
fn quiet_vulkan_device_select() {
    let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
    let absolute =
        |k: &str| std::env::var_os(k).is_some_and(|v| v.to_string_lossy().starts_with('/'));
    let wayland_possible =
        set("WAYLAND_SOCKET") || absolute("WAYLAND_DISPLAY") || absolute("XDG_RUNTIME_DIR");
    let user_chose = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|k| std::env::var_os(k).is_some());
    if !wayland_possible && !user_chose {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

/// The error and its causes on one line, each cause once: a library error that already
/// names its cause (`{path}: cannot read: {source}`) is not followed by that cause again.
fn error_text(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}

fn run(cli: Cli) -> Result<()> {
    let demo_default = || {
        Command::Demo(DemoArgs {
            out: PathBuf::from("out"),
        })
    };
    match cli.command.unwrap_or_else(demo_default) {
        Command::Propagate(a) => propagate(a),
        Command::Render(a) => render(a),
        Command::Reference(a) => reference(a),
        Command::Cave(a) => cave(a),
        Command::Track(a) => track(a),
        Command::Xr(a) => xr(a),
        Command::Compare(a) => compare(a),
        Command::Export(a) => export(a),
        Command::Demo(a) => demo(&a.out),
        Command::Verify(a) => verify(a),
        #[cfg(feature = "lab")]
        Command::Sweep(a) => cli::lab::sweep(a),
        #[cfg(feature = "lab")]
        Command::Generate(a) => cli::lab::generate(a),
        #[cfg(feature = "lab")]
        Command::Stress(a) => cli::lab::stress(a),
        #[cfg(feature = "lab")]
        Command::Bench(a) => cli::lab::bench(a),
    }
}

/// `vlf propagate`: a scene into a .vlf file, with checkpoints and a JSON report.
fn propagate(args: PropagateArgs) -> Result<()> {
    let scene = Scene::load(&args.scene)?;
    print_warnings(&scene.warnings);
    let ctx = GpuContext::new()?;
    let params = args.params.for_adapter(&ctx)?;
    estimate_time(&ctx, &scene, &params)?;
    let output = args.output;
    let plan = vlf::propagate::checkpoint::CheckpointPlan {
        path: PathBuf::from(format!("{}.checkpoint", output.display())),
        every: args.checkpoint,
        resume: args.resume,
    };
    let (lf, _resident, rep) =
        vlf::propagate::propagate_with(ctx, &scene, &params, &Bars::default(), Some(&plan))?;
    print_warnings(&rep.warnings[scene.warnings.len()..]);
    file::save(&lf, &output)?;
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

/// `vlf render`: one view from a scene (propagated first) or a .vlf file.
fn render(args: RenderArgs) -> Result<()> {
    let ssaa = args.ssaa;
    if !(1..=16).contains(&ssaa) {
        bail!("--ssaa {ssaa}: use 1 (off) to 16");
    }
    let ctx = GpuContext::new()?;
    let (lf, resident) =
        light_field_for(&ctx, &args.input, args.lightfield.as_deref(), &args.params)?;
    let cam = lf.camera(args.camera.as_deref())?.clone();
    let [w, h] = args.size.unwrap_or(cam.size);
    let mut renderer = Renderer::new(&resident, &lf, &resident.ledger)?;
    renderer.set_samples_per_pixel(args.aa)?;
    let frame = renderer.render_antialiased(&cam, w, h, ssaa)?;
    image_io::write_image(&frame, &args.output, args.exposure)?;
    println!("{} ({w}x{h}, camera {:?})", args.output.display(), cam.name);
    Ok(())
}

/// `vlf reference`: the path tracer's image (and optionally its variance).
fn reference(args: ReferenceArgs) -> Result<()> {
    let scene = Scene::load(&args.scene)?;
    print_warnings(&scene.warnings);
    let cam = scene.camera(args.camera.as_deref())?.clone();
    let size = args.size.unwrap_or(cam.size);
    let (spp, seed) = (args.spp, args.seed);
    let ctx = GpuContext::new()?;
    let r = vlf::reference::render(ctx, &scene, &cam, size, spp, seed, &Bars::default())?;
    image_io::write_image(&r.mean, &args.output, 1.0)?;
    println!(
        "{} ({}x{}, {} spp, seed {seed}, {:.2} s tracing after {:.2} s of setup)",
        args.output.display(),
        size[0],
        size[1],
        r.spp,
        r.seconds,
        r.setup_seconds
    );
    if let Some(path) = args.variance {
        image_io::write_image(&r.variance, &path, 1.0)?;
        println!("variance: {}", path.display());
    }
    Ok(())
}

/// `vlf verify`: the light field against the path tracer on every camera, in words.
fn verify(a: VerifyArgs) -> Result<()> {
    let ctx = GpuContext::new()?;
    let scene = Scene::load(&a.scene)?;
    let (lf, resident) = light_field_for(&ctx, &a.scene, a.lightfield.as_deref(), &a.params)?;
    let options = vlf::verify::VerifyOptions {
        cameras: a.camera,
        size: a.size,
        spp: a.spp,
        seed: a.seed,
        out: a.out,
    };
    let report = vlf::verify::verify(&ctx, &scene, (&lf, &resident), &options, &Bars::default())?;
    print!("{}", report.table());
    if let Some(path) = a.json {
        write_json(&path, &report)?;
    }
    Ok(())
}

/// `vlf track`: a display's live tracking, printed as it arrives.
fn track(args: TrackArgs) -> Result<()> {
    let seconds = args.seconds;
    if let Some(s) = seconds.filter(|s| !(s.is_finite() && *s >= 0.0)) {
        bail!("--seconds {s}: must be a number of seconds >= 0");
    }
    let display = vlf::display::DisplayConfig::load(&args.config)?;
    vlf::display::tracking::track(
        &display,
        &args.config,
        seconds.map(std::time::Duration::from_secs_f64),
        &mut std::io::stdout(),
    )?;
    Ok(())
}

/// `vlf compare`: an image against a reference, as a table or JSON, with a difference image.
fn compare(args: CompareArgs) -> Result<()> {
    let a = image_io::read_image(&args.image)?;
    let b = image_io::read_image(&args.reference)?;
    let keep = match &args.mask {
        Some(path) => {
            let (w, h, keep) = vlf::metrics::read_mask(path)?;
            if (w, h) != (a.width, a.height) {
                bail!(
                    "{}: the mask is {w}x{h}, the images {}x{}",
                    path.display(),
                    a.width,
                    a.height
                );
            }
            Some(keep)
        }
        None => None,
    };
    let c = vlf::metrics::compare_where(&a, &b, keep.as_deref())?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&c)?);
    } else {
        print!("{}", c.table());
    }
    if let Some(path) = args.diff {
        vlf::metrics::write_difference_png(&a, &b, &path)?;
        if !args.json {
            println!("difference: {}", path.display());
        }
    }
    Ok(())
}

/// `vlf export mitsuba`: the scene as a standalone Mitsuba 3 scene.
fn export(args: ExportArgs) -> Result<()> {
    let ExportFormat::Mitsuba = args.format;
    let export = vlf::export::mitsuba(&args.scene, &args.output, &args.python)?;
    for note in &export.notes {
        eprintln!("{note}");
    }
    for xml in &export.cameras {
        println!(
            "{}   (render: mitsuba {} -D spp=1024 -o out.exr)",
            xml.display(),
            xml.display()
        );
    }
    Ok(())
}

/// `vlf cave`: every wall and eye of a display, in windows or offscreen (`headless`).
fn cave(a: CaveArgs) -> Result<()> {
    let CaveArgs {
        config,
        scene,
        headless,
        frames,
        hold_seconds,
        exposure,
        out,
        exr,
        json,
        params,
    } = a;
    let (config, scene, out, params) = (config.as_path(), scene.as_path(), out.as_path(), &params);
    // under mpirun: one rank of a CAVE cluster (`display/cluster.rs`)
    if let Some(ranks) = vlf::display::cluster::launched_size() {
        if ranks > 1 || cfg!(feature = "mpi") {
            let run = vlf::display::cluster::CaveRun {
                config: config.to_path_buf(),
                scene: scene.to_path_buf(),
                headless,
                frames,
                hold: std::time::Duration::from_secs_f64(hold_seconds.max(0.0)),
                exposure,
                out: out.to_path_buf(),
                exr,
                json,
            };
            let mut make = |ctx: &std::sync::Arc<GpuContext>| {
                light_field_for(ctx, scene, None, params)
                    .map_err(|e| vlf::VlfError::Display(format!("{e:#}")))
            };
            return Ok(vlf::display::run_cluster(&run, &mut make)?);
        }
    }
    let display = vlf::display::DisplayConfig::load(config)?;
    let ctx = GpuContext::new()?;
    let (lf, resident) = light_field_for(&ctx, scene, None, params)?;
    estimate_cave_time(&ctx, &display, frames.or((headless).then_some(60)));
    if !headless {
        if !(hold_seconds.is_finite() && hold_seconds >= 0.0) {
            bail!("--hold-seconds {hold_seconds}: must be a number of seconds >= 0");
        }
        let options = vlf::display::window::WindowOptions {
            frames,
            hold: std::time::Duration::from_secs_f64(hold_seconds),
            exposure,
        };
        let report = vlf::display::window::run(&lf, &resident, &display, config, options)?;
        print!("{}", report.table());
        if let Some(path) = json {
            write_json(&path, &report)?;
        }
        return Ok(());
    }
    let run = (frames.unwrap_or(60), out, exr);
    let report = vlf::display::headless::run_reporting(
        &lf,
        &resident,
        &display,
        config,
        run,
        &Bars::default(),
    )?;
    print!("{}", report.table());
    if let Some(path) = json {
        write_json(&path, &report)?;
    }
    println!(
        "images in {} (overview: {})",
        out.display(),
        out.join("overview.png").display()
    );
    Ok(())
}

/// `vlf xr`: an OpenXR headset session.
fn xr(a: XrArgs) -> Result<()> {
    let XrArgs {
        scene,
        frames,
        screenshot,
        screenshot_frame,
        camera,
        exposure,
        resolution_scale,
        aa,
        fit_frame_time,
        swapchains,
        json,
        params,
    } = a;
    let options = vlf::display::xr::XrOptions {
        frames,
        screenshot,
        screenshot_frame,
        exposure,
        camera,
        resolution_scale,
        antialiasing: aa,
        fit_frame_time,
        swapchains,
    };
    let scale = options.resolution_scale;
    if !(scale.is_finite() && scale > 0.0 && scale <= 4.0) {
        bail!("--resolution-scale {scale}: must be above 0 and at most 4 (1 renders at the runtime's recommended size)");
    }
    let shot = options.screenshot_frame;
    if shot == 0 {
        bail!("--screenshot-frame 0: frames count from 1");
    }
    if let (Some(n), Some(_)) = (options.frames, &options.screenshot) {
        if shot > n {
            bail!("--screenshot-frame {shot} is after the last of --frames {n}");
        }
    }
    let mut make = |ctx: &std::sync::Arc<GpuContext>| {
        light_field_for(ctx, &scene, None, &params)
            .map_err(|e| vlf::VlfError::Display(format!("{e:#}")))
    };
    let report = vlf::display::xr::run_headset(&mut make, &options)?;
    print!("{}", report.table());
    if let Some(path) = json {
        write_json(&path, &report)?;
    }
    if report.lost {
        bail!("{}", report.ended);
    }
    Ok(())
}

/// A light field from a .vlf file, or propagated from a scene (optionally loaded from a .vlf
/// made for that scene).
fn light_field_for(
    ctx: &std::sync::Arc<GpuContext>,
    input: &Path,
    lightfield: Option<&Path>,
    params: &ParamArgs,
) -> Result<(LightField, ResidentLightField)> {
    let is_vlf = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vlf"));
    if is_vlf {
        let lf = file::load(input)?;
        let resident = lf.upload(ctx.clone())?;
        return Ok((lf, resident));
    }
    let scene = Scene::load(input)?;
    print_warnings(&scene.warnings);
    if let Some(path) = lightfield {
        let lf = file::load(path)?;
        lf.check_scene(&scene, path)?;
        let resident = lf.upload(ctx.clone())?;
        return Ok((lf, resident));
    }
    let params = params.for_adapter(ctx)?;
    estimate_time(ctx, &scene, &params)?;
    let (lf, resident, report) =
        vlf::propagate::propagate(ctx.clone(), &scene, &params, &Bars::default())?;
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

/// Seconds per eye ray on lavapipe with 2 CPU cores (a view's ray cast and resolve against the
/// light field): `cave-4wall.toml` at 480x300 per eye (8 views, 1.2 Mpixels, 4 eye rays per
/// pixel) on the Cornell box drew a frame in 16 s, with another process on the second core.
const SOFTWARE_SECONDS_PER_EYE_RAY: f64 = 4.0e-6;

/// On a software adapter, before a CAVE's first frame: how long its frames will take, by a
/// rough model, and what shortens them (a full-size CAVE takes minutes a frame there).
fn estimate_cave_time(
    ctx: &GpuContext,
    display: &vlf::display::DisplayConfig,
    frames: Option<u32>,
) {
    if !ctx.summary.software {
        return;
    }
    let views = vlf::display::frame::wall_views(display);
    let pixels: f64 = (views.iter())
        .map(|v| {
            let [w, h] = display.walls[v.wall].eye_pixels();
            w as f64 * h as f64
        })
        .sum();
    let cores = std::thread::available_parallelism().map_or(2, |n| n.get()) as f64;
    let ray_seconds = SOFTWARE_SECONDS_PER_EYE_RAY * 2.0 / cores;
    let frame_seconds = pixels * display.antialiasing as f64 * ray_seconds;
    // the fit draws every view 3 times at 1 eye ray per rung of its ladder (up to 4 rungs)
    let fit_seconds = match display.fit_frame_time {
        true => 4.0 * 3.0 * pixels * ray_seconds,
        false => 0.0,
    };
    let length = match frames {
        Some(n) => format!(
            "{n} frames take {}",
            human_seconds(frame_seconds * n as f64 + fit_seconds)
        ),
        None => format!("each frame takes {}", human_seconds(frame_seconds)),
    };
    eprintln!(
        "estimate: {} is a software adapter: {} views, {:.1} Mpixels at {} eye rays per pixel; {length}{} ({cores} CPU cores; a rough model). Fewer --frames, smaller wall `pixels` or `antialiasing = 1` in the display TOML shorten it",
        ctx.summary.name,
        views.len(),
        pixels / 1e6,
        display.antialiasing,
        if display.fit_frame_time { ", the frame-time fit's probes included" } else { "" },
    );
}

/// On a software adapter, a rough estimate of the propagation time before starting it.
fn estimate_time(ctx: &GpuContext, scene: &Scene, params: &PropagationParams) -> Result<()> {
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
fn human_seconds(s: f64) -> String {
    match s {
        s if s < 1.0 => "under a second".into(),
        s if s < 120.0 => format!("about {s:.0} s"),
        s if s < 7200.0 => format!("about {:.0} min", s / 60.0),
        s => format!("about {:.1} h", s / 3600.0),
    }
}

fn demo(out: &Path) -> Result<()> {
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

fn print_warnings(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    let tmp = path.with_extension("json.tmp");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_command_line_definition_is_consistent() {
        use clap::CommandFactory;
        super::Cli::command().debug_assert();
    }

    #[test]
    fn the_lab_commands_are_there_exactly_when_the_lab_is() {
        use clap::CommandFactory;
        let cli = super::Cli::command();
        for name in super::LAB_COMMANDS {
            let present = cli.find_subcommand(name).is_some();
            assert_eq!(present, cfg!(feature = "lab"), "vlf {name}");
        }
    }
}
