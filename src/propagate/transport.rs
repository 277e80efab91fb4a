//! Drives the transport stages: `shaders/propagate.wgsl` (diffuse-only scenes),
//! `shaders/specular.wgsl` (scenes with mirrors: texels and tile cells) and
//! `shaders/accumulate.wgsl`. Shooting iterations with unshot / next / total, ping-ponging
//! unshot and next, until the residual (unshot power over emitted power) falls below the
//! tolerance. With K perturbed direction sets, each iteration gathers once per set, rebuilding
//! the visibility lists for each (memory unchanged, time about x K). When the lists of every
//! direction do not fit (a memory budget, or one binding), directions come in batches: each
//! batch builds its lists and adds raw sums, and `shaders/normalize.wgsl` closes the iteration.

use super::visibility::{SceneBuffers, Visibility, VisibilityPipelines};
use super::{
    gpu_directions, gpu_faces, initial_radiance, non_diffuse_faces, BatchPlan, PropagationParams,
    DEPTH_EPSILON,
};
use crate::error::Result;
use crate::gpu::types::{
    GpuAccumulate, GpuDirection, GpuFace, GpuGrid, GpuPageRange, GRID_FLAG_ACCUMULATE,
    GRID_FLAG_BATCHED, GRID_FLAG_NO_MIRROR_SENDERS, GRID_FLAG_SKY,
};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, Timestamps, STORAGE};
use crate::lightfield::directions::DirectionSet;
use crate::lightfield::tiles::{TileLayout, TilePages};
use crate::lightfield::ResidentLightField;
use crate::prepare::PreparedScene;
use std::sync::Arc;

/// One finished iteration.
#[derive(Clone, Debug, serde::Serialize)]
pub struct IterationStats {
    pub iteration: u32,
    pub residual: f64,
    /// GPU milliseconds of the gathers and accumulations, when timestamps are available
    pub gpu_ms: Option<f64>,
    pub wall_ms: f64,
}

/// One kind of element (texels, or tile cells): unshot/next ping-pong, total, power weights.
struct ElementState {
    radiance: [wgpu::Buffer; 2],
    total: wgpu::Buffer,
    partials: wgpu::Buffer,
    partial_count: u32,
    params: wgpu::Buffer,
    count: u32,
}

impl ElementState {
    /// All zero (mirror tiles start dark): allocated on the GPU, which zeroes new buffers,
    /// instead of uploading zeros (1.4 GiB of tiles at Cornell-mirror's defaults).
    fn zeroed(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        what: &str,
        count: u32,
        scale: f32,
    ) -> ElementState {
        let (ax, ay) = dispatch_2d(count.div_ceil(256));
        let params = GpuAccumulate {
            count,
            scale,
            ..Default::default()
        };
        let bytes = count as u64 * 16;
        ElementState {
            radiance: [
                ctx.buffer_zeroed(ledger, &format!("{what}: unshot"), bytes, STORAGE),
                ctx.buffer_zeroed(ledger, &format!("{what}: next"), bytes, STORAGE),
            ],
            total: ctx.buffer_zeroed(ledger, &format!("{what}: total"), bytes, STORAGE),
            partials: ctx.buffer_zeroed(
                ledger,
                &format!("{what}: power sums"),
                (ax * ay) as u64 * 8,
                STORAGE,
            ),
            partial_count: ax * ay,
            params: ctx.buffer_init(
                ledger,
                &format!("{what}: accumulate parameters"),
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::UNIFORM,
            ),
            count,
        }
    }

    fn new(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        what: &str,
        unshot: &[[f32; 4]],
        total: &[[f32; 4]],
        scale: f32,
    ) -> ElementState {
        let count = unshot.len() as u32;
        let (ax, ay) = dispatch_2d(count.div_ceil(256));
        let params = GpuAccumulate {
            count,
            scale,
            ..Default::default()
        };
        ElementState {
            radiance: [
                ctx.buffer_init(
                    ledger,
                    &format!("{what}: unshot"),
                    bytemuck::cast_slice(unshot),
                    STORAGE,
                ),
                ctx.buffer_zeroed(ledger, &format!("{what}: next"), count as u64 * 16, STORAGE),
            ],
            total: ctx.buffer_init(
                ledger,
                &format!("{what}: total"),
                bytemuck::cast_slice(total),
                STORAGE,
            ),
            partials: ctx.buffer_zeroed(
                ledger,
                &format!("{what}: power sums"),
                (ax * ay) as u64 * 8,
                STORAGE,
            ),
            partial_count: ax * ay,
            params: ctx.buffer_init(
                ledger,
                &format!("{what}: accumulate parameters"),
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::UNIFORM,
            ),
            count,
        }
    }
}

/// One page of elements (texels, or mirror tile cells; at most one binding): its state, power
/// weights, and the uniform telling the gather which elements it holds.
struct Page {
    state: ElementState,
    power_weight: wgpu::Buffer,
    first: u32,
    page_uniform: wgpu::Buffer,
}

/// The mirror tiles of a scene with non-diffuse faces.
struct Tiles {
    layout: TileLayout,
    pages: Vec<Page>,
    page_plan: TilePages,
    tables: [wgpu::Buffer; 5],
    fixed_directions: wgpu::Buffer,
    layout2: wgpu::BindGroupLayout,
    gather_pipe: wgpu::ComputePipeline,
}

