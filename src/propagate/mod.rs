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
use crate::gpu::types::{GpuFace, GpuMaterial, NO_FACE};
use crate::lightfield::directions::DirectionSet;
use crate::prepare::PreparedScene;
use crate::progress::Progress;

pub use crate::lightfield::directions::gpu_directions;
pub use crate::params::PropagationParams;
pub use crate::prepare::packing::{gpu_faces, gpu_materials, non_diffuse_faces};

/// Initial state: emitters hold unshot radiosity pi*Le and show Le.
pub fn initial_radiance(
    prepared: &PreparedScene,
    faces: &[GpuFace],
    materials: &[GpuMaterial],
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let n = prepared.atlas.texel_count();
    let mut unshot = vec![[0.0f32; 4]; n];
    let mut total = vec![[0.0f32; 4]; n];
    for (i, p) in prepared.atlas.points.iter().enumerate() {
        let face = p[3].to_bits();
        if face == NO_FACE {
            continue;
        }
        let mut e = crate::material::emitted(materials, &faces[face as usize]).to_array();
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

/// Each texel's share of its face's area (normalised units): the face's triangles clipped to the
/// texel's square, exactly. The power balance weights texels by it (a texel's `coverage`, from
/// 4 x 4 samples, is off by up to a sixteenth of a texel per edge: percents of a face a few
/// texels wide, such as a small emitter, whose light direct light delivers from its exact area),
/// times the share of it that lies open (`atlas.open_share`: what lies under a picture frame or
/// a stair receives nothing, although a texel moved to the open rim beside it holds light).
pub fn texel_areas(prepared: &PreparedScene) -> Vec<f64> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    texel_areas_on(prepared, threads)
}

/// [`texel_areas`] on `threads` threads.
fn texel_areas_on(prepared: &PreparedScene, threads: usize) -> Vec<f64> {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    let areas: Vec<AtomicU64> = (0..prepared.atlas.texel_count())
        .map(|_| AtomicU64::new(0))
        .collect();
    // a face's texels are its own: each thread takes every triangle of its faces, in the
    // triangles' order, so every texel sums the same terms in the same order on any number of
    // threads (the bits of a single thread's sums)
    std::thread::scope(|scope| {
        for k in 0..threads {
            let areas = &areas;
            scope.spawn(move || {
                let mine = (prepared.triangles.iter()).filter(|t| t.face as usize % threads == k);
                for t in mine {
                    triangle_texel_areas(prepared, t, |texel, covered| {
                        let a = &areas[texel];
                        a.store(
                            (f64::from_bits(a.load(Relaxed)) + covered).to_bits(),
                            Relaxed,
                        );
                    });
                }
            });
        }
    });
    (areas.iter().zip(&prepared.atlas.open_share))
        .map(|(a, &open)| f64::from_bits(a.load(Relaxed)) * open as f64)
        .collect()
}

/// Each texel triangle `t` covers, and the area it covers of it (scene units), to `add`.
fn triangle_texel_areas(
    prepared: &PreparedScene,
    t: &crate::prepare::PreparedTriangle,
    mut add: impl FnMut(usize, f64),
) {
    use glam::DVec2;
    let d = prepared.texel_density;
    let f = &prepared.faces[t.face as usize];
    // corners in texel units of the face's chart
    let c = t.vertices.map(|v| {
        let rel = prepared.positions[v as usize] - f.origin;
        DVec2::new(f.axis_a.dot(rel), f.axis_b.dot(rel)) * d
    });
    let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
    let r = f.atlas;
    let range =
        |lo: f64, hi: f64, n: u32| (lo.floor().max(0.0) as u32)..(hi.ceil().max(0.0) as u32).min(n);
    for j in range(lo.y, hi.y, r.h) {
        for i in range(lo.x, hi.x, r.w) {
            let cell = DVec2::new(i as f64, j as f64);
            let covered = clipped_area(&c, cell, cell + DVec2::ONE);
            add(
                ((r.y + j) * prepared.atlas.width + r.x + i) as usize,
                covered / (d * d),
            );
        }
    }
}

/// Area of the triangle `t` inside the box [lo, hi] (Sutherland-Hodgman, then the shoelace).
fn clipped_area(t: &[glam::DVec2; 3], lo: glam::DVec2, hi: glam::DVec2) -> f64 {
    let mut poly: Vec<glam::DVec2> = t.to_vec();
    // (axis, bound, keep the side below the bound)
    for (axis, bound, below) in [
        (0, lo.x, false),
        (0, hi.x, true),
        (1, lo.y, false),
        (1, hi.y, true),
    ] {
        let inside = |p: glam::DVec2| (p[axis] <= bound) == below || p[axis] == bound;
        let mut out = Vec::with_capacity(poly.len() + 2);
        for k in 0..poly.len() {
            let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
            if inside(p) {
                out.push(p);
            }
            if inside(p) != inside(q) {
                out.push(p + (q - p) * ((bound - p[axis]) / (q[axis] - p[axis])));
            }
        }
        poly = out;
        if poly.len() < 3 {
            return 0.0;
        }
    }
    let twice: f64 = (0..poly.len())
        .map(|k| poly[k].perp_dot(poly[(k + 1) % poly.len()]))
        .sum();
    0.5 * twice.abs()
}

/// GPU bytes per texel while propagating: unshot, next, total, points, the power balance's
/// terms (16 bytes each), the power weight and the exact area (+ texture factors, not counted).
const TEXEL_BYTES: u64 = 16 * 5 + 8;

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
    let texel_bytes = texels * TEXEL_BYTES;
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
        estimate.texel_bytes / TEXEL_BYTES,
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
    propagate_with(ctx, scene, params, progress, Outputs::default())
}

