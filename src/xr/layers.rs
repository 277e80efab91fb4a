//! The eyes on the runtime's swapchains. Where the runtime accepts it, one colour swapchain with
//! a layer per eye, both eyes put on it in one multiview pass (`shaders/xr_multiview.wgsl`)
//! where the device has multiview, a pass per layer (`shaders/xr_eye.wgsl`) where it has not;
//! otherwise, or with `--swapchains per-eye`, a swapchain per eye. With
//! XR_KHR_composition_layer_depth, a depth swapchain of the same shape takes the renderer's
//! depth (written as each fragment's depth by the same pass) and is chained into each projection
//! view (XrCompositionLayerDepthInfoKHR), so the runtime can reproject. With `--layer-colour
//! compute`, on 8-bit RGBA swapchains the colour goes on by a compute pass and a copy
//! (`colour_pass.rs`), and the fragment pass, if the runtime takes depth, writes the depth alone.

use super::colour_pass::{copies_onto, ComputeColour, LayerColour};
use super::eye_pass::{bind_group, layer_pass, layer_view, pipeline};
use super::{xr_error, XrOptions};
use crate::error::{Result, VlfError};
use crate::gpu::types::GpuPresent;
use crate::gpu::{GpuContext, PairSpan};
use crate::render::ViewTargets;
use openxr as xr;

/// Which swapchains the eyes are put on (`vlf xr --swapchains`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Swapchains {
    /// one array swapchain where the runtime accepts it, else one per eye
    Auto,
    /// one array swapchain, a layer per eye (an error where the runtime refuses it)
    Array,
    /// a swapchain per eye
    PerEye,
}

/// How the eyes reached the runtime.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Shape {
    PerEye,
    /// one swapchain, a layer per eye; both eyes in one multiview pass, or a pass per layer
    Array {
        multiview: bool,
    },
}

/// One swapchain of the runtime and its images as wgpu textures.
pub(super) struct Chain {
    /// before `swapchain`: fields drop in order, and the runtime frees the images with it
    pub(super) images: Vec<wgpu::Texture>,
    swapchain: xr::Swapchain<xr::Vulkan>,
    /// the image acquired this frame
    acquired: usize,
}

/// The swapchains the eyes go on and the pipeline that puts them there.
pub(super) struct Layers {
    pub(super) shape: Shape,
    /// why the eyes have a swapchain each (None: an array swapchain)
    pub(super) per_eye_because: Option<String>,
    /// why an array swapchain gets a pass per layer rather than one multiview pass
    no_multiview: Option<String>,
    /// one (array) or one per eye
    pub(super) colour: Vec<Chain>,
    /// the same shape as `colour`, or none
    pub(super) depth: Vec<Chain>,
    /// the depth swapchain's Vulkan format, or why the runtime gets no depth
    pub(super) depth_format: std::result::Result<ash::vk::Format, String>,
    /// the colour by a compute pass and a copy (None: by the fragment pass)
    compute: Option<ComputeColour>,
    /// why the runtime's swapchains could not take copies, where `--layer-colour compute` asked
    compute_refused: Option<String>,
    /// the fragment pass: colour and depth, or the depth alone after `compute` (None: no
    /// fragment pass, the compute pass puts the colour and the runtime takes no depth)
    pipeline: Option<wgpu::RenderPipeline>,
    /// one for both eyes (multiview), else one per eye
    bind_groups: Vec<wgpu::BindGroup>,
    /// the eye pass's parameters (a study's condition changes the exposure), and their buffer
    present: GpuPresent,
    params: wgpu::Buffer,
}

/// The swapchain formats: colour (Vulkan, wgpu) and depth (Vulkan, wgpu, or why none).
pub(super) type Formats = (
    (ash::vk::Format, wgpu::TextureFormat),
    std::result::Result<(ash::vk::Format, wgpu::TextureFormat), String>,
);

