//! `vlf verify`.

use super::light_field::light_field_of_scene;
use super::params::ParamArgs;
use super::progress::Bars;
use super::{parse_size, write_json};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use vlf::gpu::GpuContext;
use vlf::scene::Scene;

/// `vlf verify`'s arguments.
#[derive(Args)]
pub struct VerifyArgs {
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

/// `vlf verify`: the light field against the path tracer on every camera, in words.
pub fn run(a: VerifyArgs) -> Result<()> {
    let ctx = GpuContext::new()?;
    let scene = Scene::load(&a.scene)?;
    // the scene read once: the light field's and the path tracer's (seconds at millions of
    // triangles)
    let (lf, resident) = light_field_of_scene(&ctx, &scene, a.lightfield.as_deref(), &a.params)?;
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
