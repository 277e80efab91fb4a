// Both eyes onto the two layers of one array swapchain in one multiview pass, driven by
// src/xr/layers.rs: the pass draws each layer once, view_index naming the eye (0 left,
// 1 right). fs_colour without a depth swapchain, fs_colour_depth with, fs_depth for the depth
// alone where xr_colour.wgsl puts the colour on the swapchain.
#include "common/types.wgsl"
#include "common/eye_layer.wgsl"

@group(0) @binding(1) var left_image: texture_2d<f32>;
@group(0) @binding(2) var right_image: texture_2d<f32>;
@group(0) @binding(3) var left_depth: texture_2d<f32>;
@group(0) @binding(4) var right_depth: texture_2d<f32>;

fn radiance(eye: u32, pixel: vec2<u32>) -> vec3<f32> {
    if eye == 0u {
        return textureLoad(left_image, pixel, 0).rgb;
    }
    return textureLoad(right_image, pixel, 0).rgb;
}

fn depth(eye: u32, pixel: vec2<u32>) -> f32 {
    if eye == 0u {
        return textureLoad(left_depth, pixel, 0).x;
    }
    return textureLoad(right_depth, pixel, 0).x;
}

@fragment
fn fs_colour(@builtin(position) position: vec4<f32>, @builtin(view_index) eye: u32) -> @location(0) vec4<f32> {
    return eye_colour(radiance(eye, vec2<u32>(position.xy)));
}

@fragment
fn fs_colour_depth(@builtin(position) position: vec4<f32>, @builtin(view_index) eye: u32) -> ColourDepth {
    let pixel = vec2<u32>(position.xy);
    return ColourDepth(eye_colour(radiance(eye, pixel)), depth(eye, pixel));
}

@fragment
fn fs_depth(@builtin(position) position: vec4<f32>, @builtin(view_index) eye: u32) -> @builtin(frag_depth) f32 {
    return depth(eye, vec2<u32>(position.xy));
}
