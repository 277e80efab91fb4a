// The surface textures as the transport's group 0 binds them (src/propagate/transport.rs), for
// the cut-outs its shadow rays and rim rays pass through (common/coverage.wgsl): included by
// propagate.wgsl and direct.wgsl, which share that group's layout. specular.wgsl has the same
// names from common/light_field.wgsl. Placeholders in a scene without cut-outs.
#include "common/textures.wgsl"

// per face: (diffuse, emission, coverage texture, cutoff bits), src/lightfield/textures.rs
@group(0) @binding(13) var<storage, read> face_textures: array<vec4<u32>>;
// per texture: (first texel, width, height, 0)
@group(0) @binding(14) var<storage, read> texture_info: array<vec4<u32>>;
// linear rgb, coverage in w
@group(0) @binding(15) var<storage, read> texture_texels: array<vec4<f32>>;