fn create_chain(
    ctx: &GpuContext,
    session: &xr::Session<xr::Vulkan>,
    (vk_format, format): (ash::vk::Format, wgpu::TextureFormat),
    (size, layers): ([u32; 2], u32),
    (label, copy_dst): (&str, bool),
) -> Result<std::result::Result<Chain, xr::sys::Result>> {
    let usage_flags = if format.is_depth_stencil_format() {
        xr::SwapchainUsageFlags::DEPTH_STENCIL_ATTACHMENT
    } else if copy_dst {
        xr::SwapchainUsageFlags::COLOR_ATTACHMENT
            | xr::SwapchainUsageFlags::TRANSFER_SRC
            | xr::SwapchainUsageFlags::TRANSFER_DST
    } else {
        xr::SwapchainUsageFlags::COLOR_ATTACHMENT | xr::SwapchainUsageFlags::TRANSFER_SRC
    };
    let swapchain = match session.create_swapchain(&xr::SwapchainCreateInfo {
        create_flags: xr::SwapchainCreateFlags::EMPTY,
        usage_flags,
        format: vk_format.as_raw() as u32,
        sample_count: 1,
        width: size[0],
        height: size[1],
        face_count: 1,
        array_size: layers,
        mip_count: 1,
    }) {
        Ok(s) => s,
        Err(e) => return Ok(Err(e)),
    };
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
                (size, layers),
                (&format!("{label} swapchain image {n}"), copy_dst),
            )
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Ok(Chain {
        images,
        swapchain,
        acquired: 0,
    }))
}

/// The colour swapchains: one array where the runtime takes it (and `mode` allows), else one per
/// eye (copy destinations where `copy_dst`); and why per eye.
fn colour_chains(
    ctx: &GpuContext,
    session: &xr::Session<xr::Vulkan>,
    colour: (ash::vk::Format, wgpu::TextureFormat),
    (sizes, copy_dst): (&[[u32; 2]], bool),
    mode: Swapchains,
) -> Result<(Vec<Chain>, Option<String>)> {
    let same_size = sizes.windows(2).all(|w| w[0] == w[1]);
    let why = match (mode, same_size) {
        (Swapchains::PerEye, _) => "--swapchains per-eye".to_string(),
        (_, false) => format!("the runtime recommends different sizes per eye ({sizes:?})"),
        (_, true) => {
            let layers = sizes.len() as u32;
            match create_chain(ctx, session, colour, (sizes[0], layers), ("eyes", copy_dst))? {
                Ok(chain) => return Ok((vec![chain], None)),
                Err(e) => format!("the runtime refused an array swapchain ({e})"),
            }
        }
    };
    if mode == Swapchains::Array {
        return Err(VlfError::Display(format!(
            "--swapchains array: {why}; run with --swapchains auto (or per-eye) to use a swapchain per eye"
        )));
    }
    let mut chains = Vec::new();
    for (size, name) in sizes.iter().zip(["left eye", "right eye"]) {
        let chain = create_chain(ctx, session, colour, (*size, 1), (name, copy_dst))?
            .map_err(xr_error("xrCreateSwapchain"))?;
        chains.push(chain);
    }
    Ok((chains, Some(why)))
}

/// Depth swapchains in the colour swapchains' shape, or why the runtime gets no depth.
fn depth_chains(
    ctx: &GpuContext,
    session: &xr::Session<xr::Vulkan>,
    depth: &std::result::Result<(ash::vk::Format, wgpu::TextureFormat), String>,
    sizes: &[[u32; 2]],
    array: bool,
) -> Result<(Vec<Chain>, std::result::Result<ash::vk::Format, String>)> {
    let depth = match depth {
        Ok(d) => *d,
        Err(why) => return Ok((Vec::new(), Err(why.clone()))),
    };
    let shapes: Vec<([u32; 2], u32)> = if array {
        vec![(sizes[0], sizes.len() as u32)]
    } else {
        sizes.iter().map(|s| (*s, 1)).collect()
    };
    let mut chains = Vec::new();
    for shape in shapes {
        match create_chain(ctx, session, depth, shape, ("depth", false))? {
            Ok(chain) => chains.push(chain),
            Err(e) => {
                return Ok((
                    Vec::new(),
                    Err(format!("the runtime refused a depth swapchain ({e})")),
                ))
            }
        }
    }
    Ok((chains, Ok(depth.0)))
}

