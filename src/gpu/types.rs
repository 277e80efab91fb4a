//! GPU structs, defined once here with `#[repr(C)]` + bytemuck. Each names the WGSL struct in
//! `shaders/common/types.wgsl` that it mirrors; `tests/shaders.rs` checks that sizes agree.

use bytemuck::{Pod, Zeroable};

pub const NO_FACE: u32 = u32::MAX;
/// Mirrors WGSL UNRESOLVED: the visibility lists cannot place a receiver along a direction.
pub const UNRESOLVED: u32 = u32::MAX - 1;
pub const FACE_EMITTER: u32 = 1;

/// Mirrors WGSL `Direction`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuDirection {
    pub w: [f32; 3],
    pub solid_angle: f32,
    pub u: [f32; 3],
    pub _pad0: f32,
    pub v: [f32; 3],
    pub _pad1: f32,
}

/// Mirrors WGSL `Face`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuFace {
    pub normal: [f32; 3],
    pub plane_offset: f32,
    pub origin: [f32; 3],
    pub texel_density: f32,
    pub axis_a: [f32; 3],
    /// the face's material: its row of the material table (`crate::material`)
    pub material: u32,
    pub axis_b: [f32; 3],
    pub flags: u32,
    pub atlas_x: u32,
    pub atlas_y: u32,
    pub atlas_w: u32,
    pub atlas_h: u32,
    pub twin: u32,
    pub tile_slot: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// Mirrors WGSL `Material` (shaders/common/bsdf.wgsl): one row of the material table
/// (`crate::material`), which the face records index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    /// the diffuse (Lambertian) part's albedo
    pub diffuse: [f32; 3],
    /// `material::MATERIAL_DELTA`, `MATERIAL_DIFFUSE`, `MATERIAL_GLOSSY`
    pub flags: u32,
    /// the specular part's reflectance
    pub mirror: [f32; 3],
    /// the specular part's GGX roughness alpha (0: an ideal mirror)
    pub roughness: f32,
    /// emitted radiance (on the emitting side: `FACE_EMITTER`)
    pub emission: [f32; 3],
    /// the share of the specular part's light propagation carries: 1 for an ideal mirror, a
    /// glossy lobe's cosine-weighted mean albedo (`material::ggx_mean_albedo`)
    pub lobe_albedo: f32,
}

/// Mirrors WGSL `GridParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuGrid {
    pub resolution: u32,
    pub direction_count: u32,
    pub triangle_count: u32,
    pub triangle_base: u32,
    pub texel_count: u32,
    pub atlas_width: u32,
    pub iteration: u32,
    pub flags: u32,
    pub sky: [f32; 3],
    pub cell_size: f32,
    pub depth_epsilon: f32,
    pub geodesic_frequency: u32,
    pub tile_size: u32,
    pub tile_face_count: u32,
    pub direction_weight: f32,
    pub tile_cell_count: u32,
    pub first_direction: u32,
    pub tile_page_cells: u32,
    pub texel_page_cells: u32,
    /// where the specular textures' factors start after the tile headers, in vec4s (0: none;
    /// `propagate::transport::specular_factor_words`)
    pub specular_words: u32,
    pub _pad2: u32,
    pub _pad3: u32,
}

/// Mirrors WGSL `PageRange`: the page of elements one dispatch writes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuPageRange {
    pub base: u32,
    pub cells: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

pub const GRID_FLAG_SKY: u32 = 1;
pub const GRID_FLAG_ACCUMULATE: u32 = 2;
pub const GRID_FLAG_BATCHED: u32 = 4;
/// the second iteration's texel gather leaves mirror senders out (their first reflections of the
/// sky came with direct light; of the emitters, `mirror_light` in direct.wgsl adds them next)
/// and puts pi x their share of its quadrature weight in w
pub const GRID_FLAG_NO_MIRROR_SENDERS: u32 = 8;
/// Tests only (`propagate::propagate_with_regression`): the sender lookup takes whichever side
/// of a two-sided surface its cell list holds first, as before `facing_side` fixed it, so that
/// tests can show the power balance catching the light that loses.
pub const GRID_FLAG_LIST_ORDER_SIDES: u32 = 16;
/// `rim_rays`: a texel the lists cannot place along a direction casts a ray through the BVH
/// (diffuse-only scenes: propagate.wgsl's gather)
pub const GRID_FLAG_RIM_RAYS: u32 = 32;

/// Mirrors WGSL `AccumulateParams` (shaders/accumulate.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuAccumulate {
    pub count: u32,
    pub scale: f32,
    pub weight_offset: u32,
    pub _pad1: u32,
}

