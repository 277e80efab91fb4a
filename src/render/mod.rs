//! Render: draws views from the resident light field (`shaders/render.wgsl`). A view is a
//! camera plus a projection; many views share one light field. Output is linear radiance,
//! written as EXR or tonemapped PNG by `image_io.rs`.

pub mod budget;
pub mod edges;
pub mod image_io;
pub mod moving;
pub mod moving_light;
pub mod objects_file;
pub mod probes;
pub mod raster;
pub mod shadow_atlas;

use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuRayTriangle, GpuView, RenderVertex};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, Timestamps};
use crate::lightfield::{LightField, ResidentLightField};
use crate::prepare::Normalisation;
use crate::scene::Camera;
use glam::{Mat4, Vec3};
use std::sync::Arc;
use wgpu::util::DeviceExt;

pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Each pixel's depth: the view's clip depth (0 near, 1 far) of the nearest point its eye rays
/// first meet, 1 where they meet nothing (the headset submits it for the runtime to reproject).
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// Antialiasing of real-time views (CAVE walls, headset eyes): eye rays per pixel. With
/// mirrors, two eye rays share one traced reflection (shaders/render.wgsl, pair_diffuse):
/// the 4-wall stereo CAVE at 1920x1200 per eye (8 views) of Cornell-mirror took 10.6 ms on an
/// H100 with a reflection per eye ray, over 120 Hz's 8.3 ms.
pub const REALTIME_SAMPLES: u32 = 4;
/// Chains of reflections sampled from a glossy lobe per eye-ray pair that meets one, in real
/// time: one (the displays' constant cost; the lobe's noise averages over a pixel's pairs).
pub const DEFAULT_LOBE_SAMPLES: u32 = 1;
/// ... and in stills (`vlf render`, `vlf verify`): with STILL_SAMPLES eye rays, 64 samples of the
/// lobe per pixel.
pub const STILL_LOBE_SAMPLES: u32 = 8;
/// Shadow rays to the emitters per chain off a glossy lobe (render.wgsl, glossy_emitter_light):
/// the emitters' share of a glossy reflection by light sampling, in real time and in stills.
pub const GLOSSY_LIGHT_SAMPLES: u32 = 2;
/// Antialiasing of stills (`vlf render`): eye rays per pixel.
pub const STILL_SAMPLES: u32 = 16;
/// The most eye rays per pixel a view may ask for.
pub const MAX_SAMPLES: u32 = 256;

/// Linear radiance, row-major from the top-left pixel.
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 4]>,
}

/// A plain 2D texture (render targets, per-eye images, overlays).
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    [width, height]: [u32; 2],
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// View-projection of a scene camera in the light field's normalised space.
pub fn view_projection(camera: &Camera, norm: &Normalisation, width: u32, height: u32) -> Mat4 {
    let to_unit = |p: [f32; 3]| norm.to_unit(p).as_vec3();
    let eye = to_unit(camera.eye);
    let target = to_unit(camera.target);
    let view = Mat4::look_at_rh(eye, target, Vec3::from(camera.up).normalize());
    // the scene lies in the unit sphere: depth range from the eye's distance to it
    let far = eye.length() + 2.0;
    let near = (far * 1e-4).max(1e-4);
    let proj = Mat4::perspective_rh(
        camera.fov_y_deg.to_radians(),
        width as f32 / height as f32,
        near,
        far,
    );
    proj * view
}

/// One view's image (linear radiance) and depth with the bindings of the pass that draws them.
/// A window keeps one per eye.
pub struct ViewTargets {
    pub width: u32,
    pub height: u32,
    pub image: wgpu::Texture,
    pub image_view: wgpu::TextureView,
    /// `DEPTH_FORMAT`, the same size
    pub depth: wgpu::Texture,
    pub depth_view: wgpu::TextureView,
    /// with raster first hits, the visibility buffer the view's eye rays read
    raster: Option<raster::RasterTargets>,
    /// with edge antialiasing, its first pass and list of edge pixels
    edges: Option<edges::EdgeTargets>,
    /// the resolve's view group for each of the renderer's light fields (their faces and
    /// materials), made by the renderer `owner`
    resolve_bind_groups: Vec<wgpu::BindGroup>,
    owner: u64,
    /// the same for other renderers that draw into these images (`Renderer::bind_targets`: a
    /// study's condition of other geometry), by their ids
    other_groups: Vec<(u64, Vec<wgpu::BindGroup>)>,
}

impl ViewTargets {
    /// With edge antialiasing: the share of the pixels the view drawn last into these targets
    /// refined (None without it; waits for the GPU).
    pub fn refined_share(&self, ctx: &GpuContext) -> Result<Option<f64>> {
        match &self.edges {
            Some(e) => e.refined(ctx).map(|r| Some(r.share())),
            None => Ok(None),
        }
    }
}

struct Target {
    targets: ViewTargets,
    readback: wgpu::Buffer,
    padded_row: u32,
}

pub struct Renderer {
    /// which renderer this is (view targets keep their bind groups by it)
    id: u64,
    ctx: Arc<GpuContext>,
    resolve_pipeline: wgpu::ComputePipeline,
    resolve_layout: wgpu::BindGroupLayout,
    /// render.wgsl compiled for `variant` (edge antialiasing's pipelines are made from it)
    resolve_module: wgpu::ShaderModule,
    /// what the resolve pipeline was compiled for (the raster one is compiled from it)
    variant: ResolveVariant,
    /// with raster first hits, the pass that draws each view's visibility buffer first
    raster: Option<raster::RasterPass>,
    /// the visibility binding of views drawn by ray casting (never read)
    placeholder_visibility: wgpu::TextureView,
    /// edge antialiasing's settings and dispatches (none: off)
    edges: Option<(edges::EdgeAntialiasing, edges::EdgePass)>,
    /// its bindings for views drawn without it (never read)
    placeholder_edges: edges::EdgeTargets,
    /// the scene's triangles and the moving objects' after them
    triangle_count: u32,
    view_buffer: wgpu::Buffer,
    /// the render mesh as ray-casting triangles, and their BVH as child pairs
    triangles: wgpu::Buffer,
    /// the same triangles as affine maps (the exhaustive ray cast of small meshes)
    ray_triangles: wgpu::Buffer,
    pairs: wgpu::Buffer,
    /// every light field it draws (the first, then those `add_light_field` adds: a study's
    /// conditions), and the one drawn now
    fields: Vec<FieldSet>,
    active: usize,
    /// the resolve's light field and moving objects' layouts, for the fields added
    field_layout: crate::lightfield::bindings::FieldLayout,
    moving_layout: wgpu::BindGroupLayout,
    /// whether the light field's mirror tiles are resident (`pair_mixed` reads them)
    view_dependent: bool,
    normalisation: Normalisation,
    view_template: GpuView,
    target: Option<Target>,
    /// the moving objects' GPU state, and the probes' grid (each field bakes its own probes)
    moving: Option<moving::MovingObjects>,
    probe_grid: Option<crate::gpu::types::GpuProbeGrid>,
    /// the moving objects' shadows drawn once per frame (none: per pixel, or no objects)
    shadow_atlas: Option<shadow_atlas::ShadowAtlas>,
    /// the moving objects' own direct light at their vertices once per frame (none: per pixel,
    /// or no objects)
    moving_light: Option<moving_light::MovingLight>,
    /// how the moving objects are lit, where there are any
    object_lighting: Option<probes::ObjectLighting>,
}

