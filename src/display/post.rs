//! After rendering, one GPU pass per output (`shaders/warp.wgsl`): the wall image, warped
//! for a projector (`warp.rs`: bilinear in the warp grid, a bilinear fetch), the tracked
//! wand's ray drawn over it (the distance from each pixel's eye ray to the wand's segment, in
//! the light field's space, through the wall's view-projection), times the blend mask. Every
//! pixel does the same work, so an output costs the same whatever it shows. `Outputs` holds a
//! display's wall images and the outputs drawn from them, the sink of the CAVE's frame of views
//! (`frame/`) for `vlf cave --headless` (`headless.rs`) and its windows (`window/`) alike: the
//! same pass, the same warps and masks.

use super::warp::{Grid, OutputSpec};
use super::{DisplayConfig, Wall};
use crate::error::{Result, VlfError};
use crate::gpu::{GpuContext, Timestamps};
use crate::render::{texture_2d, Frame, Renderer, ViewTargets, COLOR_FORMAT};
use crate::tracking::live::WandPose;
use crate::tracking::source::Pose;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use wgpu::util::DeviceExt;

/// `[wand_ray]`: the ray drawn from the tracked wand along where it points.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WandRay {
    /// draw it whenever a wand is tracked
    #[serde(default = "yes")]
    pub show: bool,
    /// metres from the wand
    #[serde(default = "default_length")]
    pub length: f32,
    /// metres; the ray is never drawn thinner than `min_pixels` wide
    #[serde(default = "default_radius")]
    pub radius: f32,
    #[serde(default = "default_min_pixels")]
    pub min_pixels: f32,
    /// linear RGB
    #[serde(default = "default_colour")]
    pub colour: [f32; 3],
}

fn yes() -> bool {
    true
}
fn default_length() -> f32 {
    10.0
}
fn default_radius() -> f32 {
    0.004
}
fn default_min_pixels() -> f32 {
    1.5
}
fn default_colour() -> [f32; 3] {
    [1.0, 0.12, 0.02]
}

impl Default for WandRay {
    fn default() -> Self {
        WandRay {
            show: true,
            length: default_length(),
            radius: default_radius(),
            min_pixels: default_min_pixels(),
            colour: default_colour(),
        }
    }
}

impl WandRay {
    pub fn validate(&self) -> std::result::Result<(), String> {
        if !(self.length.is_finite() && self.length > 0.0 && self.length <= 1000.0) {
            return Err(format!(
                "wand_ray.length: {} m must be more than 0 and at most 1000",
                self.length
            ));
        }
        if !(self.radius.is_finite() && (0.0..=1.0).contains(&self.radius)) {
            return Err(format!("wand_ray.radius: {} m must be 0 to 1", self.radius));
        }
        if !(self.min_pixels.is_finite() && (0.0..=64.0).contains(&self.min_pixels)) {
            return Err(format!(
                "wand_ray.min_pixels: {} must be 0 to 64",
                self.min_pixels
            ));
        }
        if self.colour.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
            return Err(format!(
                "wand_ray.colour: {:?} must be linear RGB, each at least 0",
                self.colour
            ));
        }
        Ok(())
    }
}

/// Mirrors WGSL `WarpParams` (shaders/warp.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuWarp {
    pub inv_view_proj: [[f32; 4]; 4],
    pub eye: [f32; 4],
    pub wand_origin: [f32; 4],
    pub wand_direction: [f32; 4],
    pub wand_colour: [f32; 4],
    pub source_size: [u32; 2],
    pub output_size: [u32; 2],
    pub grid_size: [u32; 2],
    pub use_mask: u32,
    pub _pad0: u32,
}

/// The wand's ray in one view, in the light field's normalised space.
#[derive(Clone, Copy, Debug)]
pub struct WandOverlay {
    pub view_proj: Mat4,
    pub eye: Vec3,
    pub origin: Vec3,
    /// unit
    pub direction: Vec3,
    pub length: f32,
    pub radius: f32,
    /// the least radius per unit of distance from the eye
    pub min_angle: f32,
    pub colour: [f32; 3],
}

