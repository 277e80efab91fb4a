// Structs shared by every GPU stage. Each one mirrors a #[repr(C)] struct in
// src/gpu/types.rs (named on the line above it); tests/shaders.rs checks that the sizes agree.

const NO_FACE: u32 = 0xffffffffu;
// find_upstream: the visibility lists cannot place the receiver along this direction
const UNRESOLVED: u32 = 0xfffffffeu;
const PI: f32 = 3.14159265358979;
const FACE_EMITTER: u32 = 1u;
const GRID_FLAG_SKY: u32 = 1u;
// add to `next` instead of overwriting it (perturbed direction sets after the first)
const GRID_FLAG_ACCUMULATE: u32 = 2u;
// directions come in batches: add raw sums to `next` and the quadrature weights used to
// `weight_sums`; normalize.wgsl divides once every batch has been gathered
const GRID_FLAG_BATCHED: u32 = 4u;
// the second iteration's texel gather leaves mirror senders out (what mirrors first reflect of
// the sky came with direct light; of the emitters, direct.wgsl's mirror_light adds it next) and
// puts pi x their share of its quadrature weight in w
const GRID_FLAG_NO_MIRROR_SENDERS: u32 = 8u;
// tests only: the sender lookup takes the list's first side of a two-sided surface, as before
// facing_side fixed it (the power balance must catch the light this loses)
const GRID_FLAG_LIST_ORDER_SIDES: u32 = 16u;
// rim_rays: a texel the lists cannot place along a direction casts a ray through the BVH
const GRID_FLAG_RIM_RAYS: u32 = 32u;

// mirrors gpu::types::GpuDirection
struct Direction {
    w: vec3<f32>,
    solid_angle: f32,
    u: vec3<f32>,
    _pad0: f32,
    v: vec3<f32>,
    _pad1: f32,
}

// mirrors gpu::types::GpuFace
struct Face {
    normal: vec3<f32>,
    plane_offset: f32,
    // corner of the chart's texel rectangle (padding included), on the face plane
    origin: vec3<f32>,
    texel_density: f32,
    axis_a: vec3<f32>,
    // the face's row of the material table (common/bsdf.wgsl: material_of)
    material: u32,
    axis_b: vec3<f32>,
    flags: u32,
    atlas_x: u32,
    atlas_y: u32,
    atlas_w: u32,
    atlas_h: u32,
    // the other side of a two-sided surface, or NO_FACE
    twin: u32,
    // index among the non-diffuse faces (its tiles), or NO_FACE for a diffuse-only face
    tile_slot: u32,
    _pad0: u32,
    _pad1: u32,
}

// mirrors gpu::types::GpuGrid
struct GridParams {
    resolution: u32,
    direction_count: u32,
    triangle_count: u32,
    triangle_base: u32,
    texel_count: u32,
    atlas_width: u32,
    iteration: u32,
    // bit 0: the sky shoots in this iteration
    flags: u32,
    sky: vec3<f32>,
    cell_size: f32,
    depth_epsilon: f32,
    geodesic_frequency: u32,
    tile_size: u32,
    tile_face_count: u32,
    // 1 / K for K perturbed direction sets, else 1
    direction_weight: f32,
    tile_cell_count: u32,
    // global index of `directions[0]`: 0 unless directions come in batches
    first_direction: u32,
    // mirror tiles in pages (common/light_field.wgsl): cells per page
    tile_page_cells: u32,
    // texel arrays in pages (common/upstream.wgsl): texels per page
    texel_page_cells: u32,
    // where the specular textures' factors start after the tile headers, in vec4s (0: none;
    // specular.wgsl, specular_factor)
    specular_words: u32,
    _pad2: u32,
    _pad3: u32,
}

// mirrors gpu::types::GpuPageRange: the page of elements (texels, or mirror tile cells) one
// dispatch writes
struct PageRange {
    // its first element among all, and its elements
    base: u32,
    cells: u32,
    _pad0: u32,
    _pad1: u32,
}

