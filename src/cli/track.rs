//! `vlf track`.

use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;

/// `vlf track`'s arguments.
#[derive(Args)]
pub struct TrackArgs {
    config: PathBuf,
    /// Stop after this many seconds (default: until Ctrl-C)
    #[arg(long)]
    seconds: Option<f64>,
}

/// `vlf track`: a display's live tracking, printed as it arrives.
pub fn run(args: TrackArgs) -> Result<()> {
    let seconds = args.seconds;
    if let Some(s) = seconds.filter(|s| !(s.is_finite() && *s >= 0.0)) {
        bail!("--seconds {s}: must be a number of seconds >= 0");
    }
    let display = vlf::display::DisplayConfig::load(&args.config)?;
    vlf::tracking::source::track(
        &display.name,
        &display.tracking,
        &display.start_pose,
        &args.config,
        seconds.map(std::time::Duration::from_secs_f64),
        &mut std::io::stdout(),
    )?;
    Ok(())
}