/// Where a propagation leaves its files besides what it returns.
#[derive(Clone, Copy, Default)]
pub struct Outputs<'a> {
    /// checkpoints saved (and resumed from) as the plan says
    pub checkpoints: Option<&'a checkpoint::CheckpointPlan>,
    /// the light field saved here (atomically, `lightfield::file::save`), written while the
    /// power balance is probed; the report's `command_phases` gets the write's seconds
    pub light_field: Option<&'a std::path::Path>,
}

/// `propagate`, leaving checkpoints and the light field's file as `outputs` says.
pub fn propagate_with(
    ctx: std::sync::Arc<crate::gpu::GpuContext>,
    scene: &crate::scene::Scene,
    params: &PropagationParams,
    progress: &dyn Progress,
    outputs: Outputs,
) -> Result<Propagated> {
    propagate_with_regression(ctx, scene, params, progress, outputs, Regression::default())
}

/// Tests only: fixed transport bugs turned back on, so that a test can show the power balance
/// catching the light they lose. Nothing in the CLI sets them.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, Default)]
pub struct Regression {
    /// the sender lookup takes whichever side of a two-sided surface its cell list holds first,
    /// as before `facing_side` (shaders/common/upstream.wgsl): the back sends nothing
    pub list_order_sides: bool,
}

/// `propagate_with`, with the `regression` switched on (tests only).
#[doc(hidden)]
pub fn propagate_with_regression(
    ctx: std::sync::Arc<crate::gpu::GpuContext>,
    scene: &crate::scene::Scene,
    params: &PropagationParams,
    progress: &dyn Progress,
    outputs: Outputs,
    regression: Regression,
) -> Result<Propagated> {
    let plan = outputs.checkpoints;
    use std::time::Instant;
    params.validate()?;
    let t0 = Instant::now();
    let mut job = Job::prepare(scene, params)?;
    check_memory(
        &ctx,
        &estimate_memory(&job.prepared, &job.directions, params),
    )?;
    let mut prop = transport::Propagator::new(
        ctx.clone(),
        &job.prepared,
        params,
        &job.directions,
        scene.sky,
        None,
    )?;
    // the scene's BVH is on the GPU now, and nothing after reads the host's copy (hundreds of
    // MB at millions of triangles)
    drop(std::mem::take(&mut job.prepared.bvh));
    if regression.list_order_sides {
        prop.regression_flags |= crate::gpu::types::GRID_FLAG_LIST_ORDER_SIDES;
    }
    let batch_plan = prop.plan.clone();
    ctx.wait()?;
    let setup_seconds = t0.elapsed().as_secs_f64();
    let mut setup_phases = job.prepared.laps.steps.clone();
    setup_phases.extend(prop.setup_laps.steps.iter().cloned());
    let named: f64 = setup_phases.iter().map(|p| p.1).sum();
    setup_phases.push(("other".into(), setup_seconds - named));

    progress.begin(PROGRESS_STEPS, "", &job.first_stage(&batch_plan));
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

    let mut warnings = job.setup_warnings(&batch_plan);
    let t2 = Instant::now();
    let shooting = job.shoot(&mut prop, progress, plan, &mut warnings)?;
    ctx.wait()?;
    let propagation_seconds = t2.elapsed().as_secs_f64();
    progress.finish();
    if shooting.residual >= params.tolerance {
        warnings.push(format!(
            "stopped at the iteration cap ({}) with residual {:.2e} above the tolerance {:.0e}; raise --max-iterations",
            params.max_iterations, shooting.residual, params.tolerance
        ));
    }
    let measured = Measured {
        batch_plan,
        setup_seconds,
        setup_phases,
        visibility_seconds,
        visibility_gpu_ms,
        layers,
        propagation_seconds,
        shooting,
        warnings,
        power_balance: None,
        finish_phases: Vec::new(),
    };
    job.finish(&ctx, prop, measured, outputs.light_field)
}

