// common/coverage.wgsl's view of the coverage in propagation (visibility.wgsl, propagate.wgsl,
// direct.wgsl): one array, so that the transport's group 0 grows by a single binding
// (lightfield::textures::SurfaceTextures::packed_cutouts writes it): the face count F and the
// texture count T, then per face its coverage texture and cutoff bits, per texture its first
// texel, width and height, then every texel's coverage (f32 bits). The includer binds
// `cutouts: array<u32>` (a placeholder without cut-outs).

fn cutout_of(face: u32) -> vec2<u32> {
    return vec2<u32>(cutouts[2u + 2u * face], cutouts[3u + 2u * face]);
}

fn coverage_info(texture: u32) -> vec4<u32> {
    let at = 2u + 2u * cutouts[0] + 3u * texture;
    return vec4<u32>(cutouts[at], cutouts[at + 1u], cutouts[at + 2u], 0u);
}

fn coverage_texel(index: u32) -> f32 {
    return bitcast<f32>(cutouts[2u + 2u * cutouts[0] + 3u * cutouts[1] + index]);
}
