// Shared by the transport stages (propagate.wgsl, specular.wgsl, direct.wgsl): scene and
// visibility bindings, the scene's BVH, the upstream search, and the gather of one diffuse
// texel. The including file defines `sender_specular(sender, point, dir_index, travel)`: zero
// for diffuse-only scenes, a tile lookup where mirrors exist; and `texel_rim_rays()`: whether a
// texel's gather casts rim rays (find_upstream). CPU twin: src/propagate/cpu/.

@group(0) @binding(0) var<uniform> grid: GridParams;
@group(0) @binding(1) var<storage, read> directions: array<Direction>;
@group(0) @binding(2) var<storage, read> faces: array<Face>;
// the material table the faces index (common/bsdf.wgsl, which the including stage includes)
@group(0) @binding(12) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> cell_offset: array<u32>;
@group(0) @binding(4) var<storage, read> cell_count: array<u32>;
@group(0) @binding(5) var<storage, read> layers: array<vec2<u32>>;
// Texel arrays come in pages of grid.texel_page_cells texels (one storage binding may hold
// less than a big atlas: 128 MiB on the software adapter); pages a scene does not have are
// bound to page 0. (sample point on the face, bitcast face id or NO_FACE)
@group(0) @binding(6) var<storage, read> texel_points_0: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> texel_points_1: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> texel_points_2: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> texel_points_3: array<vec4<f32>>;
// the scene's triangles in BVH order and the BVH (src/bvh.rs): the rim rays below, and
// direct.wgsl's shadow rays
@group(0) @binding(10) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(11) var<storage, read> nodes: array<BvhNode>;
// unshot radiosity (rgb)
@group(1) @binding(0) var<storage, read> unshot_0: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> unshot_1: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> unshot_2: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> unshot_3: array<vec4<f32>>;
// next unshot radiosity (rgb) and, in w, the sky's share of the irradiance (r+g+b): the page
// this dispatch writes, and which texels it holds
@group(1) @binding(4) var<storage, read_write> next: array<vec4<f32>>;
@group(1) @binding(5) var<uniform> texel_page: PageRange;
// with GRID_FLAG_BATCHED: the quadrature weights used so far, per texel then per tile cell
@group(1) @binding(6) var<storage, read_write> weight_sums: array<f32>;
// the power balance's per-texel terms of the page this dispatch writes (gather_texel):
// irradiance r+g+b, the mirror part's share of it (rho_s . E), and the shares of this texel's
// own unshot radiosity (r+g+b) that leave toward the sky and onto the back of a one-sided face
@group(1) @binding(7) var<storage, read_write> balance: array<vec4<f32>>;

#include "common/bvh.wgsl"

fn texel_point(texel: u32) -> vec4<f32> {
    let i = texel % grid.texel_page_cells;
    switch texel / grid.texel_page_cells {
        case 0u: { return texel_points_0[i]; }
        case 1u: { return texel_points_1[i]; }
        case 2u: { return texel_points_2[i]; }
        default: { return texel_points_3[i]; }
    }
}

fn unshot_load(texel: u32) -> vec4<f32> {
    let i = texel % grid.texel_page_cells;
    switch texel / grid.texel_page_cells {
        case 0u: { return unshot_0[i]; }
        case 1u: { return unshot_1[i]; }
        case 2u: { return unshot_2[i]; }
        default: { return unshot_3[i]; }
    }
}

fn layer_depth(l: vec2<u32>) -> f32 {
    return bitcast<f32>(l.y);
}

// Index of `face` in the list of `cell`, or -1.
fn find_in_cell(cell: u32, face: u32) -> i32 {
    let start = cell_offset[cell];
    let n = cell_count[cell];
    for (var k = 0u; k < n; k++) {
        if layers[start + k].x == face {
            return i32(k);
        }
    }
    return -1;
}

// The sender just upstream of entry k in the list of `cell`, skipping layers coplanar with the
// receiver (duplicated faces, the other side of a two-sided surface).
fn upstream_of_entry(cell: u32, k: u32, forward: bool) -> u32 {
    let start = cell_offset[cell];
    let n = cell_count[cell];
    let own_depth = layer_depth(layers[start + k]);
    if forward {
        var j = i32(k) - 1;
        while j >= 0 {
            let l = layers[start + u32(j)];
            if abs(layer_depth(l) - own_depth) > grid.depth_epsilon {
                return l.x;
            }
            j -= 1;
        }
    } else {
        var j = k + 1u;
        while j < n {
            let l = layers[start + j];
            if abs(layer_depth(l) - own_depth) > grid.depth_epsilon {
                return l.x;
            }
            j += 1u;
        }
    }
    return NO_FACE;
}