/// What every stage of one propagation reads: the scene, its settings, the prepared scene and
/// the directions.
struct Job<'a> {
    scene: &'a crate::scene::Scene,
    params: &'a PropagationParams,
    prepared: PreparedScene,
    directions: DirectionSet,
}

/// The shooting iterations' outcome.
struct Shooting {
    per_iteration: Vec<transport::IterationStats>,
    /// the last residual, or the tail's uncertainty where a tail ended the iterations
    residual: f64,
    tail: Option<Tail>,
}

/// What the stages before the end measured, for the report.
struct Measured {
    batch_plan: BatchPlan,
    setup_seconds: f64,
    /// its steps: the preparation's and the propagator's (`PropagationReport::setup_phases`)
    setup_phases: Vec<(String, f64)>,
    visibility_seconds: f64,
    visibility_gpu_ms: Option<f64>,
    /// layers of the resident visibility lists (0 when batched)
    layers: u64,
    propagation_seconds: f64,
    shooting: Shooting,
    warnings: Vec<String>,
    /// set at the end, from the propagator's account
    power_balance: Option<report::PowerBalance>,
    /// set at the end: the steps after the iterations (`PropagationReport::finish_phases`)
    finish_phases: Vec<(String, f64)>,
}

/// What the propagation spent and did, read from the propagator before it becomes the resident
/// light field.
struct Spent {
    non_diffuse_elements: u64,
    /// everything allocated for tiles while propagating (radiance copies, weights, tables)
    tile_bytes: u64,
    texture_bytes: u64,
    memory_bytes: u64,
    memory: Vec<report::MemoryItem>,
    iterations: u32,
    largest_batch_layers: u64,
    direct_emitters: u32,
    direct_mirrors: u32,
}

impl Spent {
    fn of(prop: &transport::Propagator, tiles: Option<&crate::lightfield::TileField>) -> Spent {
        let ledger_bytes = |keep: fn(&str) -> bool| -> u64 {
            prop.ledger
                .entries()
                .iter()
                .filter(|(n, _)| keep(n))
                .map(|(_, b)| b)
                .sum()
        };
        Spent {
            non_diffuse_elements: tiles.map_or(0, |t| t.total.len() as u64),
            tile_bytes: ledger_bytes(|n| n.contains("tile")),
            texture_bytes: ledger_bytes(|n| n.starts_with("texture")),
            memory_bytes: prop.memory_bytes(),
            memory: report::memory_items(prop.ledger.entries()),
            iterations: prop.iteration,
            largest_batch_layers: prop.largest_batch_layers,
            direct_emitters: prop.direct.as_ref().map_or(0, |d| d.emitter_count),
            direct_mirrors: prop.direct.as_ref().map_or(0, |d| d.mirror_count),
        }
    }
}

