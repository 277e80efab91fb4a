// The light field as the stages that read it see it: the one declaration of its bindings and its
// accessors. src/lightfield/bindings.rs builds the bind group; src/lightfield/tiles.rs plans the
// pages; src/lightfield/atlas_lookup.rs and src/propagate/cpu/specular.rs are the CPU twins of
// the lookups. A stage includes it after common/types.wgsl, common/atlas.wgsl and
// common/directions.wgsl, and sets `LIGHT_FIELD_GROUP`, the bind group it binds it at (the
// layout is reflected from the stage, as every group is).
//
// The renderer (render.wgsl) binds the converged light field; specular transport
// (specular.wgsl) the unshot state of the one being propagated, which has the same layout.
// A diffuse-only light field has no tiles: their bindings hold placeholders, never read.

@group(LIGHT_FIELD_GROUP) @binding(0) var<uniform> field: Field;
// the radiance atlas, in pages of field.texel_page_cells texels (rgb; w: the texel's
// visibility mark, propagate's texel_validity)
@group(LIGHT_FIELD_GROUP) @binding(1) var<storage, read> radiance_0: array<vec4<f32>>;
@group(LIGHT_FIELD_GROUP) @binding(2) var<storage, read> radiance_1: array<vec4<f32>>;
@group(LIGHT_FIELD_GROUP) @binding(3) var<storage, read> radiance_2: array<vec4<f32>>;
@group(LIGHT_FIELD_GROUP) @binding(4) var<storage, read> radiance_3: array<vec4<f32>>;
// the fixed directions, whose grids the tiles live in, and the geodesic tables that find the
// three around any unit vector (common/directions.wgsl: lookup_direction)
@group(LIGHT_FIELD_GROUP) @binding(5) var<storage, read> field_directions: array<Direction>;
@group(LIGHT_FIELD_GROUP) @binding(6) var<storage, read> geodesic_points: array<vec4<f32>>;
@group(LIGHT_FIELD_GROUP) @binding(7) var<storage, read> geodesic_index: array<u32>;
// the sparse mirror tiles: per direction and non-diffuse face [x0 | y0 << 16, w | h << 16,
// first, 0]; the tile slot of each rectangle's tiles (or NO_FACE); the tile radiance in pages
// of field.tile_page_cells cells (one array may not exceed one storage binding: 128 MiB on the
// software adapter)
@group(LIGHT_FIELD_GROUP) @binding(8) var<storage, read> tile_rects: array<vec4<u32>>;
@group(LIGHT_FIELD_GROUP) @binding(9) var<storage, read> tile_index: array<u32>;
@group(LIGHT_FIELD_GROUP) @binding(10) var<storage, read> tile_radiance_0: array<vec4<f32>>;
@group(LIGHT_FIELD_GROUP) @binding(11) var<storage, read> tile_radiance_1: array<vec4<f32>>;
@group(LIGHT_FIELD_GROUP) @binding(12) var<storage, read> tile_radiance_2: array<vec4<f32>>;
@group(LIGHT_FIELD_GROUP) @binding(13) var<storage, read> tile_radiance_3: array<vec4<f32>>;
// the texture detail (src/lightfield/textures.rs), read only by a renderer whose light field has
// diffuse textures: per atlas texel the texture factor propagation used (rgb as half floats);
// per face (diffuse texture, emission texture, -, -); the textures (common/textures.wgsl)
@group(LIGHT_FIELD_GROUP) @binding(14) var<storage, read> texel_albedo: array<vec2<u32>>;
@group(LIGHT_FIELD_GROUP) @binding(15) var<storage, read> face_textures: array<vec4<u32>>;
@group(LIGHT_FIELD_GROUP) @binding(16) var<storage, read> texture_info: array<vec4<u32>>;
@group(LIGHT_FIELD_GROUP) @binding(17) var<storage, read> texture_texels: array<vec4<f32>>;

// Texel `texel` of the atlas.
fn atlas_texel(texel: u32) -> vec4<f32> {
    let i = texel % field.texel_page_cells;
    switch texel / field.texel_page_cells {
        case 0u: { return radiance_0[i]; }
        case 1u: { return radiance_1[i]; }
        case 2u: { return radiance_2[i]; }
        default: { return radiance_3[i]; }
    }
}

// The radiance leaving point p of face f, bilinear in the atlas over the texels marked visible
// (w = 1, propagate's texel_validity): a texel inside closed geometry (under a box standing on
// the floor) drops out and the others take its weight, so no dark seam runs along the foot of
// the box. A light field without marks (w = 0 everywhere: the paper's settings, older files)
// interpolates all four.
fn atlas_radiance(f: Face, p: vec3<f32>) -> vec3<f32> {
    return atlas_radiance_at(f, p, false, vec3<f32>(1.0));
}

