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
    // the light leaving along out_dir arrived travelling along its mirror image
    let out_dir = d.w * sign(cos_w);
    let arriving = mirror_direction(out_dir, f.normal);
    let taps = lookup_direction(arriving, grid.geodesic_frequency);
    let sky_on = (grid.flags & GRID_FLAG_SKY) != 0u;
    var radiance = vec3<f32>(0.0);
    var sky = vec3<f32>(0.0);
    var found = 0.0;
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
        found += w;
        if sender == NO_FACE {
            if sky_on {
                sky += grid.sky * w;
            }
        } else {
            radiance += sender_radiance(sender, x, j, travel) * w;
        }
    }
    if (grid.flags & GRID_FLAG_BATCHED) != 0u {
        weight_sums[grid.texel_count + index] += found;
        tile_next[in_page] += vec4<f32>(carried_reflectance(material_of(f)) * (radiance + sky), sky.x + sky.y + sky.z);
        return;
    }
    if found > 0.0 {
        radiance /= found;
        sky /= found;
    }
    // w: the sky radiance this cell received, for the emitted power of the residual
    tile_next[in_page] = vec4<f32>(carried_reflectance(material_of(f)) * (radiance + sky), sky.x + sky.y + sky.z);
}