impl<'a> Job<'a> {
    fn prepare(scene: &'a crate::scene::Scene, params: &'a PropagationParams) -> Result<Job<'a>> {
        Ok(Job {
            scene,
            params,
            prepared: PreparedScene::new(scene, params.texel_density)?,
            directions: DirectionSet::geodesic(params.geodesic_frequency),
        })
    }

    /// What the progress shows while the visibility lists are built.
    fn first_stage(&self, batch_plan: &BatchPlan) -> String {
        match batch_plan.resident() {
            true => format!(
                "visibility: {} directions x {}^2 cells",
                self.directions.len(),
                self.params.grid_resolution
            ),
            false => format!(
                "{} batches of {} directions (rebuilt every iteration)",
                batch_plan.batches, batch_plan.batch_size
            ),
        }
    }

    /// The preparation's warnings, then the batching's reason and the faces smaller than a cell.
    fn setup_warnings(&self, batch_plan: &BatchPlan) -> Vec<String> {
        let (prepared, params) = (&self.prepared, self.params);
        let mut warnings = prepared.warnings.clone();
        if let Some(reason) = &batch_plan.reason {
            warnings.push(format!(
                "visibility in {} batches of {} directions, rebuilt every iteration: {reason}",
                batch_plan.batches, batch_plan.batch_size
            ));
        }
        // faces smaller than a grid cell: no cell line may cross them, so their texels rely on
        // the depth fallback; say how many and how much of the scene they are
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
        warnings
    }

    /// The state to start shooting from: `plan`'s checkpoint when resuming, else nothing shot.
    fn resume(
        &self,
        prop: &mut transport::Propagator,
        plan: Option<&checkpoint::CheckpointPlan>,
        warnings: &mut Vec<String>,
    ) -> Result<Shooting> {
        let mut start = Shooting {
            per_iteration: Vec::new(),
            residual: 1.0,
            tail: None,
        };
        if let Some(plan) = plan.filter(|p| p.resume && p.path.exists()) {
            let cp = checkpoint::Checkpoint::load(&plan.path)?;
            cp.check(&self.scene.hash, self.params, &plan.path)?;
            prop.restore(&cp)?;
            start.per_iteration = cp
                .meta
                .residuals
                .iter()
                .enumerate()
                .map(|(i, &r)| transport::IterationStats {
                    iteration: i as u32 + 1,
                    residual: r,
                    gpu_ms: None,
                    wall_ms: 0.0,
                    power: None,
                })
                .collect();
            start.residual = start.per_iteration.last().map_or(1.0, |s| s.residual);
            warnings.push(format!(
                "resumed from {} at iteration {}",
                plan.path.display(),
                cp.meta.iteration
            ));
        }
        Ok(start)
    }

    /// The shooting iterations, to the tolerance, the iteration cap or a geometric tail.
    fn shoot(
        &self,
        prop: &mut transport::Propagator,
        progress: &dyn Progress,
        plan: Option<&checkpoint::CheckpointPlan>,
        warnings: &mut Vec<String>,
    ) -> Result<Shooting> {
        let params = self.params;
        let mut run = self.resume(prop, plan, warnings)?;
        if prop.emitted_power <= 0.0 && self.scene.sky.is_none() {
            warnings.push("the scene has no emitter (no Ke, no emission override, no sky): the light field is black".into());
            run.residual = 0.0;
            return Ok(run);
        }
        // written so that a NaN residual keeps iterating (and is caught by the iteration's checks)
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let unconverged = |residual: f64| !(residual < params.tolerance);
        while prop.iteration < params.max_iterations && unconverged(run.residual) {
            let stats = prop.iterate()?;
            run.residual = stats.residual;
            let done = (run.residual.max(1e-300).ln() / params.tolerance.ln()).clamp(0.0, 1.0);
            progress.advance_to(
                (done * PROGRESS_STEPS as f64) as u64,
                &format!(
                    "iteration {} residual {:.2e} (target {:.0e})",
                    stats.iteration, run.residual, params.tolerance
                ),
            );
            run.per_iteration.push(stats);
            if let Some(plan) =
                plan.filter(|p| p.every > 0 && prop.iteration.is_multiple_of(p.every))
            {
                self.save_checkpoint(prop, &run.per_iteration, plan)?;
            }
            if run.residual < params.tolerance {
                break;
            }
            if let Some(tail) = self.geometric_tail(prop, &run)? {
                run.residual = tail.uncertainty;
                run.tail = Some(tail);
                break;
            }
        }
        Ok(run)
    }

    /// The propagator's state after `per_iteration`, saved to `plan`'s checkpoint.
    fn save_checkpoint(
        &self,
        prop: &transport::Propagator,
        per_iteration: &[transport::IterationStats],
        plan: &checkpoint::CheckpointPlan,
    ) -> Result<()> {
        checkpoint::Checkpoint {
            meta: checkpoint::CheckpointMeta {
                vlf_version: env!("CARGO_PKG_VERSION").into(),
                scene_hash: self.scene.hash.clone(),
                params: self.params.clone(),
                iteration: prop.iteration,
                emitted_power: prop.emitted_power,
                residuals: per_iteration.iter().map(|s| s.residual).collect(),
            },
            unshot: prop.read_unshot()?,
            total: prop.read_total()?,
            tile_unshot: prop.read_tile_unshot()?,
            tile_total: prop.read_tile_total()?,
        }
        .save(&plan.path)
    }

    /// The geometric tail, added to the propagator's totals, once the decay ratio is stable.
    /// The unshot state decays geometrically once its shape settles: when the decay ratio is
    /// stable enough that the tail it predicts is known to the tolerance, add that tail and
    /// stop. The tail is U r/(1-r); an error dr in r moves it by U dr/(1-r)^2, which relative
    /// to the converged total (about emitted/(1-r)) is residual * dr / (1-r).
    ///
    /// dr is the larger of the last two changes of the ratio (three ratios, four iterations),
    /// not the last one alone: two early ratios can agree by chance while the shape still
    /// settles. The glossy Cornell box (GGX alpha 0.3) at default settings had ratios 0.488,
    /// 0.485, then 0.517 ... 0.542: a tail after 3 iterations (10.6% of the power unshot) left
    /// its ceiling 6% too dark and its back wall 2-4% too bright against Mitsuba, although the
    /// image mean was right; plain shooting and a tail after 6 or more iterations agree within
    /// 1-2% everywhere (docs/results/h100/tail/).
    fn geometric_tail(
        &self,
        prop: &mut transport::Propagator,
        run: &Shooting,
    ) -> Result<Option<Tail>> {
        let params = self.params;
        if !params.accelerate {
            return Ok(None);
        }
        let residuals: Vec<f64> = run.per_iteration.iter().map(|s| s.residual).collect();
        let Some((r, uncertainty)) = settled_decay(&residuals, params.tolerance) else {
            return Ok(None);
        };
        prop.add_tail(r / (1.0 - r))?;
        Ok(Some(Tail {
            ratio: r,
            factor: r / (1.0 - r),
            uncertainty,
            plain_iterations_estimate: plain_estimate(
                run.residual,
                r,
                residuals.len() as u32,
                params.tolerance,
            ),
        }))
    }

    /// The light field and the report, from the propagator's final state; the light field is
    /// saved to `save` (where given) while the power balance is probed on the GPU.
    fn finish(
        &self,
        ctx: &crate::gpu::GpuContext,
        mut prop: transport::Propagator,
        mut measured: Measured,
        save: Option<&std::path::Path>,
    ) -> Result<Propagated> {
        let mut laps = crate::stats::Laps::default();
        let total = prop.read_total()?;
        laps.lap("read back");
        let (faces, materials) = (prop.faces.clone(), prop.materials.clone());
        let mut detail = crate::lightfield::textures::SurfaceDetail::of(self.scene, &self.prepared);
        if let Some(d) = detail.as_mut().filter(|d| !d.face_normal_maps.is_empty()) {
            let vectors = prop.light_vectors()?;
            d.texel_directions = crate::lightfield::normal_map::texel_directions(
                vectors.as_ref(),
                &total,
                &self.prepared,
                &faces,
                &materials,
            );
        }
        let tiles = match prop.tile_layout() {
            Some(layout) => Some(crate::lightfield::TileField {
                rects: layout.rects.clone(),
                index: layout.index.clone(),
                total: prop.read_tile_total()?,
                face_count: layout.faces.len() as u32,
            }),
            None => None,
        };
        laps.lap("surface detail and tiles");
        let spent = Spent::of(&prop, tiles.as_ref());
        let render_vertices = crate::lightfield::render_vertices(&self.prepared);
        let mirror_chains =
            crate::lightfield::MirrorChains::of(&faces, &materials, &render_vertices);
        let lf = self.light_field(
            &measured,
            &spent,
            (faces, materials),
            render_vertices,
            total,
        );
        let lf = crate::lightfield::LightField {
            tiles,
            detail,
            ..lf
        };
        laps.lap("render mesh");
        // the balance's probes are GPU gathers: the file is written meanwhile (a 5M-triangle
        // scene's .vlf took half a second)
        let (balance, saved) = std::thread::scope(|scope| {
            let saving = save.map(|path| {
                let lf = &lf;
                scope.spawn(move || {
                    let t = std::time::Instant::now();
                    crate::lightfield::file::save(lf, path).map(|()| t.elapsed().as_secs_f64())
                })
            });
            let balance = self.power_balance(&mut prop, &lf.total, &mut measured.warnings);
            let saved = saving.map(|h| h.join().expect("the light field's writer panicked"));
            (balance, saved)
        });
        measured.power_balance = balance?;
        laps.lap(match save {
            Some(_) => "power balance and writing the file",
            None => "power balance",
        });
        let mut resident = prop.into_resident(mirror_chains.tiles_needed);
        resident
            .ledger
            .record("render mesh", (lf.render_vertices.len() * 16) as u64);
        resident.upload_detail(&lf);
        laps.lap("render buffers");
        measured.finish_phases = laps.steps;
        let mut report = self.report(ctx, measured, spent, &resident, mirror_chains);
        if let Some(seconds) = saved.transpose()? {
            report.command_phases.push((
                "write the light field (beside the power balance)".into(),
                seconds,
            ));
        }
        Ok((lf, resident, report))
    }

    /// The light field of the propagation's `total` radiance, without tiles or surface detail.
    fn light_field(
        &self,
        measured: &Measured,
        spent: &Spent,
        (faces, materials): (
            Vec<crate::gpu::types::GpuFace>,
            Vec<crate::gpu::types::GpuMaterial>,
        ),
        render_vertices: Vec<crate::gpu::types::RenderVertex>,
        total: Vec<[f32; 4]>,
    ) -> crate::lightfield::LightField {
        let (scene, params, prepared) = (self.scene, self.params, &self.prepared);
        crate::lightfield::LightField {
            meta: crate::lightfield::LightFieldMeta {
                vlf_version: env!("CARGO_PKG_VERSION").into(),
                scene_name: scene.name.clone(),
                scene_hash: scene.hash.clone(),
                params: params.clone(),
                direction_count: self.directions.len() as u32,
                normalisation: prepared.normalisation,
                sky: scene.sky,
                cameras: scene.cameras.clone(),
                atlas_width: prepared.atlas.width,
                atlas_height: prepared.atlas.height,
                iterations: spent.iterations,
                residual: measured.shooting.residual,
            },
            faces,
            materials,
            render_vertices,
            total,
            tiles: None,
            detail: None,
        }
    }

    /// The summary of the propagation (after the paper's Table 1).
    fn report(
        &self,
        ctx: &crate::gpu::GpuContext,
        measured: Measured,
        spent: Spent,
        resident: &crate::lightfield::ResidentLightField,
        mirror_chains: crate::lightfield::MirrorChains,
    ) -> report::PropagationReport {
        let (scene, params, prepared) = (self.scene, self.params, &self.prepared);
        let (batch_plan, shooting) = (&measured.batch_plan, measured.shooting);
        let residual = shooting.residual;
        report::PropagationReport {
            scene: scene.name.clone(),
            adapter: ctx.summary.clone(),
            params: params.clone(),
            directions: self.directions.len() as u32,
            faces: prepared.faces.len() as u32,
            triangles: prepared.triangles.len() as u32,
            diffuse_elements: prepared.atlas.charted_texels,
            non_diffuse_elements: spent.non_diffuse_elements,
            specular_faces_without_tiles: crate::prepare::packing::specular_faces_without_tiles(
                prepared,
            ) as u64,
            tile_bytes: spent.tile_bytes,
            texture_bytes: spent.texture_bytes,
            host_textures: scene.texture_memory,
            layers: measured.layers.max(spent.largest_batch_layers),
            visibility_kept_resident: batch_plan.resident(),
            direction_batches: batch_plan.batches,
            directions_per_batch: batch_plan.batch_size,
            setup_seconds: measured.setup_seconds,
            setup_phases: measured.setup_phases,
            finish_seconds: measured.finish_phases.iter().map(|p| p.1).sum(),
            finish_phases: measured.finish_phases,
            command_phases: Vec::new(),
            visibility_seconds: measured.visibility_seconds,
            visibility_gpu_ms: measured.visibility_gpu_ms,
            propagation_seconds: measured.propagation_seconds,
            iterations: spent.iterations,
            final_residual: residual,
            converged: residual < params.tolerance,
            plain_iterations_estimate: shooting.tail.as_ref().map(|t| t.plain_iterations_estimate),
            tail: shooting.tail,
            per_iteration: shooting.per_iteration,
            propagation_memory_bytes: spent.memory_bytes,
            propagation_memory: spent.memory,
            render_memory_bytes: resident.ledger.total(),
            mirror_rendering: Some(mirror_chains),
            direct_emitters: spent.direct_emitters,
            direct_mirrors: spent.direct_mirrors,
            render_memory: report::memory_items(resident.ledger.entries()),
            sky: scene.sky.is_some(),
            power_balance: measured.power_balance,
            warnings: measured.warnings,
        }
    }

    /// The run's power balance (None when resumed). Where it is off, each of the materials that
    /// sent the most light is probed for the share of it the transport loses, and the verdict
    /// joins the warnings.
    fn power_balance(
        &self,
        prop: &mut transport::Propagator,
        total: &[[f32; 4]],
        warnings: &mut Vec<String>,
    ) -> Result<Option<report::PowerBalance>> {
        let Some(account) = prop.power.clone() else {
            return Ok(None);
        };
        let mut balance = report::PowerBalance::of(&account);
        if balance.off {
            balance.losses = self.material_losses(prop, total, account.injected())?;
        }
        balance.set_verdict();
        if balance.off {
            warnings.push(balance.verdict.clone());
        }
        Ok(Some(balance))
    }

    /// What the transport loses of each material's light: the materials that sent the most
    /// (pi x total radiance x area over their texels, emission included), at most
    /// `PROBED_MATERIALS`, each sent once more through the gather alone (`Propagator::probe`),
    /// largest loss first. Linear transport: the losses of all materials' light add up to the
    /// gathers' part of the residue.
    fn material_losses(
        &self,
        prop: &mut transport::Propagator,
        total: &[[f32; 4]],
        injected: f64,
    ) -> Result<Vec<report::MaterialLoss>> {
        let prepared = &self.prepared;
        let weights = std::mem::take(&mut prop.texel_weights);
        let material: Vec<Option<usize>> = (prepared.atlas.points.iter())
            .map(|p| match p[3].to_bits() {
                NO_FACE => None,
                f => Some(prepared.faces[f as usize].material as usize),
            })
            .collect();
        let radiosity = |t: &[f32; 4]| [t[0], t[1], t[2], 0.0].map(|v| v * std::f32::consts::PI);
        let mut sent = vec![0.0f64; prepared.materials.len()];
        for ((t, m), w) in total.iter().zip(&material).zip(&weights) {
            if let Some(m) = m {
                sent[*m] += radiosity(t).iter().map(|&v| v as f64).sum::<f64>() * *w as f64;
            }
        }
        let mut order: Vec<usize> = (0..sent.len()).filter(|&m| sent[m] > 0.0).collect();
        order.sort_by(|a, b| sent[*b].total_cmp(&sent[*a]));
        order.truncate(PROBED_MATERIALS);
        let mut losses = Vec::new();
        for m in order {
            let unshot: Vec<[f32; 4]> = (total.iter().zip(&material))
                .map(|(t, &mat)| match mat == Some(m) {
                    true => radiosity(t),
                    false => [0.0; 4],
                })
                .collect();
            let [sent, received, escaped, backs] = prop.probe(&unshot, &weights)?;
            let lost = sent - received - escaped - backs;
            losses.push(report::MaterialLoss {
                material: prepared.materials[m].name.clone(),
                sent,
                lost,
                lost_fraction: lost / sent.max(1e-300),
                share_of_injected: lost / injected.max(1e-300),
            });
        }
        losses.sort_by(|a, b| b.lost.abs().total_cmp(&a.lost.abs()));
        Ok(losses)
    }
}

