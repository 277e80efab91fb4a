//! `vlf export`.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum ExportFormat {
    /// Mitsuba 3 XML + PLY (tools/mitsuba/reference.py, which shares no code with vlf)
    Mitsuba,
}

/// `vlf export`'s arguments.
#[derive(Args)]
pub struct ExportArgs {
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
    /// Also export these moving objects at a frozen pose, as ordinary geometry (OUTPUT/objects.obj
    /// and .mtl): the file `vlf render --objects` draws, posed as it poses them
    #[arg(long)]
    objects: Option<PathBuf>,
    /// With --objects: the camera whose eye is the tracked head (default: the scene's first)
    #[arg(long)]
    camera: Option<String>,
}

/// Pose `objects` with the scene's camera as the head and write them as OUTPUT/objects.obj and
/// objects.mtl; returns the OBJ's path.
fn posed_objects(args: &ExportArgs, objects: &std::path::Path) -> Result<PathBuf> {
    let scene = vlf::scene::Scene::load(&args.scene)?;
    let camera = match &args.camera {
        None => scene.cameras.first(),
        Some(name) => scene.cameras.iter().find(|c| &c.name == name),
    };
    let Some(camera) = camera else {
        anyhow::bail!(
            "{}: no camera {:?} to pose the objects from",
            args.scene.display(),
            args.camera.as_deref().unwrap_or("(any)")
        );
    };
    let still = super::still_objects::still_objects(objects, camera)?;
    let (obj, mtl) =
        (still.objects.mesh()).posed_obj(&still.joints, still.objects.visible(), "objects.mtl");
    std::fs::create_dir_all(&args.output)?;
    let path = args.output.join("objects.obj");
    std::fs::write(args.output.join("objects.mtl"), mtl)?;
    std::fs::write(&path, obj)?;
    Ok(path)
}

/// `vlf export mitsuba`: the scene as a standalone Mitsuba 3 scene.
pub fn run(args: ExportArgs) -> Result<()> {
    let ExportFormat::Mitsuba = args.format;
    let extra = match &args.objects {
        Some(path) => Some(posed_objects(&args, path)?),
        None => None,
    };
    let export = vlf::export::mitsuba(&args.scene, &args.output, &args.python, extra.as_deref())?;
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
