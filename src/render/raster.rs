//! Raster first hits (issue 32): each view's eye rays take their first hits from a visibility
//! buffer the hardware rasteriser draws (`shaders/visibility_raster.wgsl`) instead of casting
//! them through the BVH. Every MSAA sample of the buffer names the triangle its eye ray meets
//! (the ray through the sample's standard position); the resolve (`shaders/render.wgsl`,
//! `first_hit`) meets that triangle's plane where `cast_ray` would and shades from there as the
//! ray-cast path does: mirrors, glossy parts and moving objects seen in them keep their BVH rays.
//! The rasteriser finds a million triangles' first hits for a view at a fixed cost per sample;
//! the casts it replaces grow with the tree's depth and the scene's overlap.

use crate::error::{Result, VlfError};
use crate::gpu::{reflect, shaders, GpuContext};
use serde::{Deserialize, Serialize};

/// How eye rays find the surface they meet first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FirstHits {
    /// each eye ray cast through the BVH (on a Hammersley set of positions in the pixel)
    #[default]
    Rays,
    /// a visibility buffer drawn by the rasteriser, one MSAA sample per eye ray
    Raster,
}

impl FirstHits {
    /// The names a display TOML and the CLI take.
    pub const NAMES: [&'static str; 2] = ["rays", "raster"];

    pub fn is_rays(&self) -> bool {
        *self == FirstHits::Rays
    }

    pub fn name(self) -> &'static str {
        match self {
            FirstHits::Rays => "rays",
            FirstHits::Raster => "raster",
        }
    }
}

impl std::str::FromStr for FirstHits {
    type Err = VlfError;

    fn from_str(s: &str) -> Result<FirstHits> {
        match s {
            "rays" => Ok(FirstHits::Rays),
            "raster" => Ok(FirstHits::Raster),
            other => Err(VlfError::Parameter {
                name: "first_hits",
                message: format!("{other:?}: use \"rays\" or \"raster\""),
            }),
        }
    }
}

impl std::fmt::Display for FirstHits {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The visibility buffer's format: the triangle plus one in two 16-bit halves. Every adapter
/// takes 4x MSAA of it (R32Uint needs an adapter-specific feature for any).
pub const VISIBILITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg16Uint;
const RASTER_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The MSAA sample counts the device draws the visibility buffer with: 4 everywhere, and 2, 8
/// and 16 where the adapter has them for both the visibility and the depth format.
pub fn msaa_counts(ctx: &GpuContext) -> Vec<u32> {
    let specific =
        (ctx.device.features()).contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);
    let takes = |format, n| {
        (ctx.adapter.get_texture_format_features(format).flags).sample_count_supported(n)
    };
    [2, 4, 8, 16]
        .into_iter()
        .filter(|&n| {
            n == 4 || (specific && takes(VISIBILITY_FORMAT, n) && takes(RASTER_DEPTH_FORMAT, n))
        })
        .collect()
}

/// The raster pass of one renderer: its pipeline, its bind group (the view, the triangles) and
/// the resolve pipeline that reads what it draws.
pub struct RasterPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// `render.wgsl` compiled with `RASTER_FIRST_HITS` 1
    pub(super) resolve: wgpu::ComputePipeline,
    /// MSAA samples per pixel: the most eye rays a pixel has
    pub samples: u32,
    /// the scene's triangles and the moving objects' after them
    triangle_count: u32,
}

/// The renderer's buffers the raster pass draws from.
pub(super) struct RasterInputs<'a> {
    pub view: &'a wgpu::Buffer,
    pub triangles: &'a wgpu::Buffer,
    pub ray_triangles: &'a wgpu::Buffer,
    pub triangle_count: u32,
    pub moving: bool,
}

/// One view's visibility buffer and the depth buffer it is drawn with.
pub struct RasterTargets {
    pub samples: u32,
    pub visibility: wgpu::TextureView,
    depth: wgpu::TextureView,
}

impl RasterPass {
    /// The pass for `samples` MSAA samples (one of `msaa_counts`), reading `resolve`'s output.
    pub(super) fn new(
        ctx: &GpuContext,
        samples: u32,
        inputs: &RasterInputs,
        resolve: wgpu::ComputePipeline,
    ) -> Result<RasterPass> {
        let counts = msaa_counts(ctx);
        if !counts.contains(&samples) {
            return Err(VlfError::Parameter {
                name: "first_hits",
                message: format!(
                    "raster first hits draw one MSAA sample per eye ray, and this adapter takes \
                     {counts:?} samples per pixel, not {samples}: set the eye rays per pixel \
                     (antialiasing, --aa) to one of them"
                ),
            });
        }
        let device = &ctx.device;
        let stage = "visibility_raster.wgsl";
        let module = shaders::module_with(
            device,
            stage,
            &[("MOVING_OBJECTS", u32::from(inputs.moving))],
        )?;
        let layout = reflect::layout(device, stage, 0)?;
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(stage),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(stage),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("triangle_corner"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            // no culling: the back of a one-sided face occludes, as it stops an eye ray
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: RASTER_DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: samples,
                mask: !0,
                alpha_to_coverage_enabled: false,
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("mark_triangle"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: VISIBILITY_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let bind_group = ctx.bind_group(
            &layout,
            &[inputs.view, inputs.triangles, inputs.ray_triangles],
        );
        Ok(RasterPass {
            pipeline,
            bind_group,
            resolve,
            samples,
            triangle_count: inputs.triangle_count,
        })
    }

    /// A view's visibility and depth buffers, `width` x `height`.
    pub fn targets(&self, device: &wgpu::Device, [width, height]: [u32; 2]) -> RasterTargets {
        RasterTargets {
            samples: self.samples,
            visibility: multisampled(device, [width, height], VISIBILITY_FORMAT, self.samples),
            depth: multisampled(device, [width, height], RASTER_DEPTH_FORMAT, self.samples),
        }
    }

    /// Draw the view set last into `targets`: every triangle, nothing culled but the moving
    /// objects' backs (in the vertex shader). The resolve reads the buffer next.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &RasterTargets,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("visibility"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &targets.visibility,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.draw(0..self.triangle_count * 3, 0..1);
    }
}

/// The visibility binding of a renderer that casts its first hits: one texel, never read.
pub(super) fn placeholder_visibility(device: &wgpu::Device) -> wgpu::TextureView {
    multisampled(device, [1, 1], VISIBILITY_FORMAT, 4)
}

fn multisampled(
    device: &wgpu::Device,
    [width, height]: [u32; 2],
    format: wgpu::TextureFormat,
    samples: u32,
) -> wgpu::TextureView {
    let usage = if format == VISIBILITY_FORMAT {
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING
    } else {
        wgpu::TextureUsages::RENDER_ATTACHMENT
    };
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some(if format == VISIBILITY_FORMAT {
                "visibility"
            } else {
                "visibility depth"
            }),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
        .create_view(&Default::default())
}
