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
}

/// `vlf export mitsuba`: the scene as a standalone Mitsuba 3 scene.
pub fn run(args: ExportArgs) -> Result<()> {
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
