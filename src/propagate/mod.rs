//! Propagate: fills the light field with converged radiance on the GPU. Visibility per
//! direction (`visibility.rs`) is built once and kept for all iterations (the paper's
//! "pre-sort"); shooting iterations (`transport.rs`) gather until the unshot power falls below
//! the tolerance. `cpu.rs` is the small CPU twin of both kernels, used to check the GPU.

pub mod checkpoint;
pub mod cpu;
pub mod direct;
pub mod report;
pub mod transport;
pub mod visibility;

use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuFace, NO_FACE};
use crate::lightfield::directions::DirectionSet;
use crate::prepare::PreparedScene;
use crate::progress::Progress;

pub use crate::lightfield::directions::gpu_directions;
pub use crate::params::PropagationParams;
pub use crate::prepare::packing::{gpu_faces, non_diffuse_faces};

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

/// Steps of the propagation's progress: the fraction of the way, in log residual, from 1 to
/// the tolerance.
const PROGRESS_STEPS: u64 = 1000;

type Propagated = (
    crate::lightfield::LightField,
    crate::lightfield::ResidentLightField,
    report::PropagationReport,
);

/// Propagate a scene to convergence, reporting each iteration to `progress`.
pub fn propagate(
    ctx: std::sync::Arc<crate::gpu::GpuContext>,
    scene: &crate::scene::Scene,
    params: &PropagationParams,
    progress: &dyn Progress,
) -> Result<Propagated> {
    propagate_with(ctx, scene, params, progress, None)
}

/// `propagate`, with checkpoints saved (and resumed from) as `plan` says.
pub fn propagate_with(
    ctx: std::sync::Arc<crate::gpu::GpuContext>,
    scene: &crate::scene::Scene,
    params: &PropagationParams,
    progress: &dyn Progress,
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

    let stage = match batch_plan.resident() {
        true => format!(
            "visibility: {} directions x {}^2 cells",
            directions.len(),
            params.grid_resolution
        ),
        false => format!(
            "{} batches of {} directions (rebuilt every iteration)",
            batch_plan.batches, batch_plan.batch_size
        ),
    };
    progress.begin(PROGRESS_STEPS, "", &stage);
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
        // written so that a NaN residual keeps iterating (and is caught by the iteration's checks)
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let unconverged = |residual: f64| !(residual < params.tolerance);
        while prop.iteration < params.max_iterations && unconverged(residual) {
            let stats = prop.iterate()?;
            residual = stats.residual;
            let done = (residual.max(1e-300).ln() / params.tolerance.ln()).clamp(0.0, 1.0);
            progress.advance_to(
                (done * PROGRESS_STEPS as f64) as u64,
                &format!(
                    "iteration {} residual {:.2e} (target {:.0e})",
                    stats.iteration, residual, params.tolerance
                ),
            );
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
    progress.finish();
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
    let propagation_memory = report::memory_items(prop.ledger.entries());
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
    let report = report::PropagationReport {
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
        render_memory: report::memory_items(resident.ledger.entries()),
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