/// The wand's ray on `wall` seen by eye `side` (as `super::wall_view`); None when not shown.
pub fn wand_overlay(
    config: &DisplayConfig,
    wall: &Wall,
    side: f32,
    pose: &Pose,
    wand: Option<&WandPose>,
    norm: &crate::prepare::Normalisation,
) -> Option<WandOverlay> {
    let wand = wand.filter(|_| config.wand_ray.show)?;
    let (view_proj, eye) = super::wall_view(config, wall, side, pose, norm);
    let to_unit = |p: Vec3| norm.to_unit(pose.room_to_world(p).into()).as_vec3();
    let origin = to_unit(wand.position);
    let tip = to_unit(wand.position + wand.rotation * Vec3::NEG_Z * config.wand_ray.length);
    let ray = &config.wand_ray;
    // one pixel's angle seen from the eye at the wall's nearest point, roughly
    let [ll, lr, ul] = wall.corners();
    let eye_room = pose.eye(Vec3::from(config.eye_offset), config.eye_separation, side);
    let normal = (lr - ll).cross(ul - ll).normalize();
    let distance = (eye_room - ll).dot(normal).abs().max(0.05);
    let pixel = (lr - ll).length() / wall.eye_pixels()[0] as f32;
    Some(WandOverlay {
        view_proj,
        eye,
        origin,
        direction: (tip - origin).normalize_or(Vec3::NEG_Z),
        length: (tip - origin).length(),
        radius: ray.radius * norm.scale as f32,
        min_angle: 0.5 * ray.min_pixels * pixel / distance,
        colour: ray.colour,
    })
}

/// The pipeline of `shaders/warp.wgsl`.
pub struct PostPass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

/// One output's GPU resources: grid, mask, parameters and image.
pub struct Output {
    pub name: String,
    pub pixels: [u32; 2],
    grid: wgpu::Buffer,
    grid_size: [u32; 2],
    mask: wgpu::Buffer,
    has_mask: bool,
    params: wgpu::Buffer,
    pub image: wgpu::Texture,
    pub image_view: wgpu::TextureView,
}

/// How far along the eye ray the wand is looked for (normalised units; the scene is in the unit sphere).
const EYE_RAY_LENGTH: f32 = 64.0;

impl PostPass {
    pub fn new(ctx: &GpuContext) -> Result<PostPass> {
        let device = &ctx.device;
        let module = crate::gpu::shaders::module(device, "warp.wgsl")?;
        // params, the wall image, the warp grid, the mask, the output: as warp.wgsl declares them
        let layout = crate::gpu::reflect::layout(device, "warp.wgsl", 0)?;
        let pipeline = ctx.compute_pipeline(&module, "warp", &[&layout]);
        Ok(PostPass { pipeline, layout })
    }

    /// An output's resources: its grid and mask uploaded once.
    pub fn output(&self, ctx: &GpuContext, spec: &OutputSpec) -> Output {
        let device = &ctx.device;
        let storage = |label, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let grid = storage("warp grid", bytemuck::cast_slice(&spec.grid.points));
        let mask = storage(
            "blend mask",
            bytemuck::cast_slice(spec.mask.as_deref().unwrap_or(&[1.0f32])),
        );
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("warp parameters"),
            size: std::mem::size_of::<GpuWarp>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        use wgpu::TextureUsages as U;
        let image = texture_2d(
            device,
            "output",
            spec.pixels,
            COLOR_FORMAT,
            U::STORAGE_BINDING | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        let image_view = image.create_view(&Default::default());
        Output {
            name: spec.name.clone(),
            pixels: spec.pixels,
            grid,
            grid_size: [spec.grid.columns, spec.grid.rows],
            mask,
            has_mask: spec.mask.is_some(),
            params,
            image,
            image_view,
        }
    }

    /// Encode one output from the wall image `source` (`source_size` pixels). Its parameters are
    /// written now (queue order): submit before encoding the same output again.
    #[allow(clippy::too_many_arguments)] // the pass, its target and timing: one call per output
    pub fn encode(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        source: &wgpu::TextureView,
        source_size: [u32; 2],
        output: &Output,
        wand: Option<&WandOverlay>,
        timestamps: Option<&mut Timestamps>,
    ) {
        let mut params = GpuWarp {
            inv_view_proj: Mat4::IDENTITY.to_cols_array_2d(),
            eye: [0.0, 0.0, 0.0, EYE_RAY_LENGTH],
            wand_origin: [0.0; 4],
            wand_direction: [0.0, 0.0, -1.0, 0.0],
            wand_colour: [0.0; 4],
            source_size,
            output_size: output.pixels,
            grid_size: output.grid_size,
            use_mask: output.has_mask as u32,
            _pad0: 0,
        };
        if let Some(w) = wand {
            params.inv_view_proj = w.view_proj.inverse().to_cols_array_2d();
            params.eye = w.eye.extend(EYE_RAY_LENGTH).into();
            params.wand_origin = w.origin.extend(w.length).into();
            params.wand_direction = w.direction.extend(w.radius).into();
            params.wand_colour = [w.colour[0], w.colour[1], w.colour[2], w.min_angle];
        }
        ctx.queue
            .write_buffer(&output.params, 0, bytemuck::bytes_of(&params));
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("warp"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: output.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(source),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: output.grid.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: output.mask.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&output.image_view),
                },
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("warp"),
            timestamp_writes: timestamps.and_then(|t| t.compute_writes()),
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(
            output.pixels[0].div_ceil(8),
            output.pixels[1].div_ceil(8),
            1,
        );
    }
}

