//! `vlf compare`.

use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use vlf::render::image_io;

/// `vlf compare`'s arguments.
#[derive(Args)]
pub struct CompareArgs {
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

/// `vlf compare`: an image against a reference, as a table or JSON, with a difference image.
pub fn run(args: CompareArgs) -> Result<()> {
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