/// Mirrors WGSL `View`: one view's camera and drawing settings.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuView {
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    pub eye: [f32; 3],
    /// antialiasing: eye rays per pixel
    pub samples_per_pixel: u32,
    /// mirror reflections traced per eye ray (0: the scene has no mirror)
    pub mirror_bounces: u32,
    /// frame pacing (render/budget.rs): the share `paced_fraction` of the view's 8x8 tiles draws
    /// `paced_samples` eye rays per pixel instead of `samples_per_pixel`
    pub paced_samples: u32,
    pub paced_fraction: f32,
    /// 1: every pixel traces its reflections whatever it sees (constant work without frame
    /// pacing); 0: only pixels that see a mirror (the pacer holds the time)
    pub fixed_work: u32,
    /// > 0: the mesh is this small, and every eye ray tests every triangle
    pub exhaustive_triangles: u32,
    /// the moving objects' tree: its root pair (`u32::MAX`: none) and first triangle, after the
    /// scene's in the pairs and triangle buffers (`render::dynamic`)
    pub moving_root: u32,
    pub moving_first: u32,
    /// the moving objects' switches: `MOVING_SHADOWS`, `MOVING_IN_MIRRORS`
    pub moving_flags: u32,
    /// 0: eye rays on the Hammersley set; 2, 4, 8 or 16: on the standard positions of that many
    /// MSAA samples, as the visibility buffer of raster first hits has them (`render::raster`)
    pub msaa_samples: u32,
    /// chains of reflections sampled from a glossy lobe per eye-ray pair that meets one
    pub lobe_samples: u32,
    /// shadow rays to the emitters per chain's first glossy reflection (0: the lobe's sampled
    /// rays alone)
    pub glossy_light_samples: u32,
    /// edge antialiasing (`render::edges`): 0 off; else the eye rays per pixel of the pixels
    /// that differ from a neighbour, on one progressive set whose first ray is the pixel's
    /// centre
    pub edge_samples: u32,
    /// the relative difference in luminance from a neighbour that makes a pixel an edge
    pub edge_contrast: f32,
    pub _pad3: u32,
    pub _pad4: u32,
    pub _pad5: u32,
}

/// `GpuView::moving_flags`: the moving objects take direct light from the scene (their shadows).
pub const MOVING_SHADOWS: u32 = 1;
/// `GpuView::moving_flags`: reflections off the scene's mirrors show the moving objects.
pub const MOVING_IN_MIRRORS: u32 = 2;
/// `GpuView::moving_flags`: the shadows on the scene come from the shadow atlas
/// (`render::shadow_atlas`; `MOVING_SHADOW_ATLAS` in shaders/common/moving_shadow.wgsl), not from
/// shadow rays per pixel.
pub const MOVING_SHADOW_ATLAS: u32 = 4;

/// Mirrors WGSL `Field`: the layout of the light field a stage reads, and the scene's sky
/// (`shaders/common/light_field.wgsl`; made by `lightfield::bindings`), the same for every view.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuField {
    pub sky: [f32; 4],
    pub cell_size: f32,
    pub atlas_width: u32,
    pub geodesic_frequency: u32,
    pub tile_size: u32,
    pub tile_face_count: u32,
    pub grid_resolution: u32,
    /// mirror tiles: cells per page, and cells in all
    pub tile_page_cells: u32,
    pub tile_cell_count: u32,
    /// the radiance atlas in pages: texels per page
    pub texel_page_cells: u32,
    /// normal maps: where the faces' records and the texels' light directions start in the
    /// texture detail's `texel_albedo` (`SurfaceDetail::detail_words`; 0 and 0: none)
    pub normal_records: u32,
    pub normal_texels: u32,
    /// specular textures: where the faces' records start in `texel_albedo` (0: none)
    pub specular_records: u32,
}

/// Render vertex: position in normalised scene space and the face it belongs to: the render
/// mesh stored in `.vlf`, turned into ray-casting triangles by `render::ray_casting_mesh`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RenderVertex {
    pub position: [f32; 3],
    pub face: u32,
}

/// Mirrors WGSL `PresentParams` (shaders/present.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuPresent {
    pub viewport_origin: [f32; 2],
    pub viewport_size: [f32; 2],
    pub exposure: f32,
    pub encode_srgb: u32,
    pub show_overlay: u32,
    pub _pad0: u32,
}

/// Mirrors WGSL `Emitter` (shaders/direct.wgsl, driven by src/propagate/direct.rs): one emitting triangle.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuEmitter {
    pub v0: [f32; 3],
    pub face: u32,
    pub e1: [f32; 3],
    /// 1 where the emission varies over the face (map_Ke)
    pub textured: u32,
    pub e2: [f32; 3],
    /// the moving objects' shadow rays (`render::probes::emitters`): this triangle's share of
    /// the emitters' power, the chance a shadow ray picks it (direct light leaves it 0)
    pub chance: f32,
    /// mean emitted radiance over the face, r+g+b in w
    pub radiance: [f32; 4],
}

/// Mirrors WGSL `DirectParams` (shaders/direct.wgsl, driven by src/propagate/direct.rs).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuDirectParams {
    pub emitter_count: u32,
    pub emitter_samples: u32,
    pub sky_samples: u32,
    pub mirror_count: u32,
}

