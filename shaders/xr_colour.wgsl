// Each eye's colour for its swapchain image by a compute pass, driven by src/xr/colour_pass.rs:
// the eye's linear image as common/eye_colour.wgsl makes it (sRGB-encoded here: the pass writes
// 8-bit linear storage), into an image of the swapchain's size that a copy then puts on the
// swapchain image, whose sRGB format takes the encoded bytes as they are. On GPUs with few
// graphics units (an H200's full-screen fragment pass over both 2064x2208 eyes took 1.4 ms) a
// compute pass and a copy cost a fraction of that.
#include "common/types.wgsl"
#include "common/eye_colour.wgsl"

@group(0) @binding(1) var image: texture_2d<f32>;
@group(0) @binding(2) var colour: texture_storage_2d<rgba8unorm, write>;

@compute @workgroup_size(8, 8)
fn cs_colour(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= textureDimensions(colour)) {
        return;
    }
    textureStore(colour, id.xy, eye_colour(textureLoad(image, id.xy, 0).rgb));
}