// The sender upstream of depth `depth` in the list of `cell`, for a receiver that the cell's
// centre line misses (texels at a face's rim, faces smaller than a cell).
fn upstream_of_depth(cell: u32, depth: f32, forward: bool) -> u32 {
    let start = cell_offset[cell];
    let n = cell_count[cell];
    var found = NO_FACE;
    for (var k = 0u; k < n; k++) {
        let l = layers[start + k];
        let ld = layer_depth(l);
        if forward {
            if ld < depth - grid.depth_epsilon {
                found = l.x;
            }
        } else if ld > depth + grid.depth_epsilon {
            return l.x;
        }
    }
    return found;
}

fn clamp_cell(c: vec2<i32>) -> vec2<u32> {
    let n = i32(grid.resolution) - 1;
    return vec2<u32>(clamp(c, vec2<i32>(0), vec2<i32>(n)));
}

// The side of a two-sided surface that faces the light's way of travel. Both sides lie in the
// same cells at (nearly) the same depth, and which of them a list puts first is an accident of
// depth rounding and face ids: taking the list's first would send the back's nothing along half
// the directions. A one-sided face (no twin) is returned as it is.
fn facing_side(sender: u32, travel: vec3<f32>) -> u32 {
    // GRID_FLAG_LIST_ORDER_SIDES (tests only) takes the list's first side, as before the fix
    if sender >= UNRESOLVED || (grid.flags & GRID_FLAG_LIST_ORDER_SIDES) != 0u {
        return sender;
    }
    let s = faces[sender];
    if s.twin != NO_FACE && dot(s.normal, travel) <= 1e-6 {
        return s.twin;
    }
    return sender;
}

// The rim fallback of a texel's gather: what a ray from x against the light's way meets
// first (the scene's BVH, x's own face and its twin skipped), on its side facing the light's
// way; the sky (NO_FACE) where it meets nothing. The cell lists cannot say this at a rim: x's
// own line misses its face there, and a neighbouring line may pass in front of, behind or
// through what x sees (a two-sided chair frame, a thin leg), which is why the lists' fallback
// below must drop directions it cannot tell.
// Triangles are not grown here (shadow rays grow them, so that none slips through the crack
// between two): a rim ray starts on an object's boundary, where a grown neighbour would be met
// from behind, and a closed two-sided object would then show its inside.
fn rim_ray_sender(x: vec3<f32>, travel: vec3<f32>, face: u32) -> u32 {
    let hit = trace_skipping(x, -travel, 4.0, false, face, 0.0);
    if hit.tri == NO_FACE {
        return NO_FACE;
    }
    return facing_side(triangles[hit.tri].face, travel);
}

// The lists' rim fallback (mirror tile cells): the face met, if it faces the light's way, else
// UNRESOLVED. Of a two-sided surface the original face decides (its generated back, the twin
// with the higher id, lies in the same place): when the original faces away, the lists cannot
// tell whether x looks at an open surface's back or into closed geometry, and the direction is
// dropped as it is for a one-sided face, so a closed two-sided object gathers exactly as a
// one-sided one.
fn rim_sender(found: u32, travel: vec3<f32>) -> u32 {
    if found >= UNRESOLVED {
        return UNRESOLVED;
    }
    var original = found;
    if faces[found].twin < found {
        original = faces[found].twin;
    }
    if dot(faces[original].normal, travel) > 1e-6 {
        return original;
    }
    return UNRESOLVED;
}

