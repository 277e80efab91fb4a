// What a moving object shows where a ray meets it (src/render/moving.rs): its own albedo and
// emission, lit by the converged static light field through the irradiance probes
// (common/irradiance.wgsl) at the smooth normal of the triangle's skinned corners. The renderer
// binds this group; cast_ray (common/scene_cast.wgsl) calls moving_radiance.

// mirrors gpu::types::GpuMovingTriangle: the corners' normals in normalised space, and in n0's
// w the triangle's material (bits of a u32)
struct MovingTriangle {
    n0: vec4<f32>,
    n1: vec4<f32>,
    n2: vec4<f32>,
}

// mirrors gpu::types::GpuMovingMaterial
struct MovingMaterial {
    albedo: vec4<f32>,
    emission: vec4<f32>,
}

@group(2) @binding(0) var<storage, read> moving_triangles: array<MovingTriangle>;
@group(2) @binding(1) var<storage, read> moving_materials: array<MovingMaterial>;
@group(2) @binding(2) var<uniform> probe_grid: ProbeGrid;
@group(2) @binding(3) var<storage, read> probes: array<vec4<f32>>;

// Probe `probe`'s irradiance for the basis `b` (irradiance_basis), never negative (order 2
// rings where the light is sharp).
fn probe_irradiance(probe: u32, b: array<f32, 9>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    for (var i = 0u; i < PROBE_COEFFICIENTS; i++) {
        e += probes[probe * PROBE_COEFFICIENTS + i].xyz * b[i];
    }
    return max(e, vec3<f32>(0.0));
}

// Irradiance at point p on a surface facing n: the eight probes around p, trilinear, each
// weighted down by the share of its rays that met a one-sided back (a probe inside a wall or a
// cupboard sees black and would darken what stands beside it); where all eight are inside,
// plain trilinear.
fn irradiance_at(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let top = vec3<f32>(probe_grid.counts - vec3<u32>(1u));
    let g = clamp((p - probe_grid.origin) / probe_grid.spacing, vec3<f32>(0.0), top);
    let base = min(vec3<u32>(floor(g)), probe_grid.counts - vec3<u32>(2u));
    let f = g - vec3<f32>(base);
    let b = irradiance_basis(n);
    var weighted = vec3<f32>(0.0);
    var weights = 0.0;
    var plain = vec3<f32>(0.0);
    for (var c = 0u; c < 8u; c++) {
        let o = vec3<u32>(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
        let t = select(vec3<f32>(1.0) - f, f, o == vec3<u32>(1u));
        let w = t.x * t.y * t.z;
        let at = base + o;
        let probe = at.x + probe_grid.counts.x * (at.y + probe_grid.counts.y * at.z);
        let e = probe_irradiance(probe, b);
        let inside = probes[probe * PROBE_COEFFICIENTS].w;
        let valid = w * clamp(1.0 - 4.0 * inside, 0.0, 1.0);
        weighted += e * valid;
        weights += valid;
        plain += e * w;
    }
    return select(plain, weighted / weights, weights > 1e-4);
}

// The radiance leaving moving triangle `index` (counted from view.moving_first) at `point`
// toward the ray's origin.
fn moving_radiance(index: u32, point: vec3<f32>, ray: vec3<f32>) -> vec3<f32> {
    let tri = ray_triangles[view.moving_first + index];
    let u = dot(tri.u.xyz, point) + tri.u.w;
    let v = dot(tri.v.xyz, point) + tri.v.w;
    let m = moving_triangles[index];
    var n = m.n0.xyz * (1.0 - u - v) + m.n1.xyz * u + m.n2.xyz * v;
    n = select(tri.w.xyz, n, dot(n, n) > 1e-12);
    // the side the ray sees
    n = normalize(select(n, -n, dot(n, ray) > 0.0));
    let material = moving_materials[bitcast<u32>(m.n0.w)];
    return material.albedo.xyz / PI * irradiance_at(point, n) + material.emission.xyz;
}