/// The next renderer's id.
static RENDERER_IDS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// One light field as the resolve binds it: its bind group, the faces and material table the
/// view groups bind, and the moving objects' group (their shading records, materials and the
/// irradiance probes baked from this light field; placeholders without objects).
struct FieldSet {
    field_bind_group: wgpu::BindGroup,
    faces: wgpu::Buffer,
    materials: wgpu::Buffer,
    moving_group: wgpu::BindGroup,
    /// the light field's layout uniform (the probes of a field added later bake from it)
    field_buffer: wgpu::Buffer,
    probes: Option<probes::Probes>,
    /// the shadow atlas's groups for this light field
    shadow: Option<shadow_atlas::ShadowField>,
    /// the vertices' light pass's groups for this light field
    vertex_light: Option<moving_light::MovingLightField>,
}

impl FieldSet {
    /// `lf` resident as `resident`, bound with the resolve's field and moving layouts (the
    /// moving objects' group a placeholder until its probes are baked).
    fn new(
        resident: &ResidentLightField,
        lf: &LightField,
        ledger: &MemoryLedger,
        (field_layout, moving_layout): (
            &crate::lightfield::bindings::FieldLayout,
            &wgpu::BindGroupLayout,
        ),
    ) -> FieldSet {
        let ctx = &resident.ctx;
        let field = resident.field_params(lf);
        let field_buffer = ctx.buffer_init(
            ledger,
            "light field layout",
            bytemuck::bytes_of(&field),
            wgpu::BufferUsages::UNIFORM,
        );
        FieldSet {
            field_bind_group: resident.bind_group(field_layout, &field_buffer),
            faces: resident.faces.clone(),
            materials: resident.materials.clone(),
            moving_group: placeholder_moving_group(ctx, moving_layout, lf),
            field_buffer,
            probes: None,
            shadow: None,
            vertex_light: None,
        }
    }
}

/// Moving objects for a renderer: their rest-pose mesh and how the probes that light them are
/// laid out.
pub struct ObjectsToDraw<'a> {
    pub mesh: &'a crate::dynamic::MovingMesh,
    pub lighting: probes::ObjectLighting,
}

impl Renderer {
    pub fn new(
        resident: &ResidentLightField,
        lf: &LightField,
        ledger: &MemoryLedger,
    ) -> Result<Renderer> {
        Renderer::with_objects(resident, lf, ledger, None)
    }

