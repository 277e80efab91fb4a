// Visibility per direction as sorted per-cell layer lists (an A-buffer), driven by
// src/propagate/visibility.rs. Every triangle is rasterised orthographically along w_i into the
// N x N grid of direction i: count fragments per cell, prefix-sum, fill (face, depth), then sort
// each cell's short list by (depth, face). The CPU twin is src/propagate/cpu.rs.
//
// Coordinates are in "cell units": the centre of cell (col, row) sits at (col, row).
#include "common/types.wgsl"
#include "common/bilinear.wgsl"
#include "common/coverage.wgsl"
#include "common/packed_cutouts.wgsl"

@group(0) @binding(0) var<uniform> grid: GridParams;
@group(0) @binding(1) var<storage, read> directions: array<Direction>;
@group(0) @binding(2) var<storage, read> vertices: array<vec4<f32>>;
// (vertex 0, vertex 1, vertex 2, face)
@group(0) @binding(3) var<storage, read> triangles: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read_write> cell_count: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> cell_offset: array<u32>;
// per direction: its first layer; entry [direction_count] holds the total
@group(0) @binding(6) var<storage, read_write> direction_base: array<u32>;
// cut-outs (placeholders in a scene without one): the coverage (common/packed_cutouts.wgsl) and
// per triangle its corners' texture coordinates ((uv0, uv1), (uv2, -))
@group(0) @binding(7) var<storage, read> cutouts: array<u32>;
@group(0) @binding(8) var<storage, read> triangle_uv: array<vec4<f32>>;
// (face, bitcast depth)
@group(1) @binding(0) var<storage, read_write> layers: array<vec2<u32>>;

fn to_cell_units(p: vec3<f32>, d: Direction) -> vec3<f32> {
    let inv_h = 1.0 / grid.cell_size;
    return vec3<f32>((dot(p, d.u) + 1.0) * inv_h - 0.5, (dot(p, d.v) + 1.0) * inv_h - 0.5, dot(p, d.w));
}

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// Edge function of edge (a -> b), always evaluated from the lower vertex id so that the two
// triangles sharing an edge see exactly opposite values: no cell is counted twice or lost.
fn canonical_edge(pa: vec2<f32>, ia: u32, pb: vec2<f32>, ib: u32, p: vec2<f32>) -> f32 {
    if ia < ib {
        return cross2(pb - pa, p - pa);
    }
    return -cross2(pa - pb, p - pb);
}

// Is p inside on the interior side of edge (a -> b) of a triangle with area sign `orient`?
// A point exactly on the edge belongs to the triangle whose interior lies on the positive side
// of the canonical (low id -> high id) orientation.
fn edge_admits(value: f32, orient: f32, ia: u32, ib: u32) -> bool {
    var sigma = orient;
    if ia > ib {
        sigma = -orient;
    }
    let canonical = select(-value, value, ia < ib);
    return sigma * canonical > 0.0 || (canonical == 0.0 && sigma > 0.0);
}

// x-range where row y crosses the triangle (before the exact per-cell test).
fn row_span(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, y: f32) -> vec2<f32> {
    var lo = 1e30;
    var hi = -1e30;
    let ps = array<vec2<f32>, 3>(a, b, c);
    for (var e = 0u; e < 3u; e++) {
        let p = ps[e];
        let q = ps[(e + 1u) % 3u];
        if (p.y <= y && y <= q.y) || (q.y <= y && y <= p.y) {
            if p.y == q.y {
                lo = min(lo, min(p.x, q.x));
                hi = max(hi, max(p.x, q.x));
            } else {
                let x = p.x + (y - p.y) * (q.x - p.x) / (q.y - p.y);
                lo = min(lo, x);
                hi = max(hi, x);
            }
        }
    }
    return vec2<f32>(lo, hi);
}

// A triangle of one direction in cell units.
struct Projected {
    a3: vec3<f32>,
    b3: vec3<f32>,
    c3: vec3<f32>,
    area: f32,
}

