// One eye onto its swapchain image (a per-eye swapchain, or one layer of an array swapchain),
// driven by src/xr/layers.rs: fs_colour without a depth swapchain, fs_colour_depth with, fs_depth
// for the depth alone where xr_colour.wgsl puts the colour on the swapchain.
#include "common/types.wgsl"
#include "common/eye_layer.wgsl"

@group(0) @binding(1) var image: texture_2d<f32>;
@group(0) @binding(2) var depth: texture_2d<f32>;

@fragment
fn fs_colour(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return eye_colour(textureLoad(image, vec2<u32>(position.xy), 0).rgb);
}

@fragment
fn fs_colour_depth(@builtin(position) position: vec4<f32>) -> ColourDepth {
    let pixel = vec2<u32>(position.xy);
    return ColourDepth(eye_colour(textureLoad(image, pixel, 0).rgb), textureLoad(depth, pixel, 0).x);
}

@fragment
fn fs_depth(@builtin(position) position: vec4<f32>) -> @builtin(frag_depth) f32 {
    return textureLoad(depth, vec2<u32>(position.xy), 0).x;
}
