// One output of a wall (the whole wall, or one of its projectors), driven by
// src/display/post.rs: for every output pixel, bilinear interpolation in the warp grid gives
// the position in the wall image it shows, a bilinear fetch of the rendered wall image (linear
// radiance) gives its colour, the tracked wand's ray is drawn over it, and the blend mask
// attenuates it. Every pixel does the same work: constant cost per output.

struct WarpParams {
    // the wall's (and eye's) inverse view-projection, light field's normalised space
    inv_view_proj: mat4x4<f32>,
    // xyz: the eye; w: the eye ray's length
    eye: vec4<f32>,
    // xyz: where the wand is; w: the ray's length (0: no wand)
    wand_origin: vec4<f32>,
    // xyz: where it points (unit); w: the ray's radius
    wand_direction: vec4<f32>,
    // rgb: the ray's colour (linear); a: its least radius per unit of distance from the eye
    wand_colour: vec4<f32>,
    source_size: vec2<u32>,
    output_size: vec2<u32>,
    // columns, rows
    grid_size: vec2<u32>,
    // 1: multiply by the mask
    use_mask: u32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> params: WarpParams;
@group(0) @binding(1) var source: texture_2d<f32>;
@group(0) @binding(2) var<storage, read> grid: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read> mask: array<f32>;
@group(0) @binding(4) var output: texture_storage_2d<rgba32float, write>;

// The wall image at `uv` (0..1 from the top-left edge), bilinear between texel centres, with
// the sub-texel position rounded to 1/256 as texture units do (so the identity is exact).
fn fetch(uv: vec2<f32>) -> vec4<f32> {
    let size = vec2<f32>(params.source_size);
    let p = round((uv * size - 0.5) * 256.0) / 256.0;
    let i = floor(p);
    let f = p - i;
    let last = vec2<i32>(params.source_size) - 1;
    let i0 = clamp(vec2<i32>(i), vec2<i32>(0), last);
    let i1 = clamp(vec2<i32>(i) + 1, vec2<i32>(0), last);
    let a = textureLoad(source, vec2<i32>(i0.x, i0.y), 0);
    let b = textureLoad(source, vec2<i32>(i1.x, i0.y), 0);
    let c = textureLoad(source, vec2<i32>(i0.x, i1.y), 0);
    let d = textureLoad(source, vec2<i32>(i1.x, i1.y), 0);
    let inside = all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
    return select(vec4<f32>(0.0, 0.0, 0.0, 1.0), mix(mix(a, b, f.x), mix(c, d, f.x), f.y), inside);
}

// Closest approach of the segments p1 + s d1 and p2 + t d2 (s, t in 0..1): (distance, s).
// Ericson, Real-Time Collision Detection, 5.1.9; selects rather than branches.
fn segment_distance(p1: vec3<f32>, d1: vec3<f32>, p2: vec3<f32>, d2: vec3<f32>) -> vec2<f32> {
    let r = p1 - p2;
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let c = dot(d1, r);
    let b = dot(d1, d2);
    let denom = a * e - b * b;
    var s = select(0.0, clamp((b * f - c * e) / denom, 0.0, 1.0), denom > 1e-12 * a * e);
    var t = (b * s + f) / e;
    let below = t < 0.0;
    let above = t > 1.0;
    s = select(s, clamp(-c / a, 0.0, 1.0), below);
    s = select(s, clamp((b - c) / a, 0.0, 1.0), above);
    t = clamp(t, 0.0, 1.0);
    return vec2<f32>(length(p1 + d1 * s - (p2 + d2 * t)), s);
}

// 1 where the eye ray through wall position `uv` passes within the wand ray's radius of it.
fn wand_cover(uv: vec2<f32>) -> f32 {
    let ndc = vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    let far = params.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let eye = params.eye.xyz;
    let direction = normalize(far.xyz / far.w - eye) * params.eye.w;
    let wand = params.wand_direction.xyz * max(params.wand_origin.w, 1e-6);
    let closest = segment_distance(eye, direction, params.wand_origin.xyz, wand);
    let radius = max(params.wand_direction.w, params.wand_colour.a * closest.y * params.eye.w);
    return select(0.0, 1.0, closest.x <= radius && params.wand_origin.w > 0.0);
}

@compute @workgroup_size(8, 8)
fn warp(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.output_size.x || id.y >= params.output_size.y {
        return;
    }
    let t = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(params.output_size);
    let cells = params.grid_size - 1u;
    let g = t * vec2<f32>(cells);
    let gi = min(vec2<u32>(max(floor(g), vec2<f32>(0.0))), cells - 1u);
    let gf = g - vec2<f32>(gi);
    let row = params.grid_size.x;
    let p00 = grid[gi.y * row + gi.x];
    let p10 = grid[gi.y * row + gi.x + 1u];
    let p01 = grid[(gi.y + 1u) * row + gi.x];
    let p11 = grid[(gi.y + 1u) * row + gi.x + 1u];
    let uv = mix(mix(p00, p10, gf.x), mix(p01, p11, gf.x), gf.y);
    var colour = fetch(uv);
    let ray = wand_cover(uv);
    colour = vec4<f32>(mix(colour.rgb, params.wand_colour.rgb, ray), colour.a);
    let m = select(1.0, mask[min(id.y * params.output_size.x + id.x, arrayLength(&mask) - 1u)], params.use_mask != 0u);
    textureStore(output, vec2<i32>(id.xy), vec4<f32>(colour.rgb * m, colour.a));
}
