// What every pass that puts a linear image on a colour target shares (present.wgsl for windows,
// common/eye_layer.wgsl for the headset's swapchains): one triangle over the viewport.

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // one triangle covering the viewport
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}
