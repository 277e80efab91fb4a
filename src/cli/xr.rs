//! `vlf xr`.

use super::light_field::light_field_for;
use super::params::ParamArgs;
use super::write_json;
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use vlf::gpu::GpuContext;

/// `vlf xr`'s arguments.
#[derive(Args)]
pub struct XrArgs {
    /// scene.toml (propagated first) or file.vlf
    #[arg(long)]
    scene: PathBuf,
    /// End the session after this many frames (default: when the runtime or the user ends it)
    #[arg(long)]
    frames: Option<u32>,
    /// Write the left eye's image of frame --screenshot-frame: PNG, as it went onto the
    /// swapchain, or EXR, the linear radiance drawn (what `vlf replay --exr` draws again)
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
    /// First hits of the eye rays: rays (cast through the BVH) or raster (a visibility buffer
    /// drawn by the rasteriser, one MSAA sample per eye ray: --aa must be an MSAA count the
    /// adapter takes, 4 on every one)
    #[arg(long, default_value = "rays")]
    first_hits: vlf::render::raster::FirstHits,
    #[command(flatten)]
    edges: super::edge_args::EdgeArgs,
    /// The eyes' swapchains: one array swapchain with a layer per eye where the runtime takes it
    /// (auto, else one per eye), insist on the array (array), or one per eye (per-eye)
    #[arg(long, value_enum, default_value = "auto")]
    swapchains: vlf::xr::Swapchains,
    /// How the eyes' colour goes onto the swapchains: fragment (one full-screen fragment pass with
    /// the depth; 1.30 ms for both 2064x2208 eyes on an H200) or compute (a compute pass and a
    /// copy where the swapchain is 8-bit RGBA, the depth by a fragment pass; 1.42 ms there)
    #[arg(long, value_enum, default_value = "fragment")]
    layer_colour: vlf::xr::LayerColour,
    /// Moving objects that follow the headset and controllers: a TOML with a display config's
    /// [[object]] and [object_lighting] tables (e.g. config/headset/body.toml: the participant's
    /// body, its hands on the controllers' grips)
    #[arg(long)]
    objects: Option<PathBuf>,
    /// Listen for an experiment script's commands (JSON lines over TCP) on host:port, e.g.
    /// 127.0.0.1:7400 (port 0: any free one, said on stderr); as `vlf cave --control`, less the
    /// latency test's flash (docs/guide/studies.md)
    #[arg(long)]
    control: Option<String>,
    /// A study's named conditions, switched by the script's `condition` command: a TOML with
    /// `default_condition` and [[condition]] tables as a display config has them (e.g.
    /// config/headset/conditions.toml); every light field they name is made before the first frame
    #[arg(long)]
    conditions: Option<PathBuf>,
    /// Log every frame into this new folder (session.json, frames.csv and frames.parquet/: the
    /// head between the eyes, the controllers' grips, the predicted display time)
    #[arg(long)]
    log: Option<PathBuf>,
    /// Send every frame's pose, the frames and the events on Lab Streaming Layer outlets
    /// (vlf.pose, vlf.frames, vlf.events) for LabRecorder
    #[arg(long)]
    lsl: bool,
    /// Write the frame-time report as JSON
    #[arg(long)]
    json: Option<PathBuf>,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf xr`: an OpenXR headset session.
pub fn run(a: XrArgs) -> Result<()> {
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
        first_hits,
        edges,
        swapchains,
        layer_colour,
        objects,
        control,
        conditions,
        log,
        lsl,
        json,
        params,
    } = a;
    let options = vlf::xr::XrOptions {
        frames,
        screenshot,
        screenshot_frame,
        exposure,
        camera,
        resolution_scale,
        antialiasing: aa,
        fit_frame_time,
        first_hits,
        edge_antialiasing: edges.edge_antialiasing()?,
        swapchains,
        layer_colour,
        objects,
        study: vlf::xr::XrStudy {
            control,
            log: log.map(|dir| (dir, scene.clone())),
            lsl,
            conditions: conditions.map(|file| (file, scene.clone())),
        },
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
    let report = vlf::xr::run_headset(&mut make, &options)?;
    print!("{}", report.table());
    if let Some(path) = json {
        write_json(&path, &report)?;
    }
    if report.lost {
        bail!("{}", report.ended);
    }
    Ok(())
}