    /// A renderer that also draws moving objects: their triangles and tree after the scene's in
    /// the casting buffers, and the probes that light them baked from the light field here.
    pub fn with_objects(
        resident: &ResidentLightField,
        lf: &LightField,
        ledger: &MemoryLedger,
        objects: Option<ObjectsToDraw>,
    ) -> Result<Renderer> {
        let ctx = resident.ctx.clone();
        let device = &ctx.device;
        // the texture detail where the light field has it and the device took it
        let detail = lf.detail.as_ref().filter(|_| resident.detail.is_some());
        let (mut triangles, mut tree) = ray_casting_mesh(&lf.render_vertices, detail)?;
        // a test hook moves the threshold (`with_exhaustive_triangles`): the tests render one
        // scene both ways and compare
        let threshold = EXHAUSTIVE_OVERRIDE.get().unwrap_or(EXHAUSTIVE_TRIANGLES);
        let exhaustive_triangles = if triangles.len() <= threshold {
            triangles.len() as u32
        } else {
            0
        };
        let mut maps: Vec<GpuRayTriangle> = triangles
            .iter()
            .map(|t| {
                let a = Vec3::from(t.v0);
                GpuRayTriangle::new(a, a + Vec3::from(t.e1), a + Vec3::from(t.e2))
            })
            .collect();
        let plan = match &objects {
            Some(o) => {
                let plan = moving::MovingPlan::new(
                    o.mesh,
                    triangles.len() as u32,
                    tree.pairs.len() as u32,
                )?;
                triangles.extend_from_slice(&plan.records);
                maps.extend_from_slice(&plan.maps);
                tree.pairs.extend_from_slice(&plan.pairs);
                tree.depth = tree.depth.max(plan.depth);
                Some(plan)
            }
            None => None,
        };
        let stack = tree.depth.next_multiple_of(8).max(16);
        let variant = ResolveVariant {
            tiles: resident.tiles.is_some(),
            stack,
            moving: plan.is_some(),
            textured: detail.is_some(),
            cutouts: detail.is_some_and(|d| d.textures.any_cutout()),
            normal_maps: detail.is_some_and(|d| !d.face_normal_maps.is_empty()),
            raster: false,
            sampled_direct: objects.as_ref().is_some_and(samples_direct),
        };
        let (resolve_pipeline, layouts) = resolve_pipeline(&ctx, variant)?;
        let triangle_count = triangles.len() as u32;
        let view_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view"),
            size: std::mem::size_of::<GpuView>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let storage = |label, bytes: &[u8]| {
            ledger.record(label, bytes.len() as u64);
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: if bytes.is_empty() { &[0u8; 64] } else { bytes },
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let ray_triangles = storage("render mesh: triangle maps", bytemuck::cast_slice(&maps));
        let triangles = storage("render mesh: triangles", bytemuck::cast_slice(&triangles));
        let pairs = storage("render mesh: BVH", bytemuck::cast_slice(&tree.pairs));
        let view_template = GpuView {
            samples_per_pixel: REALTIME_SAMPLES,
            mirror_bounces: lf.mirror_chains().bounces,
            fixed_work: 1,
            lobe_samples: DEFAULT_LOBE_SAMPLES,
            glossy_light_samples: GLOSSY_LIGHT_SAMPLES,
            exhaustive_triangles,
            moving_root: u32::MAX,
            moving_first: 0,
            moving_flags: crate::gpu::types::MOVING_SHADOWS | crate::gpu::types::MOVING_IN_MIRRORS,
            ..Default::default()
        };
        let first = FieldSet::new(resident, lf, ledger, (&layouts.field, &layouts.moving));
        let mut renderer = Renderer {
            id: RENDERER_IDS.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            ctx: ctx.clone(),
            resolve_pipeline,
            variant,
            raster: None,
            placeholder_visibility: raster::placeholder_visibility(device),
            edges: None,
            placeholder_edges: edges::EdgeTargets::placeholder(device),
            triangle_count,
            resolve_layout: layouts.view,
            resolve_module: layouts.module,
            field_layout: layouts.field,
            moving_layout: layouts.moving,
            view_buffer,
            triangles,
            ray_triangles,
            pairs,
            fields: vec![first],
            active: 0,
            view_dependent: resident.tiles.is_some(),
            normalisation: lf.meta.normalisation,
            view_template,
            target: None,
            moving: None,
            probe_grid: None,
            shadow_atlas: None,
            moving_light: None,
            object_lighting: objects.as_ref().map(|o| o.lighting),
        };
        if let (Some(o), Some(plan)) = (objects, plan) {
            renderer.add_objects(lf, ledger, (o, &plan))?;
            renderer.bake_field_probes(0, resident, lf, ledger)?;
        }
        Ok(renderer)
    }

    /// Another light field to draw (a study's condition: direct light only, other light on the
    /// same geometry), resident beside the first: its bind groups made and, with moving objects,
    /// its probes baked now, so that `use_light_field` only rebinds. Make view targets after
    /// adding every field (each target binds every field's faces and materials). Its number.
    pub fn add_light_field(
        &mut self,
        resident: &ResidentLightField,
        lf: &LightField,
        ledger: &MemoryLedger,
    ) -> Result<usize> {
        let textured = lf.detail.is_some() && resident.detail.is_some();
        if resident.tiles.is_some() != self.variant.tiles || textured != self.variant.textured {
            return Err(VlfError::Display(format!(
                "light field of {:?}: {} mirror tiles and {} texture detail where the first has {} and {}: the renderer draws both through one pipeline",
                lf.meta.scene_name,
                if resident.tiles.is_some() { "with" } else { "without" },
                if textured { "with" } else { "without" },
                if self.variant.tiles { "them" } else { "none" },
                if self.variant.textured { "it" } else { "none" },
            )));
        }
        let layouts = (&self.field_layout, &self.moving_layout);
        self.fields
            .push(FieldSet::new(resident, lf, ledger, layouts));
        let k = self.fields.len() - 1;
        if self.moving.is_some() {
            self.bake_field_probes(k, resident, lf, ledger)?;
        }
        self.target = None;
        Ok(k)
    }

    /// Draw light field `k` (0: the first) from the next view on: a rebinding, no other work.
    pub fn use_light_field(&mut self, k: usize) -> Result<()> {
        if k >= self.fields.len() {
            return Err(VlfError::Display(format!(
                "light field {k}: the renderer has {}",
                self.fields.len()
            )));
        }
        self.active = k;
        Ok(())
    }

    /// The light field drawn now (0: the first).
    pub fn light_field_in_use(&self) -> usize {
        self.active
    }

    /// Upload the moving objects planned in `plan`; the probes' grid (the probes are baked for
    /// each light field, `bake_field_probes`).
    fn add_objects(
        &mut self,
        lf: &LightField,
        ledger: &MemoryLedger,
        (objects, plan): (ObjectsToDraw, &moving::MovingPlan),
    ) -> Result<()> {
        let (lo, hi) = (lf.render_vertices.iter()).fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), v| (lo.min(v.position.into()), hi.max(v.position.into())),
        );
        self.probe_grid = Some(probes::probe_grid(lo, hi, &objects.lighting));
        let moving = moving::MovingObjects::new(
            &self.ctx,
            ledger,
            objects.mesh,
            plan,
            (&self.ray_triangles, &self.pairs),
            self.normalisation,
        )?;
        self.view_template.moving_root = moving.root_pair;
        self.view_template.moving_first = moving.first_triangle;
        self.moving = Some(moving);
        if objects.lighting.shadows == probes::ShadowMethod::Atlas {
            let scene = shadow_atlas::AtlasScene {
                faces: &lf.faces,
                stack: self.variant.stack,
                cutouts: self.variant.cutouts,
                scale: self.normalisation.scale,
            };
            let atlas =
                shadow_atlas::ShadowAtlas::new(&self.ctx, ledger, &objects.lighting, &scene)?;
            self.shadow_atlas = Some(atlas);
            self.view_template.moving_flags |= crate::gpu::types::MOVING_SHADOW_ATLAS;
        }
        if objects.lighting.direct_light == probes::DirectLightMethod::PerVertex {
            let variant = (self.variant.stack, self.variant.cutouts);
            let light = (&objects.lighting, self.moving.as_ref().expect("just made"));
            let pass = moving_light::MovingLight::new(&self.ctx, ledger, light, variant)?;
            self.moving_light = Some(pass);
        }
        Ok(())
    }

    /// Bake field `k`'s probes (the moving objects lit by that light field) and make its moving
    /// objects' group.
    fn bake_field_probes(
        &mut self,
        k: usize,
        resident: &ResidentLightField,
        lf: &LightField,
        ledger: &MemoryLedger,
    ) -> Result<()> {
        let (Some(grid), Some(moving)) = (self.probe_grid, &self.moving) else {
            return Ok(());
        };
        let emitters = probes::emitters(lf);
        let grid = crate::gpu::types::GpuProbeGrid {
            emitter_count: emitters.len() as u32,
            ..grid
        };
        let set = &self.fields[k];
        let inputs = probes::BakeInputs {
            view: &self.view_template,
            faces: &set.faces,
            triangles: &self.triangles,
            pairs: &self.pairs,
            ray_triangles: &self.ray_triangles,
            materials: &set.materials,
            resident,
            field: &set.field_buffer,
            stack: self.variant.stack,
            cutouts: self.variant.cutouts,
            emitters: &emitters,
        };
        let probes = probes::bake(&self.ctx, ledger, grid, &inputs)?;
        let atlas = self.shadow_atlas.as_ref();
        let light = self.moving_light.as_ref();
        let lit = light.map(|l| &l.lit);
        let shadow = atlas.map(|a| a.field(&self.ctx, ledger, &inputs, (moving, &probes, lit)));
        let vertex_light =
            light.map(|l| l.field(&self.ctx, ledger, &inputs, (moving, &probes), atlas));
        let passes = (atlas, light);
        let group = moving_group(&self.ctx, &self.moving_layout, (moving, &probes), passes);
        let set = &mut self.fields[k];
        set.moving_group = group;
        set.probes = Some(probes);
        set.shadow = shadow;
        set.vertex_light = vertex_light;
        Ok(())
    }

    /// Pose the moving objects for the views drawn next: `joints` are their joint matrices in
    /// world metres (`dynamic::Objects::joint_matrices`), and for the light field drawn now
    /// their own direct light at their vertices (`moving_light`) and, with the shadow atlas,
    /// their shadows (`shadow_atlas`; made whether the shadows are on or off, so that switching
    /// them costs no step in frame time). Submitted at once, its GPU time in `timestamps` where
    /// given; nothing without objects.
    pub fn pose_objects(&self, joints: &[Mat4], timestamps: Option<&mut Timestamps>) {
        if let Some(m) = &self.moving {
            m.set_joints(&self.ctx.queue, joints);
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            let set = &self.fields[self.active];
            let shadows = self.shadow_atlas.as_ref().zip(set.shadow.as_ref());
            let light = self.moving_light.as_ref().zip(set.vertex_light.as_ref());
            // the vertices' direct light, then the shadows (what the objects send back of the
            // indirect light they block reads it), then the probes' correction at the vertices
            // (it reads the shadows)
            let after_refit = move |pass: &mut wgpu::ComputePass<'_>| {
                if let Some((l, f)) = light {
                    l.encode_direct(pass, f);
                }
                if let Some((a, f)) = shadows {
                    a.encode(pass, f);
                }
                if let Some((l, f)) = light {
                    l.encode_occlusion(pass, f);
                }
            };
            m.encode(&mut encoder, timestamps, Some(after_refit));
            self.ctx.queue.submit([encoder.finish()]);
        }
    }

    /// The moving objects' switches (a study's conditions): their shadows on the scene, and
    /// whether mirrors show them.
    pub fn set_object_switches(&mut self, shadows: bool, in_mirrors: bool) {
        use crate::gpu::types::{MOVING_IN_MIRRORS, MOVING_SHADOWS, MOVING_SHADOW_ATLAS};
        let atlas = self.view_template.moving_flags & MOVING_SHADOW_ATLAS;
        self.view_template.moving_flags = if shadows { MOVING_SHADOWS } else { 0 }
            | if in_mirrors { MOVING_IN_MIRRORS } else { 0 }
            | atlas;
    }

    /// Whether this renderer draws moving objects.
    pub fn has_objects(&self) -> bool {
        self.moving.is_some()
    }

    /// The irradiance probes' grid, where there are moving objects to light.
    pub fn probe_grid(&self) -> Option<crate::gpu::types::GpuProbeGrid> {
        self.fields[0].probes.as_ref().map(|p| p.grid)
    }

    /// Antialiasing: `n` eye rays per pixel (1: one ray through the pixel's centre); with raster
    /// first hits no more than the visibility buffer's MSAA samples.
    pub fn set_samples_per_pixel(&mut self, n: u32) -> Result<()> {
        if !(1..=MAX_SAMPLES).contains(&n) {
            return Err(VlfError::Parameter {
                name: "aa",
                message: format!("{n} eye rays per pixel: use 1 (off) to {MAX_SAMPLES}"),
            });
        }
        if let Some(raster) = self.raster.as_ref().filter(|r| n > r.samples) {
            return Err(VlfError::Parameter {
                name: "aa",
                message: format!(
                    "{n} eye rays per pixel: raster first hits read at most the visibility \
                     buffer's {} MSAA samples (set the count before `first_hits`)",
                    raster.samples
                ),
            });
        }
        self.view_template.samples_per_pixel = n;
        // the same everywhere: no tile draws more (frame pacing, budget.rs, may change it)
        self.view_template.paced_samples = n;
        self.view_template.paced_fraction = 0.0;
        Ok(())
    }

    pub fn samples_per_pixel(&self) -> u32 {
        self.view_template.samples_per_pixel
    }

    /// How eye rays find their first hits. With `Raster` each view is drawn by the rasteriser
    /// into a visibility buffer of as many MSAA samples as the eye rays per pixel now (one of
    /// `raster::msaa_counts`; a paced tile reads fewer of them, never more), and its eye rays go
    /// through the samples' standard positions. Set it before making view targets: those made
    /// before have no visibility buffer and are drawn by ray casting.
    pub fn set_first_hits(&mut self, hits: raster::FirstHits) -> Result<()> {
        self.target = None;
        self.raster = None;
        self.view_template.msaa_samples = 0;
        if hits == raster::FirstHits::Raster && self.edges.is_some() {
            return Err(VlfError::Parameter {
                name: "first_hits",
                message: "raster first hits read a fixed number of MSAA samples per pixel, and \
                          edge antialiasing adds eye rays where it finds edges: use \"rays\" \
                          with edge antialiasing (edge_samples), or leave it out"
                    .into(),
            });
        }
        if hits == raster::FirstHits::Raster && self.variant.cutouts {
            return Err(VlfError::Parameter {
                name: "first_hits",
                message: "raster first hits cannot show a cut-out's holes (the visibility \
                          buffer's pass does not read the coverage): use \"rays\" for this scene"
                    .into(),
            });
        }
        if hits == raster::FirstHits::Raster {
            let samples = self.view_template.samples_per_pixel;
            let variant = ResolveVariant {
                raster: true,
                ..self.variant
            };
            let (resolve, _) = resolve_pipeline(&self.ctx, variant)?;
            let inputs = raster::RasterInputs {
                view: &self.view_buffer,
                triangles: &self.triangles,
                ray_triangles: &self.ray_triangles,
                triangle_count: self.triangle_count,
                moving: self.variant.moving,
            };
            self.raster = Some(raster::RasterPass::new(
                &self.ctx, samples, &inputs, resolve,
            )?);
            self.view_template.msaa_samples = samples;
        }
        Ok(())
    }

    pub fn first_hits(&self) -> raster::FirstHits {
        match self.raster {
            Some(_) => raster::FirstHits::Raster,
            None => raster::FirstHits::Rays,
        }
    }

    /// Cast eye rays through the standard positions of `samples` MSAA samples (0: the
    /// Hammersley set), as raster first hits have them: the two ways compared sample by sample
    /// (tests/raster.rs). Ray casting only.
    pub fn set_msaa_sample_positions(&mut self, samples: u32) -> Result<()> {
        if ![0, 1, 2, 4, 8, 16].contains(&samples)
            || self.raster.is_some()
            || (samples > 0 && self.edges.is_some())
        {
            return Err(VlfError::Parameter {
                name: "first_hits",
                message: format!(
                    "MSAA positions of {samples} samples for cast eye rays: use 0, 1, 2, 4, 8 or                      16, with ray-cast first hits"
                ),
            });
        }
        self.view_template.msaa_samples = samples;
        Ok(())
    }

    /// Edge antialiasing (`edges.rs`; None: off): pixels that differ from a neighbour take
    /// `samples` eye rays, the others the view's own count, all on one progressive set whose
    /// first ray goes through the pixel's centre. Set it before making view targets (those made
    /// before have no buffers for it and are drawn without it); ray-cast first hits only.
    pub fn set_edge_antialiasing(&mut self, edge: Option<edges::EdgeAntialiasing>) -> Result<()> {
        self.target = None;
        let Some(edge) = edge else {
            self.edges = None;
            self.view_template.edge_samples = 0;
            return Ok(());
        };
        let edge = edge.checked()?;
        if self.raster.is_some() || self.view_template.msaa_samples > 0 {
            return Err(VlfError::Parameter {
                name: "edge_samples",
                message: "edge antialiasing casts its eye rays on its own progressive set: \
                          it cannot read raster first hits' or MSAA sample positions (use \
                          first_hits = \"rays\")"
                    .into(),
            });
        }
        let layouts = [
            &self.resolve_layout,
            &self.field_layout.layout,
            &self.moving_layout,
        ];
        self.edges = Some((
            edge,
            edges::EdgePass::new(&self.ctx, &self.resolve_module, &layouts),
        ));
        self.view_template.edge_samples = edge.samples;
        self.view_template.edge_contrast = edge.contrast;
        Ok(())
    }

    pub fn edge_antialiasing(&self) -> Option<edges::EdgeAntialiasing> {
        self.edges.as_ref().map(|(e, _)| *e)
    }

    /// How many pixels edge antialiasing refined in the view `render` drew last (None without
    /// it; waits for the GPU).
    pub fn refined_pixels(&self) -> Result<Option<edges::Refined>> {
        match self.target.as_ref().and_then(|t| t.targets.edges.as_ref()) {
            Some(e) if self.edges.is_some() => e.refined(&self.ctx).map(Some),
            _ => Ok(None),
        }
    }

    /// Chains of reflections sampled from a glossy lobe per eye-ray pair that meets one (at
    /// least 1): a still takes more than a real-time view (`vlf render --lobe-samples`).
    pub fn set_lobe_samples(&mut self, n: u32) {
        self.view_template.lobe_samples = n.max(1);
    }

    /// Shadow rays to the emitters per chain's first glossy reflection (`GLOSSY_LIGHT_SAMPLES`
    /// by default; 0: the lobe's sampled rays alone, `vlf render --glossy-light-samples`).
    pub fn set_glossy_light_samples(&mut self, n: u32) {
        self.view_template.glossy_light_samples = n;
    }

    /// Mirror reflections traced per eye ray (0 without mirrors).
    pub fn mirror_bounces(&self) -> u32 {
        self.view_template.mirror_bounces
    }

    /// A view's visibility buffer, image and resolve bindings, `width` x `height`.
    pub fn view_targets(&self, width: u32, height: u32) -> ViewTargets {
        let device = &self.ctx.device;
        use wgpu::TextureUsages as U;
        // written by the resolve, read by the present passes, copied for screenshots
        let usage = U::STORAGE_BINDING | U::TEXTURE_BINDING | U::COPY_SRC;
        let target = |label, format| texture_2d(device, label, [width, height], format, usage);
        let (image, depth) = (target("image", COLOR_FORMAT), target("depth", DEPTH_FORMAT));
        let image_view = image.create_view(&Default::default());
        let depth_view = depth.create_view(&Default::default());
        let raster = (self.raster.as_ref()).map(|r| r.targets(device, [width, height]));
        let visibility = raster
            .as_ref()
            .map_or(&self.placeholder_visibility, |r| &r.visibility);
        let edges = (self.edges.as_ref()).map(|_| edges::EdgeTargets::new(device, [width, height]));
        let edge_buffers = edges.as_ref().unwrap_or(&self.placeholder_edges);
        let resolve_bind_groups =
            self.view_groups((&image_view, &depth_view), visibility, edge_buffers);
        ViewTargets {
            width,
            height,
            image,
            image_view,
            depth,
            depth_view,
            raster,
            edges,
            resolve_bind_groups,
            owner: self.id,
            other_groups: Vec::new(),
        }
    }

    /// Let this renderer draw into `targets` too (made by another: a study's condition of other
    /// geometry draws into the same wall or eye images), or again after light fields were added.
    pub fn bind_targets(&self, targets: &mut ViewTargets) {
        let own = targets.owner == self.id;
        let at = (targets.other_groups.iter()).position(|(id, _)| *id == self.id);
        let bound = match (own, at) {
            (true, _) => targets.resolve_bind_groups.len(),
            (false, Some(k)) => targets.other_groups[k].1.len(),
            (false, None) => 0,
        };
        if bound == self.fields.len() {
            return;
        }
        let visibility =
            (targets.raster.as_ref()).map_or(&self.placeholder_visibility, |r| &r.visibility);
        let edge_buffers = targets.edges.as_ref().unwrap_or(&self.placeholder_edges);
        let groups = self.view_groups(
            (&targets.image_view, &targets.depth_view),
            visibility,
            edge_buffers,
        );
        match (own, at) {
            (true, _) => targets.resolve_bind_groups = groups,
            (false, Some(k)) => targets.other_groups[k].1 = groups,
            (false, None) => targets.other_groups.push((self.id, groups)),
        }
    }

    /// The resolve's view group of each light field for an image, its depth and visibility.
    fn view_groups(
        &self,
        (image_view, depth_view): (&wgpu::TextureView, &wgpu::TextureView),
        visibility: &wgpu::TextureView,
        edges: &edges::EdgeTargets,
    ) -> Vec<wgpu::BindGroup> {
        let device = &self.ctx.device;
        let group = |field: &FieldSet| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("view"),
                layout: &self.resolve_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.view_buffer.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: field.faces.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: self.triangles.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: self.pairs.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: wgpu::BindingResource::TextureView(image_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: self.ray_triangles.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 6,
                        resource: wgpu::BindingResource::TextureView(depth_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 7,
                        resource: field.materials.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 8,
                        resource: wgpu::BindingResource::TextureView(visibility),
                    },
                    wgpu::BindGroupEntry {
                        binding: 9,
                        resource: edges.buffer.as_entire_binding(),
                    },
                ],
            })
        };
        self.fields.iter().map(group).collect()
    }

    /// Where the light field's normalised space is in the world (each scene has its own).
    pub fn normalisation(&self) -> Normalisation {
        self.normalisation
    }

    /// How the moving objects are lit (None: the renderer draws none).
    pub fn object_lighting(&self) -> Option<probes::ObjectLighting> {
        self.object_lighting
    }

    fn target(&mut self, width: u32, height: u32) -> &Target {
        if self
            .target
            .as_ref()
            .is_none_or(|t| t.targets.width != width || t.targets.height != height)
        {
            let padded_row = (width * 16).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
            let readback = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame readback"),
                size: padded_row as u64 * height as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            self.target = Some(Target {
                targets: self.view_targets(width, height),
                readback,
                padded_row,
            });
        }
        self.target.as_ref().unwrap()
    }

    fn encode_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<&mut Timestamps>,
    ) {
        let target = self.target.as_ref().expect("target sized");
        self.encode_view(encoder, &target.targets, timestamps);
    }

    /// Draw the view last set with `set_view_matrix` into `targets`: one compute pass, after
    /// the raster pass of its visibility buffer with raster first hits, and with edge
    /// antialiasing a refine pass after it (each timed as one).
    pub fn encode_view(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &ViewTargets,
        timestamps: Option<&mut Timestamps>,
    ) {
        let edges = match (&self.edges, &targets.edges) {
            (Some((_, pass)), Some(buffers)) => {
                buffers.clear(encoder);
                Some((pass, buffers))
            }
            _ => None,
        };
        // one timestamp pair spans the view's passes: raster then resolve, or resolve then
        // refine, or the resolve alone
        let span = timestamps.and_then(|t| t.next_span());
        let (pipeline, timestamp_writes, refine_writes) =
            match (&self.raster, &targets.raster, edges) {
                (Some(raster), Some(visibility), _) if raster.samples == visibility.samples => {
                    raster.encode(encoder, visibility, span.and_then(|s| s.render(0, 1)));
                    (&raster.resolve, span.and_then(|s| s.compute(1, 1)), None)
                }
                (_, _, Some(_)) => (
                    &self.resolve_pipeline,
                    span.and_then(|s| s.compute(0, 1)),
                    span.and_then(|s| s.compute(1, 1)),
                ),
                _ => (
                    &self.resolve_pipeline,
                    span.and_then(|s| s.compute(0, 0)),
                    None,
                ),
            };
        let size = [targets.width, targets.height];
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("view"),
                timestamp_writes,
            });
            self.set_view_groups(&mut pass, targets);
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups(size[0].div_ceil(8), size[1].div_ceil(8), 1);
            if let Some((edge_pass, _)) = edges {
                edge_pass.encode_find(&mut pass, size);
            }
        }
        if let Some((edge_pass, buffers)) = edges {
            edge_pass.encode_arguments(encoder, buffers);
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("view: edges"),
                timestamp_writes: refine_writes,
            });
            self.set_view_groups(&mut pass, targets);
            edge_pass.encode_refine(&mut pass, buffers);
        }
    }

    /// The resolve's bind groups for a view into `targets`, with the light field in use.
    fn set_view_groups(&self, pass: &mut wgpu::ComputePass, targets: &ViewTargets) {
        let field = &self.fields[self.active];
        let groups = match targets.owner == self.id {
            true => &targets.resolve_bind_groups,
            false => (targets.other_groups.iter().find(|(id, _)| *id == self.id))
                .map(|(_, g)| g)
                .expect("view targets of another renderer are bound first (bind_targets)"),
        };
        let view_group = groups.get(self.active).unwrap_or(&groups[0]);
        pass.set_bind_group(0, view_group, &[]);
        pass.set_bind_group(1, &field.field_bind_group, &[]);
        pass.set_bind_group(2, &field.moving_group, &[]);
    }

    fn set_view(&mut self, camera: &Camera, width: u32, height: u32) {
        let eye = self.normalisation.to_unit(camera.eye).as_vec3();
        self.set_view_matrix(
            view_projection(camera, &self.normalisation, width, height),
            eye,
        );
    }

    /// Any view: a view-projection and the eye, both in the light field's normalised space
    /// (off-axis CAVE walls, headset eyes).
    pub fn set_view_matrix(&mut self, view_proj: Mat4, eye: Vec3) {
        let view = GpuView {
            view_proj: view_proj.to_cols_array_2d(),
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            eye: eye.into(),
            ..self.view_template
        };
        self.ctx
            .queue
            .write_buffer(&self.view_buffer, 0, bytemuck::bytes_of(&view));
    }

    /// Render the view last set with `set_view_matrix`, timed with GPU timestamps where the
    /// adapter has them (milliseconds).
    pub fn render_matrix(
        &mut self,
        view_proj: Mat4,
        eye: Vec3,
        width: u32,
        height: u32,
    ) -> Result<(Frame, Option<f64>)> {
        self.set_view_matrix(view_proj, eye);
        self.target(width, height);
        let mut ts = Timestamps::new(&self.ctx, 1);
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_frame(&mut encoder, ts.as_mut());
        let frame = self.read_target(encoder, width, height)?;
        let gpu_ms = match ts.as_mut() {
            Some(t) => t.read_ms(&self.ctx)?.first().copied(),
            None => None,
        };
        Ok((frame, gpu_ms))
    }

    /// Encode and submit one view without waiting (views of one frame queue up back to back,
    /// as in a CAVE); its GPU time lands in `timestamps`.
    pub fn submit_matrix(
        &mut self,
        view_proj: Mat4,
        eye: Vec3,
        width: u32,
        height: u32,
        timestamps: Option<&mut Timestamps>,
    ) {
        self.set_view_matrix(view_proj, eye);
        self.target(width, height);
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_frame(&mut encoder, timestamps);
        self.ctx.queue.submit([encoder.finish()]);
    }

    fn read_target(
        &mut self,
        mut encoder: wgpu::CommandEncoder,
        width: u32,
        height: u32,
    ) -> Result<Frame> {
        let t = self.target.as_ref().unwrap();
        encoder.copy_texture_to_buffer(
            t.targets.image.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &t.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(t.padded_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        self.ctx.queue.submit([encoder.finish()]);
        let raw: Vec<[f32; 4]> = self
            .ctx
            .read_buffer(&t.readback, t.padded_row as u64 * height as u64)?;
        let stride = (t.padded_row / 16) as usize;
        let mut pixels = Vec::with_capacity((width * height) as usize);
        for row in 0..height as usize {
            pixels.extend_from_slice(&raw[row * stride..row * stride + width as usize]);
        }
        Ok(Frame {
            width,
            height,
            pixels,
        })
    }

    /// Render one view and read it back.
    pub fn render(&mut self, camera: &Camera, width: u32, height: u32) -> Result<Frame> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(VlfError::Parameter {
                name: "size",
                message: format!("{width}x{height} must be 1..16384 each way"),
            });
        }
        self.set_view(camera, width, height);
        self.target(width, height);
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_frame(&mut encoder, None);
        self.read_target(encoder, width, height)
    }

    /// Render `frames` frames of one view; per-frame GPU milliseconds from timestamp queries
    /// (or wall-clock milliseconds per submitted frame when the adapter has none).
    /// Render with `ssaa` x `ssaa` samples per pixel on a regular grid, box-filtered over the
    /// pixel (for comparisons with the path tracer, whose samples cover the pixel too).
    pub fn render_antialiased(
        &mut self,
        camera: &Camera,
        width: u32,
        height: u32,
        ssaa: u32,
    ) -> Result<Frame> {
        if ssaa <= 1 {
            return self.render(camera, width, height);
        }
        let big = self.render(camera, width * ssaa, height * ssaa)?;
        Ok(downsample(&big, ssaa))
    }

    /// Does this renderer draw a view-dependent (mirror) part?
    pub fn view_dependent(&self) -> bool {
        self.view_dependent
    }

    pub fn time_frames(
        &mut self,
        camera: &Camera,
        width: u32,
        height: u32,
        frames: u32,
    ) -> Result<(Vec<f64>, bool)> {
        self.set_view(camera, width, height);
        self.target(width, height);
        const BATCH: u32 = 64;
        let mut out = Vec::with_capacity(frames as usize);
        match Timestamps::new(&self.ctx, BATCH) {
            Some(mut ts) => {
                let mut left = frames;
                while left > 0 {
                    let n = left.min(BATCH);
                    let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
                    for _ in 0..n {
                        self.encode_frame(&mut encoder, Some(&mut ts));
                    }
                    self.ctx.queue.submit([encoder.finish()]);
                    out.extend(ts.read_ms(&self.ctx)?);
                    left -= n;
                }
                Ok((out, true))
            }
            None => {
                for _ in 0..frames {
                    let start = std::time::Instant::now();
                    let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
                    self.encode_frame(&mut encoder, None);
                    self.ctx.queue.submit([encoder.finish()]);
                    self.ctx.wait()?;
                    out.push(start.elapsed().as_secs_f64() * 1e3);
                }
                Ok((out, false))
            }
        }
    }
}

