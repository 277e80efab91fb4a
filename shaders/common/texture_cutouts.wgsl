// common/coverage.wgsl's view of the coverage in the surface textures (the renderer through the
// light field's texture detail, the path tracer through its own bindings): the includer binds
// `face_textures` (per face: diffuse, emission, coverage texture, cutoff bits), `texture_info`
// and `texture_texels` (coverage in w).

fn cutout_of(face: u32) -> vec2<u32> {
    return face_textures[face].zw;
}

fn coverage_info(texture: u32) -> vec4<u32> {
    return texture_info[texture];
}

fn coverage_texel(index: u32) -> f32 {
    return texture_texels[index].w;
}
