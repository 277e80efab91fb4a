// The material model on the GPU: the material table that the face records index, and what a
// surface does with light (src/material.rs holds the material type and the CPU twins of these
// helpers, written the same way). Every stage that shades a surface includes it: propagation
// (common/upstream.wgsl), specular transport, direct light, the renderer and the path tracer.
// The including stage binds `materials: array<Material>` (the table, crate::material's
// material_table). A glossy lobe or a cut-out is a field of Material, a flag and a helper here.

// mirrors gpu::types::GpuMaterial
struct Material {
    // the diffuse (Lambertian) part's albedo
    diffuse: vec3<f32>,
    // MATERIAL_DELTA | MATERIAL_DIFFUSE
    flags: u32,
    // the specular part's reflectance: an ideal mirror, or a glossy lobe where roughness > 0
    mirror: vec3<f32>,
    // the specular part's GGX roughness alpha (0: an ideal mirror)
    roughness: f32,
    // emitted radiance, on an emitting side (the face's FACE_EMITTER)
    emission: vec3<f32>,
    // the share of the specular part's light propagation carries: 1 for an ideal mirror, a
    // glossy lobe's cosine-weighted mean albedo
    lobe_albedo: f32,
}

// the material has an ideal mirror part (a delta lobe)
const MATERIAL_DELTA: u32 = 1u;
// the material has a diffuse part
const MATERIAL_DIFFUSE: u32 = 2u;
// the specular part is a glossy GGX lobe (roughness > 0); propagation carries it as an ideal
// mirror of the same reflectance (MATERIAL_DELTA stays set), the views and the path tracer
// sample the lobe
const MATERIAL_GLOSSY: u32 = 4u;

fn material_of(f: Face) -> Material {
    return materials[f.material];
}

// An ideal mirror part: its light leaves along one direction (mirror chains, tiles, virtual
// emitters follow it).
fn is_delta(m: Material) -> bool {
    return (m.flags & MATERIAL_DELTA) != 0u;
}

fn diffuse_reflectance(m: Material) -> vec3<f32> {
    return m.diffuse;
}

fn mirror_reflectance(m: Material) -> vec3<f32> {
    return m.mirror;
}

// The specular reflectance propagation carries (as an ideal mirror): a glossy lobe's times its
// mean albedo, so the light field loses what single scattering loses.
fn carried_reflectance(m: Material) -> vec3<f32> {
    return m.mirror * m.lobe_albedo;
}

// A face with a specular part (an ideal mirror or a glossy lobe) but without tiles: smaller than
// prepare::packing::SPECULAR_TILES_MIN_AREA. Propagation sends its specular part's
// light on as diffuse light of the part's carried reflectance, so its texels hold diffuse and
// specular light together; the views show their diffuse part's share where they trace the
// reflection (shown_diffuse_share), and the whole where a chain ends on it.
fn carried_diffusely(f: Face, m: Material) -> bool {
    return is_delta(m) && f.tile_slot == NO_FACE;
}

// The albedo of what face f's texels send on as diffuse light (its next unshot radiosity per unit
// irradiance): the diffuse part's, and a tile-less face's specular part (carried_diffusely).
fn propagated_diffuse(f: Face, m: Material) -> vec3<f32> {
    return diffuse_reflectance(m) + select(vec3<f32>(0.0), carried_reflectance(m), carried_diffusely(f, m));
}

// The specular reflectance face f's tiles carry (none for a tile-less face).
fn propagated_specular(f: Face, m: Material) -> vec3<f32> {
    return select(carried_reflectance(m), vec3<f32>(0.0), carried_diffusely(f, m));
}

// The share of face f's texel radiance (emission aside) that its diffuse part reflects: 1, but
// on a tile-less specular face, whose texels also hold its specular part's light (shown by
// traced reflections instead), diffuse / (diffuse + the carried specular part) per channel.
fn shown_diffuse_share(f: Face, m: Material) -> vec3<f32> {
    if !carried_diffusely(f, m) {
        return vec3<f32>(1.0);
    }
    let sent = propagated_diffuse(f, m);
    return select(vec3<f32>(0.0), diffuse_reflectance(m) / max(sent, vec3<f32>(1e-30)), sent > vec3<f32>(0.0));
}

