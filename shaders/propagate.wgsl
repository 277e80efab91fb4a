// Shooting iterations of diffuse transport by gathering, driven by src/propagate/transport.rs.
// The gather serves diffuse-only scenes: it binds no tiles (specular.wgsl serves the rest). The
// power balance's passes at the end of this file serve every scene.
// For every texel and every direction pair (+w_i, -w_i), the texel looks itself up in the
// cell lists built by visibility.wgsl and takes the layer just upstream as its sender: no
// atomics, a fixed weight per texel, bit-for-bit repeatable. The CPU twin is
// src/propagate/cpu.rs, written to read like this file.
#include "common/types.wgsl"
#include "common/bsdf.wgsl"
#include "common/atlas.wgsl"
#include "common/upstream.wgsl"
#include "common/bilinear.wgsl"
#include "common/packed_cutouts.wgsl"

// the cut-outs' coverage (common/packed_cutouts.wgsl), shared with direct.wgsl / propagate.wgsl
@group(0) @binding(13) var<storage, read> cutouts: array<u32>;

// A diffuse-only scene: senders have no mirror part.
fn sender_specular(s: Face, xs: vec3<f32>, dir_index: u32, travel: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}

// With `rim_rays`, a texel the lists cannot place along a direction casts a ray
// (common/upstream.wgsl).
fn texel_rim_rays() -> bool {
    return (grid.flags & GRID_FLAG_RIM_RAYS) != 0u;
}

@compute @workgroup_size(64)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    gather_and_store(gid.x + gid.y * groups.x * 64u);
}

// ---- The power balance (src/propagate/transport.rs, `Balance`), for every scene: these entry
// points bind their own group 2, and the mirror tiles' headers and radiance where a scene has
// them (placeholders otherwise). Sums come from tree reductions of a fixed order: repeatable.

// per texel of the page: the area of its face that it stands for (propagate::texel_areas)
@group(2) @binding(0) var<storage, read> balance_weight: array<f32>;
// one vec4 per workgroup
@group(2) @binding(1) var<storage, read_write> balance_partials: array<vec4<f32>>;
// per tile: (direction, face, tile x, tile y)
@group(2) @binding(2) var<storage, read> balance_tile_headers: array<vec4<u32>>;
// one page of mirror tile radiance, and which cells it holds
@group(2) @binding(3) var<storage, read> balance_tile_values: array<vec4<f32>>;
@group(2) @binding(4) var<uniform> balance_tile_page: PageRange;
// 2 bits per tile cell, 16 cells a word: where the light a cell sends along its direction goes
// (TILE_* below)
@group(2) @binding(5) var<storage, read_write> balance_tile_class: array<u32>;
// the fixed directions, whose grids the tiles live in
@group(2) @binding(6) var<storage, read> balance_directions: array<Direction>;

// a tile cell whose line misses its face (rim cells kept for bilinear lookups) or grazes it
const TILE_OFF_FACE: u32 = 0u;
// its light reaches the front of a face (or the twin side of a two-sided surface)
const TILE_RECEIVED: u32 = 1u;
// nothing is downstream: it leaves for the sky
const TILE_ESCAPES: u32 = 2u;
// the back of a one-sided face is downstream: absorbed there
const TILE_BACK: u32 = 3u;

const BALANCE_THREADS: u32 = 256u;
var<workgroup> balance_scratch: array<vec4<f32>, BALANCE_THREADS>;

// Sum of `value` over the workgroup into balance_partials[group] (called by every thread).
fn reduce_balance(lid: u32, group: u32, value: vec4<f32>) {
    balance_scratch[lid] = value;
    workgroupBarrier();
    for (var stride = BALANCE_THREADS / 2u; stride > 0u; stride /= 2u) {
        if lid < stride {
            balance_scratch[lid] += balance_scratch[lid + stride];
        }
        workgroupBarrier();
    }
    if lid == 0u {
        balance_partials[group] = balance_scratch[0];
    }
}