// Which face sends light along direction d (travelling +w when `forward`) to point x on `face`.
// `rim_rays`: where no nearby cell's line meets the face, cast a ray (texels); otherwise fall
// back on the lists (mirror tile cells, whose rim cells exist only for bilinear lookups).
fn find_upstream(dir_index: u32, d: Direction, x: vec3<f32>, face: u32, forward: bool, rim_rays: bool) -> u32 {
    let travel = select(-d.w, d.w, forward);
    let inv_h = 1.0 / grid.cell_size;
    let q = vec2<f32>((dot(x, d.u) + 1.0) * inv_h - 0.5, (dot(x, d.v) + 1.0) * inv_h - 0.5);
    let base = dir_index * grid.resolution * grid.resolution;
    let nearest = vec2<i32>(round(q));
    // the nearest cell centre first, then its 3x3 neighbourhood
    let c0 = clamp_cell(nearest);
    let cell0 = base + c0.y * grid.resolution + c0.x;
    let k0 = find_in_cell(cell0, face);
    if k0 >= 0 {
        return facing_side(upstream_of_entry(cell0, u32(k0), forward), travel);
    }
    for (var i = 0; i < 9; i++) {
        let c = clamp_cell(nearest + vec2<i32>(i % 3 - 1, i / 3 - 1));
        if all(c == c0) {
            continue;
        }
        let cell = base + c.y * grid.resolution + c.x;
        let k = find_in_cell(cell, face);
        if k >= 0 {
            return facing_side(upstream_of_entry(cell, u32(k), forward), travel);
        }
    }
    // The face has no cell centre nearby (a grazing direction at a rim or corner, or a face
    // smaller than a cell). With rim rays, cast one. Otherwise take the first layer upstream of
    // x's depth in the nearest cell whose line meets one. If it does not face the light's way,
    // the lists cannot tell what x sees along this direction: UNRESOLVED drops the direction
    // from x's quadrature rather than counting it black (a leak that high albedos would
    // amplify a thousandfold). Only where no nearby line meets anything is x in the open: the
    // sky.
    if rim_rays {
        return rim_ray_sender(x, travel, face);
    }
    let depth = dot(x, d.w);
    for (var i = -1; i < 9; i++) {
        var c = c0;
        if i >= 0 {
            c = clamp_cell(nearest + vec2<i32>(i % 3 - 1, i / 3 - 1));
        }
        let cell = base + c.y * grid.resolution + c.x;
        if cell_count[cell] == 0u {
            continue;
        }
        return rim_sender(upstream_of_depth(cell, depth, forward), travel);
    }
    return NO_FACE;
}

// Unshot radiance arriving at x along travel direction `travel` from `sender`.
fn sender_radiance(sender: u32, x: vec3<f32>, dir_index: u32, travel: vec3<f32>) -> vec3<f32> {
    let s = faces[sender];
    let facing = dot(s.normal, travel);
    // the back of a one-sided face absorbs and sends nothing
    if facing <= 1e-6 {
        return vec3<f32>(0.0);
    }
    // where this texel's own line meets the sender's plane
    let t = (dot(s.normal, x) - s.plane_offset) / facing;
    let xs = x - travel * t;
    let taps = atlas_taps(s, xs, grid.atlas_width);
    let b = unshot_load(taps.index.x).xyz * taps.weight.x + unshot_load(taps.index.y).xyz * taps.weight.y
        + unshot_load(taps.index.z).xyz * taps.weight.z + unshot_load(taps.index.w).xyz * taps.weight.w;
    return b / PI + sender_specular(s, xs, dir_index, travel);
}

