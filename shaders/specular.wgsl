// Transport for scenes with mirrors, driven by src/propagate/transport.rs. Two entry points
// read the same unshot state and write the next one:
// - gather_mixed: diffuse texels, as propagate.wgsl, plus the mirror part of each sender
//   (its tile in the sender's direction, bilinear over cells);
// - gather_tiles: every stored mirror tile cell reflects the radiance arriving along the
//   mirrored direction, gathered from the three fixed directions around it (barycentric).
#include "common/types.wgsl"
#include "common/bsdf.wgsl"
#include "common/atlas.wgsl"
#include "common/directions.wgsl"
#include "common/light_field.wgsl"
#include "common/upstream.wgsl"
#include "common/bilinear.wgsl"
#include "common/sampling.wgsl"

// The mirror tiles' gather never cuts (its rim rays and the lists see cut-outs' faces whole,
// ALPHA_MASKS stays 0 here): common/coverage.wgsl's hooks return none, so this stage binds
// nothing more (its pipeline is at the adapter's storage-binding limit on lavapipe).
fn cutout_of(face: u32) -> vec2<u32> {
    return vec2<u32>(0u);
}

fn coverage_info(texture: u32) -> vec4<u32> {
    return vec4<u32>(0u, 1u, 1u, 0u);
}

fn coverage_texel(index: u32) -> f32 {
    return 1.0;
}

// the light field being propagated, its unshot state (common/light_field.wgsl): the unshot atlas
// and mirror tiles, the fixed directions whose grids the tiles live in (perturbed sets move
// `directions`, not these), the geodesic tables
const LIGHT_FIELD_GROUP: u32 = 2u;

// per tile: (direction, face, tile x, tile y)
@group(3) @binding(0) var<storage, read> tile_headers: array<vec4<u32>>;
// next unshot mirror radiance (rgb) and, in w, the share that came from the sky (r+g+b): the
// page this dispatch writes
@group(3) @binding(1) var<storage, read_write> tile_next: array<vec4<f32>>;
@group(3) @binding(2) var<uniform> tile_page: PageRange;

// Texels of scenes with mirrors keep the lists' rim fallback (`rim_rays` is for diffuse-only
// scenes): the mirror tiles' rim cells and the power balance's tile classes have no rule for
// what a rim ray may see of them.
fn texel_rim_rays() -> bool {
    return false;
}

// Word i of the specular textures' factors after the tile headers (grid.specular_words > 0).
fn specular_word(i: u32) -> u32 {
    let v = tile_headers[grid.specular_words + i / 4u];
    return v[i % 4u];
}

// The specular texture's factor on face f's (id face_id) mirror colour at its atlas texel
// `texel` (src/propagate/transport.rs, specular_factor_words): 1 where the face has none, so a
// metal that varies over its surface sends its light on from its metal texels only.
fn specular_factor(face_id: u32, f: Face, texel: vec2<u32>) -> vec3<f32> {
    if grid.specular_words == 0u {
        return vec3<f32>(1.0);
    }
    let base = specular_word(face_id);
    if base == NO_FACE {
        return vec3<f32>(1.0);
    }
    let k = base + 2u * (texel.y * f.atlas_w + texel.x);
    let rg = specular_word(k);
    return vec3<f32>(half_float(rg), half_float(rg >> 16u), half_float(specular_word(k + 1u)));
}

fn sender_specular(s: Face, xs: vec3<f32>, dir_index: u32, travel: vec3<f32>) -> vec3<f32> {
    if s.tile_slot == NO_FACE {
        return vec3<f32>(0.0);
    }
    let d = field_directions[dir_index];
    return tile_bilinear(dir_index, d, s.tile_slot, xs, false).xyz;
}

@compute @workgroup_size(64)
fn gather_mixed(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    gather_and_store(gid.x + gid.y * groups.x * 64u);
}

@compute @workgroup_size(64)
fn gather_tiles(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // one dispatch per page: `in_page` indexes this page's tile_next, `index` all tile cells
    let in_page = gid.x + gid.y * groups.x * 64u;
    let index = tile_page.base + in_page;
    if in_page >= tile_page.cells {
        return;
    }
    let m = grid.tile_size;
    let header = tile_headers[index / (m * m)];
    let local = index % (m * m);
    let dir_index = header.x;
    let face_id = header.y;
    let col = header.z * m + local % m;
    let row = header.w * m + local / m;
    let d = field_directions[dir_index];
    let f = faces[face_id];
    let cos_w = dot(f.normal, d.w);
    if abs(cos_w) < 1e-6 {
        tile_next[in_page] = vec4<f32>(0.0);
        return;
    }
    // where this cell's line meets the face's plane
    let line = d.u * ((f32(col) + 0.5) * grid.cell_size - 1.0) + d.v * ((f32(row) + 0.5) * grid.cell_size - 1.0);
    let on_plane = line + d.w * ((f.plane_offset - dot(f.normal, line)) / cos_w);
    // Cells at the rim (kept for bilinear lookups) whose line misses the face take the sample
    // point of the nearest texel, which prepare put just inside the face: the atlas padding's
    // rule. Outside the face, "upstream" would mean nothing.
    let rel = on_plane - f.origin;
    let st = vec2<f32>(dot(rel, f.axis_a), dot(rel, f.axis_b)) * f.texel_density - 0.5;
    let texel = vec2<u32>(clamp(round(st), vec2<f32>(0.0), vec2<f32>(f32(f.atlas_w - 1u), f32(f.atlas_h - 1u))));
    let sample = texel_point((f.atlas_y + texel.y) * grid.atlas_width + f.atlas_x + texel.x).xyz;
    let centre = f.origin + (f.axis_a * (f32(texel.x) + 0.5) + f.axis_b * (f32(texel.y) + 0.5)) / f.texel_density;
    let inside = all(abs(st - vec2<f32>(texel)) <= vec2<f32>(0.5)) && distance(sample, centre) < 1e-5;
    let x = select(sample, on_plane, inside);
    let out_dir = d.w * sign(cos_w);
    let m_f = material_of(f);
    // a specular texture's factor at the cell's texel (1 without one)
    let factor = specular_factor(face_id, f, texel);
    if is_glossy(m_f) && (grid.flags & GRID_FLAG_BATCHED) == 0u {
        let lobe = gather_lobe(index, x, f, face_id, out_dir, m_f);
        tile_next[in_page] = vec4<f32>(lobe.xyz * factor, lobe.w);
        return;
    }
    // the light leaving along out_dir arrived travelling along its mirror image
    let g = gather_along(mirror_direction(out_dir, f.normal), x, face_id);
    if (grid.flags & GRID_FLAG_BATCHED) != 0u {
        weight_sums[grid.texel_count + index] += g.found;
        tile_next[in_page] += vec4<f32>(carried_reflectance(m_f) * factor * (g.radiance + g.sky), g.sky.x + g.sky.y + g.sky.z);
        return;
    }
    var radiance = g.radiance;
    var sky = g.sky;
    if g.found > 0.0 {
        radiance /= g.found;
        sky /= g.found;
    }
    // w: the sky radiance this cell received, for the emitted power of the residual
    tile_next[in_page] = vec4<f32>(carried_reflectance(m_f) * factor * (radiance + sky), sky.x + sky.y + sky.z);
}