impl Layers {
    /// The swapchains for `eyes` (the left first) and the pipeline that puts the eyes on them.
    pub(super) fn create(
        ctx: &GpuContext,
        session: &xr::Session<xr::Vulkan>,
        eyes: &[&ViewTargets],
        (colour, depth): Formats,
        options: &XrOptions,
    ) -> Result<Layers> {
        let sizes: Vec<[u32; 2]> = eyes.iter().map(|t| [t.width, t.height]).collect();
        let by_compute = options.layer_colour == LayerColour::Compute && copies_onto(colour.1);
        let chains =
            |copy_dst| colour_chains(ctx, session, colour, (&sizes, copy_dst), options.swapchains);
        // a runtime that refuses copies onto its images gets the fragment pass
        let (by_compute, compute_refused, (colour_chains, per_eye_because)) =
            match chains(by_compute) {
                Ok(made) => (by_compute, None, made),
                Err(e) if by_compute => {
                    log::warn!(
                        "{e} (swapchains that take copies, for --layer-colour compute); \
                         the eyes' colour goes on by the fragment pass"
                    );
                    (false, Some(e.to_string()), chains(false)?)
                }
                Err(e) => return Err(e),
            };
        let array = per_eye_because.is_none();
        let (depth_chains, depth_format) = depth_chains(ctx, session, &depth, &sizes, array)?;
        let device = &ctx.device;
        let depth_target = depth.ok().map(|d| d.1).filter(|_| depth_format.is_ok());
        let formats = (colour.1, depth_target);
        // the multiview pipeline, checked, where the array can take it; else a pass per eye
        let checked = match array {
            true => Some(multiview_pipeline(ctx, eyes.len() as u32, formats)?),
            false => None,
        };
        let (multiview, no_multiview) = match checked {
            Some(Ok(checked)) => (Some(checked), None),
            Some(Err(why)) => (None, Some(why)),
            None => (None, None),
        };
        let shape = match array {
            true => Shape::Array {
                multiview: multiview.is_some(),
            },
            false => Shape::PerEye,
        };
        let stage = match multiview.is_some() {
            true => "xr_multiview.wgsl",
            false => "xr_eye.wgsl",
        };
        let (layout, fragment_pipeline) = match multiview {
            Some(checked) => checked,
            None => {
                let layout = crate::gpu::reflect::layout(device, stage, 0)?;
                let pipeline =
                    pipeline(ctx, stage, &layout, (Some(colour.1), depth_target), false)?;
                (layout, pipeline)
            }
        };
        let present = GpuPresent {
            viewport_origin: [0.0, 0.0],
            viewport_size: [sizes[0][0] as f32, sizes[0][1] as f32],
            exposure: options.exposure,
            // the compute pass writes 8-bit storage, which never encodes
            encode_srgb: (by_compute || !colour.1.is_srgb()) as u32,
            show_overlay: 0,
            _pad0: 0,
        };
        let params =
            crate::display::present::params_buffer(ctx, "eye layer parameters", Some(&present));
        let compute = match by_compute {
            true => Some(ComputeColour::create(ctx, eyes, &params)?),
            false => None,
        };
        // after the compute pass, the fragment pass writes the depth alone, if any
        let fragment_pipeline = match (&compute, depth_target) {
            (None, _) => Some(fragment_pipeline),
            (Some(_), None) => None,
            (Some(_), Some(d)) => {
                let multiview = shape == (Shape::Array { multiview: true });
                Some(pipeline(ctx, stage, &layout, (None, Some(d)), multiview)?)
            }
        };
        let texture = wgpu::BindingResource::TextureView;
        let bind_groups = if shape == (Shape::Array { multiview: true }) {
            let entries = [
                params.as_entire_binding(),
                texture(&eyes[0].image_view),
                texture(&eyes[1].image_view),
                texture(&eyes[0].depth_view),
                texture(&eyes[1].depth_view),
            ];
            vec![bind_group(ctx, &layout, &entries)]
        } else {
            (eyes.iter())
                .map(|e| {
                    let entries = [
                        params.as_entire_binding(),
                        texture(&e.image_view),
                        texture(&e.depth_view),
                    ];
                    bind_group(ctx, &layout, &entries)
                })
                .collect()
        };
        Ok(Layers {
            shape,
            per_eye_because,
            no_multiview,
            colour: colour_chains,
            depth: depth_chains,
            depth_format,
            compute,
            compute_refused,
            pipeline: fragment_pipeline,
            bind_groups,
            present,
            params,
        })
    }

