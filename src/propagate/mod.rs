//! Propagate: fills the light field with converged radiance on the GPU. Visibility per
//! direction (`visibility.rs`) is built once and kept for all iterations (the paper's
//! "pre-sort"); shooting iterations (`transport.rs`) gather until the unshot power falls below
//! the tolerance. `cpu.rs` is the small CPU twin of both kernels, used to check the GPU.

pub mod checkpoint;
pub mod cpu;
pub mod cpu_specular;
pub mod direct;
pub mod transport;
pub mod visibility;

use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuDirection, GpuFace, FACE_EMITTER, NO_FACE};
use crate::lightfield::directions::DirectionSet;
use crate::prepare::PreparedScene;
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
}

fn yes() -> bool {
    true
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

/// Does face f have a mirror part (and so tiles)?
pub fn non_diffuse_faces(prepared: &PreparedScene) -> Vec<bool> {
    (0..prepared.faces.len())
        .map(|f| prepared.material_of(f).mirror.iter().any(|&m| m > 0.0))
        .collect()
}

/// GPU face records for a prepared scene; `tile_slot[f]` is face f's index
/// among the non-diffuse faces (NO_FACE for diffuse-only faces).
pub fn gpu_faces(prepared: &PreparedScene, tile_slot: &[u32]) -> Vec<GpuFace> {
    let density = prepared.texel_density as f32;
    prepared
        .faces
        .iter()
        .enumerate()
        .map(|(fi, f)| {
            let m = prepared.material_of(fi);
            let emissive = m.emission.iter().any(|&e| e > 0.0) && !f.is_back;
            let v3 = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32];
            GpuFace {
                normal: v3(f.normal),
                plane_offset: f.plane_offset as f32,
                origin: v3(f.origin),
                texel_density: density,
                axis_a: v3(f.axis_a),
                _pad0: 0.0,
                axis_b: v3(f.axis_b),
                flags: if emissive { FACE_EMITTER } else { 0 },
                albedo: m.diffuse,
                atlas_x: f.atlas.x,
                emission: if f.is_back { [0.0; 3] } else { m.emission },
                atlas_y: f.atlas.y,
                atlas_w: f.atlas.w,
                atlas_h: f.atlas.h,
                twin: f.twin.unwrap_or(NO_FACE),
                tile_slot: tile_slot[fi],
                mirror: m.mirror,
                _pad: 0.0,
            }
        })
        .collect()
}

pub fn gpu_directions(
    directions: &[crate::lightfield::directions::Direction],
) -> Vec<GpuDirection> {
    directions
        .iter()
        .map(|d| {
            let (u, v) = d.frame();
            GpuDirection {
                w: [d.w.x as f32, d.w.y as f32, d.w.z as f32],
                solid_angle: d.solid_angle as f32,
                u: [u.x as f32, u.y as f32, u.z as f32],
                _pad0: 0.0,
                v: [v.x as f32, v.y as f32, v.z as f32],
                _pad1: 0.0,
            }
        })
        .collect()
}

/// Initial state: emitters hold unshot radiosity pi*Le and show Le.
pub fn initial_radiance(
    prepared: &PreparedScene,
    faces: &[GpuFace],
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let n = prepared.atlas.texel_count();
    let mut unshot = vec![[0.0f32; 4]; n];
    let mut total = vec![[0.0f32; 4]; n];
    for (i, p) in prepared.atlas.points.iter().enumerate() {
        let face = p[3].to_bits();
        if face == NO_FACE {
            continue;
        }
        let mut e = faces[face as usize].emission;
        if let Some(t) = &prepared.atlas.texture_emission {
            e = std::array::from_fn(|k| e[k] * t[i][k]);
        }
        unshot[i] = [
            e[0] * std::f32::consts::PI,
            e[1] * std::f32::consts::PI,
            e[2] * std::f32::consts::PI,
            0.0,
        ];
        total[i] = [e[0], e[1], e[2], 0.0];
    }
    (unshot, total)
}

/// The big GPU buffers a propagation will need, estimated before anything is allocated.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MemoryEstimate {
    pub cell_table_bytes: u64,
    /// visibility layers: every face's projected area over a cell's area, per direction
    pub layer_bytes: u64,
    pub texel_bytes: u64,
    pub total_bytes: u64,
}

