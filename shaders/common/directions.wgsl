// The three fixed directions around any unit vector, with barycentric weights: the geodesic
// lookup of src/lightfield/directions.rs (DirectionSet::lookup), which is its CPU twin.
// `geodesic_points` and `geodesic_index` (DirectionSet::gpu_tables) are the light field's bindings
// (common/light_field.wgsl, which the including stage includes too):
//   geodesic_points: the 12 icosahedron corners, then every sphere point
//   geodesic_index: 20 x 3 corner ids, then each face's grid of point ids (row by row), then
//                   per point its direction index, with bit 31 set for -w

struct DirectionTaps {
    index: vec3<u32>,
    sign: vec3<f32>,
    weight: vec3<f32>,
}

fn solve3(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let det = dot(a, cross(b, c));
    return vec3<f32>(dot(d, cross(b, c)), dot(a, cross(d, c)), dot(a, cross(b, d))) / det;
}

fn geodesic_row_start(n: u32, j: u32) -> u32 {
    return j * (n + 1u) - (j * max(j, 1u) - j) / 2u;
}

fn lookup_direction(d: vec3<f32>, n: u32) -> DirectionTaps {
    var best_face = 0u;
    var best_min = -1e30;
    var best = vec3<f32>(0.0);
    for (var f = 0u; f < 20u; f++) {
        let a = geodesic_points[geodesic_index[f * 3u]].xyz;
        let b = geodesic_points[geodesic_index[f * 3u + 1u]].xyz;
        let c = geodesic_points[geodesic_index[f * 3u + 2u]].xyz;
        let bary = solve3(a, b, c, d);
        let worst = min(bary.x, min(bary.y, bary.z));
        if worst > best_min {
            best_min = worst;
            best_face = f;
            best = bary;
        }
    }
    let clamped = max(best, vec3<f32>(0.0));
    let planar = clamped / (clamped.x + clamped.y + clamped.z);
    let gi = planar.y * f32(n);
    let gj = planar.z * f32(n);
    let ni = i32(n);
    let i0 = clamp(i32(floor(gi)), 0, ni - 1);
    let j0 = clamp(i32(floor(gj)), 0, ni - 1 - i0);
    let fi = gi - f32(i0);
    let fj = gj - f32(j0);
    let rows = (n + 1u) * (n + 2u) / 2u;
    let grid_base = 60u + best_face * rows;
    var corners: vec3<u32>;
    if fi + fj <= 1.0 || i0 + j0 + 1 >= ni {
        corners = vec3<u32>(
            geodesic_index[grid_base + geodesic_row_start(n, u32(j0)) + u32(i0)],
            geodesic_index[grid_base + geodesic_row_start(n, u32(j0)) + u32(i0) + 1u],
            geodesic_index[grid_base + geodesic_row_start(n, u32(j0) + 1u) + u32(i0)],
        );
    } else {
        corners = vec3<u32>(
            geodesic_index[grid_base + geodesic_row_start(n, u32(j0)) + u32(i0) + 1u],
            geodesic_index[grid_base + geodesic_row_start(n, u32(j0) + 1u) + u32(i0) + 1u],
            geodesic_index[grid_base + geodesic_row_start(n, u32(j0) + 1u) + u32(i0)],
        );
    }
    let p0 = geodesic_points[12u + corners.x].xyz;
    let p1 = geodesic_points[12u + corners.y].xyz;
    let p2 = geodesic_points[12u + corners.z].xyz;
    var w = max(solve3(p0, p1, p2, d), vec3<f32>(0.0));
    w = w / (w.x + w.y + w.z);
    let table = 60u + 20u * rows;
    let e = vec3<u32>(geodesic_index[table + corners.x], geodesic_index[table + corners.y], geodesic_index[table + corners.z]);
    var taps: DirectionTaps;
    taps.index = e & vec3<u32>(0x7fffffffu);
    taps.sign = select(vec3<f32>(1.0), vec3<f32>(-1.0), (e >> vec3<u32>(31u)) == vec3<u32>(1u));
    taps.weight = w;
    return taps;
}
