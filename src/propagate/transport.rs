//! Drives `shaders/propagate.wgsl` (gather) and `shaders/accumulate.wgsl`: shooting iterations
//! with unshot / next / total, ping-ponging unshot and next, until the residual (unshot power
//! over emitted power) falls below the tolerance.

use super::visibility::{SceneBuffers, Visibility};
use super::{gpu_directions, gpu_faces, initial_radiance, PropagationParams, DEPTH_EPSILON};
use crate::error::Result;
use crate::gpu::types::{GpuGrid, GRID_FLAG_SKY};
use crate::gpu::{bind_group_layout, shaders, Binding, GpuContext, MemoryLedger, Timestamps, STORAGE};
use crate::lightfield::directions::DirectionSet;
use crate::lightfield::ResidentLightField;
use crate::prepare::PreparedScene;
use std::sync::Arc;

/// One finished iteration.
#[derive(Clone, Debug, serde::Serialize)]
pub struct IterationStats {
    pub iteration: u32,
    pub residual: f64,
    /// GPU milliseconds of gather + accumulate, when timestamps are available
    pub gpu_ms: Option<f64>,
    pub wall_ms: f64,
}

pub struct Propagator {
    pub ctx: Arc<GpuContext>,
    pub ledger: MemoryLedger,
    pub grid: GpuGrid,
    pub scene: SceneBuffers,
    pub visibility: Option<Visibility>,
    /// radiance[current] holds unshot radiosity, the other receives next
    radiance: [wgpu::Buffer; 2],
    current: usize,
    pub total: wgpu::Buffer,
    partials: wgpu::Buffer,
    partial_count: u32,
    gather_pipe: wgpu::ComputePipeline,
    accumulate_pipe: wgpu::ComputePipeline,
    gather_layout0: wgpu::BindGroupLayout,
    gather_layout1: wgpu::BindGroupLayout,
    accumulate_layout: wgpu::BindGroupLayout,
    /// coverage-weighted r+g+b power emitted by surfaces (texel area cancels in the ratio)
    pub emitted_power: f64,
    pub iteration: u32,
    pub texel_count: u32,
    timestamps: Option<Timestamps>,
}

fn dispatch_2d(groups: u32) -> (u32, u32) {
    let x = groups.clamp(1, 65535);
    (x, groups.div_ceil(x).max(1))
}

