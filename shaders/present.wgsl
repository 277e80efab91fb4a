// Puts one eye's linear image on a window, driven by src/display/window.rs: the viewport is
// the eye's part of the window (all of it, or a side-by-side / top-bottom half), the image is
// scaled to it (nearest), exposed, clamped and, unless the surface encodes sRGB itself,
// encoded. A status line (tracking gone quiet) is blended over the top-left corner.
#include "common/types.wgsl"

@group(0) @binding(0) var<uniform> params: PresentParams;
@group(0) @binding(1) var image: texture_2d<f32>;
@group(0) @binding(2) var overlay: texture_2d<f32>;

#include "common/fullscreen.wgsl"
#include "common/srgb.wgsl"

@fragment
fn fs_present(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let local = position.xy - params.viewport_origin;
    let size = vec2<f32>(textureDimensions(image));
    let texel = vec2<u32>(clamp(local * size / params.viewport_size, vec2<f32>(0.0), size - 1.0));
    var c = clamp(textureLoad(image, texel, 0).rgb * params.exposure, vec3<f32>(0.0), vec3<f32>(1.0));
    if params.show_overlay != 0u {
        let o = vec2<u32>(local);
        let osize = textureDimensions(overlay);
        if o.x < osize.x && o.y < osize.y {
            let text = textureLoad(overlay, o, 0);
            c = mix(c, text.rgb, text.a);
        }
    }
    if params.encode_srgb != 0u {
        c = encode_srgb(c);
    }
    return vec4<f32>(c, 1.0);
}
