// Lookups in the sparse mirror tiles (src/lightfield/tiles.rs). The including file binds
// `tile_rects` (per direction and non-diffuse face: [x0 | y0 << 16, w | h << 16, first, 0]),
// `tile_index` (slot per tile of each rectangle, or NO_FACE) and `tile_radiance` (rgb per cell).

// Radiance of tile cell (col, row) of non-diffuse face `slot` in direction `dir_index`; w is 1
// where the cell is stored, 0 where it is not.
fn tile_cell(dir_index: u32, slot: u32, col: i32, row: i32, tile_size: u32, tile_face_count: u32) -> vec4<f32> {
    let rect = tile_rects[dir_index * tile_face_count + slot];
    let m = i32(tile_size);
    if col < 0 || row < 0 {
        return vec4<f32>(0.0);
    }
    let tx = col / m - i32(rect.x & 0xffffu);
    let ty = row / m - i32(rect.x >> 16u);
    let tw = i32(rect.y & 0xffffu);
    let th = i32(rect.y >> 16u);
    if tx < 0 || ty < 0 || tx >= tw || ty >= th {
        return vec4<f32>(0.0);
    }
    let tile = tile_index[rect.z + u32(ty * tw + tx)];
    if tile == NO_FACE {
        return vec4<f32>(0.0);
    }
    let cell = tile * tile_size * tile_size + u32((row % m) * m + col % m);
    return vec4<f32>(tile_radiance[cell].xyz, 1.0);
}

// Bilinear over the four cells around point p in direction d's grid; cells that are not stored
// drop out and the rest are renormalised. w is the total weight found (0: nothing stored).
fn tile_bilinear(dir_index: u32, d: Direction, slot: u32, p: vec3<f32>, cell_size: f32, tile_size: u32, tile_face_count: u32) -> vec4<f32> {
    let q = vec2<f32>((dot(p, d.u) + 1.0) / cell_size - 0.5, (dot(p, d.v) + 1.0) / cell_size - 0.5);
    let c0 = vec2<i32>(floor(q));
    let f = q - floor(q);
    let a = tile_cell(dir_index, slot, c0.x, c0.y, tile_size, tile_face_count);
    let b = tile_cell(dir_index, slot, c0.x + 1, c0.y, tile_size, tile_face_count);
    let c = tile_cell(dir_index, slot, c0.x, c0.y + 1, tile_size, tile_face_count);
    let e = tile_cell(dir_index, slot, c0.x + 1, c0.y + 1, tile_size, tile_face_count);
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