    /// Show the eyes at `exposure` from the next frame (`--exposure` times a study condition's).
    pub(super) fn set_exposure(&mut self, ctx: &GpuContext, exposure: f32) {
        if self.present.exposure != exposure {
            self.present.exposure = exposure;
            (ctx.queue).write_buffer(&self.params, 0, bytemuck::bytes_of(&self.present));
        }
    }

    /// Acquire and wait for this frame's image of every swapchain.
    pub(super) fn acquire(&mut self) -> Result<()> {
        for chain in self.colour.iter_mut().chain(self.depth.iter_mut()) {
            chain.acquired = chain
                .swapchain
                .acquire_image()
                .map_err(xr_error("xrAcquireSwapchainImage"))?
                as usize;
            chain
                .swapchain
                .wait_image(xr::Duration::INFINITE)
                .map_err(xr_error("xrWaitSwapchainImage"))?;
        }
        Ok(())
    }

    /// Release every swapchain's image of this frame.
    pub(super) fn release(&mut self) -> Result<()> {
        for chain in self.colour.iter_mut().chain(self.depth.iter_mut()) {
            chain
                .swapchain
                .release_image()
                .map_err(xr_error("xrReleaseSwapchainImage"))?;
        }
        Ok(())
    }

    /// This frame's images: colour, then depth, one per swapchain.
    pub(super) fn acquired(&self) -> (Vec<&wgpu::Texture>, Vec<&wgpu::Texture>) {
        let colour = self.colour.iter().map(|c| &c.images[c.acquired]);
        let depth = self.depth.iter().map(|c| &c.images[c.acquired]);
        (colour.collect(), depth.collect())
    }

    /// Textures of the swapchains' shape, format and usage (the warm-up frame draws into them).
    pub(super) fn scratch(&self, ctx: &GpuContext) -> (Vec<wgpu::Texture>, Vec<wgpu::Texture>) {
        let like = |chains: &[Chain]| {
            (chains.iter())
                .map(|c| {
                    let t = &c.images[0];
                    ctx.device.create_texture(&wgpu::TextureDescriptor {
                        label: Some("warm-up"),
                        size: t.size(),
                        mip_level_count: 1,
                        sample_count: 1,
                        dimension: wgpu::TextureDimension::D2,
                        format: t.format(),
                        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                            | wgpu::TextureUsages::COPY_DST,
                        view_formats: &[],
                    })
                })
                .collect::<Vec<_>>()
        };
        (like(&self.colour), like(&self.depth))
    }