// The same with the material at the point (texture detail, src/lightfield/textures.rs): each
// tap's radiance divided by the texture factor its texel was propagated with, times `albedo`,
// the texture at p. That is the texel's irradiance times the material where the ray lands, so a
// texture finer than the atlas keeps its detail and the texel keeps its mean. Only for a light
// field with texture detail, on a face with a diffuse texture that does not emit.
fn atlas_radiance_detailed(f: Face, p: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    return atlas_radiance_at(f, p, true, albedo);
}

// The half float in the low 16 bits of `h` (unpack2x16float needs a device capability that
// not every adapter has; infinities and NaN do not occur in texture factors).
fn half_float(h: u32) -> f32 {
    let sign = (h & 0x8000u) << 16u;
    let exponent = (h >> 10u) & 31u;
    let mantissa = h & 1023u;
    let subnormal = f32(mantissa) * 5.9604645e-8;
    let normal = bitcast<f32>(sign | ((exponent + 112u) << 23u) | (mantissa << 13u));
    return select(normal, select(subnormal, -subnormal, sign != 0u), exponent == 0u);
}

// A channel the texel's factor leaves (almost) black says nothing of the irradiance: it keeps
// its radiance.
fn with_albedo(radiance: vec3<f32>, texel: u32, albedo: vec3<f32>) -> vec3<f32> {
    let packed = texel_albedo[texel];
    let factor = vec3<f32>(half_float(packed.x), half_float(packed.x >> 16u), half_float(packed.y));
    return select(radiance, radiance / factor * albedo, factor > vec3<f32>(1e-3));
}

fn atlas_radiance_at(f: Face, p: vec3<f32>, detailed: bool, albedo: vec3<f32>) -> vec3<f32> {
    let taps = atlas_taps(f, p, field.atlas_width);
    let r0 = atlas_texel(taps.index.x);
    let r1 = atlas_texel(taps.index.y);
    let r2 = atlas_texel(taps.index.z);
    let r3 = atlas_texel(taps.index.w);
    let marked = taps.weight * vec4<f32>(r0.w, r1.w, r2.w, r3.w);
    let sum = marked.x + marked.y + marked.z + marked.w;
    let w = select(taps.weight, marked / sum, sum > 1e-6);
    if detailed {
        return with_albedo(r0.xyz, taps.index.x, albedo) * w.x + with_albedo(r1.xyz, taps.index.y, albedo) * w.y + with_albedo(r2.xyz, taps.index.z, albedo) * w.z + with_albedo(r3.xyz, taps.index.w, albedo) * w.w;
    }
    return r0.xyz * w.x + r1.xyz * w.y + r2.xyz * w.z + r3.xyz * w.w;
}

// Normal maps (field.normal_records > 0): face `face`'s normal texture (NO_FACE for none) and
// its scale's bits, stored in texel_albedo after the texel factors (SurfaceDetail::detail_words).
fn normal_record(face: u32) -> vec2<u32> {
    if field.normal_records == 0u {
        return vec2<u32>(NO_FACE, 0u);
    }
    return texel_albedo[field.normal_records + face];
}

// Specular textures (field.specular_records > 0): face `face`'s specular texture (NO_FACE for
// none; rgb a multiple of its material's mirror colour, w the GGX alpha), stored in
// texel_albedo after the normal maps (SurfaceDetail::detail_words).
fn specular_record(face: u32) -> u32 {
    if field.specular_records == 0u {
        return NO_FACE;
    }
    return texel_albedo[field.specular_records + face].x;
}

// The light direction and the rest's moment of the texels around point p of face f
// (common/normal_map.wgsl, tilted_irradiance), bilinear: two records per texel.
fn light_direction(f: Face, p: vec3<f32>) -> array<vec3<f32>, 2> {
    let taps = atlas_taps(f, p, field.atlas_width);
    var out = array<vec3<f32>, 2>(vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = 0u; k < 4u; k++) {
        for (var j = 0u; j < 2u; j++) {
            let packed = texel_albedo[field.normal_texels + 2u * taps.index[k] + j];
            out[j] += vec3<f32>(half_float(packed.x), half_float(packed.x >> 16u), half_float(packed.y)) * taps.weight[k];
        }
    }
    return out;
}

