//! The propagation settings (directions, grid, tiles, texel density, tolerance, direct light):
//! what decides a light field's accuracy and cost. Below both the light field, which records
//! them in every `.vlf`, and propagation, which runs by them.

use crate::error::{Result, VlfError};
use serde::{Deserialize, Serialize};

/// Everything that decides the light field's accuracy and cost.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PropagationParams {
    /// Geodesic frequency n: 5n^2+1 directions over the hemisphere.
    pub geodesic_frequency: u32,
    /// Cells per side of each direction's grid (N).
    pub grid_resolution: u32,
    /// Cells per side of a tile (m); N/m must be integral. Tiles hold non-diffuse elements,
    /// which a diffuse-only scene does not allocate.
    pub tile_size: u32,
    /// Diffuse texels per unit length of the normalised scene.
    pub texel_density: f64,
    /// Stop when unshot power / emitted power falls below this.
    pub tolerance: f64,
    pub max_iterations: u32,
    /// K perturbed ("virtual") direction sets per fixed direction, used during transport only:
    /// memory unchanged, time about x K. 1 = the fixed directions alone.
    #[serde(default = "one")]
    pub perturb: u32,
    /// Stop early and add the geometric tail once the unshot power decays by a stable ratio
    /// (the ambient term, per element): stiff scenes converge in a few iterations.
    #[serde(default = "yes")]
    pub accelerate: bool,
    /// GPU memory the propagation may use, in MiB. When the visibility lists of every
    /// direction do not fit (in it, or in one binding), directions are processed in batches
    /// whose lists are rebuilt every iteration. None: the adapter's binding limits alone decide.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub memory_budget_mib: Option<u64>,
    /// Shadow rays per texel for direct light (`shaders/direct.wgsl`), toward the emitters and
    /// again toward the sky. 0: direct light comes through the fixed directions like every
    /// other bounce (the paper's method, and light fields saved before this setting existed).
    #[serde(default)]
    pub direct_samples: u32,
    /// Where direct light is on: also through planar mirrors (emitters seen in them as virtual
    /// emitters, in closed form, in the second iteration; sky rays followed through one
    /// reflection) instead of through the mirror tiles' fixed directions, whose caustics alias.
    /// On by default (a file without the key included): exact for a mirror alone and in the
    /// closed box of emitting mirrors and walls (tests/picture.rs, tests/mirrors.rs).
    #[serde(default = "yes")]
    pub mirror_direct: bool,
    /// Where a texel's own face has no visibility-list line nearby along a direction (a rim, a
    /// junction, a part smaller than a grid cell), cast a ray through the scene's BVH for it
    /// instead of dropping the direction (scenes without mirrors). More accurate on
    /// two-sided, finely detailed models, 2-6x the propagation time there (measured on the
    /// Bitterli interiors); off by default. Written to a .vlf only when on, so light fields
    /// made without it stay byte for byte what they were.
    #[serde(default, skip_serializing_if = "is_false")]
    pub rim_rays: bool,
}

fn yes() -> bool {
    true
}

fn is_false(b: &bool) -> bool {
    !b
}

fn one() -> u32 {
    1
}

impl Default for PropagationParams {
    fn default() -> Self {
        PropagationParams {
            geodesic_frequency: 20,
            grid_resolution: 256,
            tile_size: 8,
            texel_density: 96.0,
            tolerance: 1e-3,
            max_iterations: 200,
            perturb: 1,
            accelerate: true,
            memory_budget_mib: None,
            direct_samples: 256,
            mirror_direct: true,
            rim_rays: false,
        }
    }
}

impl PropagationParams {
    /// Lighter settings that finish in about a minute on a software adapter with 2 cores.
    pub fn software() -> Self {
        PropagationParams {
            geodesic_frequency: 14,
            grid_resolution: 96,
            tile_size: 8,
            texel_density: 40.0,
            direct_samples: 64,
            ..Self::default()
        }
    }

    /// Smallest geodesic frequency giving at least `count` directions.
    pub fn frequency_for_directions(count: u32) -> u32 {
        let mut n = 1;
        while 5 * n * n + 1 < count {
            n += 1;
        }
        n
    }

    /// Settings from a TOML file (see `config/propagation/`); unknown keys are refused.
    pub fn from_toml_file(path: &std::path::Path) -> Result<PropagationParams> {
        let text = std::fs::read_to_string(path).map_err(|e| VlfError::io(path, e))?;
        let params: PropagationParams = toml::from_str(&text).map_err(|e| VlfError::Config {
            path: path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })?;
        params.validate().map_err(|e| VlfError::Config {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Ok(params)
    }

    pub fn direction_count(&self) -> u32 {
        5 * self.geodesic_frequency * self.geodesic_frequency + 1
    }

    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, message: String| Err(VlfError::Parameter { name, message });
        if self.geodesic_frequency == 0 || self.geodesic_frequency > 100 {
            return bad(
                "directions",
                format!(
                    "geodesic frequency {} must be 1..=100",
                    self.geodesic_frequency
                ),
            );
        }
        if !(4..=1024).contains(&self.grid_resolution) {
            return bad(
                "grid",
                format!("{} cells per side must be 4..=1024", self.grid_resolution),
            );
        }
        if self.tile_size == 0 || !self.grid_resolution.is_multiple_of(self.tile_size) {
            return bad(
                "tile",
                format!(
                    "tile size {} must divide the grid resolution {}",
                    self.tile_size, self.grid_resolution
                ),
            );
        }
        if !(self.texel_density.is_finite() && self.texel_density > 0.0) {
            return bad(
                "texel-density",
                format!("{} must be a positive number", self.texel_density),
            );
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0 && self.tolerance < 1.0) {
            return bad("tolerance", format!("{} must be in (0, 1)", self.tolerance));
        }
        if self.direct_samples > 65536 {
            return bad(
                "direct-samples",
                format!(
                    "{} shadow rays per texel: at most 65536",
                    self.direct_samples
                ),
            );
        }
        if self.max_iterations == 0 {
            return bad("max-iterations", "must be at least 1".into());
        }
        if self.memory_budget_mib == Some(0) {
            return bad("memory-budget", "must be more than 0 MiB".into());
        }
        if !(1..=64).contains(&self.perturb) {
            return bad(
                "perturb",
                format!("{} perturbed sets: use 1 (none) to 64", self.perturb),
            );
        }
        Ok(())
    }
}