/// The resolve pass's bind group layouts: its own group (the view, the render mesh, the
/// targets), the light field's (`lightfield::bindings`) and the moving objects'.
struct ResolveLayouts {
    /// render.wgsl as compiled for the pipeline (edge antialiasing's entry points come from it)
    module: wgpu::ShaderModule,
    view: wgpu::BindGroupLayout,
    field: crate::lightfield::bindings::FieldLayout,
    moving: wgpu::BindGroupLayout,
}

/// Whether `objects` sample direct light per point in the views (`SAMPLED_DIRECT`).
fn samples_direct(objects: &ObjectsToDraw) -> bool {
    objects.lighting.samples_direct()
}

/// What a resolve pipeline is compiled for.
#[derive(Clone, Copy)]
struct ResolveVariant {
    /// the light field has mirror tiles
    tiles: bool,
    /// the traversal stack's entries
    stack: u32,
    /// the renderer draws moving objects
    moving: bool,
    /// the light field has texture detail
    textured: bool,
    /// some face cuts holes (its coverage in the texture detail): `ALPHA_MASKS`
    cutouts: bool,
    /// some face has a normal map (in the texture detail): `NORMAL_MAPS`
    normal_maps: bool,
    /// eye rays read their first hits from a visibility buffer (`raster`)
    raster: bool,
    /// moving surfaces sample their direct light per point, or their shadows are drawn per
    /// pixel (`SAMPLED_DIRECT`; else the vertices and the shadow atlas carry both)
    sampled_direct: bool,
}