/// Materials probed for their share of a power balance that is off (the ones that sent the
/// most light): each probe costs one more gather.
const PROBED_MATERIALS: usize = 8;

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

/// The decay ratio r of the residuals after each iteration so far, and the tail's uncertainty,
/// once that is below `tolerance` (`Job::geometric_tail` says why): the last residual times dr
/// / (1 - r), dr the larger of the last two changes of the ratio. None before four iterations,
/// for a ratio outside (0, 0.9999), or while the ratio is not settled enough.
fn settled_decay(residuals: &[f64], tolerance: f64) -> Option<(f64, f64)> {
    let n = residuals.len();
    if n < 4 {
        return None;
    }
    let ratio = |k: usize| residuals[k] / residuals[k - 1].max(1e-300);
    let (r, r1, r2) = (ratio(n - 1), ratio(n - 2), ratio(n - 3));
    let dr = (r - r1).abs().max((r1 - r2).abs());
    let uncertainty = residuals[n - 1] * dr / (1.0 - r);
    (r > 0.0 && r < 0.9999 && uncertainty < tolerance).then_some((r, uncertainty))
}

/// Iterations plain shooting needs from residual `residual` after `done` iterations, decaying by
/// `r` per iteration, to fall below `tolerance`.
fn plain_estimate(residual: f64, r: f64, done: u32, tolerance: f64) -> u32 {
    if residual <= tolerance {
        return done;
    }
    done + ((tolerance / residual).ln() / r.ln()).ceil().max(0.0) as u32
}