    /// Put both eyes on `colour` (and their depth on `depth`, when the runtime takes depth):
    /// images in the swapchains' shape, one per swapchain; timed by `span`, from the first pass's
    /// start to the last's end.
    pub(super) fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        (colour, depth): (&[&wgpu::Texture], &[&wgpu::Texture]),
        span: Option<PairSpan<'_>>,
    ) {
        let eyes = self.eye_count();
        // (colour image, its layer or all of them, the bind group) of each fragment pass
        let passes: Vec<(usize, Option<u32>, usize)> = match self.shape {
            Shape::Array { multiview: true } => vec![(0, None, 0)],
            Shape::Array { multiview: false } => {
                (0..eyes).map(|i| (0, Some(i), i as usize)).collect()
            }
            Shape::PerEye => (0..eyes)
                .map(|i| (i as usize, Some(0), i as usize))
                .collect(),
        };
        let fragment = self.pipeline.as_ref().map(|p| (p, passes.len()));
        // the span's passes: the compute pass's, then the fragment passes
        let compute_passes = self.compute.as_ref().map_or(0, |c| c.passes());
        let last = (compute_passes + fragment.map_or(0, |(_, n)| n)).saturating_sub(1);
        if let Some(compute) = &self.compute {
            let targets: Vec<(&wgpu::Texture, u32)> = match self.shape {
                Shape::PerEye => (0..eyes as usize).map(|i| (colour[i], 0)).collect(),
                Shape::Array { .. } => (0..eyes).map(|i| (colour[0], i)).collect(),
            };
            compute.encode(encoder, &targets, span.map(|s| (s, last)));
        }
        let Some((fragment_pipeline, _)) = fragment else {
            return;
        };
        for (k, (image, layer, group)) in passes.into_iter().enumerate() {
            let writes = span.and_then(|s| s.render(compute_passes + k, last));
            // after the compute pass, the depth alone
            let colour = colour
                .get(image)
                .copied()
                .filter(|_| self.compute.is_none());
            layer_pass(
                encoder,
                (colour, depth.get(image).copied()),
                (fragment_pipeline, &self.bind_groups[group]),
                layer,
                writes,
            );
        }
    }

    fn eye_count(&self) -> u32 {
        match self.shape {
            Shape::PerEye => self.colour.len() as u32,
            Shape::Array { .. } => self.colour[0].images[0].depth_or_array_layers(),
        }
    }

    /// The left eye's image this frame (layer 0 of an array image) and a view of it alone.
    pub(super) fn left(&self) -> (&wgpu::Texture, wgpu::TextureView) {
        let texture = &self.colour[0].images[self.colour[0].acquired];
        (texture, layer_view(texture, Some(0), 1))
    }

    /// Eye `i`'s place in the swapchains: its colour sub-image, and its depth sub-image if any
    /// (the same swapchain index and layer).
    fn sub_images(
        &self,
        i: usize,
    ) -> (
        xr::SwapchainSubImage<'_, xr::Vulkan>,
        Option<xr::sys::SwapchainSubImage>,
    ) {
        let (chain, layer) = match self.shape {
            Shape::PerEye => (i, 0),
            Shape::Array { .. } => (0, i as u32),
        };
        (
            sub_image(&self.colour[chain], layer),
            self.depth
                .get(chain)
                .map(|d| sub_image(d, layer).into_raw()),
        )
    }

    /// Both eyes as one projection layer at the predicted display time, each view with its depth
    /// (near and far of the eyes' projection, metres) where the runtime takes depth.
    pub(super) fn end_frame(
        &self,
        stream: &mut xr::FrameStream<xr::Vulkan>,
        (frame_state, blend, space): (&xr::FrameState, xr::EnvironmentBlendMode, &xr::Space),
        views: &[xr::View],
        (near, far): (f32, f32),
    ) -> Result<()> {
        // the depth infos first, in a vector that does not move while the views point at them
        let depth_infos: Vec<Option<xr::sys::CompositionLayerDepthInfoKHR>> = (0..views.len())
            .map(|i| {
                self.sub_images(i)
                    .1
                    .map(|sub_image| xr::sys::CompositionLayerDepthInfoKHR {
                        ty: xr::sys::CompositionLayerDepthInfoKHR::TYPE,
                        next: std::ptr::null(),
                        sub_image,
                        min_depth: 0.0,
                        max_depth: 1.0,
                        near_z: near,
                        far_z: far,
                    })
            })
            .collect();
        let projection_views: Vec<xr::CompositionLayerProjectionView<xr::Vulkan>> = views
            .iter()
            .enumerate()
            .map(|(i, view)| {
                let v = xr::CompositionLayerProjectionView::new()
                    .pose(view.pose)
                    .fov(view.fov)
                    .sub_image(self.sub_images(i).0);
                match &depth_infos[i] {
                    None => v,
                    Some(info) => {
                        let mut raw = v.into_raw();
                        raw.next = info as *const _ as *const std::ffi::c_void;
                        // SAFETY: `raw` came from the builder, with its swapchain borrowed from
                        // `self`; the depth info it now points at lives in `depth_infos`, which
                        // outlives the xrEndFrame call below.
                        unsafe { xr::CompositionLayerProjectionView::from_raw(raw) }
                    }
                }
            })
            .collect();
        let layer = xr::CompositionLayerProjection::new()
            .space(space)
            .views(&projection_views);
        stream
            .end(frame_state.predicted_display_time, blend, &[&layer])
            .map_err(xr_error("xrEndFrame"))
    }

    /// How the eyes reached the runtime, in words.
    pub(super) fn eyes_text(&self) -> String {
        let passes = self.passes_text();
        match (&self.compute, &self.pipeline, &self.compute_refused) {
            (None, _, None) => passes,
            (None, _, Some(why)) => format!(
                "{passes}; the colour by the fragment pass \
                 (the runtime refused swapchains that take copies: {why})"
            ),
            (Some(_), Some(_), _) => format!(
                "{passes}; the colour by a compute pass and a copy, the depth by the fragment pass"
            ),
            (Some(_), None, _) => format!(
                "{}; the colour by a compute pass and a copy, no fragment pass",
                self.swapchains_text()
            ),
        }
    }

    /// The swapchains alone, in words.
    fn swapchains_text(&self) -> String {
        match (self.shape, &self.per_eye_because) {
            (Shape::Array { .. }, _) => "one array swapchain (2 layers)".into(),
            (Shape::PerEye, Some(why)) => format!("per-eye swapchains ({why})"),
            (Shape::PerEye, None) => "per-eye swapchains".into(),
        }
    }

    /// The swapchains and the fragment pass that puts the eyes on them, in words.
    fn passes_text(&self) -> String {
        match (self.shape, &self.per_eye_because) {
            (Shape::Array { multiview: true }, _) => {
                "one array swapchain (2 layers), both eyes in one pass (multiview)".into()
            }
            (Shape::Array { multiview: false }, _) => format!(
                "one array swapchain (2 layers), a pass per layer ({})",
                self.no_multiview.as_deref().unwrap_or("no multiview")
            ),
            (Shape::PerEye, Some(why)) => format!("per-eye swapchains ({why})"),
            (Shape::PerEye, None) => "per-eye swapchains".into(),
        }
    }

    /// Whether and how the runtime got depth, in words.
    pub(super) fn depth_text(&self, (near, far): (f32, f32)) -> String {
        match &self.depth_format {
            Ok(format) => format!(
                "submitted (XR_KHR_composition_layer_depth; {format:?}, {} swapchain(s), near {near} m, far {far} m)",
                self.depth.len()
            ),
            Err(why) => why.clone(),
        }
    }
}