pub struct Propagator {
    pub ctx: Arc<GpuContext>,
    pub ledger: MemoryLedger,
    pub grid: GpuGrid,
    pub scene: SceneBuffers,
    pub visibility: Option<Visibility>,
    visibility_pipelines: VisibilityPipelines,
    pub faces: Vec<GpuFace>,
    /// the texel arrays in pages (one for any atlas that fits one binding)
    texels: Vec<Page>,
    texel_pages: TilePages,
    tiles: Option<Tiles>,
    /// map_Kd factors per texel (per page) and their pass; None for an untextured scene
    texture: Option<(
        Vec<wgpu::Buffer>,
        wgpu::ComputePipeline,
        wgpu::BindGroupLayout,
    )>,
    /// the K direction sets (only kept when K > 1, or with batches)
    direction_sets: Vec<Vec<GpuDirection>>,
    /// (first direction, count) per batch; one batch keeps the lists resident
    batches: Vec<(u32, u32)>,
    /// per texel then per tile cell, the quadrature weights gathered so far (batches only;
    /// a placeholder otherwise) and the pass that divides by them
    weight_sums: wgpu::Buffer,
    normalize: Option<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
    /// the largest layer count of any batch (batches only)
    pub largest_batch_layers: u64,
    pub plan: BatchPlan,
    /// which of the two radiance buffers holds unshot
    current: usize,
    gather_pipe: wgpu::ComputePipeline,
    accumulate_pipe: wgpu::ComputePipeline,
    layout0: wgpu::BindGroupLayout,
    layout1: wgpu::BindGroupLayout,
    accumulate_layout: wgpu::BindGroupLayout,
    /// power emitted by surfaces and received from the sky, r+g+b
    pub emitted_power: f64,
    pub iteration: u32,
    pub texel_count: u32,
    timestamps: Option<Timestamps>,
    /// direct light for the first iteration's texels; None: through the fixed directions
    pub direct: Option<super::direct::DirectLight>,
}

fn dispatch_2d(groups: u32) -> (u32, u32) {
    let x = groups.clamp(1, 65535);
    (x, groups.div_ceil(x).max(1))
}