#[cfg(test)]
mod tests {
    use super::settled_decay;

    /// The texel areas are the same to the bit on any number of threads (each texel's terms
    /// summed in the triangles' order), and add up to the scene's open area.
    #[test]
    fn texel_areas_are_the_same_on_any_number_of_threads() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell/scene.toml");
        let scene = crate::scene::Scene::load(&path).unwrap();
        let prepared = crate::prepare::PreparedScene::new(&scene, 16.0).unwrap();
        let one = super::texel_areas_on(&prepared, 1);
        for threads in [2, 3, 8] {
            let many = super::texel_areas_on(&prepared, threads);
            assert!(
                one.iter()
                    .zip(&many)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{threads} threads"
            );
        }
        assert!(one.iter().sum::<f64>() > 0.0);
    }

    /// The glossy Cornell box at GGX alpha 0.3, default settings, plain shooting on an H100
    /// (docs/results/h100/tail/before/): its first two ratios agree (0.4882, 0.4848) while
    /// the ratio still rises to 0.54. No tail until three ratios agree: after 6 iterations,
    /// as the H100 run after the fix stopped.
    #[test]
    fn the_tail_waits_for_three_ratios_that_agree() {
        let residuals = [0.4973, 0.2428, 0.1177, 0.06081, 0.03118, 0.01646, 0.008694];
        let first_tail = (1..=residuals.len())
            .find(|&n| settled_decay(&residuals[..n], 1e-3).is_some())
            .unwrap();
        assert_eq!(first_tail, 6);
        let (r, uncertainty) = settled_decay(&residuals[..6], 1e-3).unwrap();
        assert!(
            (r - 0.5279).abs() < 1e-3 && uncertainty < 1e-3,
            "{r} {uncertainty}"
        );
        // a furnace's constant ratio: a tail as soon as there are three ratios
        let furnace: Vec<f64> = (1..=4).map(|k| 0.99f64.powi(k)).collect();
        assert!(settled_decay(&furnace[..3], 1e-3).is_none());
        assert!(settled_decay(&furnace, 1e-3).is_some_and(|(r, _)| (r - 0.99).abs() < 1e-12));
    }
}