// The radiance face f emits: its material's on an emitting side.
fn emitted(f: Face) -> vec3<f32> {
    return select(vec3<f32>(0.0), material_of(f).emission, (f.flags & FACE_EMITTER) != 0u);
}

// What a ray that also traces face f's reflection takes of its texel radiance `texel`: the
// emission and the diffuse part's share (shown_diffuse_share) on a tile-less specular face
// (carried_diffusely), whose texels also hold its specular light; the texel on any other face.
fn shown_texel_radiance(f: Face, texel: vec3<f32>) -> vec3<f32> {
    let m = material_of(f);
    if !carried_diffusely(f, m) {
        return texel;
    }
    let e = emitted(f);
    return (texel - e) * shown_diffuse_share(f, m) + e;
}

// `ray` reflected about the plane of normal n: the ideal mirror's one reflection tap.
fn mirror_direction(ray: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return ray - 2.0 * dot(ray, n) * n;
}

// The specular part is a glossy lobe, not an ideal mirror.
fn is_glossy(m: Material) -> bool {
    return (m.flags & MATERIAL_GLOSSY) != 0u;
}

// An orthonormal frame (t, b, n) around unit n (Duff et al. 2017, "Building an Orthonormal
// Basis, Revisited").
fn frame_around(n: vec3<f32>) -> mat3x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let bt = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

// Smith's G1 for GGX of roughness alpha, for a direction of cosine `cos_theta` to the normal.
fn ggx_g1(cos_theta: f32, alpha: f32) -> f32 {
    let c2 = max(cos_theta * cos_theta, 1e-12);
    let tan2 = max(1.0 - c2, 0.0) / c2;
    return 2.0 / (1.0 + sqrt(1.0 + alpha * alpha * tan2));
}

// GGX's distribution of normals for a microfacet normal at cosine `cos_m` to the normal. CPU
// twin: crate::material::ggx_d.
fn ggx_d(cos_m: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let k = cos_m * cos_m * (a2 - 1.0) + 1.0;
    return a2 / (PI * k * k);
}

// The glossy lobe's BRDF per unit reflectance for unit directions leaving the surface of normal
// n, f = D G1(wo) G1(wi) / (4 cos_o cos_i) (0 below it): what reflect_sampled samples. CPU twin:
// crate::material::ggx_brdf.
fn ggx_brdf(n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    let cos_o = dot(n, wo);
    let cos_i = dot(n, wi);
    if cos_o <= 0.0 || cos_i <= 0.0 {
        return 0.0;
    }
    let h = normalize(wo + wi);
    return ggx_d(dot(n, h), alpha) * ggx_g1(cos_o, alpha) * ggx_g1(cos_i, alpha) / (4.0 * cos_o * cos_i);
}

// The specular part's reflection of a ray travelling along `ray` that meets the surface of
// normal n (facing the ray): for an ideal mirror, the mirror direction with weight 1; for a
// glossy lobe, a direction sampled from GGX's visible normals (Heitz 2018) with `u` in [0,1)^2,
// and its weight f cos / pdf = G1(out) (Smith's separable masking, as Mitsuba 3's microfacet
// model; no Fresnel: the reflectance is the material's), 0 below the surface. The lobe's energy
// lost to single scattering is the stated loss (material.rs: ggx_albedo). CPU twin:
// crate::material::reflect_sampled.
fn reflect_sampled(ray: vec3<f32>, n: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec4<f32> {
    if alpha <= 0.0 {
        return vec4<f32>(mirror_direction(ray, n), 1.0);
    }
    let frame = frame_around(n);
    let wo = -ray * frame;
    let vh = normalize(vec3<f32>(alpha * wo.x, alpha * wo.y, max(wo.z, 1e-6)));
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-vh.y, vh.x, 0.0) / sqrt(max(lensq, 1e-20)), lensq > 1e-12);
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = 6.283185307 * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
    let nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    let m = normalize(vec3<f32>(alpha * nh.x, alpha * nh.y, max(nh.z, 1e-6)));
    let wi = 2.0 * dot(wo, m) * m - wo;
    if wi.z <= 0.0 {
        return vec4<f32>(frame * wi, 0.0);
    }
    return vec4<f32>(frame * wi, ggx_g1(wi.z, alpha));
}