/// The resolve pass: its pipeline and layouts. A light field with mirror tiles is drawn with
/// `pair_mixed`, which reads them; a diffuse-only one with `pair_diffuse` (`TILES`). The traversal's
/// stack has `stack` entries, as deep as the scene's tree needs: local memory per thread is what
/// a ray cast waits on (an H100 cast the 100K classroom's views 1.6x faster with 24 entries than
/// with 64). Without moving objects their code is compiled out (`MOVING_OBJECTS` 0), and so is
/// the texture detail's without it (`SURFACE_TEXTURES` 0), the cut-outs' test without one
/// (`ALPHA_MASKS` 0, common/coverage.wgsl), the normal maps' without one (`NORMAL_MAPS` 0,
/// common/normal_map.wgsl), and the visibility buffer's reads
/// without raster first hits (`RASTER_FIRST_HITS` 0).
fn resolve_pipeline(
    ctx: &GpuContext,
    variant: ResolveVariant,
) -> Result<(wgpu::ComputePipeline, ResolveLayouts)> {
    let device = &ctx.device;
    let module = resolve_module(ctx, variant)?;
    let view = reflect::layout(device, "render.wgsl", 0)?;
    let field = crate::lightfield::bindings::layout(device, "render.wgsl")?;
    let moving = reflect::layout(device, "render.wgsl", 2)?;
    if field.group != 1 {
        return Err(VlfError::Gpu(format!(
            "shaders/render.wgsl binds the light field at group {}; the renderer binds it at 1",
            field.group
        )));
    }
    let pipeline = ctx.compute_pipeline(&module, "resolve", &[&view, &field.layout, &moving]);
    Ok((
        pipeline,
        ResolveLayouts {
            module,
            view,
            field,
            moving,
        },
    ))
}

