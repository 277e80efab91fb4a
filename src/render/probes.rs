//! Irradiance probes baked from the converged light field (`shaders/probes.wgsl`): a grid over
//! the scene's box, each probe the radiance arriving at its point in nine spherical-harmonic
//! coefficients per colour. Moving objects, which the light field does not hold, are lit from
//! them (`common/moving_surface.wgsl`). Baked once per light field, only where a display has
//! moving objects.

use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuProbeGrid, GpuView};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use glam::Vec3;

/// How the probes are laid out and baked.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSettings {
    /// probes along the scene box's longest side (the others in proportion, at least 2)
    #[serde(default = "default_resolution")]
    pub resolution: u32,
    /// rays per probe (a multiple of 64)
    #[serde(default = "default_rays")]
    pub rays: u32,
}

fn default_resolution() -> u32 {
    24
}

fn default_rays() -> u32 {
    1024
}

impl Default for ProbeSettings {
    fn default() -> Self {
        ProbeSettings {
            resolution: default_resolution(),
            rays: default_rays(),
        }
    }
}

impl ProbeSettings {
    pub fn check(&self) -> std::result::Result<(), String> {
        if !(2..=128).contains(&self.resolution) {
            return Err(format!(
                "[probes] resolution = {}: use 2 to 128",
                self.resolution
            ));
        }
        if self.rays == 0 || !self.rays.is_multiple_of(64) || self.rays > 65536 {
            return Err(format!(
                "[probes] rays = {}: use a multiple of 64 up to 65536",
                self.rays
            ));
        }
        Ok(())
    }
}

/// The grid over the box `lo`..`hi` (normalised space): cells as cubic as the box allows, probes
/// at the cells' centres.
pub fn probe_grid(lo: Vec3, hi: Vec3, settings: &ProbeSettings) -> GpuProbeGrid {
    let extent = (hi - lo).max(Vec3::splat(1e-6));
    let cell = extent.max_element() / settings.resolution as f32;
    let counts = (extent / cell).ceil().as_uvec3().max(glam::UVec3::splat(2));
    let spacing = extent / counts.as_vec3();
    GpuProbeGrid {
        origin: (lo + spacing * 0.5).into(),
        rays: settings.rays,
        spacing: spacing.into(),
        counts: counts.into(),
        ..Default::default()
    }
}

/// The baked probes: the grid (a uniform) and the coefficients, 9 vec4 per probe.
pub struct Probes {
    pub grid: GpuProbeGrid,
    pub grid_buffer: wgpu::Buffer,
    pub coefficients: wgpu::Buffer,
}

/// What the bake reads: the renderer's scene buffers (group 0 of probes.wgsl, as render.wgsl
/// binds them) and the light field's bind group.
pub struct BakeInputs<'a> {
    pub view: &'a GpuView,
    pub faces: &'a wgpu::Buffer,
    pub triangles: &'a wgpu::Buffer,
    pub pairs: &'a wgpu::Buffer,
    pub ray_triangles: &'a wgpu::Buffer,
    pub materials: &'a wgpu::Buffer,
    /// the light field and its layout uniform (`lightfield::bindings`)
    pub resident: &'a crate::lightfield::ResidentLightField,
    pub field: &'a wgpu::Buffer,
    pub stack: u32,
}

/// Bake `grid`'s probes from the light field and wait for them.
pub fn bake(
    ctx: &GpuContext,
    ledger: &MemoryLedger,
    grid: GpuProbeGrid,
    inputs: &BakeInputs,
) -> Result<Probes> {
    let device = &ctx.device;
    let module = shaders::module_with(
        device,
        "probes.wgsl",
        &[("PROBE_RAYS", grid.rays), ("PAIR_STACK", inputs.stack)],
    )?;
    let layout = reflect::layout(device, "probes.wgsl", 0)?;
    let field_layout = crate::lightfield::bindings::layout(device, "probes.wgsl")?;
    let field = inputs.resident.bind_group(&field_layout, inputs.field);
    let pipeline = ctx.compute_pipeline(&module, "bake", &[&layout, &field_layout.layout]);
    let count = grid.counts.iter().product::<u32>();
    let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
    let view = GpuView {
        moving_root: u32::MAX,
        ..*inputs.view
    };
    let view_buffer = ctx.buffer_init(ledger, "probes: view", bytemuck::bytes_of(&view), uniform);
    let grid_buffer = ctx.buffer_init(ledger, "probes: grid", bytemuck::bytes_of(&grid), uniform);
    let coefficients = ctx.buffer_init(
        ledger,
        "probes: coefficients",
        &vec![0u8; count as usize * 9 * 16],
        STORAGE,
    );
    let group = ctx.bind_group(
        &layout,
        &[
            &view_buffer,
            inputs.faces,
            inputs.triangles,
            inputs.pairs,
            &grid_buffer,
            inputs.ray_triangles,
            &coefficients,
            inputs.materials,
        ],
    );
    // a row of at most 65535 workgroups (the limit of one dimension), one per probe
    let (x, y) = (count.min(65535), count.div_ceil(65535));
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.set_bind_group(1, &field, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    ctx.wait()
        .map_err(|e| VlfError::Gpu(format!("baking {count} irradiance probes: {e}")))?;
    Ok(Probes {
        grid,
        grid_buffer,
        coefficients,
    })
}