// What arrives at x (on face `face_id`) travelling along `arriving`: the unshot radiance of the
// senders upstream along the three fixed directions around it (barycentric weights; taps beyond
// the horizon, in another batch or unresolved left out) and the sky's, with the weights found.
struct Gathered {
    radiance: vec3<f32>,
    sky: vec3<f32>,
    found: f32,
}

fn gather_along(arriving: vec3<f32>, x: vec3<f32>, face_id: u32) -> Gathered {
    let f = faces[face_id];
    let taps = lookup_direction(arriving, grid.geodesic_frequency);
    let sky_on = (grid.flags & GRID_FLAG_SKY) != 0u;
    var g = Gathered(vec3<f32>(0.0), vec3<f32>(0.0), 0.0);
    for (var k = 0u; k < 3u; k++) {
        let w = taps.weight[k];
        let j = taps.index[k];
        // batched directions: this batch serves only its own taps
        if j < grid.first_direction || j >= grid.first_direction + grid.direction_count {
            continue;
        }
        let dj = directions[j - grid.first_direction];
        let travel = dj.w * taps.sign[k];
        // a tap beyond the horizon cannot light the front: the others are renormalised
        if w <= 0.0 || dot(f.normal, travel) > -1e-6 {
            continue;
        }
        let sender = find_upstream(j - grid.first_direction, dj, x, face_id, taps.sign[k] > 0.0, false);
        if sender == UNRESOLVED {
            continue;
        }
        g.found += w;
        if sender == NO_FACE {
            if sky_on {
                g.sky += grid.sky * w;
            }
        } else {
            g.radiance += sender_radiance(sender, x, j, travel) * w;
        }
    }
    return g;
}

// A glossy tile cell: the light leaving x along out_dir is the reflectance times the lobe's
// integral of what arrives, estimated with lobe_taps directions sampled from the lobe
// (common/bsdf.wgsl, reflect_sampled: weights f cos / pdf; a Hammersley set rotated by a hash of
// the cell, the same every iteration, so a run repeats bit for bit), each gathered as a
// mirror's (gather_along). Directions no sender resolves are left out of the mean. Not in
// batched propagation (directions in batches), where a glossy face is carried as a mirror of its
// mean albedo.
// Directions sampled per glossy tile cell: a narrow lobe spans few of the fixed directions
// (about 3 degrees apart at the default 2001), whose three-tap lookups already blend it; up to
// alpha 0.3, 8 (16 there took 90% of a glossy box's iteration, for an error against Mitsuba
// well inside the bounds with 8); rougher lobes 16.
fn lobe_taps(alpha: f32) -> u32 {
    return select(select(16u, 8u, alpha <= 0.3), 4u, alpha <= 0.05);
}

fn gather_lobe(index: u32, x: vec3<f32>, f: Face, face_id: u32, out_dir: vec3<f32>, m: Material) -> vec4<f32> {
    let n_out = select(f.normal, -f.normal, dot(f.normal, out_dir) < 0.0);
    let h = hash(index ^ 0x2545f491u);
    let shift = vec2<f32>(unit_float(h), unit_float(hash(h)));
    var radiance = vec3<f32>(0.0);
    var sky = vec3<f32>(0.0);
    var used = 0.0;
    let taps = lobe_taps(m.roughness);
    for (var k = 0u; k < taps; k++) {
        let sampled = reflect_sampled(-out_dir, n_out, m.roughness, hammersley(k, taps, shift));
        if sampled.w <= 0.0 {
            // below the surface: a sample of the lobe that reflects nothing
            used += 1.0;
            continue;
        }
        let g = gather_along(-sampled.xyz, x, face_id);
        if g.found > 0.0 {
            radiance += g.radiance * (sampled.w / g.found);
            sky += g.sky * (sampled.w / g.found);
            used += 1.0;
        }
    }
    if used > 0.0 {
        radiance /= used;
        sky /= used;
    }
    return vec4<f32>(mirror_reflectance(m) * (radiance + sky), sky.x + sky.y + sky.z);
}
