//! Putting a view's linear image on a window's surface: the pipeline of `shaders/present.wgsl`
//! (scaled to the viewport, exposed, sRGB encoded unless the target does it, the status
//! overlay), one binding per image shown, and the render pass that draws it (the headset uses
//! the pass alone; its eyes go on the swapchains by `xr/layers.rs`).

use crate::error::Result;
use crate::gpu::types::GpuPresent;
use crate::gpu::GpuContext;

pub(crate) struct PresentPipeline {
    pub(crate) pipeline: wgpu::RenderPipeline,
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) surface_is_srgb: bool,
}

/// A render pass onto one colour target (a window's surface, a headset's swapchain image),
/// stored at the end.
pub(crate) fn present_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("present"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

pub(crate) fn present_pipeline(
    ctx: &GpuContext,
    format: wgpu::TextureFormat,
) -> Result<PresentPipeline> {
    // params, the eye's image, the status overlay: as present.wgsl declares them
    let layout = crate::gpu::reflect::layout(&ctx.device, "present.wgsl", 0)?;
    let pipeline = fullscreen_pipeline(
        ctx,
        ("present.wgsl", "fs_present"),
        &layout,
        (Some(format), None),
        None,
    )?;
    Ok(PresentPipeline {
        pipeline,
        layout,
        surface_is_srgb: format.is_srgb(),
    })
}

/// A pipeline that draws one triangle over the target (`vs_fullscreen`, common/fullscreen.wgsl)
/// with `fragment` of `stage`: onto a `colour` target (none: depth alone), and writing the
/// fragment's depth into a `depth` target where there is one (no depth test: the pass covers the
/// image once), into the layers of `multiview_mask` at once where there is one. Windows' present
/// pass and the headset's eye layers.
pub(crate) fn fullscreen_pipeline(
    ctx: &GpuContext,
    (stage, fragment): (&str, &str),
    layout: &wgpu::BindGroupLayout,
    (colour, depth): (Option<wgpu::TextureFormat>, Option<wgpu::TextureFormat>),
    multiview_mask: Option<std::num::NonZeroU32>,
) -> Result<wgpu::RenderPipeline> {
    // none: a pass that writes depth alone
    let targets: Vec<Option<wgpu::ColorTargetState>> = (colour.into_iter())
        .map(|format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        })
        .collect();
    let device = &ctx.device;
    let module = crate::gpu::shaders::module(device, stage)?;
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(stage),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    Ok(
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(stage),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: depth.map(|format| wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(fragment),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask,
            cache: None,
        }),
    )
}

/// A uniform buffer of present parameters (`PresentParams` in WGSL), holding `initial` if given.
pub(crate) fn params_buffer(
    ctx: &GpuContext,
    label: &str,
    initial: Option<&GpuPresent>,
) -> wgpu::Buffer {
    let params = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: std::mem::size_of::<GpuPresent>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    if let Some(p) = initial {
        ctx.queue.write_buffer(&params, 0, bytemuck::bytes_of(p));
    }
    params
}

/// One image as a target shows it: its parameters (viewport, exposure, encoding) and the bind
/// group of the present pipeline that reads it.
pub(crate) struct PresentBinding {
    pub(crate) params: wgpu::Buffer,
    pub(crate) bind_group: wgpu::BindGroup,
}

impl PresentBinding {
    pub(crate) fn new(
        ctx: &GpuContext,
        present: &PresentPipeline,
        image: &wgpu::TextureView,
        overlay: &wgpu::TextureView,
    ) -> PresentBinding {
        let params = params_buffer(ctx, "present parameters", None);
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("present"),
            layout: &present.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(image),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(overlay),
                },
            ],
        });
        PresentBinding { params, bind_group }
    }

    pub(crate) fn set(&self, ctx: &GpuContext, params: &GpuPresent) {
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(params));
    }
}
