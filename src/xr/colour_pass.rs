//! The eyes' colour onto the swapchain images without the rasteriser (`--layer-colour compute`):
//! a compute pass per eye (`shaders/xr_colour.wgsl`) writes the swapchain's bytes into an 8-bit
//! image of the eye's size, and a copy puts them on the eye's swapchain image (its layer of an
//! array swapchain). For 8-bit RGBA swapchains (sRGB or not), the formats vlf asks for first;
//! others keep the fragment pass (`layers.rs`). The depth, where the runtime takes it, still needs
//! a fragment pass: only a render pass writes a depth image. On an H200, both 2064x2208 eyes:
//! 1.42 ms with the depth, 0.76 ms without, against 1.30 ms for the default fragment pass with the
//! depth (2.60 ms while it cleared its images first: the clears, not the fragments, were most of
//! it).

use super::eye_pass::bind_group;
use crate::error::Result;
use crate::gpu::{GpuContext, PairSpan};
use crate::render::ViewTargets;

/// How the eyes' colour reaches the swapchain images (`vlf xr --layer-colour`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LayerColour {
    /// a compute pass and a copy where the swapchain is 8-bit RGBA, else a fragment pass
    Compute,
    /// a full-screen fragment pass (with the depth, where the runtime takes depth): the default
    Fragment,
}

/// The storage format the pass writes: a copy puts its bytes on swapchains of this format or its
/// sRGB twin unchanged.
const STORAGE: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Whether swapchain images of `format` take the compute pass's bytes by a copy.
pub(super) fn copies_onto(format: wgpu::TextureFormat) -> bool {
    format.remove_srgb_suffix() == STORAGE
}

/// The compute pass, and per eye its bind group and the image it writes.
pub(super) struct ComputeColour {
    pipeline: wgpu::ComputePipeline,
    eyes: Vec<(wgpu::BindGroup, wgpu::Texture)>,
}

impl ComputeColour {
    /// For `eyes` (their linear images), with the eye-layer parameters `params` (exposure; sRGB
    /// encoding on, as the storage does not encode).
    pub(super) fn create(
        ctx: &GpuContext,
        eyes: &[&ViewTargets],
        params: &wgpu::Buffer,
    ) -> Result<ComputeColour> {
        let stage = "xr_colour.wgsl";
        let layout = crate::gpu::reflect::layout(&ctx.device, stage, 0)?;
        let module = crate::gpu::shaders::module(&ctx.device, stage)?;
        let pipeline = ctx.compute_pipeline(&module, "cs_colour", &[&layout]);
        let eyes = (eyes.iter())
            .map(|eye| {
                let image = ctx.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("eye colour for the swapchain"),
                    size: wgpu::Extent3d {
                        width: eye.width,
                        height: eye.height,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: STORAGE,
                    usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                });
                let view = image.create_view(&Default::default());
                let entries = [
                    params.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&eye.image_view),
                    wgpu::BindingResource::TextureView(&view),
                ];
                (bind_group(ctx, &layout, &entries), image)
            })
            .collect();
        Ok(ComputeColour { pipeline, eyes })
    }

    /// The passes `encode` writes, for a timestamp span over them: a compute pass and an empty
    /// render pass per eye.
    pub(super) fn passes(&self) -> usize {
        2 * self.eyes.len()
    }

    /// Each eye's pass, then its copy onto `targets[i]` (the swapchain image and its layer) and
    /// an empty render pass on that layer: the runtime takes its images back as colour
    /// attachments (XR_KHR_vulkan_enable2), the layout a render pass leaves them in. `span`
    /// (with the index of its last pass, from later passes where there are any) times them.
    pub(super) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &[(&wgpu::Texture, u32)],
        span: Option<(PairSpan<'_>, usize)>,
    ) {
        for (i, (group, image)) in self.eyes.iter().enumerate() {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("eye colour"),
                timestamp_writes: span.and_then(|(s, last)| s.compute(i, last)),
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, group, &[]);
            let size = image.size();
            pass.dispatch_workgroups(size.width.div_ceil(8), size.height.div_ceil(8), 1);
        }
        let computed = self.eyes.len();
        for (k, ((_, image), &(target, layer))) in self.eyes.iter().zip(targets).enumerate() {
            encoder.copy_texture_to_texture(
                image.as_image_copy(),
                super::eye_pass::layer_copy(target, layer),
                image.size(),
            );
            let writes = span.and_then(|(s, last)| s.render(computed + k, last));
            keep_as_attachment(encoder, target, layer, writes);
        }
    }
}

/// An empty render pass on `layer` of `target`, which leaves it a colour attachment.
fn keep_as_attachment(
    encoder: &mut wgpu::CommandEncoder,
    target: &wgpu::Texture,
    layer: u32,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) {
    let view = super::eye_pass::layer_view(target, Some(layer), 1);
    drop(encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("eye colour: back to a colour attachment"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: &view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: None,
    }));
}