/// The multiview pipeline that puts both eyes on an array swapchain's layers in one pass, with
/// its bind group layout; or why this device cannot: it lacks the feature or enough views, or
/// its multiview fails the check that draws two tiny eyes with this pipeline
/// (multiview_check.rs).
fn multiview_pipeline(
    ctx: &GpuContext,
    eyes: u32,
    formats: (wgpu::TextureFormat, Option<wgpu::TextureFormat>),
) -> Result<std::result::Result<(wgpu::BindGroupLayout, wgpu::RenderPipeline), String>> {
    let device = &ctx.device;
    if !device.features().contains(wgpu::Features::MULTIVIEW) {
        return Ok(Err("the device has no multiview".into()));
    }
    let views = device.limits().max_multiview_view_count;
    if views < eyes {
        return Ok(Err(format!("the device's multiview takes {views} views")));
    }
    let stage = "xr_multiview.wgsl";
    let layout = crate::gpu::reflect::layout(device, stage, 0)?;
    let pipeline = pipeline(ctx, stage, &layout, (Some(formats.0), formats.1), true)?;
    match super::multiview_check::multiview_failure(ctx, (&layout, &pipeline), formats)? {
        None => Ok(Ok((layout, pipeline))),
        Some(what) => {
            log::warn!("{what}; vlf draws each eye's layer in a pass of its own");
            Ok(Err(format!(
                "the device's multiview failed vlf's check: {what}"
            )))
        }
    }
}

/// All of one layer of a swapchain's images.
fn sub_image(c: &Chain, layer: u32) -> xr::SwapchainSubImage<'_, xr::Vulkan> {
    let size = c.images[0].size();
    xr::SwapchainSubImage::new()
        .swapchain(&c.swapchain)
        .image_array_index(layer)
        .image_rect(xr::Rect2Di {
            offset: xr::Offset2Di { x: 0, y: 0 },
            extent: xr::Extent2Di {
                width: size.width as i32,
                height: size.height as i32,
            },
        })
}