// Next unshot radiosity of one texel (rgb) and the sky's share of its irradiance (w); with
// GRID_FLAG_NO_MIRROR_SENDERS (never in the sky's iteration) senders with a mirror part are left
// out and w is instead pi x their share of the quadrature weight. The texel's power-balance terms
// go to `balance` (see store_balance).
fn gather_texel(texel: u32) -> vec4<f32> {
    let point = texel_point(texel);
    let face_id = bitcast<u32>(point.w);
    if face_id == NO_FACE {
        store_balance(texel, vec4<f32>(0.0));
        return vec4<f32>(0.0);
    }
    let f = faces[face_id];
    let m = material_of(f);
    let x = point.xyz;
    let sky_on = (grid.flags & 1u) != 0u;
    var irradiance = vec3<f32>(0.0);
    var sky_irradiance = vec3<f32>(0.0);
    // the cosine quadrature's weights over the directions used: normalising by their sum makes
    // the quadrature exact for uniform light (pi / sum over all directions when none is dropped)
    var weight_sum = 0.0;
    // with GRID_FLAG_NO_MIRROR_SENDERS: the weight of the directions whose sender has a mirror
    // part (left out, both parts), which direct.wgsl's mirror_light trades for the mirrors'
    // exact solid angle
    let mirror_senders_out = (grid.flags & GRID_FLAG_NO_MIRROR_SENDERS) != 0u;
    var mirror_weight = 0.0;
    // the power balance: by reciprocity, the weight of the directions that see the sky (or the
    // back of a one-sided face) is the share of this texel's own diffuse light that goes there
    var open_weight = 0.0;
    var back_weight = 0.0;
    // what the mirror senders left out would deliver: the balance's irradiance on faces whose
    // next unshot radiosity cannot tell it (a channel of albedo 0: mirrors, black faces)
    let blind = !all(propagated_diffuse(f, m) > vec3<f32>(0.0));
    var mirrored_in = vec3<f32>(0.0);
    for (var i = 0u; i < grid.direction_count; i++) {
        let d = directions[i];
        let cos_w = dot(f.normal, d.w);
        if abs(cos_w) < 1e-6 {
            continue;
        }
        // light reaches the front when it travels against the normal
        let forward = cos_w < 0.0;
        let travel = select(-d.w, d.w, forward);
        let weight = abs(cos_w) * d.solid_angle;
        let sender = find_upstream(i, d, x, face_id, forward, texel_rim_rays());
        if sender == UNRESOLVED {
            continue;
        }
        weight_sum += weight;
        if sender == NO_FACE {
            open_weight += weight;
            if sky_on {
                sky_irradiance += grid.sky * weight;
            }
        } else {
            let s = faces[sender];
            // the back of a two-sided surface stands for its twin's front, which receives
            if dot(s.normal, travel) <= 1e-6 && s.twin == NO_FACE {
                back_weight += weight;
            }
            if mirror_senders_out {
                // an ideal mirror's (a glossy lobe's tiles are read as they are)
                if s.tile_slot != NO_FACE && !is_glossy(material_of(s)) && dot(s.normal, travel) > 1e-6 {
                    mirror_weight += weight;
                    if blind {
                        mirrored_in += sender_radiance(sender, x, grid.first_direction + i, travel) * weight;
                    }
                    continue;
                }
            }
            irradiance += sender_radiance(sender, x, grid.first_direction + i, travel) * weight;
        }
    }

    let own = unshot_load(texel).xyz;
    let own_sum = own.x + own.y + own.z;
    let batched = (grid.flags & GRID_FLAG_BATCHED) != 0u;
    // raw sums when batched (normalize.wgsl multiplies by pi / the weights of every batch)
    let norm = select(select(0.0, PI / weight_sum, weight_sum > 0.0), 1.0, batched);
    let e = (irradiance + sky_irradiance) * norm;
    let seen = e + mirrored_in * norm;
    let shares = vec2<f32>(open_weight, back_weight) * (own_sum / PI * norm);
    store_balance(texel, vec4<f32>(seen.x + seen.y + seen.z, dot(propagated_specular(f, m), seen), shares) * grid.direction_weight);
    if batched {
        weight_sums[texel] += weight_sum * grid.direction_weight;
        let sky_raw = select(sky_irradiance.x + sky_irradiance.y + sky_irradiance.z, mirror_weight, mirror_senders_out);
        return vec4<f32>(propagated_diffuse(f, m) * (irradiance + sky_irradiance) * grid.direction_weight, sky_raw * grid.direction_weight);
    }
    let sky_share = select(sky_irradiance.x + sky_irradiance.y + sky_irradiance.z, mirror_weight, mirror_senders_out) * norm;
    return vec4<f32>(propagated_diffuse(f, m) * e * grid.direction_weight, sky_share * grid.direction_weight);
}

// One texel's power-balance terms (per unit area; the balance passes weight them by area),
// written or added as the gather writes `next`: irradiance r+g+b, rho_s . irradiance, and the
// texel's own unshot r+g+b times the cosine-weighted share of its hemisphere that is open to the
// sky, and that meets the back of a one-sided face.
fn store_balance(texel: u32, terms: vec4<f32>) {
    let in_page = texel - texel_page.base;
    if (grid.flags & (GRID_FLAG_ACCUMULATE | GRID_FLAG_BATCHED)) != 0u {
        balance[in_page] += terms;
    } else {
        balance[in_page] = terms;
    }
}

// One texel's gather, written to `next` (added to it for perturbed sets after the first);
// `in_page` counts from the first texel of the page this dispatch writes.
fn gather_and_store(in_page: u32) {
    if in_page >= texel_page.cells {
        return;
    }
    let value = gather_texel(texel_page.base + in_page);
    if (grid.flags & (GRID_FLAG_ACCUMULATE | GRID_FLAG_BATCHED)) != 0u {
        next[in_page] += value;
    } else {
        next[in_page] = value;
    }
}
