//! Edge antialiasing: many eye rays where a pixel shows an edge, one where it does not.
//!
//! Inside a surface the light field varies slowly across a pixel: one eye ray through the
//! pixel's centre shows what 16 would, and what the extra rays buy is the edges (a face's
//! silhouette, a crease between two faces, a sharp change of texture or light). So a view is
//! drawn in two compute passes (`shaders/render.wgsl`):
//! - the first pass: `resolve`, each pixel its tile's eye rays (frame pacing's count), on one
//!   progressive set whose first ray goes through the pixel's centre, leaving its average and
//!   what its first ray met (the face, the sky or a moving object); `find_edges`, which lists a
//!   pixel whose eye rays met different things, or whose 3x3 neighbours met something else or
//!   differ in luminance by more than `edge_contrast`; `edge_dispatch`, one thread that sizes
//!   the second pass;
//! - `refine`, dispatched indirectly: each listed pixel adds eye rays up to `edge_samples` from
//!   the same set, each with its own reflection, cast side by side by up to 64 threads and
//!   summed in workgroup memory, so an edge pixel is what a still with that many eye rays shows
//!   there (to within the pairing of reflections).
//!
//! The cost follows how many pixels are edges. Paced (`budget.rs`), only the tiles the pacer
//! gives 2 eye rays per pixel or more refine their edges: the fit's 1 eye ray per pixel stays the
//! floor, and the share of tiles the pacer moves carries the edges' cost with it (refining every
//! tile's edges put a floor under the pacer that it could not go below: on an H200 the 1M
//! classroom's walk CAVE took 8.6 ms a frame, over the 8.3 ms period).

use crate::error::{Result, VlfError};
use crate::gpu::GpuContext;

/// The relative difference in luminance from a neighbour that makes a pixel an edge when the
/// display config or command line does not say (`edge_contrast`).
pub const DEFAULT_EDGE_CONTRAST: f32 = 0.1;
/// Bytes of one pixel's first pass (render.wgsl `EdgePixel`: an rgb average and a u32).
const EDGE_PIXEL_BYTES: u64 = 16;
/// Bytes before the pixels (render.wgsl `EdgeBuffer`: x, y, z, count).
const HEADER_BYTES: u64 = 16;

/// Edge antialiasing's settings: eye rays per edge pixel (0: off) and the contrast test.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EdgeAntialiasing {
    /// eye rays per pixel where a pixel differs from a neighbour (2 to 256; more than the
    /// view's own eye rays per pixel, or nothing is refined)
    pub samples: u32,
    /// the relative difference in luminance from a neighbour that makes a pixel an edge
    #[serde(default = "default_contrast")]
    pub contrast: f32,
}

fn default_contrast() -> f32 {
    DEFAULT_EDGE_CONTRAST
}

impl EdgeAntialiasing {
    /// Checked settings (`samples` 2 to MAX_SAMPLES, `contrast` finite and not negative).
    pub fn new(samples: u32, contrast: f32) -> Result<EdgeAntialiasing> {
        let max = super::MAX_SAMPLES;
        if !(2..=max).contains(&samples) {
            return Err(VlfError::Parameter {
                name: "edge_samples",
                message: format!(
                    "{samples} eye rays per edge pixel: use 2 to {max} (left out: no edge \
                     antialiasing)"
                ),
            });
        }
        if !contrast.is_finite() || contrast < 0.0 {
            return Err(VlfError::Parameter {
                name: "edge_contrast",
                message: format!(
                    "{contrast}: a relative difference in luminance, 0 or more (0.1: a \
                     neighbour 10% brighter or darker makes an edge)"
                ),
            });
        }
        Ok(EdgeAntialiasing { samples, contrast })
    }

    /// These settings checked as `new` checks them (a display config's, read unchecked).
    pub fn checked(self) -> Result<EdgeAntialiasing> {
        EdgeAntialiasing::new(self.samples, self.contrast)
    }
}

