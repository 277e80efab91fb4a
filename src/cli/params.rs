//! The propagation settings on the command line (`ParamArgs`, flattened into `propagate`,
//! `render`, `verify`, `cave`, `xr` and the lab's commands): `--config`, the `--quality` presets
//! shipped as config/propagation/<name>.toml, the software adapter's default, and the flags.

use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use vlf::gpu::GpuContext;
use vlf::propagate::PropagationParams;

/// `--quality`: the propagation presets, shipped as config/propagation/<name>.toml.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Quality {
    /// a quick look: coarse, seconds on a software adapter
    Draft,
    /// the default settings (what a GPU gets when no preset is given)
    Default,
    /// finer and tighter than the default: for a GPU
    High,
}

/// The shipped presets: (name, file, text). Parsed like any --config file, so an error names it.
const PRESETS: [(&str, &str, &str); 4] = [
    (
        "draft",
        "config/propagation/draft.toml",
        include_str!("../../config/propagation/draft.toml"),
    ),
    (
        "default",
        "config/propagation/default.toml",
        include_str!("../../config/propagation/default.toml"),
    ),
    (
        "high",
        "config/propagation/high.toml",
        include_str!("../../config/propagation/high.toml"),
    ),
    (
        "software",
        "config/propagation/software.toml",
        include_str!("../../config/propagation/software.toml"),
    ),
];

fn preset(name: &str) -> Result<PropagationParams> {
    let (_, file, text) = PRESETS
        .iter()
        .find(|p| p.0 == name)
        .with_context(|| format!("no preset {name:?}"))?;
    let params: PropagationParams =
        toml::from_str(text).with_context(|| format!("{file} (built in)"))?;
    params
        .validate()
        .with_context(|| format!("{file} (built in)"))?;
    Ok(params)
}

#[derive(Args, Clone, Default)]
pub struct ParamArgs {
    /// Start from the settings in this TOML file (see config/propagation/); flags override it
    #[arg(long, conflicts_with = "quality")]
    config: Option<PathBuf>,
    /// Start from a preset (config/propagation/<name>.toml); flags override it. Without it (and
    /// without --config): default on a GPU, lighter settings on a software adapter
    #[arg(long, value_enum)]
    quality: Option<Quality>,
    /// Number of directions over the hemisphere (rounded up to a geodesic set, 5n^2+1)
    #[arg(long)]
    directions: Option<u32>,
    /// Grid cells per side for each direction
    #[arg(long)]
    grid: Option<u32>,
    /// Tile size in cells (must divide the grid)
    #[arg(long)]
    tile: Option<u32>,
    /// Diffuse texels per unit length of the normalised scene
    #[arg(long)]
    texel_density: Option<f64>,
    /// Stop when unshot power / emitted power falls below this
    #[arg(long)]
    tolerance: Option<f64>,
    #[arg(long)]
    max_iterations: Option<u32>,
    /// K perturbed ("virtual") direction sets used during transport: memory unchanged, time x K
    #[arg(long)]
    perturb: Option<u32>,
    /// Plain shooting to the tolerance: no geometric-tail acceleration
    #[arg(long)]
    no_accelerate: bool,
    /// GPU memory the propagation may use (e.g. 512MiB, 2GiB; a bare number is MiB). Directions
    /// whose visibility does not fit are processed in batches, rebuilt every iteration
    #[arg(long, value_parser = parse_mebibytes)]
    memory_budget: Option<u64>,
    /// Shadow rays per texel for direct light from the emitters (and again from the sky);
    /// 0 sends direct light through the fixed directions as the paper does
    #[arg(long)]
    direct_samples: Option<u32>,
    /// Direct light also through planar mirrors: emitters seen in them as virtual emitters (on
    /// by default where direct light is on; for settings files that turn it off)
    #[arg(long, conflicts_with = "no_mirror_direct")]
    mirror_direct: bool,
    /// Mirrors' first reflections of the emitters through the mirror tiles' fixed directions
    /// instead of as virtual emitters
    #[arg(long)]
    no_mirror_direct: bool,
    /// A texel the visibility lists cannot place along a direction (a rim, a part smaller than
    /// a grid cell) casts a ray through the scene's BVH instead of dropping the direction
    /// (scenes without mirrors; slower, more accurate on two-sided, finely detailed models)
    #[arg(long)]
    rim_rays: bool,
}

impl ParamArgs {
    /// The settings for this adapter: --config, else --quality, else the default on a GPU and
    /// the software preset on a software adapter (said on stderr); then the flags.
    pub fn for_adapter(&self, ctx: &GpuContext) -> Result<PropagationParams> {
        let base = match (&self.config, self.quality) {
            (Some(path), _) => PropagationParams::from_toml_file(path)?,
            (None, Some(q)) => preset(&format!("{q:?}").to_lowercase())?,
            (None, None) if ctx.summary.software => {
                let p = preset("software")?;
                eprintln!(
                    "note: {} is a software adapter (no GPU found): using lighter settings ({} directions, {}^2 grid, {} texels/unit, config/propagation/software.toml); --quality default|high or --config for others",
                    ctx.summary.name,
                    p.direction_count(),
                    p.grid_resolution,
                    p.texel_density
                );
                p
            }
            (None, None) => PropagationParams::default(),
        };
        self.apply(base)
    }

    /// The flags over `base`.
    pub fn apply(&self, base: PropagationParams) -> Result<PropagationParams> {
        let mut p = base;
        if let Some(d) = self.directions {
            p.geodesic_frequency = PropagationParams::frequency_for_directions(d);
        }
        if let Some(g) = self.grid {
            p.grid_resolution = g;
        }
        if let Some(t) = self.tile {
            p.tile_size = t;
        }
        if let Some(t) = self.texel_density {
            p.texel_density = t;
        }
        if let Some(t) = self.tolerance {
            p.tolerance = t;
        }
        if let Some(m) = self.max_iterations {
            p.max_iterations = m;
        }
        if let Some(k) = self.perturb {
            p.perturb = k;
        }
        if self.no_accelerate {
            p.accelerate = false;
        }
        if let Some(m) = self.memory_budget {
            p.memory_budget_mib = Some(m);
        }
        if let Some(d) = self.direct_samples {
            p.direct_samples = d;
        }
        if self.mirror_direct || self.no_mirror_direct {
            p.mirror_direct = self.mirror_direct;
        }
        if self.rim_rays {
            p.rim_rays = true;
        }
        Ok(p)
    }
}

/// "512MiB", "2GiB", "1.5G", "800M" or a bare number of MiB, as MiB.
fn parse_mebibytes(s: &str) -> std::result::Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("{s:?}: expected a size such as 512MiB or 2GiB"))?;
    let mib = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "m" | "mb" | "mib" => value,
        "g" | "gb" | "gib" => value * 1024.0,
        "t" | "tb" | "tib" => value * 1024.0 * 1024.0,
        other => return Err(format!("{s:?}: unknown unit {other:?}; use MiB or GiB")),
    };
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must be refused too
    if !(mib >= 1.0) {
        return Err(format!("{s:?}: a memory budget must be at least 1 MiB"));
    }
    Ok(mib.round() as u64)
}
