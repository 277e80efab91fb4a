//! The headset's eyes: each eye's size (the runtime's recommendation, scaled) and the offscreen
//! image and depth the renderer draws into (the swapchains they go on: `layers.rs`); the
//! untimed warm-up frame; the left eye's screenshot.

use super::layers::Layers;
use super::{xr_error, XrOptions, VIEW_TYPE};
use crate::error::{Result, VlfError};
use crate::gpu::{GpuContext, Timestamps};
use crate::lightfield::LightField;
use crate::render::{Renderer, ViewTargets};
use openxr as xr;

/// One eye: its size and the offscreen image and depth the renderer draws into.
pub(super) struct Eye {
    pub(super) name: &'static str,
    pub(super) size: [u32; 2],
    pub(super) targets: ViewTargets,
}

/// Both eyes, at the size the runtime recommends (times `options.resolution_scale`).
pub(super) fn create(
    (instance, system): (&xr::Instance, xr::SystemId),
    renderer: &Renderer,
    options: &XrOptions,
) -> Result<Vec<Eye>> {
    let view_configs = instance
        .enumerate_view_configuration_views(system, VIEW_TYPE)
        .map_err(xr_error("view configuration"))?;
    if view_configs.len() != 2 {
        return Err(VlfError::Display(format!(
            "the OpenXR headset has {} views in its primary stereo configuration, expected 2",
            view_configs.len()
        )));
    }
    let scaled = |recommended: u32, max: u32| {
        ((recommended as f32 * options.resolution_scale).round() as u32).clamp(1, max.max(1))
    };
    Ok((view_configs.iter().zip(["left", "right"]))
        .map(|(vc, name)| {
            let size = [
                scaled(vc.recommended_image_rect_width, vc.max_image_rect_width),
                scaled(vc.recommended_image_rect_height, vc.max_image_rect_height),
            ];
            Eye {
                name,
                size,
                targets: renderer.view_targets(size[0], size[1]),
            }
        })
        .collect())
}

/// One untimed frame before the session: the first use of every pipeline and image costs
/// more than a display period, and would otherwise be the first frame the headset shows
/// (timestamps included: their first read-back sets up more of the driver). The eyes go onto
/// images of the swapchains' shape, not the swapchains' own (the runtime counts those).
pub(super) fn warm_up(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    eyes: &[Eye],
    (camera, lf): (&crate::scene::Camera, &LightField),
    layers: &Layers,
) -> Result<()> {
    let (colour, depth) = layers.scratch(ctx);
    // a pair per eye and one for the layers, as a timed frame writes them
    let mut timestamps = Timestamps::new(ctx, 3);
    for (i, eye) in eyes.iter().enumerate() {
        let view_proj = crate::render::view_projection(
            camera,
            &lf.meta.normalisation,
            eye.size[0],
            eye.size[1],
        );
        renderer.set_view_matrix(
            view_proj,
            lf.meta.normalisation.to_unit(camera.eye).as_vec3(),
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        renderer.encode_view(&mut encoder, &eye.targets, timestamps.as_mut());
        if i + 1 == eyes.len() {
            let colour: Vec<&wgpu::Texture> = colour.iter().collect();
            let depth: Vec<&wgpu::Texture> = depth.iter().collect();
            let span = timestamps.as_mut().and_then(|t| t.next_span());
            layers.draw(&mut encoder, (&colour, &depth), span);
        }
        ctx.queue.submit([encoder.finish()]);
    }
    ctx.wait()?;
    if let Some(t) = timestamps.as_mut() {
        t.read_ms(ctx)?;
    }
    ctx.check_errors()
}

pub(super) fn copy_to_buffer(
    ctx: &GpuContext,
    encoder: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    [width, height]: [u32; 2],
) -> (wgpu::Buffer, u32) {
    let padded_row = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("left eye screenshot"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    crate::gpu::copy_texture_to_buffer(encoder, texture, &buffer, padded_row, [width, height]);
    (buffer, padded_row)
}

/// The swapchain image as the runtime got it (8-bit, sRGB-encoded) to PNG, written atomically.
pub(super) fn write_screenshot(
    bytes: &[u8],
    padded_row: u32,
    [width, height]: [u32; 2],
    format: wgpu::TextureFormat,
    path: &std::path::Path,
) -> Result<()> {
    let bgra = matches!(
        format,
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let mut rgba = Vec::with_capacity((width * height * 4) as usize);
    for row in bytes.chunks_exact(padded_row as usize) {
        for px in row[..(width * 4) as usize].chunks_exact(4) {
            let (r, b) = if bgra { (px[2], px[0]) } else { (px[0], px[2]) };
            rgba.extend_from_slice(&[r, px[1], b, 255]);
        }
    }
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &rgba,
        width,
        height,
        image::ExtendedColorType::Rgba8,
    )
    .map_err(|e| VlfError::Display(format!("{}: cannot encode PNG: {e}", path.display())))?;
    crate::lightfield::file::write_atomic(path, &png)
}
