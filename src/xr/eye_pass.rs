//! The eye-layer pass: the pipeline that puts the rendered eyes (and their depth) on the
//! swapchain images, `shaders/xr_eye.wgsl` a layer at a time or `shaders/xr_multiview.wgsl` onto
//! every layer at once, its bind group, and the pass itself. The swapchains (`layers`) and the
//! multiview check (`multiview_check`) both draw with it.

use crate::error::{Result, VlfError};
use crate::gpu::GpuContext;
use std::num::NonZeroU32;

/// One pass of the eye-layer pipeline onto `layer` of the colour and/or depth image, or onto all
/// of their layers in one multiview pass (`layer` None).
pub(super) fn layer_pass(
    encoder: &mut wgpu::CommandEncoder,
    (colour, depth): (Option<&wgpu::Texture>, Option<&wgpu::Texture>),
    (pipeline, bind_group): (&wgpu::RenderPipeline, &wgpu::BindGroup),
    layer: Option<u32>,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) {
    let layers = (colour.or(depth)).map_or(1, |t| t.depth_or_array_layers());
    let colour_view = colour.map(|c| layer_view(c, layer, layers));
    let depth_view = depth.map(|d| layer_view(d, layer, layers));
    let colour_attachments: Vec<_> = (colour_view.iter())
        .map(|view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                // the triangle covers every pixel: nothing to clear first
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })
        })
        .collect();
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("eye layers"),
        color_attachments: &colour_attachments,
        depth_stencil_attachment: depth_view.as_ref().map(|view| {
            wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }
        }),
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: layer.is_none().then(|| all_views(layers)),
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.draw(0..3, 0..1);
}

/// Layer `layer` of `texture` (its first mip, from its corner) as a copy's source or
/// destination.
pub(super) fn layer_copy(texture: &wgpu::Texture, layer: u32) -> wgpu::TexelCopyTextureInfo<'_> {
    wgpu::TexelCopyTextureInfo {
        texture,
        mip_level: 0,
        origin: wgpu::Origin3d {
            x: 0,
            y: 0,
            z: layer,
        },
        aspect: wgpu::TextureAspect::All,
    }
}

/// All of the views of a multiview pass.
fn all_views(eyes: u32) -> NonZeroU32 {
    NonZeroU32::new((1u32 << eyes) - 1).unwrap_or(NonZeroU32::MIN)
}

/// A view of one layer of `texture` (2D), or of all `layers` (an array, multiview).
pub(super) fn layer_view(
    texture: &wgpu::Texture,
    layer: Option<u32>,
    layers: u32,
) -> wgpu::TextureView {
    let (dimension, base_array_layer, count) = match layer {
        Some(l) => (wgpu::TextureViewDimension::D2, l, 1),
        None => (wgpu::TextureViewDimension::D2Array, 0, layers),
    };
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(dimension),
        base_array_layer,
        array_layer_count: Some(count),
        ..Default::default()
    })
}

pub(super) fn bind_group(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource<'_>],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = (resources.iter().enumerate())
        .map(|(i, r)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: r.clone(),
        })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("eye layers"),
        layout,
        entries: &entries,
    })
}

/// The pipeline that puts the eyes on the swapchain images: `stage` (xr_eye.wgsl, or
/// xr_multiview.wgsl for both eyes at once), writing colour where there is a colour target (none:
/// xr_colour.wgsl puts it there) and depth where there is a depth target.
pub(super) fn pipeline(
    ctx: &GpuContext,
    stage: &str,
    layout: &wgpu::BindGroupLayout,
    (colour, depth): (Option<wgpu::TextureFormat>, Option<wgpu::TextureFormat>),
    multiview: bool,
) -> Result<wgpu::RenderPipeline> {
    let fragment = match (colour, depth) {
        (Some(_), Some(_)) => "fs_colour_depth",
        (Some(_), None) => "fs_colour",
        (None, Some(_)) => "fs_depth",
        (None, None) => {
            return Err(VlfError::Display(format!(
                "{stage}: an eye-layer pipeline needs a colour or a depth target"
            )))
        }
    };
    let eyes = multiview.then(|| all_views(2));
    crate::display::present::fullscreen_pipeline(
        ctx,
        (stage, fragment),
        layout,
        (colour, depth),
        eyes,
    )
}
