//! The light field's bind group: the Rust side of `shaders/common/light_field.wgsl`, the one
//! declaration of the light field's bindings (layout uniform, atlas pages, fixed directions,
//! geodesic tables, mirror tiles and their pages) and of its accessors, which the renderer and
//! specular transport include. A stage reflects the group's layout from its own WGSL
//! (`gpu::reflect`, at the group its `LIGHT_FIELD_GROUP` names); this module fills it, in the
//! module's binding order. A change of the light field's storage layout stays here, in the WGSL
//! module, in the `.vlf` format (`file.rs`) and in the CPU twins.

use super::{LightField, ResidentLightField};
use crate::error::Result;
use crate::gpu::types::{GpuField, GpuGrid};
use crate::gpu::{reflect, GpuContext, MemoryLedger};

/// The name of the layout uniform in `common/light_field.wgsl`: the binding the group is found by.
const FIELD_BINDING_NAME: &str = "field";
/// The first of the texture detail's bindings in `common/light_field.wgsl`.
const DETAIL_BINDINGS: u32 = 14;

/// What a bind group of the light field binds: its layout uniform (`GpuField`), the radiance
/// atlas in pages, and the mirror tiles where the light field has them.
pub struct FieldBuffers<'a> {
    pub field: &'a wgpu::Buffer,
    pub atlas: Vec<&'a wgpu::Buffer>,
    pub tiles: Option<FieldTiles<'a>>,
    /// the texture detail (`textures::ResidentDetail`), where the light field has it
    pub detail: Option<&'a super::textures::ResidentDetail>,
}

/// The view-dependent part: the fixed directions the tiles live in, the geodesic lookup, the
/// sparse tile tables and the tile radiance in pages.
pub struct FieldTiles<'a> {
    pub directions: &'a wgpu::Buffer,
    pub geodesic_points: &'a wgpu::Buffer,
    pub geodesic_index: &'a wgpu::Buffer,
    pub rects: &'a wgpu::Buffer,
    pub index: &'a wgpu::Buffer,
    pub radiance: Vec<&'a wgpu::Buffer>,
}

/// The light field's group in one stage: where the stage binds it, its layout, and which of
/// the module's bindings the stage's entry points read (the others are left out of the layout:
/// every binding in a layout counts against the device's limit on storage buffers per stage,
/// and specular transport reads its unshot atlas through its own group).
pub struct FieldLayout {
    pub group: u32,
    pub layout: wgpu::BindGroupLayout,
    bindings: Vec<u32>,
}

/// The light field's group in `stage`, reflected from the stage's WGSL: the group of the
/// `field` uniform that `common/light_field.wgsl` declares, and the bindings its entry points use.
pub fn layout(device: &wgpu::Device, stage: &str) -> Result<FieldLayout> {
    let group = reflect::group_of(stage, FIELD_BINDING_NAME)?;
    let entries = reflect::used_layout_entries(stage, group)?;
    Ok(FieldLayout {
        group,
        layout: reflect::layout_of(device, stage, group, &entries),
        bindings: entries.iter().map(|e| e.binding).collect(),
    })
}

/// Page `p` of `pages`, or page 0 where there are fewer.
fn page<'a>(pages: &[&'a wgpu::Buffer], p: usize) -> &'a wgpu::Buffer {
    pages.get(p).copied().unwrap_or(pages[0])
}

