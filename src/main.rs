//! The `vlf` command line. Library errors are reported through anyhow here, and only here.

mod cli {
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
    Propagate {
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
    },
    /// Render a view from a scene (propagating first) or from a .vlf file
    Render {
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
    },
    /// Path-trace a reference image with the same scene semantics (GPU, BVH, NEE + MIS)
    Reference {
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
    },
    /// Error against run time: the light field over a grid of settings and the path tracer over
    /// samples per pixel -> CSV + log-log chart with the Pareto front
    Sweep {
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
    },
    /// Draw every wall and eye of a display configuration (CAVE, power wall, window): one window
    /// per wall (W/A/S/D or arrows walk, Q/E turn, R/F rise/sink in fly mode, G toggles fly,
    /// left-drag turns, Home resets, gamepad sticks; Esc quits), or offscreen with --headless
    Cave {
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
    },
    /// Print a display configuration's live tracking as it arrives: head and wand poses in the
    /// room (after [tracking.calibration]), buttons and joystick
    Track {
        config: PathBuf,
        /// Stop after this many seconds (default: until Ctrl-C)
        #[arg(long)]
        seconds: Option<f64>,
    },
    /// An OpenXR headset: the runtime's Vulkan device, a swapchain per eye, thumbstick navigation
    Xr {
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
        /// Write the frame-time report as JSON
        #[arg(long)]
        json: Option<PathBuf>,
        #[command(flatten)]
        params: ParamArgs,
    },
    /// Write a procedural scene (scene.toml + OBJ + MTL, or glTF) that scales to a million triangles
    Generate {
        kind: vlf::lab::generate::SceneKind,
        /// About this many triangles (classroom) or faces (gallery)
        #[arg(long, default_value_t = 10_000)]
        size: u64,
        /// The mirror variant (a mirror wall in the classroom, mirrors along the gallery)
        #[arg(long)]
        mirrors: bool,
        /// The mesh as OBJ + MTL or as glTF 2.0 (.gltf + .bin)
        #[arg(long, value_enum, default_value = "obj")]
        format: vlf::lab::generate::MeshFormat,
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Run the stability cases and write their table (STABILITY.md)
    Stress {
        /// Where the table goes (default: STABILITY.md; with --quick, none unless given)
        #[arg(long)]
        out: Option<PathBuf>,
        /// Only the quick cases (about a minute on lavapipe); the table marks the others "not run"
        #[arg(long)]
        quick: bool,
    },
    /// Compare a linear image with a reference: MSE, RMSE, relMSE, max error, display MSE, FLIP
    Compare {
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
    },
    /// Write the scene for another renderer, e.g. `vlf export mitsuba scene.toml -o DIR`: a
    /// standalone Mitsuba 3 scene (DIR/<camera>.xml per camera), for an independent ground truth
    Export {
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
    },
    /// Propagate the built-in Cornell box and write PNG + EXR into out/
    Demo {
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Measure setup, visibility, propagation and rendering
    Bench {
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
        #[command(flatten)]
        params: ParamArgs,
    },
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
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {}", error_text(&e));
        std::process::exit(1);
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
    match cli.command.unwrap_or(Command::Demo {
        out: PathBuf::from("out"),
    }) {
        Command::Propagate {
            scene,
            output,
            report,
            checkpoint,
            resume,
            params,
        } => {
            let scene = Scene::load(&scene)?;
            print_warnings(&scene.warnings);
            let ctx = GpuContext::new()?;
            let params = params.for_adapter(&ctx)?;
            estimate_time(&ctx, &scene, &params)?;
            let plan = vlf::propagate::checkpoint::CheckpointPlan {
                path: PathBuf::from(format!("{}.checkpoint", output.display())),
                every: checkpoint,
                resume,
            };
            let (lf, _resident, rep) = vlf::propagate::propagate_with(
                ctx,
                &scene,
                &params,
                &Bars::default(),
                Some(&plan),
            )?;
            print_warnings(&rep.warnings[scene.warnings.len()..]);
            file::save(&lf, &output)?;
            if plan.path.exists() {
                std::fs::remove_file(&plan.path)
                    .with_context(|| format!("removing {}", plan.path.display()))?;
            }
            println!("{}", rep.table());
            if let Some(path) = report {
                write_json(&path, &rep)?;
                println!("report: {}", path.display());
            }
            println!("light field: {}", output.display());
        }
        Command::Render {
            input,
            camera,
            size,
            lightfield,
            exposure,
            ssaa,
            aa,
            output,
            params,
        } => {
            if !(1..=16).contains(&ssaa) {
                bail!("--ssaa {ssaa}: use 1 (off) to 16");
            }
            let ctx = GpuContext::new()?;
            let (lf, resident) = light_field_for(&ctx, &input, lightfield.as_deref(), &params)?;
            let cam = lf.camera(camera.as_deref())?.clone();
            let [w, h] = size.unwrap_or(cam.size);
            let mut renderer = Renderer::new(&resident, &lf, &resident.ledger)?;
            renderer.set_samples_per_pixel(aa)?;
            let frame = renderer.render_antialiased(&cam, w, h, ssaa)?;
            image_io::write_image(&frame, &output, exposure)?;
            println!("{} ({w}x{h}, camera {:?})", output.display(), cam.name);
        }
        Command::Demo { out } => demo(&out)?,
        Command::Reference {
            scene,
            camera,
            size,
            spp,
            seed,
            variance,
            output,
        } => {
            let scene = Scene::load(&scene)?;
            print_warnings(&scene.warnings);
            let cam = scene.camera(camera.as_deref())?.clone();
            let size = size.unwrap_or(cam.size);
            let ctx = GpuContext::new()?;
            let r = vlf::reference::render(ctx, &scene, &cam, size, spp, seed, &Bars::default())?;
            image_io::write_image(&r.mean, &output, 1.0)?;
            println!(
                "{} ({}x{}, {} spp, seed {seed}, {:.2} s tracing after {:.2} s of setup)",
                output.display(),
                size[0],
                size[1],
                r.spp,
                r.seconds,
                r.setup_seconds
            );
            if let Some(path) = variance {
                image_io::write_image(&r.variance, &path, 1.0)?;
                println!("variance: {}", path.display());
            }
        }
        Command::Sweep {
            scene,
            reference,
            camera,
            directions,
            grid,
            texel_density,
            tolerance,
            perturb,
            spp,
            ssaa,
            walkthrough,
            budget_ms,
            frames,
            reference_spp,
            size,
            out,
            config,
        } => {
            let grid = vlf::lab::sweep::SweepGrid {
                directions,
                grid,
                texel_density,
                tolerance,
                perturb,
                spp,
                ssaa: ssaa.max(1),
            };
            let walk = walkthrough.then_some(Walkthrough {
                budget_ms,
                frames,
                reference_spp,
                config,
            });
            sweep(
                &scene,
                reference.as_deref(),
                camera.as_deref(),
                grid,
                walk,
                size,
                &out,
            )?;
        }
        Command::Cave {
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
        } => {
            cave(
                &config,
                &scene,
                headless,
                frames,
                hold_seconds,
                exposure,
                &out,
                exr,
                json,
                &params,
            )?;
        }
        Command::Track { config, seconds } => {
            if let Some(s) = seconds.filter(|s| !(s.is_finite() && *s >= 0.0)) {
                bail!("--seconds {s}: must be a number of seconds >= 0");
            }
            let display = vlf::display::DisplayConfig::load(&config)?;
            vlf::display::tracking::track(
                &display,
                &config,
                seconds.map(std::time::Duration::from_secs_f64),
                &mut std::io::stdout(),
            )?;
        }
        Command::Xr {
            scene,
            frames,
            screenshot,
            screenshot_frame,
            camera,
            exposure,
            resolution_scale,
            aa,
            json,
            params,
        } => {
            let options = vlf::display::xr::XrOptions {
                frames,
                screenshot,
                screenshot_frame,
                exposure,
                camera,
                resolution_scale,
                antialiasing: aa,
            };
            xr(&scene, options, json, &params)?;
        }
        Command::Generate {
            kind,
            size,
            mirrors,
            format,
            out,
        } => {
            let g = vlf::lab::generate::generate_as(
                &vlf::lab::generate::GenerateOptions {
                    kind,
                    size,
                    mirrors,
                },
                &out,
                format,
            )?;
            println!(
                "{}: {} triangles, {} faces ({})",
                g.scene.display(),
                g.triangles,
                g.faces,
                g.description
            );
        }
        Command::Stress { out, quick } => {
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
        }
        Command::Compare {
            image,
            reference,
            json,
            diff,
            mask,
        } => {
            let a = image_io::read_image(&image)?;
            let b = image_io::read_image(&reference)?;
            let keep = match &mask {
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
            if json {
                println!("{}", serde_json::to_string_pretty(&c)?);
            } else {
                print!("{}", c.table());
            }
            if let Some(path) = diff {
                vlf::metrics::write_difference_png(&a, &b, &path)?;
                if !json {
                    println!("difference: {}", path.display());
                }
            }
        }
        Command::Export {
            format: ExportFormat::Mitsuba,
            scene,
            output,
            python,
        } => {
            let export = vlf::export::mitsuba(&scene, &output, &python)?;
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
        }
        Command::Bench {
            scene,
            suite,
            quick,
            work,
            plot,
            from_json,
            json,
            markdown,
            frames,
            size,
            aa,
            params,
        } => {
            let outputs = BenchOutputs {
                json,
                markdown,
                plot,
            };
            bench(
                &scene,
                suite.then_some((quick, work)),
                from_json.as_deref(),
                outputs,
                frames,
                size,
                aa,
                &params,
            )?;
        }
    }
    Ok(())
}

/// `vlf cave`: every wall and eye of a display, in windows or offscreen (`headless`).
#[allow(clippy::too_many_arguments)]
fn cave(
    config: &Path,
    scene: &Path,
    headless: bool,
    frames: Option<u32>,
    hold_seconds: f64,
    exposure: f32,
    out: &Path,
    exr: bool,
    json: Option<PathBuf>,
    params: &ParamArgs,
) -> Result<()> {
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
    let report = vlf::display::headless::run(
        &lf,
        &resident,
        &display,
        config,
        frames.unwrap_or(60),
        out,
        exr,
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
fn xr(
    scene: &Path,
    options: vlf::display::xr::XrOptions,
    json: Option<PathBuf>,
    params: &ParamArgs,
) -> Result<()> {
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
        light_field_for(ctx, scene, None, params)
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

/// Where `vlf bench` writes.
struct BenchOutputs {
    json: Option<PathBuf>,
    markdown: Option<PathBuf>,
    plot: Option<PathBuf>,
}

/// `vlf bench`: one scene, the suite (`suite`: quick, work folder), or the tables of an earlier report.
#[allow(clippy::too_many_arguments)]
fn bench(
    scene: &Path,
    suite: Option<(bool, PathBuf)>,
    from_json: Option<&Path>,
    outputs: BenchOutputs,
    frames: u32,
    size: [u32; 2],
    aa: u32,
    params: &ParamArgs,
) -> Result<()> {
    let BenchOutputs {
        json,
        markdown,
        plot,
    } = outputs;
    if let Some(input) = from_json {
        let report = vlf::lab::suite::SuiteReport::load(input)?;
        let md = report.markdown();
        match markdown {
            Some(path) => {
                std::fs::write(&path, &md).with_context(|| format!("writing {}", path.display()))?
            }
            None => print!("{md}"),
        }
        if let Some(path) = plot {
            report.plot(&path)?;
        }
        return Ok(());
    }
    let ctx = GpuContext::new()?;
    if ctx.summary.software {
        eprintln!(
            "note: {} is a software adapter: these timings say nothing about GPU speed",
            ctx.summary.name
        );
    }
    if let Some((quick, work)) = suite {
        let root = std::env::current_dir().context("the current folder")?;
        let report =
            vlf::lab::suite::run(ctx, &root, &work, quick, frames.min(100), &Bars::default())?;
        let md = report.markdown();
        print!("{md}");
        if let Some(path) = json {
            write_json(&path, &report)?;
            println!("json: {}", path.display());
        }
        if let Some(path) = markdown {
            std::fs::write(&path, &md).with_context(|| format!("writing {}", path.display()))?;
            println!("markdown: {}", path.display());
        }
        if let Some(path) = plot {
            report.plot(&path)?;
            println!("chart: {}", path.display());
        }
        return Ok(());
    }
    let scene = Scene::load(scene)?;
    let params = params.for_adapter(&ctx)?;
    let report = vlf::lab::bench::run(ctx, &scene, &params, size, frames, aa)?;
    print!("{}", report.table());
    if let Some(path) = json {
        write_json(&path, &report)?;
        println!("json: {}", path.display());
    }
    if let Some(path) = markdown {
        std::fs::write(&path, report.markdown())
            .with_context(|| format!("writing {}", path.display()))?;
        println!("markdown: {}", path.display());
    }
    Ok(())
}

/// `vlf sweep --walkthrough`'s settings.
struct Walkthrough {
    budget_ms: f64,
    frames: u32,
    reference_spp: u32,
    config: Option<PathBuf>,
}

/// `vlf sweep`: the grid of settings against a reference, or the walkthrough at a frame budget.
fn sweep(
    scene: &Path,
    reference: Option<&Path>,
    camera: Option<&str>,
    grid: vlf::lab::sweep::SweepGrid,
    walk: Option<Walkthrough>,
    size: [u32; 2],
    out: &Path,
) -> Result<()> {
    let scene = Scene::load(scene)?;
    print_warnings(&scene.warnings);
    let cam = scene.camera(camera)?.clone();
    let ctx = GpuContext::new()?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    if let Some(Walkthrough {
        budget_ms,
        frames,
        reference_spp,
        config,
    }) = walk
    {
        let params = match &config {
            Some(path) => PropagationParams::from_toml_file(path)?,
            None => PropagationParams::default(),
        };
        let path = vlf::lab::sweep::walkthrough_path(&cam, frames.max(2), 30.0);
        let (rows, propagation_s, pt_spp) = vlf::lab::sweep::walkthrough(
            ctx,
            &scene,
            &params,
            &path,
            size,
            budget_ms,
            reference_spp,
            &Bars::default(),
        )?;
        let csv = out.join("walkthrough.csv");
        let mut text = String::from("frame,method,spp,frame_ms,rel_mse,flip\n");
        for r in &rows {
            text.push_str(&format!(
                "{},{},{},{:.4},{:.6e},{:.6}\n",
                r.frame, r.method, r.spp, r.frame_ms, r.rel_mse, r.flip
            ));
        }
        std::fs::write(&csv, text)?;
        let series = |m: &'static str, color| vlf::lab::sweep::plot::Series {
            name: m,
            color,
            points: rows
                .iter()
                .filter(|r| r.method == m)
                .map(|r| (r.frame as f64, r.rel_mse))
                .collect(),
        };
        let png = out.join("walkthrough.png");
        vlf::lab::sweep::plot::error_per_frame(
            &png,
            &format!(
                "{}: walkthrough at {budget_ms} ms per frame (path tracer {pt_spp} spp)",
                scene.name
            ),
            "relMSE against the frame's reference",
            &[
                series("light field", plotters::style::RGBColor(200, 60, 40)),
                series("path tracer", plotters::style::RGBColor(40, 90, 200)),
            ],
        )?;
        let mean = |m: &str| {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| r.method == m)
                .map(|r| r.rel_mse)
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        println!(
            "walkthrough, {} frames at {}x{}, budget {budget_ms} ms: light field (one propagation of {propagation_s:.3} s) mean relMSE {:.3e}; path tracer at {pt_spp} spp mean relMSE {:.3e}",
            path.len(), size[0], size[1], mean("light field"), mean("path tracer")
        );
        println!("{}\n{}", csv.display(), png.display());
    } else {
        let reference = image_io::read_image(reference.expect("clap requires it"))?;
        let rows = vlf::lab::sweep::run(ctx, &scene, &cam, &reference, &grid, &Bars::default())?;
        let csv = out.join("sweep.csv");
        let mut text = format!("{}\n", vlf::lab::sweep::SweepRow::CSV_HEADER);
        for r in &rows {
            text.push_str(&r.csv());
            text.push('\n');
        }
        std::fs::write(&csv, text)?;
        let png = out.join("sweep.png");
        vlf::lab::sweep::chart(&rows, &scene.name, &png)?;
        println!("{}\n{}", csv.display(), png.display());
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
        "estimate: propagating takes about {} on {} ({} directions x {} texels x ~{ESTIMATE_ITERATIONS} iterations, {cores} CPU cores; a rough model, mirrors add more)",
        human_seconds(seconds),
        ctx.summary.name,
        params.direction_count(),
        texels
    );
    Ok(())
}

fn human_seconds(s: f64) -> String {
    match s {
        s if s < 1.0 => "under a second".into(),
        s if s < 120.0 => format!("{s:.0} s"),
        s if s < 7200.0 => format!("{:.0} min", s / 60.0),
        s => format!("{:.1} h", s / 3600.0),
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
}
