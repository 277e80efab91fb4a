// Lookups in the sparse mirror tiles (src/lightfield/tiles.rs). The including file binds
// `tile_rects` (per direction and non-diffuse face: [x0 | y0 << 16, w | h << 16, first, 0]),
// `tile_index` (slot per tile of each rectangle, or NO_FACE) and the pages of tile radiance read
// through `tile_load` (common/tile_pages.wgsl), and defines `tile_cells_total()`.

// Radiance of tile cell (col, row) of non-diffuse face `slot` in direction `dir_index`; w is 1
// where the cell is stored, 0 where it is not. With `fixed_work` (the renderer) every call
// makes the same three reads whatever it finds: a cell outside the face's rectangle wraps into
// it and a tile that is not stored reads a neighbour of where it would be, and the result is
// then dropped, so that a view of diffuse walls costs what a view of mirrors does.
fn tile_cell(dir_index: u32, slot: u32, col: i32, row: i32, tile_size: u32, tile_face_count: u32, fixed_work: bool) -> vec4<f32> {
    let rect = tile_rects[dir_index * tile_face_count + slot];
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
    let tiles = tile_cells_total() / (tile_size * tile_size);
    let read_tile = select(tile, at % max(tiles, 1u), tile == NO_FACE);
    let local = ((row % m) + m) % m * m + ((col % m) + m) % m;
    let cell = read_tile * tile_size * tile_size + u32(local);
    let stored = inside && tile != NO_FACE;
    return select(vec4<f32>(0.0), vec4<f32>(tile_load(cell).xyz, 1.0), stored);
}

// Bilinear over the four cells around point p in direction d's grid; cells that are not stored
// drop out and the rest are renormalised. w is the total weight found (0: nothing stored).
fn tile_bilinear(dir_index: u32, d: Direction, slot: u32, p: vec3<f32>, cell_size: f32, tile_size: u32, tile_face_count: u32, fixed_work: bool) -> vec4<f32> {
    let q = vec2<f32>((dot(p, d.u) + 1.0) / cell_size - 0.5, (dot(p, d.v) + 1.0) / cell_size - 0.5);
    let c0 = vec2<i32>(floor(q));
    let f = q - floor(q);
    let a = tile_cell(dir_index, slot, c0.x, c0.y, tile_size, tile_face_count, fixed_work);
    let b = tile_cell(dir_index, slot, c0.x + 1, c0.y, tile_size, tile_face_count, fixed_work);
    let c = tile_cell(dir_index, slot, c0.x, c0.y + 1, tile_size, tile_face_count, fixed_work);
    let e = tile_cell(dir_index, slot, c0.x + 1, c0.y + 1, tile_size, tile_face_count, fixed_work);
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
