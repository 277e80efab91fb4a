// An eye's linear image (and depth) put pixel for pixel on the runtime's swapchain images: the
// eye images are the swapchain's size. Exposed, clamped and sRGB-encoded unless the swapchain
// encodes itself, as present.wgsl does for windows; the depth is the renderer's clip depth
// (render.wgsl), written as the fragment's depth into the depth swapchain.
// Included by xr_eye.wgsl (one eye per pass) and xr_multiview.wgsl (both eyes in one pass).

@group(0) @binding(0) var<uniform> params: PresentParams;

#include "common/fullscreen.wgsl"

// The swapchain's colour of one pixel of the eye's linear radiance.
fn eye_colour(radiance: vec3<f32>) -> vec4<f32> {
    var c = clamp(radiance * params.exposure, vec3<f32>(0.0), vec3<f32>(1.0));
    if params.encode_srgb != 0u {
        c = encode_srgb(c);
    }
    return vec4<f32>(c, 1.0);
}

struct ColourDepth {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}