/// Read an rgba32float texture back (all GPU work submitted so far finishes first).
pub fn read_texture(ctx: &GpuContext, texture: &wgpu::Texture) -> Result<Frame> {
    let (width, height) = (texture.width(), texture.height());
    let padded_row = (width * 16).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("output readback"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    crate::gpu::copy_texture_to_buffer(
        &mut encoder,
        texture,
        &readback,
        padded_row,
        [width, height],
    );
    ctx.queue.submit([encoder.finish()]);
    let raw: Vec<[f32; 4]> = ctx.read_buffer(&readback, padded_row as u64 * height as u64)?;
    let stride = (padded_row / 16) as usize;
    let pixels = (0..height as usize)
        .flat_map(|row| {
            raw[row * stride..row * stride + width as usize]
                .iter()
                .copied()
        })
        .collect();
    Ok(Frame {
        width,
        height,
        pixels,
    })
}

/// Apply one output to an image on the CPU side (uploaded, warped, read back): for tests and
/// tools; the CAVE keeps everything on the GPU.
pub fn apply(
    ctx: &GpuContext,
    image: &Frame,
    spec: &OutputSpec,
    wand: Option<&WandOverlay>,
) -> Result<Frame> {
    if image.pixels.len() != (image.width * image.height) as usize
        || image.width == 0
        || image.height == 0
    {
        return Err(VlfError::Parameter {
            name: "image",
            message: format!(
                "{} pixels for {}x{}",
                image.pixels.len(),
                image.width,
                image.height
            ),
        });
    }
    spec.grid.check().map_err(|message| VlfError::Parameter {
        name: "warp",
        message,
    })?;
    if spec
        .mask
        .as_ref()
        .is_some_and(|m| m.len() != (spec.pixels[0] * spec.pixels[1]) as usize)
    {
        return Err(VlfError::Parameter {
            name: "mask",
            message: format!(
                "the mask is not {}x{} values",
                spec.pixels[0], spec.pixels[1]
            ),
        });
    }
    let pass = PostPass::new(ctx)?;
    use wgpu::TextureUsages as U;
    let source = texture_2d(
        &ctx.device,
        "wall image",
        [image.width, image.height],
        COLOR_FORMAT,
        U::TEXTURE_BINDING | U::COPY_DST,
    );
    ctx.queue.write_texture(
        source.as_image_copy(),
        bytemuck::cast_slice(&image.pixels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(image.width * 16),
            rows_per_image: Some(image.height),
        },
        wgpu::Extent3d {
            width: image.width,
            height: image.height,
            depth_or_array_layers: 1,
        },
    );
    let output = pass.output(ctx, spec);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    pass.encode(
        ctx,
        &mut encoder,
        &source.create_view(&Default::default()),
        [image.width, image.height],
        &output,
        wand,
        None,
    );
    ctx.queue.submit([encoder.finish()]);
    let frame = read_texture(ctx, &output.image)?;
    ctx.check_errors()?;
    Ok(frame)
}

/// The whole wall as one output: the identity warp, no mask (the wand's ray only).
pub fn wall_output(wall: &Wall) -> OutputSpec {
    OutputSpec {
        name: String::new(),
        pixels: wall.eye_pixels(),
        grid: Grid::identity(),
        mask: None,
    }
}

/// Which outputs `Outputs::encode` draws after rendering a view, and whether they are timed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draw {
    /// the outputs shown (the wall's projectors, or the whole wall when it has none), each timed
    Timed,
    /// the outputs shown, untimed (only the rendering is timed)
    Shown,
    /// the whole wall's output and every projector's, untimed: to read them all back
    Everything,
}

/// One wall image (a wall seen by one eye, or a wall's views one after another) and the
/// outputs drawn from it.
pub struct Slot {
    pub wall: usize,
    pub target: ViewTargets,
    /// the whole wall: the identity warp, no mask (the wand's ray only); None without the pass
    whole: Option<Output>,
    /// the wall's projectors, in configuration order
    projectors: Vec<Output>,
}

/// A display's wall images and their outputs. With the pass, each view is rendered into its
/// slot's wall image on the GPU and its outputs are drawn from it (the projectors', or the
/// whole wall's when it has none), wand ray included; without it (no wall has projectors and
/// no wand may be tracked) the wall image is what is shown.
pub struct Outputs {
    ctx: Arc<GpuContext>,
    pass: Option<PostPass>,
    slots: Vec<Slot>,
}