/// `shaders/render.wgsl` compiled for `variant` (every entry point: the resolve and edge
/// antialiasing's).
fn resolve_module(ctx: &GpuContext, variant: ResolveVariant) -> Result<wgpu::ShaderModule> {
    let ResolveVariant {
        tiles,
        stack,
        moving,
        textured,
        cutouts,
        normal_maps,
        raster,
        sampled_direct,
    } = variant;
    let constants = [
        ("TILES", u32::from(tiles)),
        ("PAIR_STACK", stack),
        ("MOVING_OBJECTS", u32::from(moving)),
        ("SURFACE_TEXTURES", u32::from(textured)),
        ("ALPHA_MASKS", u32::from(cutouts)),
        ("NORMAL_MAPS", u32::from(normal_maps && textured)),
        ("RASTER_FIRST_HITS", u32::from(raster)),
        ("SAMPLED_DIRECT", u32::from(sampled_direct)),
    ];
    shaders::module_with(&ctx.device, "render.wgsl", &constants)
}

/// The moving objects' group of the resolve pass: their shading records, materials and probes,
/// their vertices' light and corners, and the shadow atlas's face slots and texels
/// (placeholders, never read, without the vertices' light pass or the atlas).
pub(super) fn moving_group(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    (m, p): (&moving::MovingObjects, &probes::Probes),
    (atlas, light): (
        Option<&shadow_atlas::ShadowAtlas>,
        Option<&moving_light::MovingLight>,
    ),
) -> wgpu::BindGroup {
    let placeholder = ctx.buffer_init(
        &MemoryLedger::default(),
        "no shadow atlas or vertices' light",
        &[0u8; 64],
        wgpu::BufferUsages::STORAGE,
    );
    let (slots, texels) = atlas.map_or((&placeholder, &placeholder), |a| (&a.slots, &a.texels));
    let lit = light.map_or(&placeholder, |l| &l.lit);
    ctx.bind_group(
        layout,
        &[
            &m.shading,
            &m.materials,
            &p.grid_buffer,
            &p.coefficients,
            &p.emitters,
            &p.emitter_alias,
            lit,
            &m.corners,
            slots,
            texels,
        ],
    )
}

