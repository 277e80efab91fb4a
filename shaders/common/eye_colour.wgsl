// An eye's linear radiance as a swapchain's colour: exposed, clamped and sRGB-encoded unless the
// swapchain encodes itself. Included by common/eye_layer.wgsl (the fragment passes) and
// xr_colour.wgsl (the compute pass).
#include "common/srgb.wgsl"

@group(0) @binding(0) var<uniform> params: PresentParams;

fn eye_colour(radiance: vec3<f32>) -> vec4<f32> {
    var c = clamp(radiance * params.exposure, vec3<f32>(0.0), vec3<f32>(1.0));
    if params.encode_srgb != 0u {
        c = encode_srgb(c);
    }
    return vec4<f32>(c, 1.0);
}
