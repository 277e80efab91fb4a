//! Drives the transport stages: `shaders/propagate.wgsl` (diffuse-only scenes),
//! `shaders/specular.wgsl` (scenes with mirrors: texels and tile cells) and
//! `shaders/accumulate.wgsl`. Shooting iterations with unshot / next / total, ping-ponging
//! unshot and next, until the residual (unshot power over emitted power) falls below the
//! tolerance. With K perturbed direction sets, each iteration gathers once per set, rebuilding
//! the visibility lists for each (memory unchanged, time about x K). When the lists of every
//! direction do not fit (a memory budget, or one binding), directions come in batches: each
//! batch builds its lists and adds raw sums, and `shaders/normalize.wgsl` closes the iteration.
//!
//! Every iteration also measures the power balance (`BalancePasses`, `PowerAccount`):
//! emitted + sky = absorbed + escaped + unshot + residue, each term measured on its own, in
//! r+g+b radiosity x area, every texel weighted by the exact area of its face it stands for
//! (`super::texel_areas`):
//! - emitted: the emitters' initial unshot radiosity (pi Le, map_Ke included) x area; exact.
//! - sky: the sky's irradiance x area over the texels in the first iteration (the gather's, or
//!   direct light's shadow rays); exact as delivered.
//! - received: irradiance x area at every texel. Where the albedo is positive in every channel,
//!   next / albedo: exactly what the light field took in, direct light included; on black and
//!   pure mirror faces, the gather's irradiance through the fixed directions (an estimate of
//!   what direct light gives there in the first two iterations; in the second, mirror senders
//!   count through their tiles).
//! - absorbed at the fronts: received - reflected diffusely (the texels' next unshot power,
//!   map_Kd included) - reflected by the mirror parts (mirror reflectance x irradiance); exact
//!   given received.
//! - escaped, and absorbed by the backs of one-sided faces: measured at the senders, apart from
//!   what the receivers got. A texel's share is its unshot radiosity x area x the cosine-weighted
//!   share of its own quadrature directions whose upstream lookup finds the sky (the back of a
//!   one-sided face): by reciprocity the share of its diffuse light that goes there, an estimate
//!   through the fixed directions. A mirror tile cell's is its radiance x cell area x solid angle
//!   where the first layer downstream of its face in its own cell list is nothing (a one-sided
//!   back).
//! - unshot: the texels' unshot radiosity x area, plus the mirror tiles' radiance x cell area x
//!   solid angle over the cells whose line crosses their face.
//!
//! The residue is what is left: light the transport lost (> 0) or made (< 0). Discretisation
//! moves light but makes the terms differ a little (the receivers' gathers and the senders'
//! reciprocity shares are two quadratures of the same transport, the tiles a third of the
//! mirrors'): about 0.1% on the shipped scenes. A transport that loses light (a sender read as
//! black) shows as a residue of percents.

use super::visibility::{SceneBuffers, SurfaceBuffers, Visibility, VisibilityPipelines};
use super::{
    gpu_directions, gpu_faces, gpu_materials, initial_radiance, non_diffuse_faces, BatchPlan,
    PropagationParams, DEPTH_EPSILON,
};
use crate::error::{Result, VlfError};
use crate::gpu::types::{
    GpuAccumulate, GpuDirection, GpuFace, GpuGrid, GpuMaterial, GpuPageRange, GRID_FLAG_ACCUMULATE,
    GRID_FLAG_BATCHED, GRID_FLAG_NO_MIRROR_SENDERS, GRID_FLAG_RIM_RAYS, GRID_FLAG_SKY,
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
    /// where this iteration's light went (None for iterations before a resumed checkpoint)
    pub power: Option<IterationPower>,
}

/// One iteration's power, r+g+b, in normalised units (radiosity x area): what it moved and where
/// that went. Fractions of the injected power (emitted + sky) in the table.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct IterationPower {
    /// what the texels (unshot radiosity x area) and the mirror tiles (radiance x cell area x
    /// solid angle, cells on their face) sent in this iteration
    pub shot: f64,
    /// the sky's power, received in the first iteration (part of `received`)
    pub sky: f64,
    /// power arriving at the front of every face (irradiance x area, summed over the texels)
    pub received: f64,
    /// of it: reflected diffusely (the texels' next unshot power)
    pub reflected: f64,
    /// reflected by the mirror parts (mirror reflectance x irradiance x area)
    pub mirrored: f64,
    /// absorbed at the fronts: received - reflected - mirrored, i.e. (1 - albedo - mirror) E A
    pub absorbed: f64,
    /// of what was shot: absorbed by the backs of one-sided faces
    pub absorbed_by_backs: f64,
    /// of what was shot: left for the sky
    pub escaped: f64,
    /// what is left to shoot after the iteration (texels and mirror tiles)
    pub unshot: f64,
    /// (emitted + sky - absorbed so far - escaped so far - unshot) / (emitted + sky): the light
    /// the transport lost (> 0) or made (< 0) up to here
    pub residue: f64,
}

/// The running sums of the power balance, one `close` per iteration (`transport::Propagator`).
#[derive(Clone, Debug, Default)]
pub struct PowerAccount {
    pub emitted: f64,
    pub sky: f64,
    pub absorbed: f64,
    pub absorbed_by_backs: f64,
    pub escaped: f64,
    /// what the next iteration shoots: texels; mirror tiles, and their escaping and
    /// back-absorbed parts
    texels_unshot: f64,
    tiles_unshot: [f64; 3],
}

/// What the balance passes measured in one iteration.
pub struct MeasuredPower {
    /// texel sums (received, mirrored, escaped, absorbed by backs) of shaders/propagate.wgsl's
    /// `texel_balance`
    pub texels: [f64; 4],
    /// the texels' next unshot power (shaders/accumulate.wgsl)
    pub reflected: f64,
    /// the sky's power (first iteration)
    pub sky: f64,
    /// the mirror tiles' next unshot power and its escaping and back-absorbed parts
    /// (`tile_balance`)
    pub tiles_next: [f64; 3],
}

impl PowerAccount {
    pub fn new(emitted: f64) -> PowerAccount {
        PowerAccount {
            emitted,
            texels_unshot: emitted,
            ..Default::default()
        }
    }

    pub fn injected(&self) -> f64 {
        self.emitted + self.sky
    }

    pub fn unshot(&self) -> f64 {
        self.texels_unshot + self.tiles_unshot[0]
    }

    /// The injected power that is neither absorbed, nor escaped, nor still unshot.
    pub fn residue(&self) -> f64 {
        self.injected() - self.absorbed - self.absorbed_by_backs - self.escaped - self.unshot()
    }