/// The dispatches after the resolve: `find_edges` and `edge_dispatch` in the resolve's pass,
/// `refine` in a pass of its own (its indirect arguments are copied out of the buffer the first
/// pass writes: a buffer bound for writing cannot also give a dispatch its arguments).
pub struct EdgePass {
    find_edges: wgpu::ComputePipeline,
    edge_dispatch: wgpu::ComputePipeline,
    refine: wgpu::ComputePipeline,
}

/// How many of a view's pixels edge antialiasing refined in its last pass, of how many.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Refined {
    pub pixels: u32,
    pub of: u32,
}

impl Refined {
    /// The refined pixels' share of the view's.
    pub fn share(&self) -> f64 {
        self.pixels as f64 / self.of.max(1) as f64
    }
}

/// One view's buffer for edge antialiasing (render.wgsl `EdgeBuffer`: the refine pass's
/// dispatch and count, every pixel's first pass, the refined pixels) and the refine pass's
/// arguments copied out of it.
pub struct EdgeTargets {
    pub(super) buffer: wgpu::Buffer,
    arguments: wgpu::Buffer,
    pixel_count: u32,
}

impl EdgePass {
    /// The pipelines from `module` (render.wgsl compiled as the resolve is) and its layouts.
    pub(super) fn new(
        ctx: &GpuContext,
        module: &wgpu::ShaderModule,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> EdgePass {
        EdgePass {
            find_edges: ctx.compute_pipeline(module, "find_edges", layouts),
            edge_dispatch: ctx.compute_pipeline(module, "edge_dispatch", layouts),
            refine: ctx.compute_pipeline(module, "refine", layouts),
        }
    }

    /// Into the resolve's pass (after the resolve; its bind groups set): find the edge pixels
    /// of a view of `width` x `height` and size the refine pass.
    pub(super) fn encode_find(&self, pass: &mut wgpu::ComputePass, [width, height]: [u32; 2]) {
        pass.set_pipeline(&self.find_edges);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        pass.set_pipeline(&self.edge_dispatch);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// After the resolve's pass: copy the refine pass's arguments out of `targets`' buffer.
    pub(super) fn encode_arguments(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &EdgeTargets,
    ) {
        encoder.copy_buffer_to_buffer(&targets.buffer, 0, &targets.arguments, 0, 12);
    }

    /// Into the refine pass (its bind groups set): the listed pixels' added eye rays.
    pub(super) fn encode_refine(&self, pass: &mut wgpu::ComputePass, targets: &EdgeTargets) {
        pass.set_pipeline(&self.refine);
        pass.dispatch_workgroups_indirect(&targets.arguments, 0);
    }
}

impl EdgeTargets {
    /// The buffer for a view of `width` x `height`.
    pub(super) fn new(device: &wgpu::Device, [width, height]: [u32; 2]) -> EdgeTargets {
        let pixel_count = width * height;
        use wgpu::BufferUsages as U;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("edge antialiasing"),
            size: HEADER_BYTES + pixel_count as u64 * (EDGE_PIXEL_BYTES + 4),
            usage: U::STORAGE | U::INDIRECT | U::COPY_DST | U::COPY_SRC,
            mapped_at_creation: false,
        });
        let arguments = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("edge antialiasing: refine workgroups"),
            size: 16,
            usage: U::INDIRECT | U::COPY_DST,
            mapped_at_creation: false,
        });
        EdgeTargets {
            buffer,
            arguments,
            pixel_count,
        }
    }

    /// Stand-ins for views drawn without edge antialiasing (bound, never read).
    pub(super) fn placeholder(device: &wgpu::Device) -> EdgeTargets {
        EdgeTargets::new(device, [1, 1])
    }

    /// Empty the list before the view's pass (its count and dispatch).
    pub(super) fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.buffer, 0, Some(HEADER_BYTES));
    }

    /// How many pixels the last pass refined (waits for the GPU).
    pub fn refined(&self, ctx: &GpuContext) -> Result<Refined> {
        let header: Vec<u32> = ctx.read_buffer(&self.buffer, HEADER_BYTES)?;
        Ok(Refined {
            pixels: header[3],
            of: self.pixel_count,
        })
    }
}