// The texels of one page, after the iteration's gather, direct light and normalisation and before
// the texture factors: sums of power received (irradiance x area), its mirror part (rho_s E A),
// and the escaping and back-absorbed shares of what the texels shot (from `balance`). Where every
// channel of the albedo is positive, the irradiance is next / albedo: what the light field
// actually took in, direct light included; elsewhere (black or pure mirror faces) the gather's.
@compute @workgroup_size(256)
fn texel_balance(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let in_page = gid.x + gid.y * groups.x * BALANCE_THREADS;
    var value = vec4<f32>(0.0);
    if in_page < texel_page.cells {
        let face_id = bitcast<u32>(texel_point(texel_page.base + in_page).w);
        if face_id != NO_FACE {
            let f = faces[face_id];
            let b = balance[in_page];
            var terms = b;
            let m = material_of(f);
            let sent = propagated_diffuse(f, m);
            if all(sent > vec3<f32>(0.0)) {
                let e = next[in_page].xyz / sent;
                terms = vec4<f32>(e.x + e.y + e.z, dot(propagated_specular(f, m), e), b.z, b.w);
            }
            value = terms * balance_weight[in_page];
        }
    }
    reduce_balance(lid, wg.x + wg.y * groups.x, value);
}

// The texels of one page at the end of an iteration (texture factors applied): sums of their
// next unshot power and of the sky's share of their irradiance (w, first iteration) x area.
@compute @workgroup_size(256)
fn texel_power(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let in_page = gid.x + gid.y * groups.x * BALANCE_THREADS;
    var value = vec4<f32>(0.0);
    if in_page < texel_page.cells {
        let n = next[in_page];
        value = vec4<f32>(n.x + n.y + n.z, n.w, 0.0, 0.0) * balance_weight[in_page];
    }
    reduce_balance(lid, wg.x + wg.y * groups.x, value);
}

// Where the light of tile cell `index` goes along its direction (this batch's `local` index):
// the first layer downstream of its face in the cell's own list.
fn tile_cell_class(index: u32, header: vec4<u32>, local: u32) -> u32 {
    let m = grid.tile_size;
    let in_tile = index % (m * m);
    let col = header.z * m + in_tile % m;
    let row = header.w * m + in_tile / m;
    let d = directions[local];
    let f = faces[header.y];
    let cos_w = dot(f.normal, d.w);
    if abs(cos_w) < 1e-6 {
        return TILE_OFF_FACE;
    }
    let cell = local * grid.resolution * grid.resolution + row * grid.resolution + col;
    let k = find_in_cell(cell, header.y);
    if k < 0 {
        return TILE_OFF_FACE;
    }
    // the light leaves along out_dir; downstream along +w is deeper in the list
    let out_dir = d.w * sign(cos_w);
    let to = upstream_of_entry(cell, u32(k), cos_w < 0.0);
    if to == NO_FACE {
        return TILE_ESCAPES;
    }
    let g = faces[to];
    if dot(g.normal, out_dir) < 0.0 || g.twin != NO_FACE {
        return TILE_RECEIVED;
    }
    return TILE_BACK;
}

// Classify the tile cells whose direction is in this batch (run once, with the fixed
// directions' lists): one thread per word of 16 cells.
@compute @workgroup_size(64)
fn tile_classes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let word = gid.x + gid.y * groups.x * 64u;
    if word >= (grid.tile_cell_count + 15u) / 16u {
        return;
    }
    let m2 = grid.tile_size * grid.tile_size;
    var bits = balance_tile_class[word];
    for (var k = 0u; k < 16u; k++) {
        let index = word * 16u + k;
        if index >= grid.tile_cell_count {
            break;
        }
        let header = balance_tile_headers[index / m2];
        if header.x < grid.first_direction || header.x >= grid.first_direction + grid.direction_count {
            continue;
        }
        let fate = tile_cell_class(index, header, header.x - grid.first_direction);
        bits = (bits & ~(3u << (2u * k))) | (fate << (2u * k));
    }
    balance_tile_class[word] = bits;
}

// One page of mirror tile radiance: sums of the power its cells on their face send (radiance x
// cell area x solid angle, r+g+b), and of the parts that escape and that meet a one-sided back.
@compute @workgroup_size(256)
fn tile_balance(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let in_page = gid.x + gid.y * groups.x * BALANCE_THREADS;
    var value = vec4<f32>(0.0);
    if in_page < balance_tile_page.cells {
        let index = balance_tile_page.base + in_page;
        let fate = (balance_tile_class[index / 16u] >> (2u * (index % 16u))) & 3u;
        if fate != TILE_OFF_FACE {
            let header = balance_tile_headers[index / (grid.tile_size * grid.tile_size)];
            let v = balance_tile_values[in_page].xyz;
            let power = (v.x + v.y + v.z) * grid.cell_size * grid.cell_size * balance_directions[header.x].solid_angle;
            value = vec4<f32>(power, select(0.0, power, fate == TILE_ESCAPES), select(0.0, power, fate == TILE_BACK), 0.0);
        }
    }
    reduce_balance(lid, wg.x + wg.y * groups.x, value);
}
