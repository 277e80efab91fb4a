//! Drives `shaders/visibility.wgsl`: per direction, each cell's layer list sorted by depth,
//! built as an A-buffer (count, prefix-sum, fill, sort). Built once and kept for all
//! iterations.

use crate::error::Result;
use crate::gpu::types::GpuGrid;
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, Timestamps, STORAGE};
use crate::prepare::PreparedScene;
use wgpu::util::DeviceExt;

/// Buffers describing the scene, shared by visibility and transport.
pub struct SceneBuffers {
    pub grid: wgpu::Buffer,
    pub directions: wgpu::Buffer,
    pub faces: wgpu::Buffer,
    /// the material table the faces index (`crate::material`)
    pub materials: wgpu::Buffer,
    pub vertices: wgpu::Buffer,
    pub triangles: wgpu::Buffer,
    /// sample point per texel, in pages (see TilePages::plan_texels)
    pub texel_points: Vec<wgpu::Buffer>,
    /// the triangles in BVH order and the BVH (src/bvh.rs): the texels' rim rays and direct
    /// light's shadow rays (common/upstream.wgsl, group 0)
    pub bvh_triangles: wgpu::Buffer,
    pub bvh_nodes: wgpu::Buffer,
    /// the cut-outs' coverage (placeholders without one)
    pub surface: SurfaceBuffers,
}

/// What propagation's stages read of the cut-outs (shaders/common/coverage.wgsl): the packed
/// coverage (`lightfield::textures::SurfaceTextures::packed_cutouts`; visibility.wgsl and the
/// transport's group 0) and per triangle its corners' texture coordinates (visibility.wgsl's cell
/// lines; the BVH's triangles carry their own). 16-byte placeholders in a scene without cut-outs.
pub struct SurfaceBuffers {
    pub cutouts: wgpu::Buffer,
    /// per triangle of `SceneBuffers::triangles`: (uv0, uv1), (uv2, 0, 0)
    pub triangle_uv: wgpu::Buffer,
}

impl SurfaceBuffers {
    pub fn new(ctx: &GpuContext, ledger: &MemoryLedger, prepared: &PreparedScene) -> Self {
        let Some(t) = crate::lightfield::textures::SurfaceTextures::cutouts(prepared) else {
            let none = MemoryLedger::default();
            let placeholder = || ctx.buffer_zeroed(&none, "no cut-outs", 16, STORAGE);
            return SurfaceBuffers {
                cutouts: placeholder(),
                triangle_uv: placeholder(),
            };
        };
        let uv: Vec<[f32; 8]> = (prepared.triangles.iter())
            .map(|t| {
                let [a, b, c] = t.uv.unwrap_or([[0.0; 2]; 3]);
                [a[0], a[1], b[0], b[1], c[0], c[1], 0.0, 0.0]
            })
            .collect();
        let words = t.packed_cutouts();
        SurfaceBuffers {
            cutouts: ctx.buffer_init(ledger, "cut-outs", bytemuck::cast_slice(&words), STORAGE),
            triangle_uv: ctx.buffer_init(
                ledger,
                "cut-outs: triangle uv",
                bytemuck::cast_slice(&uv),
                STORAGE,
            ),
        }
    }
}

/// The resident layer lists.
pub struct Visibility {
    pub cell_offset: wgpu::Buffer,
    pub cell_count: wgpu::Buffer,
    pub layers: wgpu::Buffer,
    pub direction_base: wgpu::Buffer,
    pub layer_count: u64,
    /// GPU milliseconds of count, scans, fill and sort (when timestamps are available)
    pub gpu_ms: Option<f64>,
}

/// Cell offsets, cell counts and layers (face, depth bits), as read back from the GPU.
pub type LayerLists = (Vec<u32>, Vec<u32>, Vec<[u32; 2]>);

/// The visibility stage's pipelines, made once per propagation (rebuilding the lists for
/// perturbed direction sets reuses them).
pub struct VisibilityPipelines {
    layout0: wgpu::BindGroupLayout,
    layout1: wgpu::BindGroupLayout,
    count_pipe: wgpu::ComputePipeline,
    scan_cells: wgpu::ComputePipeline,
    scan_dirs: wgpu::ComputePipeline,
    fill_pipe: wgpu::ComputePipeline,
    sort_pipe: wgpu::ComputePipeline,
    placeholder_bg: wgpu::BindGroup,
}