// Tile cell `cell`, counted over all pages.
fn tile_load(cell: u32) -> vec4<f32> {
    let page = cell / field.tile_page_cells;
    let i = cell % field.tile_page_cells;
    switch page {
        case 0u: { return tile_radiance_0[i]; }
        case 1u: { return tile_radiance_1[i]; }
        case 2u: { return tile_radiance_2[i]; }
        default: { return tile_radiance_3[i]; }
    }
}

// Radiance of tile cell (col, row) of non-diffuse face `slot` in direction `dir_index`; w is 1
// where the cell is stored, 0 where it is not. With `fixed_work` (the renderer) every call
// makes the same three reads whatever it finds: a cell outside the face's rectangle wraps into
// it and a tile that is not stored reads a neighbour of where it would be, and the result is
// then dropped, so that a view of diffuse walls costs what a view of mirrors does.
fn tile_cell(dir_index: u32, slot: u32, col: i32, row: i32, fixed_work: bool) -> vec4<f32> {
    let tile_size = field.tile_size;
    let rect = tile_rects[dir_index * field.tile_face_count + slot];
    let m = i32(tile_size);
    let tx = col / m - i32(rect.x & 0xffffu);
    let ty = row / m - i32(rect.x >> 16u);
    let tw = i32(rect.y & 0xffffu);
    let th = i32(rect.y >> 16u);
    let inside = col >= 0 && row >= 0 && tx >= 0 && ty >= 0 && tx < tw && ty < th;
    if !inside && !fixed_work {
        return vec4<f32>(0.0);
    }
    let wx = ((tx % max(tw, 1)) + max(tw, 1)) % max(tw, 1);
    let wy = ((ty % max(th, 1)) + max(th, 1)) % max(th, 1);
    let at = rect.z + u32(wy * tw + wx);
    let tile = tile_index[at];
    if tile == NO_FACE && !fixed_work {
        return vec4<f32>(0.0);
    }
    let tiles = field.tile_cell_count / (tile_size * tile_size);
    let read_tile = select(tile, at % max(tiles, 1u), tile == NO_FACE);
    let local = ((row % m) + m) % m * m + ((col % m) + m) % m;
    let cell = read_tile * tile_size * tile_size + u32(local);
    let stored = inside && tile != NO_FACE;
    return select(vec4<f32>(0.0), vec4<f32>(tile_load(cell).xyz, 1.0), stored);
}

// Bilinear over the four cells around point p in direction d's grid; cells that are not stored
// drop out and the rest are renormalised. w is the total weight found (0: nothing stored).
fn tile_bilinear(dir_index: u32, d: Direction, slot: u32, p: vec3<f32>, fixed_work: bool) -> vec4<f32> {
    let cell_size = field.cell_size;
    let q = vec2<f32>((dot(p, d.u) + 1.0) / cell_size - 0.5, (dot(p, d.v) + 1.0) / cell_size - 0.5);
    let c0 = vec2<i32>(floor(q));
    let f = q - floor(q);
    let a = tile_cell(dir_index, slot, c0.x, c0.y, fixed_work);
    let b = tile_cell(dir_index, slot, c0.x + 1, c0.y, fixed_work);
    let c = tile_cell(dir_index, slot, c0.x, c0.y + 1, fixed_work);
    let e = tile_cell(dir_index, slot, c0.x + 1, c0.y + 1, fixed_work);
    let wa = (1.0 - f.x) * (1.0 - f.y) * a.w;
    let wb = f.x * (1.0 - f.y) * b.w;
    let wc = (1.0 - f.x) * f.y * c.w;
    let we = f.x * f.y * e.w;
    let total = wa + wb + wc + we;
    if total <= 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>((a.xyz * wa + b.xyz * wb + c.xyz * wc + e.xyz * we) / total, total);
}

// The mirror radiance leaving point p of face f (tile slot `slot`) along out_dir: the three
// fixed directions around it, each bilinear in its tiles (fixed work), weighted barycentrically.
fn tile_radiance_leaving(f: Face, slot: u32, p: vec3<f32>, out_dir: vec3<f32>) -> vec3<f32> {
    let taps = lookup_direction(out_dir, field.geodesic_frequency);
    var sum = vec3<f32>(0.0);
    var found = 0.0;
    for (var k = 0u; k < 3u; k++) {
        let d = field_directions[taps.index[k]];
        // tiles hold the radiance leaving the front; a tap behind the face drops out
        let front = select(0.0, 1.0, dot(d.w * taps.sign[k], f.normal) > 0.0);
        let v = tile_bilinear(taps.index[k], d, slot, p, true);
        let w = taps.weight[k] * min(v.w, 1.0) * front;
        sum += v.xyz * w;
        found += w;
    }
    return select(vec3<f32>(0.0), sum / found, found > 0.0);
}