    /// Book one iteration.
    pub fn close(&mut self, m: &MeasuredPower) -> IterationPower {
        let shot = self.unshot() + m.sky;
        self.sky += m.sky;
        let [received, mirrored, escaped, backs] = m.texels;
        let escaped = escaped + self.tiles_unshot[1];
        let backs = backs + self.tiles_unshot[2];
        let absorbed = received - m.reflected - mirrored;
        self.absorbed += absorbed;
        self.absorbed_by_backs += backs;
        self.escaped += escaped;
        self.texels_unshot = m.reflected;
        self.tiles_unshot = m.tiles_next;
        IterationPower {
            shot,
            sky: m.sky,
            received,
            reflected: m.reflected,
            mirrored,
            absorbed,
            absorbed_by_backs: backs,
            escaped,
            unshot: self.unshot(),
            residue: self.residue() / self.injected().max(1e-300),
        }
    }
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
        let bytes = count as u64 * 16;
        let radiance = [
            ctx.buffer_zeroed(ledger, &format!("{what}: unshot"), bytes, STORAGE),
            ctx.buffer_zeroed(ledger, &format!("{what}: next"), bytes, STORAGE),
        ];
        let total = ctx.buffer_zeroed(ledger, &format!("{what}: total"), bytes, STORAGE);
        Self::around(ctx, ledger, what, count, scale, radiance, total)
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
        let radiance = [
            ctx.buffer_init(
                ledger,
                &format!("{what}: unshot"),
                bytemuck::cast_slice(unshot),
                STORAGE,
            ),
            ctx.buffer_zeroed(ledger, &format!("{what}: next"), count as u64 * 16, STORAGE),
        ];
        let total = ctx.buffer_init(
            ledger,
            &format!("{what}: total"),
            bytemuck::cast_slice(total),
            STORAGE,
        );
        Self::around(ctx, ledger, what, count, scale, radiance, total)
    }

    /// The state around its radiance buffers: the power sums and the accumulate uniform.
    fn around(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        what: &str,
        count: u32,
        scale: f32,
        radiance: [wgpu::Buffer; 2],
        total: wgpu::Buffer,
    ) -> ElementState {
        let (ax, ay) = dispatch_2d(count.div_ceil(256));
        let params = GpuAccumulate {
            count,
            scale,
            ..Default::default()
        };
        ElementState {
            radiance,
            total,
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

impl Page {
    /// The page of `what` from element `first` on, holding `state`, with its power weights.
    fn new(s: &Setup, what: &str, state: ElementState, weights: &[f32], first: u32) -> Page {
        let range = GpuPageRange {
            base: first,
            cells: state.count,
            ..Default::default()
        };
        Page {
            power_weight: s.ctx.buffer_init(
                s.ledger,
                &format!("{what}: power weights"),
                bytemuck::cast_slice(weights),
                STORAGE,
            ),
            first,
            page_uniform: s.ctx.buffer_init(
                s.ledger,
                &format!("{what}: page"),
                bytemuck::bytes_of(&range),
                wgpu::BufferUsages::UNIFORM,
            ),
            state,
        }
    }
}

/// The mirror tiles of a scene with non-diffuse faces.
struct Tiles {
    layout: TileLayout,
    pages: Vec<Page>,
    page_plan: TilePages,
    tables: [wgpu::Buffer; 5],
    fixed_directions: wgpu::Buffer,
    /// the layout uniform of the light field being propagated (`GpuField`, from the grid)
    field: wgpu::Buffer,
    /// specular.wgsl's groups: the light field's (`lightfield::bindings`), and the tiles' own
    /// (headers, the page written, its range)
    field_layout: crate::lightfield::bindings::FieldLayout,
    page_layout: wgpu::BindGroupLayout,
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
    /// the material table the faces index (the distinct materials they use)
    pub materials: Vec<GpuMaterial>,
    /// the texel arrays in pages (one for any atlas that fits one binding)
    texels: Vec<Page>,
    texel_pages: TilePages,
    tiles: Option<Tiles>,
    /// map_Kd factors per texel (per page) and their pass; None for an untextured scene
    texture: Option<TextureStage>,
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
    /// the power balance's buffers and passes
    balance: BalancePasses,
    /// the power balance's running sums; None once resumed from a checkpoint
    pub power: Option<PowerAccount>,
    /// the area each texel stands for (`super::texel_areas`, as f32): the power balance's
    /// weights, kept for the probes of a balance that is off (computing them again took a
    /// second of the finish at five million triangles)
    pub texel_weights: Vec<f32>,
    /// tests only: gather flags that turn a fixed bug back on (`GRID_FLAG_LIST_ORDER_SIDES`)
    pub regression_flags: u32,
    /// `PropagationParams::rim_rays` (GRID_FLAG_RIM_RAYS in every gather)
    rim_rays: bool,
    /// the steps of `new` and their seconds (the report's setup)
    pub setup_laps: crate::stats::Laps,
}

/// The power balance on the GPU: the gather's per-texel terms (`balance` in
/// shaders/common/upstream.wgsl), where each mirror tile cell's light goes, and the passes of
/// shaders/propagate.wgsl that sum them (`texel_balance`, `tile_classes`, `tile_balance`).
struct BalancePasses {
    /// per texel page: irradiance, its mirror part, escaping and back-absorbed own light
    texel_terms: Vec<wgpu::Buffer>,
    /// per texel page: the exact area each texel stands for (`super::texel_areas`)
    texel_areas: Vec<wgpu::Buffer>,
    texel_pipe: wgpu::ComputePipeline,
    power_pipe: wgpu::ComputePipeline,
    classes_pipe: wgpu::ComputePipeline,
    tile_pipe: wgpu::ComputePipeline,
    layout2: wgpu::BindGroupLayout,
    /// 2 bits per mirror tile cell (a placeholder without tiles)
    tile_class: wgpu::Buffer,
    /// per-workgroup sums, room for the largest page
    partials: wgpu::Buffer,
    /// bound where a pass reads nothing
    placeholder: wgpu::Buffer,
    /// whether the tile cells have been classified (once, with the fixed directions' lists)
    classified: bool,
}

/// map_Kd factors per texel page, the pass multiplying next by them, its layout.
type TextureStage = (
    Vec<wgpu::Buffer>,
    wgpu::ComputePipeline,
    wgpu::BindGroupLayout,
);

fn dispatch_2d(groups: u32) -> (u32, u32) {
    let x = groups.clamp(1, 65535);
    (x, groups.div_ceil(x).max(1))
}

/// What building a propagator reads: the GPU and its ledger, the scene, the settings.
struct Setup<'a> {
    ctx: &'a GpuContext,
    ledger: &'a MemoryLedger,
    prepared: &'a PreparedScene,
    params: &'a PropagationParams,
    directions: &'a DirectionSet,
}

/// The sizes a propagator is built to, decided before anything is allocated.
struct Sizes {
    fixed: Vec<GpuDirection>,
    layout: TileLayout,
    faces: Vec<GpuFace>,
    materials: Vec<GpuMaterial>,
    texel_pages: TilePages,
    tile_cells: u64,
    tile_pages: TilePages,
    plan: BatchPlan,
    grid: GpuGrid,
}

/// The largest buffer one storage binding can hold.
fn max_binding(ctx: &GpuContext) -> u64 {
    let limits = ctx.limits();
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
}

/// Whether some face with tiles has a specular texture (then `specular_factor_words` has words).
fn has_specular_factors(prepared: &PreparedScene, layout: &TileLayout) -> bool {
    prepared.atlas.texture_specular.is_some()
        && (layout.faces.iter()).any(|&f| has_specular_texture(prepared, f))
}

fn has_specular_texture(prepared: &PreparedScene, face: u32) -> bool {
    let material = prepared.faces[face as usize].material;
    prepared.materials[material as usize]
        .specular_texture
        .is_some()
}

/// The specular textures' factors per texel of the faces with tiles, as the tiles' gather reads
/// them after the tile headers (`shaders/specular.wgsl`, `specular_factor`): as words, per face
/// the word where its texels' factors start (NO_FACE: none), then two words per texel (rgb as
/// half floats, its atlas rectangle row by row), in vec4s. Empty where no face with tiles has a
/// specular texture: propagation then carries each material's mean.
pub fn specular_factor_words(prepared: &PreparedScene, layout: &TileLayout) -> Vec<[u32; 4]> {
    let Some(factors) = &prepared.atlas.texture_specular else {
        return Vec::new();
    };
    if !has_specular_factors(prepared, layout) {
        return Vec::new();
    }
    let faces = &prepared.faces;
    let textured = |&f: &u32| has_specular_texture(prepared, f);
    let mut words = vec![crate::gpu::types::NO_FACE; faces.len()];
    for &f in layout.faces.iter().filter(|f| textured(f)) {
        words[f as usize] = words.len() as u32;
        let r = faces[f as usize].atlas;
        for j in 0..r.h {
            for i in 0..r.w {
                let texel = ((r.y + j) * prepared.atlas.width + r.x + i) as usize;
                words.extend(crate::lightfield::textures::pack_half_rgb(factors[texel]));
            }
        }
    }
    words.resize(words.len().div_ceil(4) * 4, 0);
    words
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

impl Setup<'_> {
    /// Tile layout, faces, pages and the batch plan (`plan`, else one that fits the budget).
    fn sizes(&self, sky: Option<[f32; 3]>, plan: Option<&BatchPlan>) -> Result<Sizes> {
        let (prepared, params) = (self.prepared, self.params);
        let fixed = gpu_directions(&self.directions.directions);
        let layout = self.mirror_tile_layout(&fixed);
        let tile_slot = if layout.face_slot.is_empty() {
            vec![crate::gpu::types::NO_FACE; prepared.faces.len()]
        } else {
            layout.face_slot.clone()
        };
        // the materials the faces use, each once, as the light field and its file hold them
        let (faces, materials) = crate::lightfield::file::canonical_materials(
            &gpu_faces(prepared, &tile_slot),
            &gpu_materials(prepared),
        );
        let texel_count = prepared.atlas.texel_count() as u32;
        let max_binding = max_binding(self.ctx);
        let texel_pages = TilePages::plan_texels(texel_count as u64, max_binding)?;
        let cells_per_tile = params.tile_size * params.tile_size;
        let tile_cells = layout.headers.len() as u64 * cells_per_tile as u64;
        let tile_pages = TilePages::plan(tile_cells, cells_per_tile, max_binding)?;
        // decided before anything is allocated, now that the tiles' size is known
        let plan = match plan {
            Some(p) => p.clone(),
            None => self.batch_plan(&layout, tile_cells, max_binding)?,
        };
        let k = params.perturb.max(1);
        let grid = GpuGrid {
            resolution: params.grid_resolution,
            direction_count: self.directions.len() as u32,
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
            specular_words: match has_specular_factors(prepared, &layout) {
                true => layout.headers.len() as u32,
                false => 0,
            },
            ..Default::default()
        };
        Ok(Sizes {
            fixed,
            layout,
            faces,
            materials,
            texel_pages,
            tile_cells,
            tile_pages,
            plan,
            grid,
        })
    }

    /// The tiles of the non-diffuse faces (empty when every face is diffuse).
    fn mirror_tile_layout(&self, fixed: &[GpuDirection]) -> TileLayout {
        let prepared = self.prepared;
        let non_diffuse = non_diffuse_faces(prepared);
        if !non_diffuse.iter().any(|&n| n) {
            return TileLayout::default();
        }
        let mut tris: Vec<Vec<[glam::DVec3; 3]>> = vec![Vec::new(); prepared.faces.len()];
        for t in &prepared.triangles {
            tris[t.face as usize].push(t.vertices.map(|v| prepared.positions[v as usize]));
        }
        let normals: Vec<glam::DVec3> = prepared.faces.iter().map(|f| f.normal).collect();
        TileLayout::build(
            fixed,
            &normals,
            &tris,
            &non_diffuse,
            self.params.grid_resolution,
            self.params.tile_size,
        )
    }

    /// Batches of directions whose visibility fits the memory budget beside the texels and
    /// tiles.
    fn batch_plan(
        &self,
        layout: &TileLayout,
        tile_cells: u64,
        max_binding: u64,
    ) -> Result<BatchPlan> {
        let estimate = super::estimate_memory(self.prepared, self.directions, self.params);
        // tile radiance x3 and power weights, tables; with batches, a weight sum per element
        let tile_bytes = tile_cells * (16 * 3 + 4)
            + layout.headers.len() as u64 * 16
            + layout.index.len() as u64 * 4
            + layout.rects.len() as u64 * 16;
        let batch_sums = (self.prepared.atlas.texel_count() as u64 + tile_cells) * 4;
        super::plan_batches(
            &estimate,
            self.params,
            self.directions.len() as u32,
            max_binding,
            estimate.texel_bytes + tile_bytes + batch_sums,
        )
    }

    /// A per-page copy of a per-texel array of `bytes_per` bytes an element.
    fn paged(
        &self,
        ranges: &[(u32, u32)],
        name: &str,
        data: &[u8],
        bytes_per: usize,
    ) -> Vec<wgpu::Buffer> {
        ranges
            .iter()
            .map(|&(first, n)| {
                self.ctx.buffer_init(
                    self.ledger,
                    name,
                    &data[first as usize * bytes_per..(first + n) as usize * bytes_per],
                    STORAGE,
                )
            })
            .collect()
    }

    /// The scene on the GPU: grid uniform, directions (with batches, room for one batch),
    /// faces, vertices, triangles, texel sample points.
    fn scene_buffers(
        &self,
        grid: &GpuGrid,
        directions: &[GpuDirection],
        (faces, materials): (&[GpuFace], &[GpuMaterial]),
        texel_ranges: &[(u32, u32)],
    ) -> SceneBuffers {
        let (ctx, ledger, prepared) = (self.ctx, self.ledger, self.prepared);
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
        // only direct light's shadow rays and rim rays trace the BVH (prepare built it for the
        // buried texels): otherwise one placeholder node and triangle fill the bindings, and
        // the GPU holds no copy
        let placeholder = crate::bvh::SceneBvh {
            nodes: vec![Default::default()],
            triangles: vec![Default::default()],
        };
        let bvh = match self.params.direct_samples > 0 || self.params.rim_rays {
            true => &prepared.bvh,
            false => &placeholder,
        };
        let (nodes, bvh_triangles) = (&bvh.nodes, &bvh.triangles);
        SceneBuffers {
            grid: ctx.buffer_init(ledger, "grid parameters", bytemuck::bytes_of(grid), uniform),
            directions: ctx.buffer_init(
                ledger,
                "directions",
                bytemuck::cast_slice(directions),
                STORAGE,
            ),
            faces: ctx.buffer_init(ledger, "faces", bytemuck::cast_slice(faces), STORAGE),
            materials: ctx.buffer_init(
                ledger,
                "materials",
                bytemuck::cast_slice(materials),
                STORAGE,
            ),
            vertices: ctx.buffer_init(ledger, "vertices", bytemuck::cast_slice(&vertices), STORAGE),
            triangles: ctx.buffer_init(
                ledger,
                "triangles",
                bytemuck::cast_slice(&triangles),
                STORAGE,
            ),
            texel_points: self.paged(
                texel_ranges,
                "texel sample points",
                bytemuck::cast_slice(&prepared.atlas.points),
                16,
            ),
            bvh_triangles: ctx.buffer_init(
                ledger,
                "BVH triangles",
                bytemuck::cast_slice(bvh_triangles),
                STORAGE,
            ),
            bvh_nodes: ctx.buffer_init(ledger, "BVH", bytemuck::cast_slice(nodes), STORAGE),
            surface: SurfaceBuffers::new(ctx, ledger, prepared),
        }
    }

    /// The texel pages, starting from the emitters' radiance, and the power they emit.
    fn texel_pages(
        &self,
        ranges: &[(u32, u32)],
        unshot: &[[f32; 4]],
        total: &[[f32; 4]],
    ) -> (Vec<Page>, f64) {
        let prepared = self.prepared;
        // power per unit of radiosity: texel area x coverage
        let texel_area = 1.0 / (prepared.texel_density * prepared.texel_density);
        let weights: Vec<f32> = prepared
            .atlas
            .coverage
            .iter()
            .map(|&c| (c as f64 * texel_area) as f32)
            .collect();
        let emitted_power = unshot
            .iter()
            .zip(&weights)
            .map(|(u, &w)| (u[0] as f64 + u[1] as f64 + u[2] as f64) * w as f64)
            .sum();
        let pages = ranges
            .iter()
            .map(|&(first, n)| {
                let r = first as usize..(first + n) as usize;
                let state = ElementState::new(
                    self.ctx,
                    self.ledger,
                    "texels",
                    &unshot[r.clone()],
                    &total[r.clone()],
                    std::f32::consts::FRAC_1_PI,
                );
                Page::new(self, "texels", state, &weights[r], first)
            })
            .collect();
        (pages, emitted_power)
    }

    /// The gather pipeline, and the mirror tiles with theirs when some face is not diffuse.
    /// `fixed_directions` gives the buffer of fixed directions the tiles read (made after the
    /// tables, as the ledger lists them).
    fn gather_stage(
        &self,
        layout: TileLayout,
        page_plan: TilePages,
        layouts: [&wgpu::BindGroupLayout; 2],
        grid: &GpuGrid,
        fixed_directions: impl FnOnce() -> wgpu::Buffer,
    ) -> Result<(wgpu::ComputePipeline, Option<Tiles>)> {
        let (ctx, device) = (self.ctx, &self.ctx.device);
        let [layout0, layout1] = layouts;
        if layout.is_empty() {
            let module =
                shaders::module_with(device, "propagate.wgsl", &alpha_masks(self.prepared))?;
            return Ok((
                ctx.compute_pipeline(&module, "gather", &[layout0, layout1]),
                None,
            ));
        }
        let module = shaders::module(device, "specular.wgsl")?;
        // the light field's group: layout, the unshot atlas, fixed directions, geodesic tables,
        // tile tables, four pages of unshot tile radiance
        let field_layout = crate::lightfield::bindings::layout(device, "specular.wgsl")?;
        // tile headers, the page written, its range
        let page_layout = reflect::layout(device, "specular.wgsl", 3)?;
        if field_layout.group != 2 {
            return Err(VlfError::Gpu(format!(
                "shaders/specular.wgsl binds the light field at group {}; transport binds it at 2",
                field_layout.group
            )));
        }
        let groups = [layout0, layout1, &field_layout.layout, &page_layout];
        let gather = ctx.compute_pipeline(&module, "gather_mixed", &groups);
        let gather_tiles = ctx.compute_pipeline(&module, "gather_tiles", &groups);
        let (points, index) = self.directions.gpu_tables();
        let pages = self.tile_pages(&layout, &page_plan, grid.cell_size as f64);
        // the specular textures' factors ride after the headers (grid.specular_words)
        let mut headers = layout.headers.clone();
        if grid.specular_words > 0 {
            headers.extend(specular_factor_words(self.prepared, &layout));
        }
        let tables: [(&str, &[u8]); 5] = [
            ("tile rectangles", bytemuck::cast_slice(&layout.rects)),
            ("tile index", bytemuck::cast_slice(&layout.index)),
            ("tile headers", bytemuck::cast_slice(&headers)),
            ("geodesic points", bytemuck::cast_slice(&points)),
            ("geodesic index", bytemuck::cast_slice(&index)),
        ];
        let field = crate::lightfield::bindings::field_of_grid(grid);
        let uniform = wgpu::BufferUsages::UNIFORM;
        let tiles = Tiles {
            pages,
            page_plan,
            tables: tables.map(|(name, data)| ctx.buffer_init(self.ledger, name, data, STORAGE)),
            fixed_directions: fixed_directions(),
            field: ctx.buffer_init(
                self.ledger,
                "light field layout",
                bytemuck::bytes_of(&field),
                uniform,
            ),
            field_layout,
            page_layout,
            gather_pipe: gather_tiles,
            layout,
        };
        Ok((gather, Some(tiles)))
    }

    /// The mirror tile pages, dark at first; a cell's power weight is its area times its
    /// direction's solid angle.
    fn tile_pages(&self, layout: &TileLayout, plan: &TilePages, h: f64) -> Vec<Page> {
        let cells_per_tile = self.params.tile_size * self.params.tile_size;
        let weights: Vec<f32> = layout
            .headers
            .iter()
            .flat_map(|hd| {
                std::iter::repeat_n(
                    (h * h * self.directions.directions[hd[0] as usize].solid_angle) as f32,
                    cells_per_tile as usize,
                )
            })
            .collect();
        plan.ranges()
            .into_iter()
            .map(|(first, cells)| {
                let state = ElementState::zeroed(self.ctx, self.ledger, "mirror tiles", cells, 1.0);
                let r = first as usize..(first + cells) as usize;
                Page::new(self, "mirror tiles", state, &weights[r], first)
            })
            .collect()
    }

    /// The pass adding next to total and summing next's power.
    fn accumulate_pass(&self) -> Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout)> {
        let device = &self.ctx.device;
        let layout = reflect::layout(device, "accumulate.wgsl", 0)?;
        let module = shaders::module(device, "accumulate.wgsl")?;
        let pipe = self.ctx.compute_pipeline(&module, "accumulate", &[&layout]);
        Ok((pipe, layout))
    }

    /// The fixed directions the mirror tiles read: the scene's directions buffer when it holds
    /// them all along, else (`separate`: perturbed sets or batches replace them there) their own.
    fn fixed_directions(
        &self,
        fixed: &[GpuDirection],
        separate: bool,
        scene_directions: &wgpu::Buffer,
    ) -> wgpu::Buffer {
        if separate {
            let data = bytemuck::cast_slice(fixed);
            self.ctx
                .buffer_init(self.ledger, "fixed directions", data, STORAGE)
        } else {
            scene_directions.clone()
        }
    }

    /// map_Kd factors per texel page and the pass that applies them; None when untextured.
    fn texture_stage(&self, texel_ranges: &[(u32, u32)]) -> Result<Option<TextureStage>> {
        let Some(albedo) = &self.prepared.atlas.texture_albedo else {
            return Ok(None);
        };
        let buffer = self.paged(
            texel_ranges,
            "texture albedo",
            bytemuck::cast_slice(albedo),
            std::mem::size_of_val(&albedo[0]),
        );
        let device = &self.ctx.device;
        let layout = reflect::layout(device, "texture.wgsl", 0)?;
        let module = shaders::module(device, "texture.wgsl")?;
        let pipe = self.ctx.compute_pipeline(&module, "modulate", &[&layout]);
        Ok(Some((buffer, pipe, layout)))
    }

    /// With batches: the quadrature weight sum per element and the pass dividing by them;
    /// without, a placeholder to bind.
    fn batch_weight_sums(
        &self,
        batched: bool,
        elements: u64,
    ) -> Result<(
        wgpu::Buffer,
        Option<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
    )> {
        let ctx = self.ctx;
        if !batched {
            let placeholder = ctx.buffer_zeroed(
                &MemoryLedger::default(),
                "weight sums placeholder",
                16,
                STORAGE,
            );
            return Ok((placeholder, None));
        }
        let buffer = ctx.buffer_zeroed(
            self.ledger,
            "batches: quadrature weight sums",
            elements * 4,
            STORAGE,
        );
        let layout = reflect::layout(&ctx.device, "normalize.wgsl", 0)?;
        let module = shaders::module(&ctx.device, "normalize.wgsl")?;
        let pipe = ctx.compute_pipeline(&module, "normalize", &[&layout]);
        Ok((buffer, Some((pipe, layout))))
    }

    /// The power balance's per-texel terms, tile classes and passes.
    fn balance_passes(
        &self,
        texels: &[Page],
        areas: &[f64],
        tiles: Option<&Tiles>,
        tile_cells: u64,
        layouts: [&wgpu::BindGroupLayout; 2],
    ) -> Result<BalancePasses> {
        let (ctx, ledger) = (self.ctx, self.ledger);
        let device = &ctx.device;
        let module = shaders::module(device, "propagate.wgsl")?;
        let layout2 = reflect::layout(device, "propagate.wgsl", 2)?;
        let pipe =
            |entry| ctx.compute_pipeline(&module, entry, &[layouts[0], layouts[1], &layout2]);
        let groups = |count: u32| {
            let (x, y) = dispatch_2d(count.div_ceil(256));
            (x * y) as u64
        };
        let largest = (texels.iter().map(|p| p.state.count))
            .chain(
                tiles
                    .iter()
                    .flat_map(|t| t.pages.iter().map(|p| p.state.count)),
            )
            .map(groups)
            .max()
            .unwrap_or(1);
        let texel_terms = texels
            .iter()
            .map(|p| {
                let bytes = p.state.count as u64 * 16;
                ctx.buffer_zeroed(ledger, "texels: power balance", bytes, STORAGE)
            })
            .collect();
        let areas: Vec<f32> = areas.iter().map(|&a| a as f32).collect();
        let texel_areas = texels
            .iter()
            .map(|p| {
                let r = p.first as usize..(p.first + p.state.count) as usize;
                let data = bytemuck::cast_slice(&areas[r]);
                ctx.buffer_init(ledger, "texels: areas", data, STORAGE)
            })
            .collect();
        let class_bytes = if tiles.is_some() {
            tile_cells.div_ceil(16) * 4
        } else {
            16
        };
        let unledgered = MemoryLedger::default();
        Ok(BalancePasses {
            texel_terms,
            texel_areas,
            texel_pipe: pipe("texel_balance"),
            power_pipe: pipe("texel_power"),
            classes_pipe: pipe("tile_classes"),
            tile_pipe: pipe("tile_balance"),
            layout2,
            // without mirror tiles a 16-byte placeholder, which the ledger does not count: a
            // diffuse-only scene allocates no tiles (tests/mirrors.rs)
            tile_class: ctx.buffer_zeroed(
                if tiles.is_some() { ledger } else { &unledgered },
                "mirror tiles: power balance classes",
                class_bytes,
                STORAGE,
            ),
            partials: ctx.buffer_zeroed(ledger, "power balance sums", largest * 16, STORAGE),
            placeholder: ctx.buffer_zeroed(&MemoryLedger::default(), "placeholder", 64, STORAGE),
            classified: tiles.is_none(),
        })
    }

    /// The first iterations' direct light, when `params.direct_samples` asks for it.
    fn direct_light(
        &self,
        sky: Option<[f32; 3]>,
        (faces, materials): (&[GpuFace], &[GpuMaterial]),
        unshot: &[[f32; 4]],
        layouts: [&wgpu::BindGroupLayout; 2],
    ) -> Result<Option<super::direct::DirectLight>> {
        let (prepared, params) = (self.prepared, self.params);
        if params.direct_samples == 0 {
            return Ok(None);
        }
        let emitters = super::direct::emitters(prepared, faces, unshot);
        let mirrors = if params.mirror_direct {
            super::direct::mirror_triangles(prepared, faces, materials)
        } else {
            Vec::new()
        };
        let sky_samples = if sky.is_some_and(|s| s.iter().any(|&v| v > 0.0)) {
            params.direct_samples
        } else {
            0
        };
        Ok(Some(super::direct::DirectLight::new(
            self.ctx,
            self.ledger,
            &emitters,
            &mirrors,
            params.direct_samples,
            sky_samples,
            layouts[0],
            layouts[1],
            &alpha_masks(prepared),
        )?))
    }
}