// Whether the cell line meets triangle `tri_index` (face `face`) in a cut-out's hole, at the
// point of barycentric weights (w_a, w_b, w_c) = (e_bc, e_ca, e_ab) / area: the coverage point
// sampled at the line's crossing, so that over many cells the light passing is the coverage.
fn crossing_hole(tri_index: u32, face: u32, e_ca: f32, e_ab: f32, area: f32) -> bool {
    if ALPHA_MASKS == 0u {
        return false;
    }
    return is_hole(face, corners_uv(triangle_uv[2u * tri_index], triangle_uv[2u * tri_index + 1u].xy, e_ca / area, e_ab / area));
}

fn visit_row(row: u32, tri_index: u32, tri: vec4<u32>, t: Projected, dir_index: u32, fill: bool) {
    let a = t.a3.xy;
    let b = t.b3.xy;
    let c = t.c3.xy;
    let y = f32(row);
    let span = row_span(a, b, c, y);
    let n = i32(grid.resolution);
    let first = clamp(i32(ceil(span.x)) - 1, 0, n - 1);
    let last = clamp(i32(floor(span.y)) + 1, 0, n - 1);
    let orient = sign(t.area);
    let row_base = dir_index * grid.resolution * grid.resolution + row * grid.resolution;
    for (var col = first; col <= last; col++) {
        let p = vec2<f32>(f32(col), y);
        let e_ab = canonical_edge(a, tri.x, b, tri.y, p);
        let e_bc = canonical_edge(b, tri.y, c, tri.z, p);
        let e_ca = canonical_edge(c, tri.z, a, tri.x, p);
        if !(edge_admits(e_ab, orient, tri.x, tri.y) && edge_admits(e_bc, orient, tri.y, tri.z)
            && edge_admits(e_ca, orient, tri.z, tri.x)) {
            continue;
        }
        if crossing_hole(tri_index, tri.w, e_ca, e_ab, t.area) {
            continue;
        }
        let cell = row_base + u32(col);
        if fill {
            // barycentric depth of the cell centre on the triangle's plane
            let depth = (e_bc * t.a3.z + e_ca * t.b3.z + e_ab * t.c3.z) / t.area;
            let slot = direction_base[dir_index] + cell_offset[cell] + atomicAdd(&cell_count[cell], 1u);
            layers[slot] = vec2<u32>(tri.w, bitcast<u32>(depth));
        } else {
            atomicAdd(&cell_count[cell], 1u);
        }
    }
}

// Threads per triangle and direction: thread k visits the rows first + k, first + k + ROW_SLOTS,
// ... of the rows the triangle covers. A thread per grid row would mostly find a small triangle
// elsewhere and stop: with a million triangles those idle threads were most of the build.
const ROW_SLOTS: u32 = 8u;

fn visit_rows(slot: u32, tri_index: u32, dir_index: u32, fill: bool) {
    let d = directions[dir_index];
    let tri = triangles[tri_index];
    var t: Projected;
    t.a3 = to_cell_units(vertices[tri.x].xyz, d);
    t.b3 = to_cell_units(vertices[tri.y].xyz, d);
    t.c3 = to_cell_units(vertices[tri.z].xyz, d);
    t.area = cross2(t.b3.xy - t.a3.xy, t.c3.xy - t.a3.xy);
    // edge-on: the face neither receives nor sends along this direction
    if abs(t.area) < 1e-9 {
        return;
    }
    // the grid rows y with min y <= y <= max y of the triangle (clamped as floats, so far-off
    // vertices cannot overflow the integer conversion)
    let last_row = f32(grid.resolution) - 1.0;
    let first = u32(clamp(ceil(min(t.a3.y, min(t.b3.y, t.c3.y))), 0.0, last_row + 1.0));
    let last = clamp(floor(max(t.a3.y, max(t.b3.y, t.c3.y))), -1.0, last_row);
    for (var row = first + slot; f32(row) <= last; row += ROW_SLOTS) {
        visit_row(row, tri_index, tri, t, dir_index, fill);
    }
}

// workgroup: ROW_SLOTS threads for each of 8 triangles (src/propagate/visibility.rs dispatches
// triangles / 8 workgroups in y, one direction per z)
@compute @workgroup_size(8, 8)
fn count_layers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let tri = gid.y + grid.triangle_base;
    if tri >= grid.triangle_count {
        return;
    }
    visit_rows(gid.x, tri, gid.z, false);
}