// mirrors gpu::types::GpuView
struct View {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // eye position in normalised space
    eye: vec3<f32>,
    // antialiasing: eye rays per pixel
    samples_per_pixel: u32,
    // mirror reflections traced per eye ray (0: the scene has no mirror)
    mirror_bounces: u32,
    // frame pacing (src/render/budget.rs): the share paced_fraction of the view's 8x8 tiles
    // draws paced_samples eye rays per pixel instead of samples_per_pixel
    paced_samples: u32,
    paced_fraction: f32,
    // 1: every pixel traces its reflections whatever it sees (see render.wgsl); 0: paced, and
    // with edge antialiasing only tiles of 2 eye rays or more refine their edges
    fixed_work: u32,
    // > 0: the mesh is this small, and every eye ray tests every triangle
    exhaustive_triangles: u32,
    // the moving objects' tree: its root pair (NO_NODE: none) and its first triangle, after the
    // scene's in `pairs` and `ray_triangles` (src/render/dynamic.rs)
    moving_root: u32,
    moving_first: u32,
    // the moving objects' switches: 1 their shadows, 2 seen in mirrors (gpu::types)
    moving_flags: u32,
    // 0: eye rays on the Hammersley set (render.wgsl, sample_offset); 2, 4, 8 or 16: on the
    // standard positions of that many MSAA samples (render.wgsl, msaa_position), as the
    // visibility buffer of raster first hits has them (src/render/raster.rs)
    msaa_samples: u32,
    // reflections sampled from a glossy lobe per chain of eye-ray pair: each pair whose
    // reflecting surface is glossy traces this many chains and averages them (render.wgsl)
    lobe_samples: u32,
    // shadow rays to the emitters per chain's first glossy reflection (render.wgsl,
    // glossy_emitter_light; 0: the lobe's sampled rays alone)
    glossy_light_samples: u32,
    // edge antialiasing (render.wgsl, find_edges and refine): 0 off; else the eye rays per pixel
    // of the pixels that differ from a neighbour, all on one progressive set whose first ray
    // goes through the pixel's centre
    edge_samples: u32,
    // the relative difference in luminance from a neighbour that makes a pixel an edge
    edge_contrast: f32,
    _pad3: u32,
    _pad4: u32,
    _pad5: u32,
}

// mirrors gpu::types::GpuField: the layout of the light field a stage reads and the scene's
// sky (common/light_field.wgsl), the same for every view of it
struct Field {
    sky: vec4<f32>,
    cell_size: f32,
    atlas_width: u32,
    geodesic_frequency: u32,
    tile_size: u32,
    tile_face_count: u32,
    grid_resolution: u32,
    // mirror tiles: cells per page, and cells in all
    tile_page_cells: u32,
    tile_cell_count: u32,
    // the radiance atlas in pages: texels per page
    texel_page_cells: u32,
    // normal maps: where the faces' records and the texels' light directions start in
    // texel_albedo (0 and 0: none)
    normal_records: u32,
    normal_texels: u32,
    // specular textures: where the faces' records start in texel_albedo (0: none)
    specular_records: u32,
}

// mirrors gpu::types::GpuAccumulate
struct AccumulateParams {
    count: u32,
    // 1/pi for texels (radiosity to radiance), 1 for tile cells (already radiance)
    scale: f32,
    // normalize.wgsl: where these elements' quadrature weights start in `weight_sums`
    weight_offset: u32,
    _pad1: u32,
}

// mirrors gpu::types::GpuPresent (shaders/present.wgsl)
struct PresentParams {
    viewport_origin: vec2<f32>,
    viewport_size: vec2<f32>,
    exposure: f32,
    // 1: the surface format is linear, so the shader encodes sRGB
    encode_srgb: u32,
    show_overlay: u32,
    _pad0: u32,
}

// mirrors gpu::types::GpuRayTriangle: a triangle as the rows u, v, w of its affine map (world ->
// the triangle's barycentric u, v and its plane distance w)
struct RayTriangle {
    u: vec4<f32>,
    v: vec4<f32>,
    w: vec4<f32>,
}

// Mirrors bvh::GpuBvhPair: an internal node of the BVH as its two children, each a box and a
// reference: (pair << 5) for an internal child, (first triangle << 5) | count for a leaf.
// Opening a node is one 64-byte read with both boxes in it.
struct BvhPair {
    lo_left: vec3<f32>,
    left: u32,
    hi_left: vec3<f32>,
    right: u32,
    lo_right: vec3<f32>,
    _pad0: u32,
    hi_right: vec3<f32>,
    _pad1: u32,
}

// mirrors gpu::types::GpuMovingTriangle: the corners' normals in normalised space, and in n0's
// w the triangle's material (bits of a u32)
struct MovingTriangle {
    n0: vec4<f32>,
    n1: vec4<f32>,
    n2: vec4<f32>,
}

// mirrors gpu::types::GpuEmitter: one emitting triangle (direct.wgsl's direct light; the moving
// objects' shadow rays, common/moving_surface.wgsl)
struct Emitter {
    v0: vec3<f32>,
    face: u32,
    e1: vec3<f32>,
    // 1: the emission varies over the face (map_Ke): read it from the atlas
    textured: u32,
    e2: vec3<f32>,
    // this triangle's share of the emitters' power: the chance a moving object's shadow ray
    // picks it (render/probes.rs; 0 for direct light)
    chance: f32,
    // mean emitted radiance over the face (rgb), and its r+g+b in w
    radiance: vec4<f32>,
}