impl VisibilityPipelines {
    /// `alpha_masks`: the cut-outs' test compiled in or out (`transport::alpha_masks`).
    pub fn new(ctx: &GpuContext, alpha_masks: &[(&str, u32)]) -> Result<VisibilityPipelines> {
        let device = &ctx.device;
        let module = shaders::module_with(device, "visibility.wgsl", alpha_masks)?;
        let layout0 = reflect::layout(device, "visibility.wgsl", 0)?;
        let layout1 = reflect::layout(device, "visibility.wgsl", 1)?;
        // count_layers shares its traversal with fill_layers, so its layout names the layers
        // binding too; a placeholder stands in until the real size is known.
        let placeholder =
            ctx.buffer_zeroed(&MemoryLedger::default(), "layers placeholder", 16, STORAGE);
        let placeholder_bg = ctx.bind_group(&layout1, &[&placeholder]);
        Ok(VisibilityPipelines {
            count_pipe: ctx.compute_pipeline(&module, "count_layers", &[&layout0, &layout1]),
            scan_cells: ctx.compute_pipeline(&module, "scan_cells", &[&layout0]),
            scan_dirs: ctx.compute_pipeline(&module, "scan_directions", &[&layout0]),
            fill_pipe: ctx.compute_pipeline(&module, "fill_layers", &[&layout0, &layout1]),
            sort_pipe: ctx.compute_pipeline(&module, "sort_layers", &[&layout0, &layout1]),
            layout0,
            layout1,
            placeholder_bg,
        })
    }
}

/// Triangles per workgroup of count/fill (the y size of shaders/visibility.wgsl's
/// `@workgroup_size(8, 8)`; x is its ROW_SLOTS threads per triangle).
const TRIANGLES_PER_WORKGROUP: u32 = 8;
/// Triangles per dispatch: the most workgroups one dispatch dimension (y) takes.
const TRIANGLES_PER_DISPATCH: u32 = 65535 * TRIANGLES_PER_WORKGROUP;

fn groups(count: u32, size: u32) -> u32 {
    count.div_ceil(size)
}

impl Visibility {
    /// Build the lists. `reuse` hands over the buffers of an earlier build with the same grid
    /// (perturbed direction sets): they are cleared and refilled instead of reallocated.
    pub fn build(
        ctx: &GpuContext,
        pipelines: &VisibilityPipelines,
        ledger: &MemoryLedger,
        scene: &SceneBuffers,
        grid: &GpuGrid,
        timestamps: &mut Option<Timestamps>,
        reuse: Option<Visibility>,
    ) -> Result<Visibility> {
        let cells = grid.resolution as u64 * grid.resolution as u64 * grid.direction_count as u64;
        ctx.check_binding(
            "the per-cell tables (directions x grid^2 x 4 bytes)",
            cells * 4,
            "use fewer directions or a coarser grid",
        )?;
        let p = pipelines;
        let (tables, old_layers) = CellTables::cleared_or_new(ctx, ledger, grid, cells, reuse);
        let chunks = tables.chunk_bind_groups(ctx, &p.layout0, scene, grid);
        let main_bg = &chunks[0].0;
        let cell_groups = groups(grid.resolution * grid.resolution, 64);

        per_triangle_pass(
            ctx,
            "count layers + scan",
            timestamps,
            (&p.count_pipe, &p.placeholder_bg),
            &chunks,
            grid,
            |pass| {
                pass.set_bind_group(0, main_bg, &[]);
                pass.set_pipeline(&p.scan_cells);
                pass.dispatch_workgroups(grid.direction_count, 1, 1);
                pass.set_pipeline(&p.scan_dirs);
                pass.dispatch_workgroups(1, 1, 1);
            },
        );
        let total: Vec<u32> =
            read_tail(ctx, &tables.direction_base, grid.direction_count as u64 * 4)?;
        let layer_count = total[0] as u64;
        ctx.check_binding(
            &format!("the layer lists ({layer_count} layers x 8 bytes)"),
            layer_count * 8,
            "use fewer directions or a coarser grid",
        )?;
        let layers = layers_buffer(ctx, ledger, old_layers, layer_count);
        let layers_bg = ctx.bind_group(&p.layout1, &[&layers]);
        per_triangle_pass(
            ctx,
            "fill + sort layers",
            timestamps,
            (&p.fill_pipe, &layers_bg),
            &chunks,
            grid,
            |pass| {
                pass.set_bind_group(0, main_bg, &[]);
                pass.set_pipeline(&p.sort_pipe);
                pass.dispatch_workgroups(cell_groups, grid.direction_count, 1);
            },
        );
        ctx.wait()?;
        let gpu_ms = match timestamps.as_mut() {
            Some(t) => Some(t.read_ms(ctx)?.iter().sum()),
            None => None,
        };
        Ok(Visibility {
            cell_offset: tables.cell_offset,
            cell_count: tables.cell_count,
            layers,
            direction_base: tables.direction_base,
            layer_count,
            gpu_ms,
        })
    }

    /// Cell offsets, counts and layers, for comparison with the CPU twin.
    pub fn read(&self, ctx: &GpuContext, cells: u64) -> Result<LayerLists> {
        Ok((
            ctx.read_buffer(&self.cell_offset, cells * 4)?,
            ctx.read_buffer(&self.cell_count, cells * 4)?,
            ctx.read_buffer(&self.layers, self.layer_count * 8)?,
        ))
    }
}

/// The per-cell tables the count and scan passes fill: layers per cell, each cell's first
/// layer, each direction's first layer (its last entry: the total).
struct CellTables {
    cell_count: wgpu::Buffer,
    cell_offset: wgpu::Buffer,
    direction_base: wgpu::Buffer,
}