pub fn estimate_memory(
    prepared: &PreparedScene,
    directions: &DirectionSet,
    params: &PropagationParams,
) -> MemoryEstimate {
    let n = params.grid_resolution as u64;
    let cells = n * n * directions.len() as u64;
    let cell_area = (2.0 / params.grid_resolution as f64).powi(2);
    let layers: f64 = prepared
        .faces
        .iter()
        .map(|f| {
            f.area * directions.cosine_sum(f.normal)
                / directions
                    .directions
                    .iter()
                    .map(|d| d.solid_angle)
                    .sum::<f64>()
                * directions.len() as f64
        })
        .sum::<f64>()
        / cell_area;
    let texels = prepared.atlas.texel_count() as u64;
    let cell_table_bytes = cells * 8;
    let layer_bytes = (layers * 8.0) as u64;
    // unshot, next, total, points, power weights (+ texture factors)
    let texel_bytes = texels * (16 * 4 + 4);
    MemoryEstimate {
        cell_table_bytes,
        layer_bytes,
        texel_bytes,
        total_bytes: cell_table_bytes + layer_bytes + texel_bytes,
    }
}

/// Refuse, before allocating anything, parameters whose buffers cannot be bound, and decide
/// how the directions are batched.
pub fn check_memory(ctx: &crate::gpu::GpuContext, estimate: &MemoryEstimate) -> Result<()> {
    // the texel arrays (16 bytes a texel) go in pages of one binding, at most four
    let limits = ctx.limits();
    let max_binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    crate::lightfield::tiles::TilePages::plan_texels(
        estimate.texel_bytes / (16 * 4 + 4),
        max_binding,
    )
    .map(|_| ())
}

/// How the directions' visibility lists are built: all at once and kept for every iteration
/// (one batch), or in batches rebuilt every iteration when they would not fit.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BatchPlan {
    pub batch_size: u32,
    pub batches: u32,
    /// why batches were needed (None when the lists stay resident)
    pub reason: Option<String>,
}

impl BatchPlan {
    /// Every direction in one batch: the lists stay resident.
    pub fn single(directions: u32) -> BatchPlan {
        BatchPlan {
            batch_size: directions,
            batches: 1,
            reason: None,
        }
    }

    pub fn resident(&self) -> bool {
        self.batches == 1
    }

    /// (first direction, count) of every batch
    pub fn ranges(&self, direction_count: u32) -> Vec<(u32, u32)> {
        (0..self.batches)
            .map(|b| {
                let first = b * self.batch_size;
                (first, self.batch_size.min(direction_count - first))
            })
            .collect()
    }
}

/// Headroom on the estimated layer count when sizing a batch (the estimate is an average).
const LAYER_HEADROOM: f64 = 1.5;

/// Largest batch of directions whose visibility fits one binding and what the memory budget
/// leaves beside `fixed_bytes` (radiance, tiles); every direction in one batch when it all fits.
pub fn plan_batches(
    estimate: &MemoryEstimate,
    params: &PropagationParams,
    directions: u32,
    max_binding: u64,
    fixed_bytes: u64,
) -> Result<BatchPlan> {
    let cells = params.grid_resolution as u64 * params.grid_resolution as u64;
    let layers_per_direction = estimate.layer_bytes as f64 / directions as f64 * LAYER_HEADROOM;
    let by_cells = max_binding / (cells * 4);
    let by_layers = (max_binding as f64 / layers_per_direction.max(1.0)) as u64;
    let mut limit = by_cells.min(by_layers);
    let mut reason = format!(
        "one binding holds {} directions' lists (the adapter binds at most {})",
        limit,
        crate::gpu::human_bytes(max_binding)
    );
    if let Some(mib) = params.memory_budget_mib {
        let budget = mib << 20;
        let fixed = fixed_bytes;
        let per_direction = cells as f64 * 8.0 + layers_per_direction;
        let by_budget = (budget.saturating_sub(fixed) as f64 / per_direction) as u64;
        if by_budget < limit {
            limit = by_budget;
            reason =
                format!("--memory-budget {mib} MiB leaves room for {by_budget} directions' lists");
        }
        if by_budget == 0 {
            return Err(VlfError::GpuBudget(format!(
                "a memory budget of {mib} MiB cannot hold the radiance ({}) and one direction's visibility ({}); raise --memory-budget, lower the texel density or use a coarser grid",
                crate::gpu::human_bytes(fixed),
                crate::gpu::human_bytes(per_direction as u64)
            )));
        }
    }
    if limit == 0 {
        return Err(VlfError::GpuBudget(format!(
            "one direction's visibility ({} cells, about {} of layers) does not fit one binding of {}; use a coarser grid",
            cells,
            crate::gpu::human_bytes(layers_per_direction as u64),
            crate::gpu::human_bytes(max_binding)
        )));
    }
    if limit >= directions as u64 {
        return Ok(BatchPlan {
            batch_size: directions,
            batches: 1,
            reason: None,
        });
    }
    let batches = (directions as u64).div_ceil(limit) as u32;
    Ok(BatchPlan {
        batch_size: directions.div_ceil(batches),
        batches,
        reason: Some(reason),
    })
}