/// The constant that compiles the cut-outs' test (shaders/common/coverage.wgsl) into a stage
/// where some material of the scene cuts holes, and out of it otherwise.
pub fn alpha_masks(prepared: &PreparedScene) -> [(&'static str, u32); 1] {
    [(
        "ALPHA_MASKS",
        u32::from(!prepared.cutout_textures.is_empty()),
    )]
}

/// The K direction sets gathered in turn (only kept when K > 1, or with batches).
fn direction_sets(
    directions: &DirectionSet,
    k: u32,
    batched: bool,
    fixed: &[GpuDirection],
) -> Vec<Vec<GpuDirection>> {
    match (k > 1, batched) {
        (true, _) => (0..k)
            .map(|s| gpu_directions(&directions.perturbed(s)))
            .collect(),
        (false, true) => vec![fixed.to_vec()],
        (false, false) => Vec::new(),
    }
}

impl Propagator {
    /// Sizes first (the batch plan among them), then the GPU buffers and passes.
    pub fn new(
        ctx: Arc<GpuContext>,
        prepared: &PreparedScene,
        params: &PropagationParams,
        directions: &DirectionSet,
        sky: Option<[f32; 3]>,
        plan: Option<&BatchPlan>,
    ) -> Result<Propagator> {
        let mut laps = crate::stats::Laps::default();
        let ledger = MemoryLedger::default();
        let device = &ctx.device;
        let s = Setup {
            ctx: &ctx,
            ledger: &ledger,
            prepared,
            params,
            directions,
        };
        let sizes = s.sizes(sky, plan)?;
        let (grid, plan, tile_pages) = (sizes.grid, sizes.plan, sizes.tile_pages);
        let k = params.perturb.max(1);
        let batched = !plan.resident();
        let texel_ranges = sizes.texel_pages.ranges();
        // with batches the directions buffer holds one batch at a time
        let batch = &sizes.fixed[..plan.batch_size as usize];
        let materials = (&sizes.faces[..], &sizes.materials[..]);
        let scene = s.scene_buffers(&grid, batch, materials, &texel_ranges);
        let (unshot, total) = initial_radiance(prepared, &sizes.faces, &sizes.materials);
        let (texels, emitted_power) = s.texel_pages(&texel_ranges, &unshot, &total);
        laps.lap("buffers");

        // grid, directions, faces, cell offsets, counts, layers, four pages of texel points, the
        // BVH's triangles and nodes
        let layout0 = reflect::layout(device, "propagate.wgsl", 0)?;
        // four pages of unshot, the page of next written, its range, the batches' weight sums
        let layout1 = reflect::layout(device, "propagate.wgsl", 1)?;
        let (accumulate_pipe, accumulate_layout) = s.accumulate_pass()?;
        let separate = k > 1 || batched;
        let (gather_pipe, tiles) = s.gather_stage(
            sizes.layout,
            tile_pages,
            [&layout0, &layout1],
            &grid,
            || s.fixed_directions(&sizes.fixed, separate, &scene.directions),
        )?;
        let texture = s.texture_stage(&texel_ranges)?;
        let (weight_sums, normalize) =
            s.batch_weight_sums(batched, grid.texel_count as u64 + sizes.tile_cells)?;
        let timestamps = Timestamps::new(&ctx, 4 + 2 * k + 2 * tile_pages.pages);
        laps.lap("pipelines");
        let direct = s.direct_light(sky, materials, &unshot, [&layout0, &layout1])?;
        laps.lap("direct light");
        let areas = super::texel_areas(prepared);
        laps.lap("texel areas");
        let emitted_exactly = (unshot.iter().zip(&areas))
            .map(|(u, a)| (u[0] as f64 + u[1] as f64 + u[2] as f64) * a)
            .sum();
        let balance = s.balance_passes(
            &texels,
            &areas,
            tiles.as_ref(),
            sizes.tile_cells,
            [&layout0, &layout1],
        )?;
        let visibility_pipelines = VisibilityPipelines::new(&ctx, &alpha_masks(prepared))?;
        laps.lap("balance and visibility pipelines");
        Ok(Propagator {
            ctx,
            ledger,
            grid,
            scene,
            visibility: None,
            visibility_pipelines,
            faces: sizes.faces,
            materials: sizes.materials,
            texels,
            texel_pages: sizes.texel_pages,
            tiles,
            texture,
            direction_sets: direction_sets(directions, k, batched, &sizes.fixed),
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
            texel_count: grid.texel_count,
            timestamps,
            direct,
            balance,
            power: Some(PowerAccount::new(emitted_exactly)),
            texel_weights: areas.iter().map(|&a| a as f32).collect(),
            regression_flags: 0,
            rim_rays: params.rim_rays,
            setup_laps: laps,
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

    /// One shooting iteration (one more bounce). Returns the residual after it, and where the
    /// light went.
    pub fn iterate(&mut self) -> Result<IterationStats> {
        let started = std::time::Instant::now();
        let first = self.iteration == 0;
        let mut gpu_ms = 0.0;
        let timed = self.gather_all(false, &mut gpu_ms)?;
        if self.iteration <= 1 && self.direct.is_some() {
            self.encode_direct(self.iteration == 1);
        }
        if first {
            self.encode_validity();
        }
        // before the texture factors: next / albedo is the irradiance
        let texels = self.sum_texel_balance()?;
        self.encode_texture();
        let [reflected, sky, _, _] = self.sum_texels(&self.balance.power_pipe)?;
        let residual = self.finish_iteration(&mut gpu_ms)?;
        let tiles_next = self.sum_tile_balance()?;
        let measured = MeasuredPower {
            texels,
            reflected,
            sky: if first { sky } else { 0.0 },
            tiles_next,
        };
        Ok(IterationStats {
            iteration: self.iteration,
            residual,
            gpu_ms: timed.then_some(gpu_ms),
            wall_ms: started.elapsed().as_secs_f64() * 1e3,
            power: self.power.as_mut().map(|a| a.close(&measured)),
        })
    }

    /// Every direction set (the fixed set last: it stays resident for rendering and tiles) and
    /// batch gathered into `next`, the batches' raw sums normalised. A `probe` gathers the texels
    /// alone, without the sky or the second iteration's mirror rule. Returns whether every
    /// gather was timed.
    fn gather_all(&mut self, probe: bool, gpu_ms: &mut f64) -> Result<bool> {
        let k = self.direction_sets.len().max(1);
        let batched = self.normalize.is_some();
        let order: Vec<usize> = (1..k).chain([0]).collect();
        let mut timed = self.timestamps.is_some();
        if batched {
            self.clear_next_and_weight_sums();
        }
        let batches = self.batches.clone();
        for (n, &set) in order.iter().enumerate() {
            for &(first, count) in &batches {
                let mut grid = self.grid;
                grid.direction_count = count;
                grid.first_direction = first;
                if k > 1 || batched {
                    self.rebuild_visibility(set, &grid, gpu_ms)?;
                }
                grid.iteration = self.iteration;
                grid.flags = self.gather_flags(&grid, n > 0, probe);
                self.ctx
                    .queue
                    .write_buffer(&self.scene.grid, 0, bytemuck::bytes_of(&grid));
                self.encode_gathers(set == 0 && !probe)?;
                if set == 0 && !self.balance.classified {
                    self.encode_tile_classes();
                }
                if let Some(t) = self.timestamps.as_mut() {
                    *gpu_ms += t.read_ms(&self.ctx)?.iter().sum::<f64>();
                } else {
                    timed = false;
                }
            }
        }
        self.balance.classified = true;
        if batched {
            self.normalize_batches();
        }
        Ok(timed)
    }

    /// With batches each batch adds raw sums: next (texels and tiles) and the weight sums
    /// start from zero.
    fn clear_next_and_weight_sums(&self) {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        for page in &self.texels {
            encoder.clear_buffer(&page.state.radiance[1 - self.current], 0, None);
        }
        encoder.clear_buffer(&self.weight_sums, 0, None);
        for terms in &self.balance.texel_terms {
            encoder.clear_buffer(terms, 0, None);
        }
        for page in self.tiles.iter().flat_map(|t| &t.pages) {
            encoder.clear_buffer(&page.state.radiance[1 - self.current], 0, None);
        }
        self.ctx.queue.submit([encoder.finish()]);
    }

    /// The visibility lists of direction set `set` over `grid`'s batch of directions, in the
    /// buffers of the previous lists. With batches their GPU time joins `gpu_ms`.
    fn rebuild_visibility(&mut self, set: usize, grid: &GpuGrid, gpu_ms: &mut f64) -> Result<()> {
        let batched = self.normalize.is_some();
        let (first, count) = (grid.first_direction, grid.direction_count);
        let slice = &self.direction_sets[set][first as usize..(first + count) as usize];
        self.ctx
            .queue
            .write_buffer(&self.scene.directions, 0, bytemuck::cast_slice(slice));
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
            grid,
            &mut visibility_timer,
            previous,
        )?;
        if batched {
            self.timestamps = visibility_timer;
            *gpu_ms += vis.gpu_ms.unwrap_or(0.0);
            self.largest_batch_layers = self.largest_batch_layers.max(vis.layer_count);
        }
        self.visibility = Some(vis);
        Ok(())
    }

    /// The gather's flags this iteration: the sky shoots in the first; mirrors do not send in
    /// the second when direct light brought their virtual emitters (neither in a `probe`);
    /// batches add raw sums, a later direction set (`accumulate`) adds to the earlier ones.
    fn gather_flags(&self, grid: &GpuGrid, accumulate: bool, probe: bool) -> u32 {
        let mut flags = self.regression_flags;
        if self.rim_rays {
            flags |= GRID_FLAG_RIM_RAYS;
        }
        if !probe && self.iteration == 0 && grid.sky.iter().any(|&s| s > 0.0) {
            flags |= GRID_FLAG_SKY;
        }
        let mirrors = self.direct.as_ref().is_some_and(|d| d.mirror_count > 0);
        if !probe && self.iteration == 1 && mirrors {
            flags |= GRID_FLAG_NO_MIRROR_SENDERS;
        }
        if self.normalize.is_some() {
            flags |= GRID_FLAG_BATCHED;
        } else if accumulate {
            flags |= GRID_FLAG_ACCUMULATE;
        }
        flags
    }

    /// Multiply the texels' next radiance by their map_Kd factors (textured scenes only).
    fn encode_texture(&self) {
        let Some((albedo, pipe, layout)) = &self.texture else {
            return;
        };
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

    /// Add next to the totals, swap unshot and next, count the iteration. Returns the residual:
    /// unshot power over emitted power.
    fn finish_iteration(&mut self, gpu_ms: &mut f64) -> Result<f64> {
        let (texel_power, texel_sky) = self.accumulate(false)?;
        let (tile_power, tile_sky) = if self.tiles.is_some() {
            self.accumulate(true)?
        } else {
            (0.0, 0.0)
        };
        if let Some(t) = self.timestamps.as_mut() {
            *gpu_ms += t.read_ms(&self.ctx)?.iter().sum::<f64>();
        }
        if self.iteration == 0 {
            // the sky shoots once, in the first iteration: what it delivered counts as emitted
            self.emitted_power += texel_sky + tile_sky;
        }
        self.current = 1 - self.current;
        self.iteration += 1;
        let unshot_power = texel_power + tile_power;
        Ok(if self.emitted_power > 0.0 {
            unshot_power / self.emitted_power
        } else {
            0.0
        })
    }

    /// One balance pass (`entry` of shaders/propagate.wgsl) over `count` elements with group 2
    /// bound to `group2`, and the sum of its per-workgroup partials.
    fn balance_pass(
        &self,
        pipe: &wgpu::ComputePipeline,
        groups01: (&wgpu::BindGroup, &wgpu::BindGroup),
        group2: &[&wgpu::Buffer],
        count: u32,
    ) -> Result<[f64; 4]> {
        let ctx = &self.ctx;
        let bg2 = ctx.bind_group(&self.balance.layout2, group2);
        let (x, y) = dispatch_2d(count.div_ceil(256));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, groups01.0, &[]);
            pass.set_bind_group(1, groups01.1, &[]);
            pass.set_bind_group(2, &bg2, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        let partials: Vec<[f32; 4]> =
            ctx.read_buffer(&self.balance.partials, (x * y) as u64 * 16)?;
        let mut sum = [0.0f64; 4];
        for p in &partials {
            for (s, v) in sum.iter_mut().zip(p) {
                *s += *v as f64;
            }
        }
        Ok(sum)
    }

    /// The texels' balance terms after the gather (and direct light), before the texture
    /// factors: received, mirrored, escaped and back-absorbed power.
    fn sum_texel_balance(&self) -> Result<[f64; 4]> {
        self.sum_texels(&self.balance.texel_pipe)
    }

    /// One of the texel balance passes over every page, summed.
    fn sum_texels(&self, pipe: &wgpu::ComputePipeline) -> Result<[f64; 4]> {
        let (bg0, bg1) = self.texel_bind_groups();
        let b = &self.balance;
        let mut sum = [0.0f64; 4];
        for ((page, bg), areas) in self.texels.iter().zip(&bg1).zip(&b.texel_areas) {
            let group2 = [
                areas,
                &b.partials,
                &b.placeholder,
                &b.placeholder,
                &page.page_uniform,
                &b.tile_class,
                &self.scene.directions,
            ];
            let part = self.balance_pass(pipe, (&bg0, bg), &group2, page.state.count)?;
            for (s, p) in sum.iter_mut().zip(part) {
                *s += p;
            }
        }
        Ok(sum)
    }

    /// The mirror tiles' unshot power (cells on their face) and its escaping and back-absorbed
    /// parts; zero without mirrors.
    fn sum_tile_balance(&self) -> Result<[f64; 3]> {
        let Some(t) = &self.tiles else {
            return Ok([0.0; 3]);
        };
        let (bg0, bg1) = self.texel_bind_groups();
        let b = &self.balance;
        let mut sum = [0.0f64; 3];
        for page in &t.pages {
            let group2 = [
                &b.placeholder,
                &b.partials,
                &t.tables[2],
                &page.state.radiance[self.current],
                &page.page_uniform,
                &b.tile_class,
                &t.fixed_directions,
            ];
            let part =
                self.balance_pass(&b.tile_pipe, (&bg0, &bg1[0]), &group2, page.state.count)?;
            for (s, p) in sum.iter_mut().zip(part) {
                *s += p;
            }
        }
        Ok(sum)
    }

    /// Where each mirror tile cell of this batch sends its light (`tile_classes`), with the
    /// fixed directions' lists in place.
    fn encode_tile_classes(&self) {
        let Some(t) = &self.tiles else { return };
        let (bg0, bg1) = self.texel_bind_groups();
        let b = &self.balance;
        let group2 = [
            &b.placeholder,
            &b.partials,
            &t.tables[2],
            &b.placeholder,
            &t.pages[0].page_uniform,
            &b.tile_class,
            &t.fixed_directions,
        ];
        let bg2 = self.ctx.bind_group(&b.layout2, &group2);
        let words = (self.grid.tile_cell_count as u64).div_ceil(16) as u32;
        let (x, y) = dispatch_2d(words.div_ceil(64));
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&b.classes_pipe);
            pass.set_bind_group(0, &bg0, &[]);
            pass.set_bind_group(1, &bg1[0], &[]);
            pass.set_bind_group(2, &bg2, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        self.ctx.queue.submit([encoder.finish()]);
    }

    /// What the transport does with one unshot state: `radiosity` per texel (r, g, b; the mirror
    /// tiles dark) gathered once more, texels only, without direct light. Returns the power its
    /// texels send (radiosity x area) and of that what is received (at any front), escapes and
    /// meets a one-sided back: a probe of where light goes missing. The propagator's unshot and
    /// next state are overwritten; the totals are not touched.
    pub fn probe(&mut self, radiosity: &[[f32; 4]], weights: &[f32]) -> Result<[f64; 4]> {
        let sent: f64 = (radiosity.iter().zip(weights))
            .map(|(u, &w)| (u[0] as f64 + u[1] as f64 + u[2] as f64) * w as f64)
            .sum();
        for page in &self.texels {
            let range = page.first as usize..(page.first + page.state.count) as usize;
            let data = bytemuck::cast_slice(&radiosity[range]);
            let unshot = &page.state.radiance[self.current];
            self.ctx.queue.write_buffer(unshot, 0, data);
        }
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        for page in self.tiles.iter().flat_map(|t| &t.pages) {
            encoder.clear_buffer(&page.state.radiance[self.current], 0, None);
        }
        self.ctx.queue.submit([encoder.finish()]);
        self.gather_all(true, &mut 0.0)?;
        let [received, _, escaped, backs] = self.sum_texel_balance()?;
        Ok([sent, received, escaped, backs])
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
                &s.bvh_triangles,
                &s.bvh_nodes,
                &s.materials,
                &s.surface.cutouts,
            ],
        );
        let current = self.current;
        let unshot =
            |p: usize| &self.texels.get(p).unwrap_or(&self.texels[0]).state.radiance[current];
        let bg1 = self
            .texels
            .iter()
            .zip(&self.balance.texel_terms)
            .map(|(page, terms)| {
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
                        terms,
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

    /// Per texel the irradiance vector of its direct light from the emitters (luminance;
    /// `direct_vector` in shaders/direct.wgsl), for normal maps; None without direct light.
    /// Run once propagation is done: it takes the `next` pages.
    /// Then, with the converged radiance copied over the unshot state (no longer needed), the
    /// tangential moment of the rest of each texel's light (`rest_vector`). None without
    /// direct light.
    pub fn light_vectors(&mut self) -> Result<Option<crate::lightfield::normal_map::LightVectors>> {
        if self.direct.is_none() {
            return Ok(None);
        }
        let current = self.current;
        let mut out = Vec::new();
        for rest in [false, true] {
            if rest {
                let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
                for page in &self.texels {
                    let (from, to) = (&page.state.total, &page.state.radiance[current]);
                    encoder.copy_buffer_to_buffer(from, 0, to, 0, page.state.count as u64 * 16);
                }
                self.ctx.queue.submit([encoder.finish()]);
            }
            self.encode_direct_stage(
                "light directions",
                |page| &page.state.radiance[1 - current],
                |d, pass, bg0, pages| d.encode_vectors(pass, bg0, pages, rest),
            );
            out.push(self.read_page_list(&self.texels, |p| &p.state.radiance[1 - current])?);
        }
        let rest = out.pop().unwrap_or_default();
        let vectors = out.pop().unwrap_or_default();
        Ok(Some((vectors, rest)))
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

    /// The light field's bind group over the unshot state: the texels' and tiles' unshot pages.
    fn unshot_field(&self, t: &Tiles) -> wgpu::BindGroup {
        let current = self.current;
        let [rects, index, _, points, geodesic_index] = &t.tables;
        let buffers = crate::lightfield::bindings::FieldBuffers {
            field: &t.field,
            atlas: (self.texels.iter())
                .map(|p| &p.state.radiance[current])
                .collect(),
            tiles: Some(crate::lightfield::bindings::FieldTiles {
                directions: &t.fixed_directions,
                geodesic_points: points,
                geodesic_index,
                rects,
                index,
                radiance: (t.pages.iter())
                    .map(|p| &p.state.radiance[current])
                    .collect(),
            }),
            detail: None,
        };
        crate::lightfield::bindings::bind_group(&self.ctx, &t.field_layout, &buffers)
    }

    fn encode_gathers(&mut self, with_tiles: bool) -> Result<()> {
        let ctx = &self.ctx;
        let (bg0, bg1) = self.texel_bind_groups();
        let current = self.current;
        // per page: every page's unshot radiance to read, and this page's next to write
        // the unshot light field (group 2), and per page the next radiance written (group 3)
        let mut bg2 = None;
        let mut bg3: Vec<wgpu::BindGroup> = Vec::new();
        if let Some(t) = &self.tiles {
            bg2 = Some(self.unshot_field(t));
            for page in &t.pages {
                let next = &page.state.radiance[1 - current];
                bg3.push(ctx.bind_group(&t.page_layout, &[&t.tables[2], next, &page.page_uniform]));
            }
        }
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("gather"),
                timestamp_writes: self.timestamps.as_mut().and_then(|t| t.compute_writes()),
            });
            pass.set_bind_group(0, &bg0, &[]);
            if let (Some(bg2), Some(bg3)) = (&bg2, bg3.first()) {
                pass.set_bind_group(2, bg2, &[]);
                pass.set_bind_group(3, bg3, &[]);
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
                for (page, bg) in t.pages.iter().zip(&bg3) {
                    pass.set_bind_group(3, bg, &[]);
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
        // the balance terms: irradiances and reciprocity shares, raw like the texels' next
        for (terms, p) in self.balance.texel_terms.iter().zip(&self.texels) {
            passes.push((terms, p.state.count, std::f32::consts::PI, p.first));
        }
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
        // the iterations before the checkpoint were not measured
        self.power = None;
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
        ledger.record("materials", self.scene.materials.size());
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
            materials: self.scene.materials,
            total: self.texels.into_iter().map(|p| p.state.total).collect(),
            texel_pages: self.texel_pages,
            tiles,
            ledger,
            detail: None,
        }
    }
}