@compute @workgroup_size(8, 8)
fn fill_layers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let tri = gid.y + grid.triangle_base;
    if tri >= grid.triangle_count {
        return;
    }
    visit_rows(gid.x, tri, gid.z, true);
}

const SCAN_THREADS: u32 = 256u;
var<workgroup> scan_scratch: array<u32, SCAN_THREADS>;

// Inclusive workgroup scan of `value` over SCAN_THREADS threads (Hillis-Steele).
fn workgroup_inclusive_scan(lid: u32, value: u32) -> u32 {
    scan_scratch[lid] = value;
    workgroupBarrier();
    for (var stride = 1u; stride < SCAN_THREADS; stride *= 2u) {
        var other = 0u;
        if lid >= stride {
            other = scan_scratch[lid - stride];
        }
        workgroupBarrier();
        scan_scratch[lid] += other;
        workgroupBarrier();
    }
    return scan_scratch[lid];
}

// One workgroup per direction: exclusive scan of that direction's cell counts into
// cell_offset (relative to the direction's base), its total into direction_base, and the
// counts reset to zero so that fill_layers can reuse them as cursors.
@compute @workgroup_size(256)
fn scan_cells(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let dir_index = wg.x;
    let cells = grid.resolution * grid.resolution;
    let per_thread = (cells + SCAN_THREADS - 1u) / SCAN_THREADS;
    let base = dir_index * cells;
    let begin = min(lid * per_thread, cells);
    let end = min(begin + per_thread, cells);
    var sum = 0u;
    for (var i = begin; i < end; i++) {
        sum += atomicLoad(&cell_count[base + i]);
    }
    let inclusive = workgroup_inclusive_scan(lid, sum);
    var running = inclusive - sum;
    for (var i = begin; i < end; i++) {
        let c = atomicLoad(&cell_count[base + i]);
        cell_offset[base + i] = running;
        running += c;
        atomicStore(&cell_count[base + i], 0u);
    }
    if lid == SCAN_THREADS - 1u {
        direction_base[dir_index] = inclusive;
    }
}

// One workgroup: exclusive scan of the per-direction totals; the grand total goes last.
@compute @workgroup_size(256)
fn scan_directions(@builtin(local_invocation_index) lid: u32) {
    let count = grid.direction_count;
    let per_thread = (count + SCAN_THREADS - 1u) / SCAN_THREADS;
    let begin = min(lid * per_thread, count);
    let end = min(begin + per_thread, count);
    var sum = 0u;
    for (var i = begin; i < end; i++) {
        sum += direction_base[i];
    }
    let inclusive = workgroup_inclusive_scan(lid, sum);
    var running = inclusive - sum;
    for (var i = begin; i < end; i++) {
        let c = direction_base[i];
        direction_base[i] = running;
        running += c;
    }
    if lid == SCAN_THREADS - 1u {
        direction_base[count] = inclusive;
    }
}

fn layer_less(a: vec2<u32>, b: vec2<u32>) -> bool {
    let da = bitcast<f32>(a.y);
    let db = bitcast<f32>(b.y);
    return da < db || (da == db && a.x < b.x);
}

// One thread per cell: make its offset absolute and insertion-sort its list by (depth, face),
// which also makes the atomics' arbitrary fill order irrelevant (bit-for-bit repeatable).
@compute @workgroup_size(64)
fn sort_layers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cells = grid.resolution * grid.resolution;
    if gid.x >= cells {
        return;
    }
    let dir_index = gid.y;
    let cell = dir_index * cells + gid.x;
    let start = direction_base[dir_index] + cell_offset[cell];
    cell_offset[cell] = start;
    let n = atomicLoad(&cell_count[cell]);
    for (var i = 1u; i < n; i++) {
        let key = layers[start + i];
        var j = i;
        loop {
            if j == 0u {
                break;
            }
            let prev = layers[start + j - 1u];
            if !layer_less(key, prev) {
                break;
            }
            layers[start + j] = prev;
            j -= 1u;
        }
        layers[start + j] = key;
    }
}
