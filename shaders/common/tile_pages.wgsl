// Mirror tile radiance in pages: one array may not exceed one storage binding (128 MiB on the
// software adapter), so the cells are split over up to four buffers of `tile_page_cells()`
// cells each (src/lightfield/tiles.rs: TilePages). The including file binds `tile_radiance_0`
// .. `tile_radiance_3` (pages it does not need are bound to page 0) and defines
// `tile_page_cells()`.

fn tile_load(cell: u32) -> vec4<f32> {
    let page = cell / tile_page_cells();
    let i = cell % tile_page_cells();
    switch page {
        case 0u: { return tile_radiance_0[i]; }
        case 1u: { return tile_radiance_1[i]; }
        case 2u: { return tile_radiance_2[i]; }
        default: { return tile_radiance_3[i]; }
    }
}