impl CellTables {
    /// The tables of an earlier build, counts cleared, and its layers buffer; or new ones.
    fn cleared_or_new(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        grid: &GpuGrid,
        cells: u64,
        reuse: Option<Visibility>,
    ) -> (CellTables, Option<wgpu::Buffer>) {
        match reuse {
            Some(v) => {
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                encoder.clear_buffer(&v.cell_count, 0, None);
                ctx.queue.submit([encoder.finish()]);
                let tables = CellTables {
                    cell_count: v.cell_count,
                    cell_offset: v.cell_offset,
                    direction_base: v.direction_base,
                };
                (tables, Some(v.layers))
            }
            None => {
                let tables = CellTables {
                    cell_count: ctx.buffer_zeroed(
                        ledger,
                        "visibility: cell counts",
                        cells * 4,
                        STORAGE,
                    ),
                    cell_offset: ctx.buffer_zeroed(
                        ledger,
                        "visibility: cell offsets",
                        cells * 4,
                        STORAGE,
                    ),
                    direction_base: ctx.buffer_zeroed(
                        ledger,
                        "visibility: direction bases",
                        (grid.direction_count as u64 + 1) * 4,
                        STORAGE,
                    ),
                };
                (tables, None)
            }
        }
    }

    /// Group 0 per triangle chunk, with the chunk's triangle count: one uniform per chunk,
    /// differing only in triangle_base.
    fn chunk_bind_groups(
        &self,
        ctx: &GpuContext,
        layout0: &wgpu::BindGroupLayout,
        scene: &SceneBuffers,
        grid: &GpuGrid,
    ) -> Vec<(wgpu::BindGroup, u32)> {
        (0..grid.triangle_count.div_ceil(TRIANGLES_PER_DISPATCH).max(1))
            .map(|c| {
                let base = c * TRIANGLES_PER_DISPATCH;
                let g = GpuGrid {
                    triangle_base: base,
                    ..*grid
                };
                let buf = ctx
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("grid chunk"),
                        contents: bytemuck::bytes_of(&g),
                        usage: wgpu::BufferUsages::UNIFORM,
                    });
                let bg = ctx.bind_group(
                    layout0,
                    &[
                        &buf,
                        &scene.directions,
                        &scene.vertices,
                        &scene.triangles,
                        &self.cell_count,
                        &self.cell_offset,
                        &self.direction_base,
                        &scene.surface.cutouts,
                        &scene.surface.triangle_uv,
                    ],
                );
                (bg, (grid.triangle_count - base).min(TRIANGLES_PER_DISPATCH))
            })
            .collect()
    }
}

/// One submitted pass: `pipeline` over every triangle chunk (count or fill, with `group1`
/// bound), then what `finish` records (the scans, or the sort).
fn per_triangle_pass(
    ctx: &GpuContext,
    label: &str,
    timestamps: &mut Option<Timestamps>,
    (pipeline, group1): (&wgpu::ComputePipeline, &wgpu::BindGroup),
    chunks: &[(wgpu::BindGroup, u32)],
    grid: &GpuGrid,
    finish: impl FnOnce(&mut wgpu::ComputePass),
) {
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: timestamps.as_mut().and_then(|t| t.compute_writes()),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(1, group1, &[]);
        for (bg, n) in chunks {
            pass.set_bind_group(0, bg, &[]);
            pass.dispatch_workgroups(1, groups(*n, TRIANGLES_PER_WORKGROUP), grid.direction_count);
        }
        finish(&mut pass);
    }
    ctx.queue.submit([encoder.finish()]);
}

/// The layers buffer for `layer_count` layers: the earlier build's when it is large enough,
/// else a new one (grown with headroom when it replaces one, the old one freed first).
fn layers_buffer(
    ctx: &GpuContext,
    ledger: &MemoryLedger,
    old_layers: Option<wgpu::Buffer>,
    layer_count: u64,
) -> wgpu::Buffer {
    match old_layers {
        Some(l) if l.size() >= layer_count * 8 => l,
        Some(l) => {
            // another direction set needs more layers: grow with headroom, free the old
            drop(l);
            let bytes = (layer_count * 8 + layer_count / 2)
                .min(ctx.limits().max_storage_buffer_binding_size)
                .max(layer_count * 8);
            let grown = ctx.buffer_zeroed(
                &MemoryLedger::default(),
                "visibility: layers",
                bytes,
                STORAGE,
            );
            ledger.replace("visibility: layers", grown.size());
            grown
        }
        None => ctx.buffer_zeroed(ledger, "visibility: layers", layer_count * 8, STORAGE),
    }
}

/// Read one u32 at byte `offset` of a storage buffer.
fn read_tail(ctx: &GpuContext, buffer: &wgpu::Buffer, offset: u64) -> Result<Vec<u32>> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("tail"),
        size: 4,
        usage: STORAGE,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, 4);
    ctx.queue.submit([encoder.finish()]);
    ctx.read_buffer(&staging, 4)
}