/// The same group for a renderer without moving objects (or before their probes are baked):
/// placeholders, never read, but for the scene's emitters and their alias table where `lf` has
/// glossy surfaces, whose first reflections sample them (render.wgsl, glossy_emitter_light).
fn placeholder_moving_group(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    lf: &LightField,
) -> wgpu::BindGroup {
    let ledger = MemoryLedger::default();
    let storage = ctx.buffer_init(
        &ledger,
        "no moving objects",
        &[0u8; 64],
        wgpu::BufferUsages::STORAGE,
    );
    let glossy = lf.materials.iter().any(|m| m.is_glossy());
    let emitters = if glossy {
        probes::emitters(lf)
    } else {
        Vec::new()
    };
    let grid = crate::gpu::types::GpuProbeGrid {
        emitter_count: emitters.len() as u32,
        ..Default::default()
    };
    let uniform = ctx.buffer_init(
        &ledger,
        "no probes",
        bytemuck::bytes_of(&grid),
        wgpu::BufferUsages::UNIFORM,
    );
    if emitters.is_empty() {
        return ctx.bind_group(
            layout,
            &[
                &storage, &storage, &uniform, &storage, &storage, &storage, &storage, &storage,
                &storage, &storage,
            ],
        );
    }
    let chances: Vec<f32> = emitters.iter().map(|e| e.chance).collect();
    let (emitter_buffer, alias) = (
        ctx.buffer_init(
            &ledger,
            "glossy lobes' emitters",
            bytemuck::cast_slice(&emitters),
            wgpu::BufferUsages::STORAGE,
        ),
        ctx.buffer_init(
            &ledger,
            "glossy lobes' emitter alias table",
            bytemuck::cast_slice(&probes::alias_table(&chances)),
            wgpu::BufferUsages::STORAGE,
        ),
    );
    ctx.bind_group(
        layout,
        &[
            &storage,
            &storage,
            &uniform,
            &storage,
            &emitter_buffer,
            &alias,
            &storage,
            &storage,
            &storage,
            &storage,
        ],
    )
}