impl Propagator {
    pub fn new(ctx: Arc<GpuContext>, prepared: &PreparedScene, params: &PropagationParams, directions: &DirectionSet, sky: Option<[f32; 3]>) -> Result<Propagator> {
        let ledger = MemoryLedger::default();
        let device = &ctx.device;
        let faces = gpu_faces(prepared, directions);
        let texel_count = prepared.atlas.texel_count() as u32;
        ctx.check_binding("the radiance atlas", texel_count as u64 * 16, "lower the texel density")?;
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
            ..Default::default()
        };
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let vertices: Vec<[f32; 4]> = prepared.positions.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0]).collect();
        let triangles: Vec<[u32; 4]> = prepared.triangles.iter().map(|t| [t.vertices[0], t.vertices[1], t.vertices[2], t.face]).collect();
        let scene = SceneBuffers {
            grid: ctx.buffer_init(&ledger, "grid parameters", bytemuck::bytes_of(&grid), uniform),
            directions: ctx.buffer_init(&ledger, "directions", bytemuck::cast_slice(&gpu_directions(directions)), STORAGE),
            faces: ctx.buffer_init(&ledger, "faces", bytemuck::cast_slice(&faces), STORAGE),
            vertices: ctx.buffer_init(&ledger, "vertices", bytemuck::cast_slice(&vertices), STORAGE),
            triangles: ctx.buffer_init(&ledger, "triangles", bytemuck::cast_slice(&triangles), STORAGE),
            texel_points: ctx.buffer_init(&ledger, "texel sample points", bytemuck::cast_slice(&prepared.atlas.points), STORAGE),
            coverage: ctx.buffer_init(&ledger, "texel coverage", bytemuck::cast_slice(&prepared.atlas.coverage), STORAGE),
        };
        let (unshot, total) = initial_radiance(prepared, &faces);
        let emitted_power = unshot
            .iter()
            .zip(&prepared.atlas.coverage)
            .map(|(u, &c)| (u[0] as f64 + u[1] as f64 + u[2] as f64) * c as f64)
            .sum();
        let radiance = [
            ctx.buffer_init(&ledger, "unshot radiosity", bytemuck::cast_slice(&unshot), STORAGE),
            ctx.buffer_zeroed(&ledger, "next radiosity", texel_count as u64 * 16, STORAGE),
        ];
        let total = ctx.buffer_init(&ledger, "total radiance", bytemuck::cast_slice(&total), STORAGE);
        let (ax, ay) = dispatch_2d(texel_count.div_ceil(256));
        let partial_count = ax * ay;
        let partials = ctx.buffer_zeroed(&ledger, "power partial sums", partial_count as u64 * 8, STORAGE);

        use Binding::*;
        let cs = wgpu::ShaderStages::COMPUTE;
        let gather_layout0 = bind_group_layout(device, cs, &[Uniform, Storage, Storage, Storage, Storage, Storage, Storage]);
        let gather_layout1 = bind_group_layout(device, cs, &[Storage, StorageReadWrite]);
        let accumulate_layout = bind_group_layout(device, cs, &[Uniform, Storage, StorageReadWrite, Storage, StorageReadWrite]);
        let gather_module = shaders::module(device, "propagate.wgsl")?;
        let accumulate_module = shaders::module(device, "accumulate.wgsl")?;
        let gather_pipe = ctx.compute_pipeline(&gather_module, "gather", &[&gather_layout0, &gather_layout1]);
        let accumulate_pipe = ctx.compute_pipeline(&accumulate_module, "accumulate", &[&accumulate_layout]);
        let timestamps = Timestamps::new(&ctx, 8);
        Ok(Propagator {
            ctx,
            ledger,
            grid,
            scene,
            visibility: None,
            radiance,
            current: 0,
            total,
            partials,
            partial_count,
            gather_pipe,
            accumulate_pipe,
            gather_layout0,
            gather_layout1,
            accumulate_layout,
            emitted_power,
            iteration: 0,
            texel_count,
            timestamps,
        })
    }

    pub fn build_visibility(&mut self) -> Result<&Visibility> {
        let vis = Visibility::build(&self.ctx, &self.ledger, &self.scene, &self.grid, &mut self.timestamps)?;
        Ok(self.visibility.insert(vis))
    }

    /// One shooting iteration (one more bounce). Returns the residual after it.
    pub fn iterate(&mut self) -> Result<IterationStats> {
        let started = std::time::Instant::now();
        let vis = self.visibility.as_ref().expect("build_visibility before iterate");
        let ctx = &self.ctx;
        let mut grid = self.grid;
        grid.iteration = self.iteration;
        grid.flags = if self.iteration == 0 && grid.sky.iter().any(|&s| s > 0.0) { GRID_FLAG_SKY } else { 0 };
        ctx.queue.write_buffer(&self.scene.grid, 0, bytemuck::bytes_of(&grid));
        let s = &self.scene;
        let bg0 = ctx.bind_group(
            &self.gather_layout0,
            &[&s.grid, &s.directions, &s.faces, &vis.cell_offset, &vis.cell_count, &vis.layers, &s.texel_points],
        );
        let unshot = &self.radiance[self.current];
        let next = &self.radiance[1 - self.current];
        let bg1 = ctx.bind_group(&self.gather_layout1, &[unshot, next]);
        let acc_bg = ctx.bind_group(&self.accumulate_layout, &[&s.grid, next, &self.total, &s.coverage, &self.partials]);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("gather"),
                timestamp_writes: self.timestamps.as_mut().and_then(|t| t.compute_writes()),
            });
            pass.set_pipeline(&self.gather_pipe);
            pass.set_bind_group(0, &bg0, &[]);
            pass.set_bind_group(1, &bg1, &[]);
            let (x, y) = dispatch_2d(self.texel_count.div_ceil(64));
            pass.dispatch_workgroups(x, y, 1);
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("accumulate"),
                timestamp_writes: self.timestamps.as_mut().and_then(|t| t.compute_writes()),
            });
            pass.set_pipeline(&self.accumulate_pipe);
            pass.set_bind_group(0, &acc_bg, &[]);
            let (x, y) = dispatch_2d(self.texel_count.div_ceil(256));
            pass.dispatch_workgroups(x, y, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        let partials: Vec<[f32; 2]> = ctx.read_buffer(&self.partials, self.partial_count as u64 * 8)?;
        let unshot_power: f64 = partials.iter().map(|p| p[0] as f64).sum();
        if self.iteration == 0 {
            // the sky shoots once, in the first iteration: its received power counts as emitted
            self.emitted_power += partials.iter().map(|p| p[1] as f64).sum::<f64>();
        }
        let gpu_ms = match self.timestamps.as_mut() {
            Some(t) => Some(t.read_ms(ctx)?.iter().sum()),
            None => None,
        };
        self.current = 1 - self.current;
        self.iteration += 1;
        let residual = if self.emitted_power > 0.0 { unshot_power / self.emitted_power } else { 0.0 };
        Ok(IterationStats { iteration: self.iteration, residual, gpu_ms, wall_ms: started.elapsed().as_secs_f64() * 1e3 })
    }

    pub fn read_total(&self) -> Result<Vec<[f32; 4]>> {
        self.ctx.read_buffer(&self.total, self.texel_count as u64 * 16)
    }

    /// The unshot radiosity the next iteration will shoot (the last iteration's "next").
    pub fn read_unshot(&self) -> Result<Vec<[f32; 4]>> {
        self.ctx.read_buffer(&self.radiance[self.current], self.texel_count as u64 * 16)
    }

    /// GPU memory while propagating.
    pub fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    /// Keep only what rendering needs (faces and total); everything else is freed.
    pub fn into_resident(self) -> ResidentLightField {
        let ledger = MemoryLedger::default();
        ledger.record("faces", self.scene.faces.size());
        ledger.record("total radiance", self.total.size());
        ResidentLightField { ctx: self.ctx, faces: self.scene.faces, total: self.total, ledger }
    }
}
