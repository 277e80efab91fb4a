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
    // the ideal mirror part's reflectance
    mirror: vec3<f32>,
    _pad0: f32,
    // emitted radiance, on an emitting side (the face's FACE_EMITTER)
    emission: vec3<f32>,
    _pad1: f32,
}

// the material has an ideal mirror part (a delta lobe)
const MATERIAL_DELTA: u32 = 1u;
// the material has a diffuse part
const MATERIAL_DIFFUSE: u32 = 2u;

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

// The radiance face f emits: its material's on an emitting side.
fn emitted(f: Face) -> vec3<f32> {
    return select(vec3<f32>(0.0), material_of(f).emission, (f.flags & FACE_EMITTER) != 0u);
}

// `ray` reflected about the plane of normal n: the ideal mirror's one reflection tap.
fn mirror_direction(ray: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return ray - 2.0 * dot(ray, n) * n;
}