/// The render mesh (triangles in the light field's normalised space, each with its face and,
/// with texture detail, its texture coordinates) as ray-casting triangles in BVH order, and the
/// BVH.
/// Meshes up to this size are ray cast exhaustively (every ray tests every triangle): the same
/// work for every pixel, and on an H200 cheaper than the BVH for meshes this small.
pub const EXHAUSTIVE_TRIANGLES: usize = 256;

thread_local! {
    /// `EXHAUSTIVE_TRIANGLES` moved for renderers made on this thread (a test hook).
    static EXHAUSTIVE_OVERRIDE: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
}

/// Runs `f` with every renderer made on this thread testing every triangle up to `threshold`
/// (0: always through the BVH; `usize::MAX`: never), as tests/bvh.rs compares the two.
pub fn with_exhaustive_triangles<T>(threshold: usize, f: impl FnOnce() -> T) -> T {
    let before = EXHAUSTIVE_OVERRIDE.replace(Some(threshold));
    let out = f();
    EXHAUSTIVE_OVERRIDE.set(before);
    out
}

fn ray_casting_mesh(
    vertices: &[RenderVertex],
    detail: Option<&crate::lightfield::textures::SurfaceDetail>,
) -> Result<(Vec<crate::bvh::GpuTriangle>, crate::bvh::BvhPairs)> {
    let corners: Vec<[Vec3; 3]> = vertices
        .chunks_exact(3)
        .map(|t| [0, 1, 2].map(|k| Vec3::from(t[k].position)))
        .collect();
    if corners.len() >= crate::bvh::MAX_PAIR_REFERENCE {
        return Err(VlfError::Parameter {
            name: "scene",
            message: format!(
                "{} triangles: the renderer casts through at most {}; simplify the mesh",
                corners.len(),
                crate::bvh::MAX_PAIR_REFERENCE - 1
            ),
        });
    }
    let uv = |i: usize| detail.map_or([[0.0; 2]; 3], |d| d.corners_uv(i));
    let (nodes, triangles) = crate::bvh::bvh_triangles(&corners, |i| vertices[i * 3].face, uv);
    // an empty mesh casts no ray through the tree (it is cast exhaustively): one unused pair
    let pairs = crate::bvh::bvh_pairs(&nodes).unwrap_or(crate::bvh::BvhPairs {
        pairs: vec![Default::default()],
        depth: 1,
    });
    Ok((triangles, pairs))
}

/// Box-filter `factor` x `factor` blocks of pixels into one.
pub fn downsample(frame: &Frame, factor: u32) -> Frame {
    let (w, h) = (frame.width / factor, frame.height / factor);
    let mut pixels = vec![[0.0f32; 4]; (w * h) as usize];
    let scale = 1.0 / (factor * factor) as f32;
    for y in 0..frame.height {
        for x in 0..frame.width {
            let p = frame.pixels[(y * frame.width + x) as usize];
            let o = &mut pixels[((y / factor) * w + x / factor) as usize];
            for c in 0..4 {
                o[c] += p[c] * scale;
            }
        }
    }
    Frame {
        width: w,
        height: h,
        pixels,
    }
}
