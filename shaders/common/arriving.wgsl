// The radiance the converged static light field sends to a point from one direction, as the
// irradiance probes are baked from it (probes.wgsl) and as the shadow atlas takes away what a
// moving object hides of it (shadow_atlas.wgsl): the atlas where a ray lands, and what one mirror
// reflection there shows. The light a moving surface samples itself with shadow rays
// (common/moving_surface.wgsl, direct_samples) is left out: an emitter's own emission where the
// ray meets one (where probe_grid.direct_sampled has 1), the sky where it meets the sky (where it
// has 2). What mirrors show of them stays (no shadow ray samples it). The including file binds
// `probe_grid` and what common/scene_cast.wgsl needs.

// The radiance arriving at `origin` from direction -`ray`, where `s` is what cast_ray (static
// scene only) found along `ray`. w: 1 where the ray met the back of a one-sided face.
fn arriving_from(origin: vec3<f32>, ray: vec3<f32>, s: Surface) -> vec4<f32> {
    let f = faces[s.face];
    let own_emission = select(vec3<f32>(0.0), emitted(f), (probe_grid.direct_sampled & 1u) != 0u && s.seen > 0.0);
    let sky_sampled = (probe_grid.direct_sampled & 2u) != 0u && s.seen == 0.0;
    // (a tile-less specular face's texels hold its specular light too: the reflection below
    // shows it)
    let texel = shown_texel_radiance(f, atlas_radiance(f, s.point));
    var radiance = max(texel - own_emission, vec3<f32>(0.0)) * s.seen + select(s.background, vec3<f32>(0.0), sky_sampled);
    let mirror = mirror_reflectance(material_of(f)) * s.seen;
    if max(mirror.x, max(mirror.y, mirror.z)) > 0.0 {
        let reflected = mirror_direction(ray, f.normal);
        let r = cast_ray(s.point + f.normal * 1e-5, reflected, false);
        radiance += mirror * (atlas_radiance(faces[r.face], r.point) * r.seen + r.background);
    }
    // a one-sided back: black, with a point (the sky's stand-in point is the origin)
    let back = s.seen == 0.0 && all(s.background == vec3<f32>(0.0)) && any(s.point != origin);
    return vec4<f32>(radiance, select(0.0, 1.0, back));
}