impl Propagator {
    pub fn new(
        ctx: Arc<GpuContext>,
        prepared: &PreparedScene,
        params: &PropagationParams,
        directions: &DirectionSet,
        sky: Option<[f32; 3]>,
        plan: Option<&BatchPlan>,
    ) -> Result<Propagator> {
        let ledger = MemoryLedger::default();
        let device = &ctx.device;
        let fixed = gpu_directions(&directions.directions);
        let non_diffuse = non_diffuse_faces(prepared);
        let layout = if non_diffuse.iter().any(|&n| n) {
            let mut tris: Vec<Vec<[glam::DVec3; 3]>> = vec![Vec::new(); prepared.faces.len()];
            for t in &prepared.triangles {
                tris[t.face as usize].push(t.vertices.map(|v| prepared.positions[v as usize]));
            }
            let normals: Vec<glam::DVec3> = prepared.faces.iter().map(|f| f.normal).collect();
            TileLayout::build(
                &fixed,
                &normals,
                &tris,
                &non_diffuse,
                params.grid_resolution,
                params.tile_size,
            )
        } else {
            TileLayout::default()
        };
        let tile_slot = if layout.face_slot.is_empty() {
            vec![crate::gpu::types::NO_FACE; prepared.faces.len()]
        } else {
            layout.face_slot.clone()
        };
        let faces = gpu_faces(prepared, &tile_slot);
        let texel_count = prepared.atlas.texel_count() as u32;
        let limits = ctx.limits();
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let texel_pages = TilePages::plan_texels(texel_count as u64, max_binding)?;
        let texel_ranges = texel_pages.ranges();
        // a per-page copy of a per-texel array
        let paged = |name: &str, data: &[u8], bytes_per: usize| -> Vec<wgpu::Buffer> {
            texel_ranges
                .iter()
                .map(|&(first, n)| {
                    ctx.buffer_init(
                        &ledger,
                        name,
                        &data[first as usize * bytes_per..(first + n) as usize * bytes_per],
                        STORAGE,
                    )
                })
                .collect()
        };
        let cells_per_tile = params.tile_size * params.tile_size;
        let tile_cells = layout.headers.len() as u64 * cells_per_tile as u64;
        let tile_pages = TilePages::plan(tile_cells, cells_per_tile, max_binding)?;
        // decided before anything is allocated, now that the tiles' size is known
        let plan = match plan {
            Some(p) => p.clone(),
            None => {
                let estimate = super::estimate_memory(prepared, directions, params);
                // tile radiance x3 and power weights, tables; with batches, a weight sum per element
                let tile_bytes = tile_cells * (16 * 3 + 4)
                    + layout.headers.len() as u64 * 16
                    + layout.index.len() as u64 * 4
                    + layout.rects.len() as u64 * 16;
                let batch_sums = (texel_count as u64 + tile_cells) * 4;
                let limits = ctx.limits();
                let max_binding = limits
                    .max_storage_buffer_binding_size
                    .min(limits.max_buffer_size);
                super::plan_batches(
                    &estimate,
                    params,
                    directions.len() as u32,
                    max_binding,
                    estimate.texel_bytes + tile_bytes + batch_sums,
                )?
            }
        };
        let k = params.perturb.max(1);
        let batched = !plan.resident();
        let grid = GpuGrid {
            resolution: params.grid_resolution,
            direction_count: directions.len() as u32,
            triangle_count: prepared.triangles.len() as u32,
            triangle_base: 0,
            texel_count,
            atlas_width: prepared.atlas.width,
            iteration: 0,
            flags: 0,
            sky: sky.unwrap_or([0.0; 3]),
            cell_size: 2.0 / params.grid_resolution as f32,
            depth_epsilon: DEPTH_EPSILON,
            geodesic_frequency: params.geodesic_frequency,
            tile_size: params.tile_size,
            tile_face_count: layout.faces.len() as u32,
            direction_weight: 1.0 / k as f32,
            tile_cell_count: tile_cells as u32,
            tile_page_cells: tile_pages.page_cells,
            texel_page_cells: texel_pages.page_cells,
            ..Default::default()
        };
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let vertices: Vec<[f32; 4]> = prepared
            .positions
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0])
            .collect();
        let triangles: Vec<[u32; 4]> = prepared
            .triangles
            .iter()
            .map(|t| [t.vertices[0], t.vertices[1], t.vertices[2], t.face])
            .collect();
        let scene = SceneBuffers {
            grid: ctx.buffer_init(
                &ledger,
                "grid parameters",
                bytemuck::bytes_of(&grid),
                uniform,
            ),
            // with batches this holds one batch at a time
            directions: ctx.buffer_init(
                &ledger,
                "directions",
                bytemuck::cast_slice(&fixed[..plan.batch_size as usize]),
                STORAGE,
            ),
            faces: ctx.buffer_init(&ledger, "faces", bytemuck::cast_slice(&faces), STORAGE),
            vertices: ctx.buffer_init(
                &ledger,
                "vertices",
                bytemuck::cast_slice(&vertices),
                STORAGE,
            ),
            triangles: ctx.buffer_init(
                &ledger,
                "triangles",
                bytemuck::cast_slice(&triangles),
                STORAGE,
            ),
            texel_points: paged(
                "texel sample points",
                bytemuck::cast_slice(&prepared.atlas.points),
                16,
            ),
        };
        // power per unit of radiosity: texel area x coverage
        let texel_area = 1.0 / (prepared.texel_density * prepared.texel_density);
        let weights: Vec<f32> = prepared
            .atlas
            .coverage
            .iter()
            .map(|&c| (c as f64 * texel_area) as f32)
            .collect();
        let (unshot, total) = initial_radiance(prepared, &faces);
        let emitted_power = unshot
            .iter()
            .zip(&weights)
            .map(|(u, &w)| (u[0] as f64 + u[1] as f64 + u[2] as f64) * w as f64)
            .sum();
        let texels: Vec<Page> = texel_ranges
            .iter()
            .map(|&(first, n)| {
                let r = first as usize..(first + n) as usize;
                let range = GpuPageRange {
                    base: first,
                    cells: n,
                    ..Default::default()
                };
                Page {
                    state: ElementState::new(
                        &ctx,
                        &ledger,
                        "texels",
                        &unshot[r.clone()],
                        &total[r.clone()],
                        std::f32::consts::FRAC_1_PI,
                    ),
                    power_weight: ctx.buffer_init(
                        &ledger,
                        "texels: power weights",
                        bytemuck::cast_slice(&weights[r]),
                        STORAGE,
                    ),
                    first,
                    page_uniform: ctx.buffer_init(
                        &ledger,
                        "texels: page",
                        bytemuck::bytes_of(&range),
                        wgpu::BufferUsages::UNIFORM,
                    ),
                }
            })
            .collect();

        // grid, directions, faces, cell offsets, counts, layers, four pages of texel points
        let layout0 = reflect::layout(device, "propagate.wgsl", 0)?;
        // four pages of unshot, the page of next written, its range, the batches' weight sums
        let layout1 = reflect::layout(device, "propagate.wgsl", 1)?;
        let accumulate_layout = reflect::layout(device, "accumulate.wgsl", 0)?;
        let accumulate_module = shaders::module(device, "accumulate.wgsl")?;
        let accumulate_pipe =
            ctx.compute_pipeline(&accumulate_module, "accumulate", &[&accumulate_layout]);
        let (gather_pipe, tiles) = if layout.is_empty() {
            let module = shaders::module(device, "propagate.wgsl")?;
            (
                ctx.compute_pipeline(&module, "gather", &[&layout0, &layout1]),
                None,
            )
        } else {
            let module = shaders::module(device, "specular.wgsl")?;
            // tables, fixed directions, four pages of unshot tile radiance, the page written, its range
            let layout2 = reflect::layout(device, "specular.wgsl", 2)?;
            let gather =
                ctx.compute_pipeline(&module, "gather_mixed", &[&layout0, &layout1, &layout2]);
            let gather_tiles =
                ctx.compute_pipeline(&module, "gather_tiles", &[&layout0, &layout1, &layout2]);
            let (points, index) = directions.gpu_tables();
            let h = grid.cell_size as f64;
            let weights: Vec<f32> = layout
                .headers
                .iter()
                .flat_map(|hd| {
                    std::iter::repeat_n(
                        (h * h * directions.directions[hd[0] as usize].solid_angle) as f32,
                        cells_per_tile as usize,
                    )
                })
                .collect();
            let pages = tile_pages
                .ranges()
                .into_iter()
                .map(|(first, cells)| {
                    let range = GpuPageRange {
                        base: first,
                        cells,
                        ..Default::default()
                    };
                    Page {
                        state: ElementState::zeroed(&ctx, &ledger, "mirror tiles", cells, 1.0),
                        power_weight: ctx.buffer_init(
                            &ledger,
                            "mirror tiles: power weights",
                            bytemuck::cast_slice(
                                &weights[first as usize..(first + cells) as usize],
                            ),
                            STORAGE,
                        ),
                        first,
                        page_uniform: ctx.buffer_init(
                            &ledger,
                            "mirror tiles: page",
                            bytemuck::bytes_of(&range),
                            wgpu::BufferUsages::UNIFORM,
                        ),
                    }
                })
                .collect();
            let tiles = Tiles {
                pages,
                page_plan: tile_pages,
                tables: [
                    ctx.buffer_init(
                        &ledger,
                        "tile rectangles",
                        bytemuck::cast_slice(&layout.rects),
                        STORAGE,
                    ),
                    ctx.buffer_init(
                        &ledger,
                        "tile index",
                        bytemuck::cast_slice(&layout.index),
                        STORAGE,
                    ),
                    ctx.buffer_init(
                        &ledger,
                        "tile headers",
                        bytemuck::cast_slice(&layout.headers),
                        STORAGE,
                    ),
                    ctx.buffer_init(
                        &ledger,
                        "geodesic points",
                        bytemuck::cast_slice(&points),
                        STORAGE,
                    ),
                    ctx.buffer_init(
                        &ledger,
                        "geodesic index",
                        bytemuck::cast_slice(&index),
                        STORAGE,
                    ),
                ],
                fixed_directions: if k > 1 || batched {
                    ctx.buffer_init(
                        &ledger,
                        "fixed directions",
                        bytemuck::cast_slice(&fixed),
                        STORAGE,
                    )
                } else {
                    scene.directions.clone()
                },
                layout2,
                gather_pipe: gather_tiles,
                layout,
            };
            (gather, Some(tiles))
        };
        let texture = match &prepared.atlas.texture_albedo {
            Some(albedo) => {
                let buffer = paged(
                    "texture albedo",
                    bytemuck::cast_slice(albedo),
                    std::mem::size_of_val(&albedo[0]),
                );
                let layout = reflect::layout(device, "texture.wgsl", 0)?;
                let module = shaders::module(device, "texture.wgsl")?;
                let pipe = ctx.compute_pipeline(&module, "modulate", &[&layout]);
                Some((buffer, pipe, layout))
            }
            None => None,
        };
        let direction_sets = match (k > 1, batched) {
            (true, _) => (0..k)
                .map(|s| gpu_directions(&directions.perturbed(s)))
                .collect(),
            (false, true) => vec![fixed.clone()],
            (false, false) => Vec::new(),
        };
        let (weight_sums, normalize) = if batched {
            let elements = texel_count as u64 + tile_cells;
            let buffer = ctx.buffer_zeroed(
                &ledger,
                "batches: quadrature weight sums",
                elements * 4,
                STORAGE,
            );
            let layout = reflect::layout(device, "normalize.wgsl", 0)?;
            let module = shaders::module(device, "normalize.wgsl")?;
            (
                buffer,
                Some((
                    ctx.compute_pipeline(&module, "normalize", &[&layout]),
                    layout,
                )),
            )
        } else {
            (
                ctx.buffer_zeroed(
                    &MemoryLedger::default(),
                    "weight sums placeholder",
                    16,
                    STORAGE,
                ),
                None,
            )
        };
        let timestamps = Timestamps::new(&ctx, 4 + 2 * k + 2 * tile_pages.pages);
        let direct = if params.direct_samples > 0 {
            let emitters = super::direct::emitters(prepared, &faces, &unshot);
            let mirrors = if params.mirror_direct {
                super::direct::mirror_triangles(prepared, &faces)
            } else {
                Vec::new()
            };
            let sky_samples = if sky.is_some_and(|s| s.iter().any(|&v| v > 0.0)) {
                params.direct_samples
            } else {
                0
            };
            Some(super::direct::DirectLight::new(
                &ctx,
                &ledger,
                prepared,
                &emitters,
                &mirrors,
                params.direct_samples,
                sky_samples,
                &layout0,
                &layout1,
            )?)
        } else {
            None
        };
        let visibility_pipelines = VisibilityPipelines::new(&ctx)?;
        Ok(Propagator {
            ctx,
            ledger,
            grid,
            scene,
            visibility: None,
            visibility_pipelines,
            faces,
            texels,
            texel_pages,
            tiles,
            texture,
            direction_sets,
            batches: plan.ranges(directions.len() as u32),
            weight_sums,
            normalize,
            largest_batch_layers: 0,
            plan,
            current: 0,
            gather_pipe,
            accumulate_pipe,
            layout0,
            layout1,
            accumulate_layout,
            emitted_power,
            iteration: 0,
            texel_count,
            timestamps,
            direct,
        })
    }

    pub fn build_visibility(&mut self) -> Result<&Visibility> {
        self.visibility = None;
        let vis = Visibility::build(
            &self.ctx,
            &self.visibility_pipelines,
            &self.ledger,
            &self.scene,
            &self.grid,
            &mut self.timestamps,
            None,
        )?;
        Ok(self.visibility.insert(vis))
    }

    pub fn tile_layout(&self) -> Option<&TileLayout> {
        self.tiles.as_ref().map(|t| &t.layout)
    }

    /// One shooting iteration (one more bounce). Returns the residual after it.
    pub fn iterate(&mut self) -> Result<IterationStats> {
        let started = std::time::Instant::now();
        let k = self.direction_sets.len().max(1);
        let batched = self.normalize.is_some();
        // perturbed sets first, the fixed set last: it stays resident for rendering and tiles
        let order: Vec<usize> = (1..k).chain([0]).collect();
        let mut gpu_ms = 0.0;
        let mut timed = self.timestamps.is_some();
        if batched {
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            for page in &self.texels {
                encoder.clear_buffer(&page.state.radiance[1 - self.current], 0, None);
            }
            encoder.clear_buffer(&self.weight_sums, 0, None);
            for page in self.tiles.iter().flat_map(|t| &t.pages) {
                encoder.clear_buffer(&page.state.radiance[1 - self.current], 0, None);
            }
            self.ctx.queue.submit([encoder.finish()]);
        }
        let batches = self.batches.clone();
        for (n, &set) in order.iter().enumerate() {
            for &(first, count) in &batches {
                let mut grid = self.grid;
                grid.direction_count = count;
                grid.first_direction = first;
                if k > 1 || batched {
                    let slice = &self.direction_sets[set][first as usize..(first + count) as usize];
                    self.ctx.queue.write_buffer(
                        &self.scene.directions,
                        0,
                        bytemuck::cast_slice(slice),
                    );
                    let previous = self.visibility.take();
                    let mut visibility_timer = if batched {
                        self.timestamps.take()
                    } else {
                        None
                    };
                    let vis = Visibility::build(
                        &self.ctx,
                        &self.visibility_pipelines,
                        &self.ledger,
                        &self.scene,
                        &grid,
                        &mut visibility_timer,
                        previous,
                    )?;
                    if batched {
                        self.timestamps = visibility_timer;
                        gpu_ms += vis.gpu_ms.unwrap_or(0.0);
                        self.largest_batch_layers = self.largest_batch_layers.max(vis.layer_count);
                    }
                    self.visibility = Some(vis);
                }
                grid.iteration = self.iteration;
                grid.flags = if self.iteration == 0 && grid.sky.iter().any(|&s| s > 0.0) {
                    GRID_FLAG_SKY
                } else {
                    0
                };
                if self.iteration == 1 && self.direct.as_ref().is_some_and(|d| d.mirror_count > 0) {
                    grid.flags |= GRID_FLAG_NO_MIRROR_SENDERS;
                }
                if batched {
                    grid.flags |= GRID_FLAG_BATCHED;
                } else if n > 0 {
                    grid.flags |= GRID_FLAG_ACCUMULATE;
                }
                self.ctx
                    .queue
                    .write_buffer(&self.scene.grid, 0, bytemuck::bytes_of(&grid));
                self.encode_gathers(set == 0)?;
                if let Some(t) = self.timestamps.as_mut() {
                    gpu_ms += t.read_ms(&self.ctx)?.iter().sum::<f64>();
                } else {
                    timed = false;
                }
            }
        }
        if batched {
            self.normalize_batches();
        }
        if self.iteration <= 1 && self.direct.is_some() {
            self.encode_direct(self.iteration == 1);
        }
        if self.iteration == 0 {
            self.encode_validity();
        }
        if let Some((albedo, pipe, layout)) = &self.texture {
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(pipe);
                for (page, albedo) in self.texels.iter().zip(albedo) {
                    let bg = self.ctx.bind_group(
                        layout,
                        &[
                            &page.state.params,
                            &page.state.radiance[1 - self.current],
                            albedo,
                        ],
                    );
                    pass.set_bind_group(0, &bg, &[]);
                    let (x, y) = dispatch_2d(page.state.count.div_ceil(256));
                    pass.dispatch_workgroups(x, y, 1);
                }
            }
            self.ctx.queue.submit([encoder.finish()]);
        }
        let (texel_power, texel_sky) = self.accumulate(false)?;
        let (tile_power, tile_sky) = if self.tiles.is_some() {
            self.accumulate(true)?
        } else {
            (0.0, 0.0)
        };
        if let Some(t) = self.timestamps.as_mut() {
            gpu_ms += t.read_ms(&self.ctx)?.iter().sum::<f64>();
        }
        if self.iteration == 0 {
            // the sky shoots once, in the first iteration: what it delivered counts as emitted
            self.emitted_power += texel_sky + tile_sky;
        }
        self.current = 1 - self.current;
        self.iteration += 1;
        let unshot_power = texel_power + tile_power;
        let residual = if self.emitted_power > 0.0 {
            unshot_power / self.emitted_power
        } else {
            0.0
        };
        Ok(IterationStats {
            iteration: self.iteration,
            residual,
            gpu_ms: timed.then_some(gpu_ms),
            wall_ms: started.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The scene bind group (group 0) and one texel-page bind group (group 1) per page: all
    /// pages' unshot to read, this page's next to write.
    fn texel_bind_groups(&self) -> (wgpu::BindGroup, Vec<wgpu::BindGroup>) {
        let current = self.current;
        self.texel_bind_groups_writing(|page| &page.state.radiance[1 - current])
    }

    /// The scene group and, per texel page, the page group with `target` bound as its output
    /// (`next`): the next radiance for the gathers, the totals for the validity marks.
    fn texel_bind_groups_writing(
        &self,
        target: impl Fn(&Page) -> &wgpu::Buffer,
    ) -> (wgpu::BindGroup, Vec<wgpu::BindGroup>) {
        let ctx = &self.ctx;
        let vis = self
            .visibility
            .as_ref()
            .expect("build_visibility before iterate");
        let s = &self.scene;
        let point = |p: usize| s.texel_points.get(p).unwrap_or(&s.texel_points[0]);
        let bg0 = ctx.bind_group(
            &self.layout0,
            &[
                &s.grid,
                &s.directions,
                &s.faces,
                &vis.cell_offset,
                &vis.cell_count,
                &vis.layers,
                point(0),
                point(1),
                point(2),
                point(3),
            ],
        );
        let current = self.current;
        let unshot =
            |p: usize| &self.texels.get(p).unwrap_or(&self.texels[0]).state.radiance[current];
        let bg1 = self
            .texels
            .iter()
            .map(|page| {
                ctx.bind_group(
                    &self.layout1,
                    &[
                        unshot(0),
                        unshot(1),
                        unshot(2),
                        unshot(3),
                        target(page),
                        &page.page_uniform,
                        &self.weight_sums,
                    ],
                )
            })
            .collect();
        (bg0, bg1)
    }

    /// The first iteration's texels take their direct light from `shaders/direct.wgsl`
    /// (overwriting what the gather found through the fixed directions: emitters and sky); with
    /// `mirrors`, the second iteration's texels add the emitters seen in mirrors to their gather.
    fn encode_direct(&self, mirrors: bool) {
        if mirrors && self.direct.as_ref().is_some_and(|d| d.mirror_count == 0) {
            return;
        }
        let current = self.current;
        self.encode_direct_stage(
            "direct light",
            |page| &page.state.radiance[1 - current],
            |d, pass, bg0, pages| d.encode(pass, bg0, pages, mirrors),
        );
    }

    /// Mark the texels inside closed geometry in w of their totals (`texel_validity`), for the
    /// renderer's lookups; without direct light (the paper's settings) nothing is marked and
    /// the renderer interpolates every texel.
    fn encode_validity(&self) {
        self.encode_direct_stage(
            "texel validity",
            |page| &page.state.total,
            |d, pass, bg0, pages| d.encode_validity(pass, bg0, pages),
        );
    }

    /// One pass of the direct-light stage over every texel page, with `target` bound as each
    /// page's output; nothing without direct light.
    fn encode_direct_stage(
        &self,
        label: &str,
        target: impl Fn(&Page) -> &wgpu::Buffer,
        record: impl FnOnce(
            &super::direct::DirectLight,
            &mut wgpu::ComputePass,
            &wgpu::BindGroup,
            &[(&wgpu::BindGroup, u32)],
        ),
    ) {
        let Some(direct) = &self.direct else { return };
        let (bg0, bg1) = self.texel_bind_groups_writing(target);
        let pages: Vec<(&wgpu::BindGroup, u32)> = bg1
            .iter()
            .zip(&self.texels)
            .map(|(bg, page)| (bg, page.state.count))
            .collect();
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: None,
            });
            record(direct, &mut pass, &bg0, &pages);
        }
        self.ctx.queue.submit([encoder.finish()]);
    }

    fn encode_gathers(&mut self, with_tiles: bool) -> Result<()> {
        let ctx = &self.ctx;
        let (bg0, bg1) = self.texel_bind_groups();
        let current = self.current;
        // per page: every page's unshot radiance to read, and this page's next to write
        let mut bg2: Vec<wgpu::BindGroup> = Vec::new();
        if let Some(t) = &self.tiles {
            let [a, b, c, d, e] = &t.tables;
            let unshot = |p: usize| &t.pages.get(p).unwrap_or(&t.pages[0]).state.radiance[current];
            for page in &t.pages {
                let next = &page.state.radiance[1 - current];
                bg2.push(ctx.bind_group(
                    &t.layout2,
                    &[
                        a,
                        b,
                        c,
                        d,
                        e,
                        &t.fixed_directions,
                        unshot(0),
                        unshot(1),
                        unshot(2),
                        unshot(3),
                        next,
                        &page.page_uniform,
                    ],
                ));
            }
        }
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("gather"),
                timestamp_writes: self.timestamps.as_mut().and_then(|t| t.compute_writes()),
            });
            pass.set_bind_group(0, &bg0, &[]);
            if let Some(bg2) = bg2.first() {
                pass.set_bind_group(2, bg2, &[]);
            }
            pass.set_pipeline(&self.gather_pipe);
            for (page, bg) in self.texels.iter().zip(&bg1) {
                pass.set_bind_group(1, bg, &[]);
                let (x, y) = dispatch_2d(page.state.count.div_ceil(64));
                pass.dispatch_workgroups(x, y, 1);
            }
            pass.set_bind_group(1, &bg1[0], &[]);
            if let (Some(t), true) = (&self.tiles, with_tiles) {
                pass.set_pipeline(&t.gather_pipe);
                for (page, bg) in t.pages.iter().zip(&bg2) {
                    pass.set_bind_group(2, bg, &[]);
                    let (x, y) = dispatch_2d(page.state.count.div_ceil(64));
                    pass.dispatch_workgroups(x, y, 1);
                }
            }
        }
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Divide the raw sums of every batch by the quadrature weights they used.
    fn normalize_batches(&self) {
        let Some((pipe, layout)) = &self.normalize else {
            return;
        };
        let ctx = &self.ctx;
        let mut passes: Vec<(&wgpu::Buffer, u32, f32, u32)> = self
            .texels
            .iter()
            .map(|p| {
                (
                    &p.state.radiance[1 - self.current],
                    p.state.count,
                    std::f32::consts::PI,
                    p.first,
                )
            })
            .collect();
        for page in self.tiles.iter().flat_map(|t| &t.pages) {
            passes.push((
                &page.state.radiance[1 - self.current],
                page.state.count,
                1.0,
                self.texel_count + page.first,
            ));
        }
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let uniforms: Vec<wgpu::Buffer> = passes
            .iter()
            .map(|&(_, count, scale, weight_offset)| {
                let params = GpuAccumulate {
                    count,
                    scale,
                    weight_offset,
                    ..Default::default()
                };
                ctx.buffer_init(
                    &MemoryLedger::default(),
                    "normalize parameters",
                    bytemuck::bytes_of(&params),
                    wgpu::BufferUsages::UNIFORM,
                )
            })
            .collect();
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipe);
            for ((next, count, _, _), uniform) in passes.iter().zip(&uniforms) {
                let bg = ctx.bind_group(layout, &[uniform, next, &self.weight_sums]);
                pass.set_bind_group(0, &bg, &[]);
                let (x, y) = dispatch_2d(count.div_ceil(256));
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        ctx.queue.submit([encoder.finish()]);
    }

    /// total += next, and the power sums of next: (unshot power, sky's share).
    fn accumulate(&mut self, tiles: bool) -> Result<(f64, f64)> {
        let parts: Vec<(usize, bool)> = match (tiles, &self.tiles) {
            (true, Some(t)) => (0..t.pages.len()).map(|p| (p, true)).collect(),
            _ => (0..self.texels.len()).map(|p| (p, false)).collect(),
        };
        let (mut power, mut sky) = (0.0, 0.0);
        for (page, is_tile) in parts {
            let (p, s) = self.accumulate_one(page, is_tile)?;
            power += p;
            sky += s;
        }
        Ok((power, sky))
    }

    fn accumulate_one(&mut self, page: usize, tiles: bool) -> Result<(f64, f64)> {
        let ctx = &self.ctx;
        let (state, weights) = match (tiles, &self.tiles) {
            (true, Some(t)) => (&t.pages[page].state, &t.pages[page].power_weight),
            _ => (&self.texels[page].state, &self.texels[page].power_weight),
        };
        let bg = ctx.bind_group(
            &self.accumulate_layout,
            &[
                &state.params,
                &state.radiance[1 - self.current],
                &state.total,
                weights,
                &state.partials,
            ],
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("accumulate"),
                timestamp_writes: self.timestamps.as_mut().and_then(|t| t.compute_writes()),
            });
            pass.set_pipeline(&self.accumulate_pipe);
            pass.set_bind_group(0, &bg, &[]);
            let (x, y) = dispatch_2d(state.count.div_ceil(256));
            pass.dispatch_workgroups(x, y, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        let partials: Vec<[f32; 2]> =
            ctx.read_buffer(&state.partials, state.partial_count as u64 * 8)?;
        Ok((
            partials.iter().map(|p| p[0] as f64).sum(),
            partials.iter().map(|p| p[1] as f64).sum(),
        ))
    }

    /// Add the geometric tail of the series to `total`: the unshot state times `factor`
    /// (= r / (1 - r) for a stable decay ratio r), as if the remaining iterations had run.
    pub fn add_tail(&mut self, factor: f64) -> Result<()> {
        let ctx = self.ctx.clone();
        let mut states: Vec<(&ElementState, &wgpu::Buffer, f32)> = self
            .texels
            .iter()
            .map(|p| {
                (
                    &p.state,
                    &p.power_weight,
                    (factor / std::f64::consts::PI) as f32,
                )
            })
            .collect();
        for page in self.tiles.iter().flat_map(|t| &t.pages) {
            states.push((&page.state, &page.power_weight, factor as f32));
        }
        for (state, weights, scale) in states {
            let params = GpuAccumulate {
                count: state.count,
                scale,
                ..Default::default()
            };
            let uniform = ctx.buffer_init(
                &MemoryLedger::default(),
                "tail parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::UNIFORM,
            );
            let bg = ctx.bind_group(
                &self.accumulate_layout,
                &[
                    &uniform,
                    &state.radiance[self.current],
                    &state.total,
                    weights,
                    &state.partials,
                ],
            );
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&self.accumulate_pipe);
                pass.set_bind_group(0, &bg, &[]);
                let (x, y) = dispatch_2d(state.count.div_ceil(256));
                pass.dispatch_workgroups(x, y, 1);
            }
            ctx.queue.submit([encoder.finish()]);
        }
        ctx.wait()
    }

    pub fn read_total(&self) -> Result<Vec<[f32; 4]>> {
        self.read_page_list(&self.texels, |p| &p.state.total)
    }

    /// Converged mirror radiance per tile cell (empty without mirrors).
    pub fn read_tile_total(&self) -> Result<Vec<[f32; 4]>> {
        match &self.tiles {
            Some(t) => self.read_pages(t, |p| &p.state.total),
            None => Ok(Vec::new()),
        }
    }

    /// The unshot mirror radiance (empty without mirrors).
    pub fn read_tile_unshot(&self) -> Result<Vec<[f32; 4]>> {
        match &self.tiles {
            Some(t) => self.read_pages(t, |p| &p.state.radiance[self.current]),
            None => Ok(Vec::new()),
        }
    }

    /// Every page of one of the tiles' arrays, read back and joined.
    fn read_pages(
        &self,
        t: &Tiles,
        buffer: impl Fn(&Page) -> &wgpu::Buffer,
    ) -> Result<Vec<[f32; 4]>> {
        self.read_page_list(&t.pages, buffer)
    }

    fn read_page_list(
        &self,
        pages: &[Page],
        buffer: impl Fn(&Page) -> &wgpu::Buffer,
    ) -> Result<Vec<[f32; 4]>> {
        let mut out = Vec::new();
        for page in pages {
            out.extend(
                self.ctx
                    .read_buffer::<[f32; 4]>(buffer(page), page.state.count as u64 * 16)?,
            );
        }
        Ok(out)
    }

    /// Continue from a checkpoint: unshot and total state, iteration count, emitted power.
    pub fn restore(&mut self, cp: &super::checkpoint::Checkpoint) -> Result<()> {
        let sizes_match = cp.unshot.len() == self.texel_count as usize
            && cp.total.len() == self.texel_count as usize
            && cp.tile_unshot.len()
                == self
                    .tiles
                    .as_ref()
                    .map_or(0, |t| t.page_plan.total_cells as usize)
            && cp.tile_total.len() == cp.tile_unshot.len();
        if !sizes_match {
            return Err(crate::error::VlfError::Parameter {
                name: "resume",
                message: "the checkpoint's state does not fit this scene's light field".into(),
            });
        }
        let q = &self.ctx.queue;
        for page in &self.texels {
            let texels = page.first as usize..(page.first + page.state.count) as usize;
            q.write_buffer(
                &page.state.radiance[self.current],
                0,
                bytemuck::cast_slice(&cp.unshot[texels.clone()]),
            );
            q.write_buffer(
                &page.state.total,
                0,
                bytemuck::cast_slice(&cp.total[texels]),
            );
        }
        for page in self.tiles.iter().flat_map(|t| &t.pages) {
            let cells = page.first as usize..(page.first + page.state.count) as usize;
            q.write_buffer(
                &page.state.radiance[self.current],
                0,
                bytemuck::cast_slice(&cp.tile_unshot[cells.clone()]),
            );
            q.write_buffer(
                &page.state.total,
                0,
                bytemuck::cast_slice(&cp.tile_total[cells]),
            );
        }
        self.iteration = cp.meta.iteration;
        self.emitted_power = cp.meta.emitted_power;
        self.ctx.wait()
    }

    /// The unshot radiosity the next iteration will shoot (the last iteration's "next").
    pub fn read_unshot(&self) -> Result<Vec<[f32; 4]>> {
        self.read_page_list(&self.texels, |p| &p.state.radiance[self.current])
    }

    /// GPU memory while propagating.
    pub fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    /// Keep only what rendering needs; everything else is freed.
    /// What stays on the GPU for rendering; the mirror tiles only with `keep_tiles`.
    pub fn into_resident(self, keep_tiles: bool) -> ResidentLightField {
        let ledger = MemoryLedger::default();
        ledger.record("faces", self.scene.faces.size());
        for page in &self.texels {
            ledger.record("total radiance", page.state.total.size());
        }
        let tiles = self.tiles.filter(|_| keep_tiles).map(|t| {
            let [rects, index, _, points, geodesic_index] = t.tables;
            for (name, b) in [
                ("tile rectangles", &rects),
                ("tile index", &index),
                ("geodesic tables", &points),
                ("geodesic index", &geodesic_index),
            ] {
                ledger.record(name, b.size());
            }
            for page in &t.pages {
                ledger.record("mirror tiles: total radiance", page.state.total.size());
            }
            ledger.record("directions", self.scene.directions.size());
            crate::lightfield::ResidentTiles {
                rects,
                index,
                radiance: t.pages.into_iter().map(|p| p.state.total).collect(),
                pages: t.page_plan,
                geodesic_points: points,
                geodesic_index,
                directions: t.fixed_directions,
            }
        });
        ResidentLightField {
            ctx: self.ctx,
            faces: self.scene.faces,
            total: self.texels.into_iter().map(|p| p.state.total).collect(),
            texel_pages: self.texel_pages,
            tiles,
            ledger,
        }
    }
}