/// The light field's bind group for `layout` (from `layout`). The atlas and the tiles have up
/// to `tiles::MAX_TILE_PAGES` pages: those a light field does not have repeat page 0. Without
/// tiles (a diffuse-only light field) the tile bindings hold one small placeholder, which the
/// diffuse entry points never read; so do the texture detail's without detail (a renderer
/// without it compiles its reads out).
pub fn bind_group(
    ctx: &GpuContext,
    layout: &FieldLayout,
    buffers: &FieldBuffers,
) -> wgpu::BindGroup {
    // made only for a light field without tiles or detail (propagation binds a field every
    // iteration)
    let placeholder;
    let no_detail;
    let atlas = &buffers.atlas;
    let (directions, points, index_table, rects, index, tiles) = match &buffers.tiles {
        Some(t) => (
            t.directions,
            t.geodesic_points,
            t.geodesic_index,
            t.rects,
            t.index,
            t.radiance.clone(),
        ),
        None => {
            let (ledger, name) = (&MemoryLedger::default(), "light field: no tiles");
            placeholder = ctx.buffer_zeroed(ledger, name, 64, crate::gpu::STORAGE);
            let p = &placeholder;
            (p, p, p, p, p, vec![p])
        }
    };
    let needs_detail = layout.bindings.iter().any(|&b| b >= DETAIL_BINDINGS);
    let detail: [&wgpu::Buffer; 4] = match buffers.detail.filter(|_| needs_detail) {
        Some(d) => [
            &d.texel_albedo,
            &d.face_textures,
            &d.texture_info,
            &d.texels,
        ],
        None if needs_detail => {
            let (ledger, name) = (&MemoryLedger::default(), "light field: no texture detail");
            no_detail = ctx.buffer_zeroed(ledger, name, 64, crate::gpu::STORAGE);
            [&no_detail; 4]
        }
        // not bound: any buffer stands in the list
        None => [buffers.field; 4],
    };
    // in the order common/light_field.wgsl declares them: binding k is the k-th
    let all = [
        buffers.field,
        page(atlas, 0),
        page(atlas, 1),
        page(atlas, 2),
        page(atlas, 3),
        directions,
        points,
        index_table,
        rects,
        index,
        page(&tiles, 0),
        page(&tiles, 1),
        page(&tiles, 2),
        page(&tiles, 3),
        detail[0],
        detail[1],
        detail[2],
        detail[3],
    ];
    let entries: Vec<wgpu::BindGroupEntry> = (layout.bindings.iter())
        .map(|&binding| wgpu::BindGroupEntry {
            binding,
            resource: all[binding as usize].as_entire_binding(),
        })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("light field"),
        layout: &layout.layout,
        entries: &entries,
    })
}

/// The layout uniform of the light field being propagated, as `common/light_field.wgsl` reads
/// it, from the propagation grid's values (transport binds its unshot state with it): so a
/// change to `Field` stays in this module.
pub fn field_of_grid(grid: &GpuGrid) -> GpuField {
    GpuField {
        sky: [grid.sky[0], grid.sky[1], grid.sky[2], 1.0],
        cell_size: grid.cell_size,
        atlas_width: grid.atlas_width,
        geodesic_frequency: grid.geodesic_frequency,
        tile_size: grid.tile_size,
        tile_face_count: grid.tile_face_count,
        grid_resolution: grid.resolution,
        tile_page_cells: grid.tile_page_cells,
        tile_cell_count: grid.tile_cell_count,
        texel_page_cells: grid.texel_page_cells,
        ..Default::default()
    }
}

impl ResidentLightField {
    /// The layout uniform of this light field as `lf` describes it (written once).
    pub fn field_params(&self, lf: &LightField) -> GpuField {
        let sky = lf.meta.sky.unwrap_or([0.0; 3]);
        let p = &lf.meta.params;
        let detail_offsets = (lf.detail.as_ref()).map_or([0; 3], |d| d.detail_words().1);
        GpuField {
            sky: [sky[0], sky[1], sky[2], 1.0],
            cell_size: 2.0 / p.grid_resolution as f32,
            atlas_width: lf.meta.atlas_width,
            geodesic_frequency: p.geodesic_frequency,
            tile_size: p.tile_size,
            tile_face_count: lf.tiles.as_ref().map_or(0, |t| t.face_count),
            grid_resolution: p.grid_resolution,
            tile_page_cells: self.tiles.as_ref().map_or(1, |t| t.pages.page_cells),
            tile_cell_count: (self.tiles.as_ref()).map_or(0, |t| t.pages.total_cells as u32),
            texel_page_cells: self.texel_pages.page_cells,
            normal_records: detail_offsets[0],
            normal_texels: detail_offsets[1],
            specular_records: detail_offsets[2],
        }
    }

    /// The converged light field's bind group for `layout`, with `field` holding its
    /// `field_params`.
    pub fn bind_group(&self, layout: &FieldLayout, field: &wgpu::Buffer) -> wgpu::BindGroup {
        let tiles = self.tiles.as_ref().map(|t| FieldTiles {
            directions: &t.directions,
            geodesic_points: &t.geodesic_points,
            geodesic_index: &t.geodesic_index,
            rects: &t.rects,
            index: &t.index,
            radiance: t.radiance.iter().collect(),
        });
        let buffers = FieldBuffers {
            field,
            atlas: self.total.iter().collect(),
            tiles,
            detail: self.detail.as_ref(),
        };
        bind_group(&self.ctx, layout, &buffers)
    }
}
