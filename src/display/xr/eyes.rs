//! The headset's eyes: a swapchain per eye at the runtime's recommended size (scaled), its
//! images wrapped as wgpu textures, the offscreen image the renderer draws into and the present
//! binding that puts it on the swapchain image; the untimed warm-up frame; the left eye's
//! screenshot.

use super::session::{xr_error, VIEW_TYPE};
use super::XrOptions;
use crate::display::present::{PresentBinding, PresentPipeline};
use crate::error::{Result, VlfError};
use crate::gpu::types::GpuPresent;
use crate::gpu::{GpuContext, Timestamps};
use crate::lightfield::LightField;
use crate::render::{Renderer, ViewTargets};
use openxr as xr;

/// One eye: the runtime's swapchain, its images as wgpu textures, and the offscreen image the
/// renderer draws into.
pub(super) struct Eye {
    pub(super) name: &'static str,
    /// before `swapchain`: fields drop in order, and the runtime frees the images with it
    pub(super) images: Vec<wgpu::Texture>,
    pub(super) swapchain: xr::Swapchain<xr::Vulkan>,
    pub(super) size: [u32; 2],
    pub(super) targets: ViewTargets,
    pub(super) binding: PresentBinding,
}

/// Both eyes' swapchains and images, as the runtime recommends them (times
/// `options.resolution_scale`).
pub(super) fn create(
    ctx: &GpuContext,
    (instance, system, session): (&xr::Instance, xr::SystemId, &xr::Session<xr::Vulkan>),
    renderer: &Renderer,
    present: &PresentPipeline,
    (vk_format, format): (ash::vk::Format, wgpu::TextureFormat),
    options: &XrOptions,
) -> Result<Vec<Eye>> {
    let overlay = crate::render::texture_2d(
        &ctx.device,
        "no overlay",
        [1, 1],
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let overlay_view = overlay.create_view(&Default::default());
    let view_configs = instance
        .enumerate_view_configuration_views(system, VIEW_TYPE)
        .map_err(xr_error("view configuration"))?;
    if view_configs.len() != 2 {
        return Err(VlfError::Display(format!(
            "the OpenXR headset has {} views in its primary stereo configuration, expected 2",
            view_configs.len()
        )));
    }
    let mut eyes = Vec::new();
    for (i, vc) in view_configs.iter().enumerate() {
        let name = ["left", "right"][i];
        let scaled = |recommended: u32, max: u32| {
            ((recommended as f32 * options.resolution_scale).round() as u32).clamp(1, max.max(1))
        };
        let size = [
            scaled(vc.recommended_image_rect_width, vc.max_image_rect_width),
            scaled(vc.recommended_image_rect_height, vc.max_image_rect_height),
        ];
        let swapchain = session
            .create_swapchain(&xr::SwapchainCreateInfo {
                create_flags: xr::SwapchainCreateFlags::EMPTY,
                usage_flags: xr::SwapchainUsageFlags::COLOR_ATTACHMENT
                    | xr::SwapchainUsageFlags::TRANSFER_SRC,
                format: vk_format.as_raw() as u32,
                sample_count: 1,
                width: size[0],
                height: size[1],
                face_count: 1,
                array_size: 1,
                mip_count: 1,
            })
            .map_err(xr_error("xrCreateSwapchain"))?;
        let images = swapchain
            .enumerate_images()
            .map_err(xr_error("swapchain images"))?
            .into_iter()
            .enumerate()
            .map(|(n, image)| {
                super::vulkan::wrap_swapchain_image(
                    ctx,
                    image,
                    format,
                    size,
                    &format!("{name} eye swapchain image {n}"),
                )
            })
            .collect::<Result<Vec<_>>>()?;
        let targets = renderer.view_targets(size[0], size[1]);
        let binding = PresentBinding::new(ctx, present, &targets.image_view, &overlay_view);
        binding.set(
            ctx,
            &GpuPresent {
                viewport_origin: [0.0, 0.0],
                viewport_size: [size[0] as f32, size[1] as f32],
                exposure: options.exposure,
                encode_srgb: (!present.surface_is_srgb) as u32,
                show_overlay: 0,
                _pad0: 0,
            },
        );
        eyes.push(Eye {
            name,
            images,
            swapchain,
            size,
            targets,
            binding,
        });
    }
    Ok(eyes)
}

/// One untimed frame before the session: the first use of every pipeline and image costs
/// more than a display period, and would otherwise be the first frame the headset shows
/// (timestamps included: their first read-back sets up more of the driver).
pub(super) fn warm_up(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    eyes: &[Eye],
    (camera, lf): (&crate::scene::Camera, &LightField),
    present: &PresentPipeline,
    format: wgpu::TextureFormat,
) -> Result<()> {
    let scratch = crate::render::texture_2d(
        &ctx.device,
        "warm-up",
        eyes[0].size,
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let scratch_view = scratch.create_view(&Default::default());
    let mut timestamps = Timestamps::new(ctx, 2);
    for eye in eyes {
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
        eye.binding.draw(&mut encoder, &scratch_view, present);
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
