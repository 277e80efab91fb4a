// An eye's linear image (and depth) put pixel for pixel on the runtime's swapchain images by a
// full-screen fragment pass: the eye images are the swapchain's size. The colour as
// common/eye_colour.wgsl makes it; the depth is the renderer's clip depth (render.wgsl), written as
// the fragment's depth into the depth swapchain. Included by xr_eye.wgsl (one eye per pass) and
// xr_multiview.wgsl (both eyes in one pass).

#include "common/eye_colour.wgsl"
#include "common/fullscreen.wgsl"

struct ColourDepth {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}
