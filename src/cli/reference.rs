//! `vlf reference`.

use super::progress::Bars;
use super::{parse_size, print_warnings};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use vlf::gpu::GpuContext;
use vlf::render::image_io;
use vlf::scene::Scene;

/// `vlf reference`'s arguments.
#[derive(Args)]
pub struct ReferenceArgs {
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

/// `vlf reference`: the path tracer's image (and optionally its variance).
pub fn run(args: ReferenceArgs) -> Result<()> {
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