/// Depth tolerance (normalised units) within which layers count as coplanar.
pub const DEPTH_EPSILON: f32 = 2e-5;

type Propagated = (
    crate::lightfield::LightField,
    crate::lightfield::ResidentLightField,
    crate::report::PropagationReport,
);

/// Propagate a scene to convergence. `progress` shows a bar on the terminal.
pub fn propagate(
    ctx: std::sync::Arc<crate::gpu::GpuContext>,
    scene: &crate::scene::Scene,
    params: &PropagationParams,
    progress: bool,
) -> Result<Propagated> {
    propagate_with(ctx, scene, params, progress, None)
}

/// `propagate`, with checkpoints saved (and resumed from) as `plan` says.
pub fn propagate_with(
    ctx: std::sync::Arc<crate::gpu::GpuContext>,
    scene: &crate::scene::Scene,
    params: &PropagationParams,
    progress: bool,
    plan: Option<&checkpoint::CheckpointPlan>,
) -> Result<Propagated> {
    use std::time::Instant;
    params.validate()?;
    let t0 = Instant::now();
    let prepared = PreparedScene::new(scene, params.texel_density)?;
    let directions = DirectionSet::geodesic(params.geodesic_frequency);
    let estimate = estimate_memory(&prepared, &directions, params);
    check_memory(&ctx, &estimate)?;
    let mut prop =
        transport::Propagator::new(ctx.clone(), &prepared, params, &directions, scene.sky, None)?;
    let batch_plan = prop.plan.clone();
    ctx.wait()?;
    let setup_seconds = t0.elapsed().as_secs_f64();

    let bar = if progress {
        indicatif::ProgressBar::new(1000)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {elapsed_precise} [{bar:40}] {msg}")
            .unwrap()
            .progress_chars("=> "),
    );
    bar.set_message(match batch_plan.resident() {
        true => format!(
            "visibility: {} directions x {}^2 cells",
            directions.len(),
            params.grid_resolution
        ),
        false => format!(
            "{} batches of {} directions (rebuilt every iteration)",
            batch_plan.batches, batch_plan.batch_size
        ),
    });
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let t1 = Instant::now();
    // batched directions build their lists inside every iteration instead
    let (layers, visibility_gpu_ms) = match batch_plan.resident() {
        true => {
            let vis = prop.build_visibility()?;
            (vis.layer_count, vis.gpu_ms)
        }
        false => (0, None),
    };
    let visibility_seconds = t1.elapsed().as_secs_f64();

    let mut warnings = prepared.warnings.clone();
    if let Some(reason) = &batch_plan.reason {
        warnings.push(format!(
            "visibility in {} batches of {} directions, rebuilt every iteration: {reason}",
            batch_plan.batches, batch_plan.batch_size
        ));
    }
    // faces smaller than a grid cell: no cell line may cross them, so their texels rely on the
    // depth fallback; say how many and how much of the scene they are
    let cell_area = (2.0 / params.grid_resolution as f64).powi(2);
    let total_area: f64 = prepared
        .faces
        .iter()
        .filter(|f| !f.is_back)
        .map(|f| f.area)
        .sum();
    let small: Vec<f64> = prepared
        .faces
        .iter()
        .filter(|f| !f.is_back && f.area < cell_area)
        .map(|f| f.area)
        .collect();
    if !small.is_empty() {
        warnings.push(format!(
            "{} face(s), {:.3}% of the surface area, are smaller than one grid cell ({} cells per side): their light arrives through the depth fallback; raise --grid to resolve them",
            small.len(),
            100.0 * small.iter().sum::<f64>() / total_area.max(1e-300),
            params.grid_resolution
        ));
    }
    let t2 = Instant::now();
    let mut per_iteration: Vec<transport::IterationStats> = Vec::new();
    let mut residual = 1.0;
    let mut tail: Option<Tail> = None;
    if let Some(plan) = plan.filter(|p| p.resume && p.path.exists()) {
        let cp = checkpoint::Checkpoint::load(&plan.path)?;
        cp.check(&scene.hash, params, &plan.path)?;
        prop.restore(&cp)?;
        per_iteration = cp
            .meta
            .residuals
            .iter()
            .enumerate()
            .map(|(i, &r)| transport::IterationStats {
                iteration: i as u32 + 1,
                residual: r,
                gpu_ms: None,
                wall_ms: 0.0,
            })
            .collect();
        residual = per_iteration.last().map_or(1.0, |s| s.residual);
        warnings.push(format!(
            "resumed from {} at iteration {}",
            plan.path.display(),
            cp.meta.iteration
        ));
    }
    if prop.emitted_power <= 0.0 && scene.sky.is_none() {
        warnings.push("the scene has no emitter (no Ke, no emission override, no sky): the light field is black".into());
        residual = 0.0;
    } else {
        while prop.iteration < params.max_iterations && !(residual < params.tolerance) {
            let stats = prop.iterate()?;
            residual = stats.residual;
            let done = (residual.max(1e-300).ln() / params.tolerance.ln()).clamp(0.0, 1.0);
            bar.set_position((done * 1000.0) as u64);
            bar.set_message(format!(
                "iteration {} residual {:.2e} (target {:.0e})",
                stats.iteration, residual, params.tolerance
            ));
            let ratio = per_iteration
                .last()
                .map(|p| residual / p.residual.max(1e-300));
            let previous_ratio = per_iteration
                .len()
                .checked_sub(2)
                .map(|i| per_iteration[i + 1].residual / per_iteration[i].residual.max(1e-300));
            per_iteration.push(stats);
            if let Some(plan) = plan.filter(|p| p.every > 0 && prop.iteration % p.every == 0) {
                checkpoint::Checkpoint {
                    meta: checkpoint::CheckpointMeta {
                        vlf_version: env!("CARGO_PKG_VERSION").into(),
                        scene_hash: scene.hash.clone(),
                        params: params.clone(),
                        iteration: prop.iteration,
                        emitted_power: prop.emitted_power,
                        residuals: per_iteration.iter().map(|s| s.residual).collect(),
                    },
                    unshot: prop.read_unshot()?,
                    total: prop.read_total()?,
                    tile_unshot: prop.read_tile_unshot()?,
                    tile_total: prop.read_tile_total()?,
                }
                .save(&plan.path)?;
            }
            if residual < params.tolerance {
                break;
            }
            // the unshot state decays geometrically once its shape settles: when the decay
            // ratio is stable enough that the tail it predicts is known to the tolerance, add
            // that tail and stop. The tail is U r/(1-r); an error dr in r moves it by
            // U dr/(1-r)^2, which relative to the converged total (about emitted/(1-r)) is
            // residual * dr / (1-r).
            if let (true, Some(r), Some(r0)) = (
                params.accelerate && per_iteration.len() >= 3,
                ratio,
                previous_ratio,
            ) {
                if r > 0.0 && r < 0.9999 {
                    let uncertainty = residual * (r - r0).abs() / (1.0 - r);
                    if uncertainty < params.tolerance {
                        prop.add_tail(r / (1.0 - r))?;
                        tail = Some(Tail {
                            ratio: r,
                            factor: r / (1.0 - r),
                            uncertainty,
                            plain_iterations_estimate: plain_estimate(
                                residual,
                                r,
                                per_iteration.len() as u32,
                                params.tolerance,
                            ),
                        });
                        residual = uncertainty;
                        break;
                    }
                }
            }
        }
    }
    ctx.wait()?;
    let propagation_seconds = t2.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if residual >= params.tolerance {
        warnings.push(format!(
            "stopped at the iteration cap ({}) with residual {residual:.2e} above the tolerance {:.0e}; raise --max-iterations",
            params.max_iterations, params.tolerance
        ));
    }
    let total = prop.read_total()?;
    let faces = prop.faces.clone();
    let tiles = match prop.tile_layout() {
        Some(layout) => Some(crate::lightfield::TileField {
            rects: layout.rects.clone(),
            index: layout.index.clone(),
            total: prop.read_tile_total()?,
            face_count: layout.faces.len() as u32,
        }),
        None => None,
    };
    let non_diffuse_elements = tiles.as_ref().map_or(0, |t| t.total.len() as u64);
    // everything allocated for tiles while propagating (radiance copies, weights, tables)
    let tile_bytes: u64 = prop
        .ledger
        .entries()
        .iter()
        .filter(|(n, _)| n.contains("tile"))
        .map(|(_, b)| b)
        .sum();
    let texture_bytes: u64 = prop
        .ledger
        .entries()
        .iter()
        .filter(|(n, _)| n.starts_with("texture"))
        .map(|(_, b)| b)
        .sum();
    let propagation_memory_bytes = prop.memory_bytes();
    let propagation_memory = crate::report::memory_items(prop.ledger.entries());
    let iterations = prop.iteration;
    let layers = layers.max(prop.largest_batch_layers);
    let render_vertices = crate::lightfield::render_vertices(&prepared);
    let mirror_chains = crate::lightfield::MirrorChains::of(&faces, &render_vertices);
    let direct_emitters = prop.direct.as_ref().map_or(0, |d| d.emitter_count);
    let direct_mirrors = prop.direct.as_ref().map_or(0, |d| d.mirror_count);
    let resident = prop.into_resident(mirror_chains.tiles_needed);
    resident
        .ledger
        .record("render mesh", (render_vertices.len() * 16) as u64);
    let lf = crate::lightfield::LightField {
        meta: crate::lightfield::LightFieldMeta {
            vlf_version: env!("CARGO_PKG_VERSION").into(),
            scene_name: scene.name.clone(),
            scene_hash: scene.hash.clone(),
            params: params.clone(),
            direction_count: directions.len() as u32,
            normalisation: prepared.normalisation,
            sky: scene.sky,
            cameras: scene.cameras.clone(),
            atlas_width: prepared.atlas.width,
            atlas_height: prepared.atlas.height,
            iterations,
            residual,
        },
        faces,
        render_vertices,
        total,
        tiles,
    };
    let report = crate::report::PropagationReport {
        scene: scene.name.clone(),
        adapter: ctx.summary.clone(),
        params: params.clone(),
        directions: directions.len() as u32,
        faces: prepared.faces.len() as u32,
        triangles: prepared.triangles.len() as u32,
        diffuse_elements: prepared.atlas.charted_texels,
        non_diffuse_elements,
        tile_bytes,
        texture_bytes,
        host_textures: scene.texture_memory,
        layers,
        visibility_kept_resident: batch_plan.resident(),
        direction_batches: batch_plan.batches,
        directions_per_batch: batch_plan.batch_size,
        setup_seconds,
        visibility_seconds,
        visibility_gpu_ms,
        propagation_seconds,
        iterations,
        final_residual: residual,
        converged: residual < params.tolerance,
        plain_iterations_estimate: tail.as_ref().map(|t| t.plain_iterations_estimate),
        tail,
        per_iteration,
        propagation_memory_bytes,
        propagation_memory,
        render_memory_bytes: resident.ledger.total(),
        mirror_rendering: Some(mirror_chains),
        direct_emitters,
        direct_mirrors,
        render_memory: crate::report::memory_items(resident.ledger.entries()),
        sky: scene.sky.is_some(),
        warnings,
    };
    Ok((lf, resident, report))
}

/// The geometric tail added by acceleration.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Tail {
    /// decay ratio of the unshot power per iteration
    pub ratio: f64,
    /// the unshot state was added to total times this (r / (1 - r))
    pub factor: f64,
    /// estimated error of the extrapolation, relative to the emitted power
    pub uncertainty: f64,
    /// iterations plain shooting would have needed to reach the tolerance
    pub plain_iterations_estimate: u32,
}

/// Iterations plain shooting needs from residual `residual` after `done` iterations, decaying by
/// `r` per iteration, to fall below `tolerance`.
fn plain_estimate(residual: f64, r: f64, done: u32, tolerance: f64) -> u32 {
    if residual <= tolerance {
        return done;
    }
    done + ((tolerance / residual).ln() / r.ln()).ceil().max(0.0) as u32
}