/// Mirrors WGSL `MirrorTriangle` (shaders/direct.wgsl): a triangle of a face with a mirror part.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuMirrorTriangle {
    pub v0: [f32; 3],
    pub face: u32,
    pub e1: [f32; 3],
    pub _pad0: u32,
    pub e2: [f32; 3],
    pub _pad1: u32,
}

/// Mirrors WGSL `RayTriangle` (shaders/render.wgsl): a triangle as the rows of its affine map
/// from world space to (u, v, w), barycentric u and v and the distance w from its plane.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuRayTriangle {
    pub u: [f32; 4],
    pub v: [f32; 4],
    pub w: [f32; 4],
}

impl GpuRayTriangle {
    /// The inverse of p = a + u (b - a) + v (c - a) + w n, computed in f64.
    pub fn new(a: glam::Vec3, b: glam::Vec3, c: glam::Vec3) -> GpuRayTriangle {
        let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let n = e1.cross(e2).normalize_or_zero();
        let m =
            glam::DMat4::from_cols(e1.extend(0.0), e2.extend(0.0), n.extend(0.0), a.extend(1.0));
        let inv = m.inverse();
        let row = |r: usize| {
            [
                inv.row(r).x as f32,
                inv.row(r).y as f32,
                inv.row(r).z as f32,
                inv.row(r).w as f32,
            ]
        };
        GpuRayTriangle {
            u: row(0),
            v: row(1),
            w: row(2),
        }
    }
}

/// Mirrors WGSL `MovingParams` (shaders/moving.wgsl): the moving objects' counts, and where
/// their triangles and tree start in the renderer's buffers.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMovingParams {
    pub vertex_count: u32,
    pub triangle_count: u32,
    pub first_triangle: u32,
    pub first_pair: u32,
}

/// Mirrors WGSL `MovingVertex` (shaders/moving.wgsl): a vertex at rest with its joints.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMovingVertex {
    pub position: [f32; 4],
    pub normal: [f32; 4],
    pub joints: [u32; 4],
    pub weights: [f32; 4],
}

/// Mirrors WGSL `MovingTriangle` (shaders/common/moving_surface.wgsl): corner normals, and the
/// material's index in `n0[3]`'s bits (written by the GPU).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMovingTriangle {
    pub n0: [f32; 4],
    pub n1: [f32; 4],
    pub n2: [f32; 4],
}

/// Mirrors WGSL `MovingMaterial` (shaders/common/moving_surface.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMovingMaterial {
    pub albedo: [f32; 4],
    pub emission: [f32; 4],
}

/// Mirrors WGSL `ShadowAtlas` (shaders/shadow_atlas.wgsl): the faces, what the atlas's buffers
/// hold, the emitters' boxes, the shadow rays per texel and the sky's reach, the rays per texel
/// for the indirect light and its reach.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuShadowAtlas {
    pub face_count: u32,
    pub texel_capacity: u32,
    pub item_capacity: u32,
    pub box_count: u32,
    pub samples: [u32; 2],
    pub sky_reach: f32,
    pub indirect_rays: u32,
    pub indirect_reach: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// Mirrors WGSL `ProbeGrid` (shaders/common/irradiance.wgsl): probe (i, j, k) at
/// origin + spacing * (i, j, k), `rays` per probe when baked; and the moving objects' shadows:
/// the emitting triangles and the shadow rays per eye ray to each and to the sky.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuProbeGrid {
    pub origin: [f32; 3],
    pub rays: u32,
    pub spacing: [f32; 3],
    pub emitter_count: u32,
    pub counts: [u32; 3],
    pub shadow_samples: u32,
    pub sky_shadow_samples: u32,
    /// the shadow atlas's texels along each side of a light-field texel
    pub shadow_subdivision: u32,
    /// 1: a moving surface's front reads its direct light from its vertices
    /// (`render::moving_light`); 0: shadow rays per eye ray
    pub vertex_light: u32,
    /// what a moving surface samples of its own direct light, which the probes leave out:
    /// `DIRECT_EMITTERS` | `DIRECT_SKY`
    pub direct_sampled: u32,
}

/// `GpuProbeGrid::direct_sampled`: the moving surfaces sample the emitters' direct light.
pub const DIRECT_EMITTERS: u32 = 1;
/// `GpuProbeGrid::direct_sampled`: the moving surfaces sample the sky's direct light.
pub const DIRECT_SKY: u32 = 2;

/// Mirrors WGSL `MovingLight` (shaders/moving_light.wgsl): the vertices lit per frame and the
/// shadow rays each takes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMovingLight {
    pub vertex_count: u32,
    pub emitter_samples: u32,
    pub sky_samples: u32,
    /// rays per vertex against the moving objects for the probes' correction (0: none)
    pub occlusion_rays: u32,
}
