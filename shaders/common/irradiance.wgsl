// Irradiance probes (src/render/probes.rs bakes them in probes.wgsl; moving objects read them in
// common/moving_surface.wgsl): a regular grid over the scene's box, each probe the radiance
// arriving at its point projected on the real spherical harmonics up to order 2 (nine
// coefficients per colour). Irradiance for a normal n is that radiance convolved with the
// clamped cosine (Ramamoorthi & Hanrahan 2001): exact for any radiance of order <= 2, e.g. the
// uniform radiance of a closed furnace.

// mirrors gpu::types::GpuProbeGrid: probe (i, j, k) sits at origin + spacing * (i, j, k); and
// the moving objects' shadows (common/moving_surface.wgsl): the emitting triangles, shadow rays
// per eye ray to each of them and to the sky
struct ProbeGrid {
    origin: vec3<f32>,
    rays: u32,
    spacing: vec3<f32>,
    emitter_count: u32,
    counts: vec3<u32>,
    shadow_samples: u32,
    sky_shadow_samples: u32,
    // the shadow atlas's texels along each side of a light-field texel (src/render/shadow_atlas.rs)
    shadow_subdivision: u32,
    // 1: a moving surface's own direct light is read from its vertices (moving_light.wgsl fills
    // them once per frame) where a ray meets its front; 0: shadow rays per eye ray
    vertex_light: u32,
    // what a moving surface samples of its own direct light, which the probes leave out
    // (probes.wgsl): 1 the emitters', 2 the sky's
    direct_sampled: u32,
}

// coefficients per probe, each a vec4: rgb, and in the first one's w the share of the probe's
// rays that met the back of a one-sided face (a probe inside closed geometry)
const PROBE_COEFFICIENTS: u32 = 9u;

// The nine real spherical harmonics at unit vector d (order 0, 1, 2).
fn sh_basis(d: vec3<f32>) -> array<f32, 9> {
    return array<f32, 9>(
        0.282095,
        0.488603 * d.y,
        0.488603 * d.z,
        0.488603 * d.x,
        1.092548 * d.x * d.y,
        1.092548 * d.y * d.z,
        0.315392 * (3.0 * d.z * d.z - 1.0),
        1.092548 * d.x * d.z,
        0.546274 * (d.x * d.x - d.y * d.y),
    );
}

// The basis at n times the clamped cosine's coefficients per order (pi, 2 pi / 3, pi / 4):
// dotted with a probe's radiance coefficients it gives the irradiance on a surface facing n.
fn irradiance_basis(n: vec3<f32>) -> array<f32, 9> {
    var b = sh_basis(n);
    b[0] *= PI;
    for (var i = 1u; i < 4u; i++) {
        b[i] *= 2.0 * PI / 3.0;
    }
    for (var i = 4u; i < 9u; i++) {
        b[i] *= PI / 4.0;
    }
    return b;
}
