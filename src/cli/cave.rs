//! `vlf cave`: a display's walls in windows or offscreen, or one rank of a cluster under
//! mpirun; on a software adapter, a rough estimate of the frames' time first.

use super::light_field::{human_seconds, light_field_for};
use super::params::ParamArgs;
use super::progress::Bars;
use super::write_json;
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use vlf::display::conditions::{Conditions, MainField};
use vlf::gpu::GpuContext;

/// `vlf cave`'s arguments.
#[derive(Args)]
pub struct CaveArgs {
    /// The display config (TOML: walls, tracking, outputs)
    #[arg(id = "display_config", value_name = "DISPLAY_TOML")]
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
    /// Log every frame into this new folder (session.json, frames.csv and frames.parquet/:
    /// poses, what each view was drawn with, times); `vlf replay DIR` draws them again
    #[arg(long)]
    log: Option<PathBuf>,
    /// Take an experiment script's commands over TCP on this address (host:port; port
    /// 0 takes a free one): one JSON command per line, each acknowledged with the frame it took
    /// effect in (docs/guide/studies.md)
    #[arg(long)]
    control: Option<String>,
    /// Send every frame's poses and times, and the events, on Lab Streaming Layer outlets
    /// (vlf.pose, vlf.frames, vlf.events) for LabRecorder (docs/guide/studies.md)
    #[arg(long)]
    lsl: bool,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf cave`: every wall and eye of a display, in windows or offscreen (`headless`).
pub fn run(a: CaveArgs) -> Result<()> {
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
        log,
        control,
        lsl,
        params,
    } = a;
    let (config, scene, out, params) = (config.as_path(), scene.as_path(), out.as_path(), &params);
    // under mpirun: one rank of a CAVE cluster (`src/cluster/`)
    if let Some(ranks) = vlf::cluster::launched_size() {
        if ranks > 1 || cfg!(feature = "mpi") {
            let run = vlf::cluster::CaveRun {
                config: config.to_path_buf(),
                scene: scene.to_path_buf(),
                headless,
                frames,
                hold: std::time::Duration::from_secs_f64(hold_seconds.max(0.0)),
                exposure,
                out: out.to_path_buf(),
                exr,
                json,
                log,
                control,
                lsl,
            };
            return run_cluster(&run, params);
        }
    }
    let display = vlf::display::DisplayConfig::load(config)?;
    let ctx = GpuContext::new()?;
    let (lf, resident) = light_field_for(&ctx, scene, None, params)?;
    // every condition's light field made now, before the first frame: a switch only rebinds
    let main = MainField {
        source: scene,
        lf: &lf,
        resident: &resident,
    };
    let conditions = Conditions::prepare(&display, config, main, &Bars::default())?;
    estimate_cave_time(&ctx, &display, frames.or((headless).then_some(60)));
    let lsl = match lsl {
        true => Some(vlf::study::LslOutlets::open(
            &display.name,
            display.refresh_hz,
            headless,
        )?),
        false => None,
    };
    let mut session = match &log {
        Some(dir) => Some(vlf::display::session_log(
            dir,
            (config, scene),
            &lf,
            &display,
            &ctx.summary.name,
        )?),
        None => None,
    };
    let control = control.as_deref().map(control_server).transpose()?;
    if !headless {
        if !(hold_seconds.is_finite() && hold_seconds >= 0.0) {
            bail!("--hold-seconds {hold_seconds}: must be a number of seconds >= 0");
        }
        let options = vlf::display::window::WindowOptions {
            frames,
            hold: std::time::Duration::from_secs_f64(hold_seconds),
            exposure,
            conditions: conditions.as_ref(),
        };
        let study = vlf::study::Session::new(session.as_mut(), control.as_ref())
            .with_display(display.refresh_hz, lsl)
            .with_objects(display.object_names());
        let report = vlf::display::window::run_locked(
            &lf, &resident, &display, config, options, None, study,
        )?;
        print!("{}", report.table());
        if let Some(path) = json {
            write_json(&path, &report)?;
        }
        return Ok(());
    }
    let run = vlf::display::headless::HeadlessRun {
        frames: frames.unwrap_or(60),
        out,
        exr,
        log: session.as_mut(),
        control: control.as_ref(),
        lsl,
        conditions: conditions.as_ref(),
        read_back_every_frame: false,
    };
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

/// This process as one rank of a CAVE cluster (`vlf::cluster`), its light field made with
/// `params` where it makes one.
fn run_cluster(run: &vlf::cluster::CaveRun, params: &ParamArgs) -> Result<()> {
    let mut make = |ctx: &std::sync::Arc<GpuContext>| {
        light_field_for(ctx, &run.scene, None, params)
            .map_err(|e| vlf::VlfError::Display(format!("{e:#}")))
    };
    Ok(vlf::cluster::run_cluster(run, &mut make)?)
}

/// The experiment script's control server on `addr`, said on stderr where it listens.
fn control_server(addr: &str) -> Result<vlf::study::ControlServer> {
    let server = vlf::study::ControlServer::bind(addr)?;
    eprintln!("control: listening on {}", server.addr);
    Ok(server)
}

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
