//! `vlf render`.

use super::light_field::light_field_for;
use super::params::ParamArgs;
use super::parse_size;
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use vlf::gpu::GpuContext;
use vlf::render::{image_io, ObjectsToDraw, Renderer};

/// `vlf render`'s arguments.
#[derive(Args)]
pub struct RenderArgs {
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
    /// Glossy surfaces: reflections sampled from the lobe per pair of eye rays that meets one
    /// (a still's default; real-time views take 1)
    #[arg(long, default_value_t = vlf::render::STILL_LOBE_SAMPLES)]
    lobe_samples: u32,
    /// Glossy surfaces: shadow rays to the emitters per sampled reflection, which take the
    /// emitters' light off the lobe by light sampling (0: the sampled reflections alone, which
    /// meet a small emitter rarely and show it as sparkles)
    #[arg(long, default_value_t = vlf::render::GLOSSY_LIGHT_SAMPLES)]
    glossy_light_samples: u32,
    /// First hits of the eye rays: rays (cast through the BVH) or raster (a visibility buffer
    /// drawn by the rasteriser, one MSAA sample per eye ray: --aa must be an MSAA count the
    /// adapter takes, 4 on every one)
    #[arg(long, default_value = "rays")]
    first_hits: vlf::render::raster::FirstHits,
    #[command(flatten)]
    edges: super::edge_args::EdgeArgs,
    /// out.exr (linear radiance) or out.png (tonemapped)
    #[arg(short, long)]
    output: PathBuf,
    /// Also draw these moving objects (a TOML of `[[object]]` and `[object_lighting]` tables, as
    /// `vlf xr --objects` takes), posed with the camera as the tracked head and no hand tracked
    #[arg(long)]
    objects: Option<PathBuf>,
    #[command(flatten)]
    params: ParamArgs,
}

/// `vlf render`: one view from a scene (propagated first) or a .vlf file.
pub fn run(args: RenderArgs) -> Result<()> {
    let ssaa = args.ssaa;
    if !(1..=16).contains(&ssaa) {
        bail!("--ssaa {ssaa}: use 1 (off) to 16");
    }
    let ctx = GpuContext::new()?;
    let (lf, resident) =
        light_field_for(&ctx, &args.input, args.lightfield.as_deref(), &args.params)?;
    let cam = lf.camera(args.camera.as_deref())?.clone();
    let [w, h] = args.size.unwrap_or(cam.size);
    let still = match &args.objects {
        Some(path) => Some(super::still_objects::still_objects(path, &cam)?),
        None => None,
    };
    let draw = still.as_ref().map(|s| ObjectsToDraw {
        mesh: s.objects.mesh(),
        lighting: s.file.object_lighting.unwrap_or_default(),
    });
    let mut renderer = Renderer::with_objects(&resident, &lf, &resident.ledger, draw)?;
    if let Some(s) = &still {
        // twice, as a display's frames follow each other: the shadow atlas's objects send back
        // what the vertices' correction of the pose before says they show
        renderer.pose_objects(&s.joints, None);
        renderer.pose_objects(&s.joints, None);
    }
    renderer.set_samples_per_pixel(args.aa)?;
    renderer.set_lobe_samples(args.lobe_samples);
    renderer.set_glossy_light_samples(args.glossy_light_samples);
    renderer.set_first_hits(args.first_hits)?;
    renderer.set_edge_antialiasing(args.edges.edge_antialiasing()?)?;
    let frame = renderer.render_antialiased(&cam, w, h, ssaa)?;
    image_io::write_image(&frame, &args.output, args.exposure)?;
    println!("{} ({w}x{h}, camera {:?})", args.output.display(), cam.name);
    if let Some(refined) = renderer.refined_pixels()? {
        println!(
            "edge antialiasing: {} of {} pixels ({:.1}%) took {} eye rays, the others {}",
            refined.pixels,
            refined.of,
            100.0 * refined.share(),
            args.edges.edge_samples.unwrap_or(0),
            args.aa
        );
    }
    Ok(())
}