impl Outputs {
    /// Whether a display needs the pass: a wall with projectors, or a wand that may be tracked.
    pub fn needed(config: &DisplayConfig, specs: &[Vec<OutputSpec>], wand: bool) -> bool {
        (wand && config.wand_ray.show) || specs.iter().any(|s| !s.is_empty())
    }

    /// One slot per entry of `walls` (wall indices, repeated as needed), each with the wall's
    /// outputs from `specs` (`warp::load_outputs`) when `post` (see `needed`).
    pub fn new(
        ctx: &Arc<GpuContext>,
        renderer: &Renderer,
        config: &DisplayConfig,
        specs: &[Vec<OutputSpec>],
        walls: &[usize],
        post: bool,
    ) -> Result<Outputs> {
        let pass = post.then(|| PostPass::new(ctx)).transpose()?;
        let slots = walls
            .iter()
            .map(|&wall| {
                let w = &config.walls[wall];
                let [width, height] = w.eye_pixels();
                Slot {
                    wall,
                    target: renderer.view_targets(width, height),
                    whole: pass.as_ref().map(|p| p.output(ctx, &wall_output(w))),
                    projectors: pass.as_ref().map_or(Vec::new(), |p| {
                        specs[wall].iter().map(|o| p.output(ctx, o)).collect()
                    }),
                }
            })
            .collect();
        Ok(Outputs {
            ctx: ctx.clone(),
            pass,
            slots,
        })
    }

    /// Let `renderer` draw into every slot's wall image too (a study's condition of other
    /// geometry).
    pub fn bind_renderer(&mut self, renderer: &Renderer) {
        for s in &mut self.slots {
            renderer.bind_targets(&mut s.target);
        }
    }

    /// Output passes timed per view in `slot` with `Draw::Timed`.
    pub fn timed_outputs(&self, slot: usize) -> usize {
        match self.pass {
            Some(_) => self.slots[slot].projectors.len().max(1),
            None => 0,
        }
    }

    /// The image shown for `projector` of `slot`'s wall (None: the whole wall): after the pass,
    /// its output; without the pass, the wall image itself.
    pub fn shown(&self, slot: usize, projector: Option<usize>) -> &wgpu::TextureView {
        let s = &self.slots[slot];
        match (projector, &s.whole) {
            (Some(p), _) => &s.projectors[p].image_view,
            (None, Some(whole)) => &whole.image_view,
            (None, None) => &s.target.image_view,
        }
    }

    /// Render one view (`view`: its view-projection and eye) into `slot`'s wall image and draw
    /// the outputs that `draw` names from it; submitted at once (the slot's outputs' parameters
    /// are written in queue order). `timestamps` times the rendering, and with `Draw::Timed`
    /// each output pass after it.
    pub fn encode(
        &self,
        renderer: &mut Renderer,
        slot: usize,
        view: (Mat4, Vec3),
        wand: Option<&WandOverlay>,
        mut timestamps: Option<&mut Timestamps>,
        draw: Draw,
    ) {
        renderer.set_view_matrix(view.0, view.1);
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        let s = &self.slots[slot];
        renderer.encode_view(&mut encoder, &s.target, timestamps.as_deref_mut());
        if let (Some(pass), Some(whole)) = (&self.pass, &s.whole) {
            let size = [s.target.width, s.target.height];
            let everything = draw == Draw::Everything;
            let whole = (everything || s.projectors.is_empty()).then_some(whole);
            for output in whole.into_iter().chain(&s.projectors) {
                let t = match draw {
                    Draw::Timed => timestamps.as_deref_mut(),
                    Draw::Shown | Draw::Everything => None,
                };
                pass.encode(
                    &self.ctx,
                    &mut encoder,
                    &s.target.image_view,
                    size,
                    output,
                    wand,
                    t,
                );
            }
        }
        self.ctx.queue.submit([encoder.finish()]);
    }

    /// Slot `slot`'s wall image and its bindings.
    pub fn target(&self, slot: usize) -> &ViewTargets {
        &self.slots[slot].target
    }

    /// Read back `slot`'s whole wall image (after the pass: its whole-wall output, so draw with
    /// `Draw::Everything` first) and each projector's output, named.
    pub fn read(&self, slot: usize) -> Result<(Frame, Vec<(String, Frame)>)> {
        let s = &self.slots[slot];
        let whole = s.whole.as_ref().map_or(&s.target.image, |w| &w.image);
        let frame = read_texture(&self.ctx, whole)?;
        let images = s
            .projectors
            .iter()
            .map(|p| Ok((p.name.clone(), read_texture(&self.ctx, &p.image)?)))
            .collect::<Result<Vec<_>>>()?;
        self.ctx.check_errors()?;
        Ok((frame, images))
    }
}
