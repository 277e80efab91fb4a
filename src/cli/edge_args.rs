//! Edge antialiasing on the command line (`EdgeArgs`, flattened into `render`, `xr` and
//! `bench`): `--edge-samples` and `--edge-contrast`, checked into the renderer's settings.

use anyhow::Result;
use clap::Args;
use vlf::render::edges::{EdgeAntialiasing, DEFAULT_EDGE_CONTRAST};

#[derive(Args, Clone, Copy)]
pub struct EdgeArgs {
    /// Edge antialiasing: pixels that differ from a neighbour (another face, or a luminance
    /// step over --edge-contrast) take N eye rays, the others --aa (1: through the pixel's
    /// centre); all on one progressive set. Left out: --aa everywhere
    #[arg(long)]
    pub edge_samples: Option<u32>,
    /// Edge antialiasing: the relative difference in luminance from a neighbour that makes a
    /// pixel an edge
    #[arg(long, default_value_t = DEFAULT_EDGE_CONTRAST)]
    pub edge_contrast: f32,
}

impl EdgeArgs {
    /// The checked settings (None without --edge-samples).
    pub fn edge_antialiasing(&self) -> Result<Option<EdgeAntialiasing>> {
        let checked = |n| EdgeAntialiasing::new(n, self.edge_contrast);
        Ok(self.edge_samples.map(checked).transpose()?)
    }
}
