//! Whether the device's multiview really draws every layer. Before the session uses multiview,
//! the eye-layer pipeline itself (`shaders/xr_multiview.wgsl`, the swapchains' formats) puts two
//! tiny eyes of different constant colour and depth on a 2-layer target in one multiview pass,
//! and both layers are read back. A device can take the feature and still draw only the first
//! layer: Mesa 22's lavapipe does, which would give the headset a black right eye.

use crate::error::Result;
use crate::gpu::types::GpuPresent;
use crate::gpu::GpuContext;

/// The check's eyes: 4x4 pixels (a whole 256-byte row of read-back per layer at 4 bytes a pixel)
const SIZE: u32 = 4;
/// each eye's constant radiance and depth (left, right)
const RADIANCE: [f32; 2] = [0.2, 0.8];
const DEPTH: [f32; 2] = [0.25, 0.75];

/// Ok(None) when both layers hold their own eye; Ok(Some(what went wrong)) when not.
/// `pipeline` (of xr_multiview.wgsl, with its bind group `layout`) draws onto `colour` and,
/// where it writes depth, `depth`.
pub(super) fn multiview_failure(
    ctx: &GpuContext,
    (layout, pipeline): (&wgpu::BindGroupLayout, &wgpu::RenderPipeline),
    (colour, depth): (wgpu::TextureFormat, Option<wgpu::TextureFormat>),
) -> Result<Option<String>> {
    let device = &ctx.device;
    let params = crate::display::present::params_buffer(
        ctx,
        "multiview check parameters",
        Some(&GpuPresent {
            viewport_origin: [0.0, 0.0],
            viewport_size: [SIZE as f32; 2],
            exposure: 1.0,
            encode_srgb: 0,
            show_overlay: 0,
            _pad0: 0,
        }),
    );
    let images = RADIANCE.map(|v| filled(ctx, wgpu::TextureFormat::Rgba32Float, [v, v, v, 1.0]));
    let depths = DEPTH.map(|v| filled(ctx, wgpu::TextureFormat::R32Float, [v, 0.0, 0.0, 0.0]));
    let views = [&images[0], &images[1], &depths[0], &depths[1]]
        .map(|t| t.create_view(&Default::default()));
    let mut entries = vec![params.as_entire_binding()];
    entries.extend(views.iter().map(wgpu::BindingResource::TextureView));
    let bind_group = super::eye_pass::bind_group(ctx, layout, &entries);
    let colour_target = target(ctx, colour);
    let depth_target = depth.map(|f| target(ctx, f));
    let mut encoder = device.create_command_encoder(&Default::default());
    super::eye_pass::layer_pass(
        &mut encoder,
        (Some(&colour_target), depth_target.as_ref()),
        (pipeline, &bind_group),
        None,
        None,
    );
    let mut readback = vec![&colour_target];
    readback.extend(depth_target.as_ref());
    let row = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let layer_bytes = (row * SIZE) as u64;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("multiview check read-back"),
        size: layer_bytes * 2 * readback.len() as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    for (t, texture) in readback.iter().enumerate() {
        for layer in 0..2u32 {
            let offset = layer_bytes * (2 * t as u64 + layer as u64);
            copy_layer(&mut encoder, texture, layer, (&buffer, offset, row));
        }
    }
    ctx.queue.submit([encoder.finish()]);
    let bytes: Vec<u8> = ctx.read_buffer(&buffer, buffer.size())?;
    Ok(judge(&bytes, layer_bytes as usize, depth.is_some()))
}

/// What the read-back says: the colour layers' first pixels (grey, so any channel order) must
/// hold the left eye's dark and the right eye's light grey (a layer left cleared is black, one
/// given the wrong eye matches the other), and each depth layer its eye's depth.
fn judge(bytes: &[u8], layer_bytes: usize, with_depth: bool) -> Option<String> {
    let grey = |layer: usize| bytes[layer * layer_bytes];
    let (left, right) = (grey(0), grey(1));
    if left == 0 || right <= left {
        return Some(format!(
            "a multiview pass drew grey {left} and {right} for eyes of {} and {}: the device does not draw each layer's own eye",
            RADIANCE[0], RADIANCE[1]
        ));
    }
    if with_depth {
        for (layer, want) in DEPTH.iter().enumerate() {
            let at = (2 + layer) * layer_bytes;
            let got = f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
            if (got - want).abs() > 1e-6 {
                return Some(format!(
                    "a multiview pass left depth {got} in layer {layer}, not its eye's {want}"
                ));
            }
        }
    }
    None
}

/// A SIZE x SIZE texture to sample, every pixel `value`.
fn filled(ctx: &GpuContext, format: wgpu::TextureFormat, value: [f32; 4]) -> wgpu::Texture {
    let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("multiview check eye"),
        size: wgpu::Extent3d {
            width: SIZE,
            height: SIZE,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let channels = if format == wgpu::TextureFormat::R32Float {
        1
    } else {
        4
    };
    let texel: Vec<f32> = value[..channels].to_vec();
    let data: Vec<f32> = (0..SIZE * SIZE)
        .flat_map(|_| texel.iter().copied())
        .collect();
    ctx.queue.write_texture(
        texture.as_image_copy(),
        bytemuck::cast_slice(&data),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(SIZE * 4 * channels as u32),
            rows_per_image: Some(SIZE),
        },
        texture.size(),
    );
    texture
}

/// A 2-layer SIZE x SIZE render target of `format` that can be read back.
fn target(ctx: &GpuContext, format: wgpu::TextureFormat) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("multiview check target"),
        size: wgpu::Extent3d {
            width: SIZE,
            height: SIZE,
            depth_or_array_layers: 2,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// One whole layer of `texture` into `buffer` at `offset`, `row` bytes a row.
fn copy_layer(
    encoder: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    layer: u32,
    (buffer, offset, row): (&wgpu::Buffer, u64, u32),
) {
    encoder.copy_texture_to_buffer(
        super::eye_pass::layer_copy(texture, layer),
        wgpu::TexelCopyBufferInfo {
            buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset,
                bytes_per_row: Some(row),
                rows_per_image: Some(SIZE),
            },
        },
        wgpu::Extent3d {
            width: SIZE,
            height: SIZE,
            depth_or_array_layers: 1,
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read_back(left: u8, right: u8, depth: [f32; 2]) -> Vec<u8> {
        let layer = 256 * SIZE as usize;
        let mut bytes = vec![0u8; layer * 4];
        bytes[0] = left;
        bytes[layer] = right;
        for (i, d) in depth.iter().enumerate() {
            bytes[(2 + i) * layer..][..4].copy_from_slice(&d.to_le_bytes());
        }
        bytes
    }

    #[test]
    fn alike_layers_or_a_wrong_depth_fail_the_check() {
        let layer = 256 * SIZE as usize;
        assert_eq!(judge(&read_back(51, 204, DEPTH), layer, true), None);
        for (left, right) in [(51, 51), (51, 0), (0, 0), (204, 51)] {
            let wrong = judge(&read_back(left, right, DEPTH), layer, true).unwrap();
            assert!(wrong.contains("each layer's own eye"), "{wrong}");
        }
        let cleared = judge(&read_back(51, 204, [0.25, 1.0]), layer, true).unwrap();
        assert!(cleared.contains("layer 1"), "{cleared}");
        assert_eq!(judge(&read_back(51, 204, [0.25, 1.0]), layer, false), None);
    }
}
