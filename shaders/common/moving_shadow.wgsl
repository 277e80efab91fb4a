// The light the moving objects take from the static surfaces the views see (the light field
// holds it; render.wgsl's pair_shown subtracts it), for render.wgsl only: read from the
// shadow atlas that shadow_atlas.wgsl fills once per frame for every view (src/render/shadow_atlas.rs),
// or per pixel with shadow rays (`[object_lighting] shadows = "per_pixel"`). Needs
// common/moving_surface.wgsl (direct_samples) and its group.

// GpuView::moving_flags: the shadows come from the shadow atlas (gpu::types::MOVING_SHADOW_ATLAS)
const MOVING_SHADOW_ATLAS: u32 = 4u;

// the shadow atlas: per face its first texel (NO_FACE: no shadow this frame), and per texel the
// irradiance the moving objects take (rgb), texels of a face row by row as in its chart
@group(2) @binding(8) var<storage, read> shadow_slots: array<u32>;
@group(2) @binding(9) var<storage, read> shadow_texels: array<vec4<f32>>;

// The light the moving objects take away from point p of static face `face`, as radiance
// leaving p: the face's albedo / pi times the irradiance they block, bilinear in the shadow atlas
// over the face's texels (the light field's own lookup, atlas_taps, in the face's chart: the
// direct light, and near the objects the indirect light they block less what they send back),
// or per pixel over probe_grid.shadow_samples shadow rays to the emitters and
// probe_grid.sky_shadow_samples to the sky (direct_samples: the direct light only). A ray counts
// where a moving object is in the way and the scene is not (the light field never had what the
// scene blocks).
fn moving_shadow(face: u32, p: vec3<f32>, seed: u32) -> vec3<f32> {
    let f = faces[face];
    let albedo = diffuse_reflectance(material_of(f));
    if view.moving_root == NO_NODE || max(albedo.x, max(albedo.y, albedo.z)) <= 0.0 {
        return vec3<f32>(0.0);
    }
    if (view.moving_flags & MOVING_SHADOW_ATLAS) != 0u {
        let slot = shadow_slots[face];
        if slot == NO_FACE {
            return vec3<f32>(0.0);
        }
        let chart = shadow_chart(f);
        let taps = atlas_taps(chart, p, chart.atlas_w);
        let blocked = shadow_texels[slot + taps.index.x].xyz * taps.weight.x + shadow_texels[slot + taps.index.y].xyz * taps.weight.y + shadow_texels[slot + taps.index.z].xyz * taps.weight.z + shadow_texels[slot + taps.index.w].xyz * taps.weight.w;
        return albedo / PI * blocked;
    }
    if SAMPLED_DIRECT == 0u {
        return vec3<f32>(0.0);
    }
    let counts = vec2<u32>(probe_grid.shadow_samples, probe_grid.sky_shadow_samples);
    return albedo / PI * direct_samples(p + f.normal * 1e-5, f.normal, seed, true, counts);
}
