//! Sparse storage for non-diffuse (mirror) radiance (ARCHITECTURE.md, "Mirror tiles"): for each
//! direction and each non-diffuse face, only the m x m-cell tiles that the face's projection
//! overlaps (widened by a cell and a half, so bilinear lookups across cells always find their
//! neighbours). A (direction, face) -> tile rectangle table and a per-rectangle index give each
//! tile's slot; slot s holds cells [s*m^2, (s+1)*m^2). A diffuse-only scene has no tiles at all.

use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuDirection, NO_FACE};
use glam::{DVec2, DVec3};

/// Elements (mirror tile cells, or texels) split into pages, none larger than one storage binding
/// (128 MiB on the software adapter), bound as up to MAX_TILE_PAGES buffers
/// (shaders/common/light_field.wgsl, shaders/common/upstream.wgsl).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TilePages {
    /// cells per page (whole tiles)
    pub page_cells: u32,
    pub pages: u32,
    pub total_cells: u64,
}

pub const MAX_TILE_PAGES: u32 = 4;

thread_local! {
    /// Page sizes below the binding limit (tiles, texels) for what this thread plans: a test
    /// hook (`with_small_pages`). Per thread, so tests running beside it plan as usual.
    static SMALL_PAGES: std::cell::Cell<(Option<u64>, Option<u64>)> =
        const { std::cell::Cell::new((None, None)) };
}

/// Runs `f` with the mirror tiles' and the texel arrays' pages at most `tile_bytes` and
/// `texel_bytes` for every plan made on this thread (tests/pages.rs: a small scene over several
/// pages, which must change no result).
pub fn with_small_pages<T>(tile_bytes: u64, texel_bytes: u64, f: impl FnOnce() -> T) -> T {
    let before = SMALL_PAGES.replace((Some(tile_bytes), Some(texel_bytes)));
    let out = f();
    SMALL_PAGES.set(before);
    out
}

impl TilePages {
    /// Pages for the mirror tiles: `total_cells` cells of 16 bytes in tiles of `cells_per_tile`,
    /// each page at most `max_binding` bytes (lower within `with_small_pages`).
    pub fn plan(total_cells: u64, cells_per_tile: u32, max_binding: u64) -> Result<TilePages> {
        Self::plan_for(
            "the mirror tiles",
            SMALL_PAGES.get().0,
            total_cells,
            cells_per_tile,
            max_binding,
        )
    }

    /// Pages for the texel arrays (16 bytes per texel; lower within `with_small_pages`).
    pub fn plan_texels(texels: u64, max_binding: u64) -> Result<TilePages> {
        Self::plan_for(
            "the radiance atlas",
            SMALL_PAGES.get().1,
            texels,
            1,
            max_binding,
        )
    }

    fn plan_for(
        what: &str,
        small_pages: Option<u64>,
        total_cells: u64,
        cells_per_tile: u32,
        max_binding: u64,
    ) -> Result<TilePages> {
        let limit = small_pages.map_or(max_binding, |v| v.min(max_binding));
        let tiles_per_page =
            (limit / (16 * cells_per_tile as u64)).clamp(1, (u32::MAX / cells_per_tile) as u64);
        let page_cells =
            (tiles_per_page * cells_per_tile as u64).min(total_cells.max(cells_per_tile as u64));
        let pages = total_cells.div_ceil(page_cells).max(1);
        if pages > MAX_TILE_PAGES as u64 {
            return Err(VlfError::GpuBudget(format!(
                "{what} ({total_cells} elements x 16 bytes = {}) need {pages} buffers of one binding ({}) and at most {MAX_TILE_PAGES} are bound; use fewer directions, a coarser grid, smaller tiles or a lower texel density",
                crate::gpu::human_bytes(total_cells * 16),
                crate::gpu::human_bytes(limit)
            )));
        }
        Ok(TilePages {
            page_cells: page_cells as u32,
            pages: pages as u32,
            total_cells,
        })
    }

    /// (first cell, cells) of every page.
    pub fn ranges(&self) -> Vec<(u32, u32)> {
        (0..self.pages)
            .map(|p| {
                let first = p as u64 * self.page_cells as u64;
                (
                    first as u32,
                    (self.total_cells - first).min(self.page_cells as u64) as u32,
                )
            })
            .collect()
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct TileLayout {
    pub grid_resolution: u32,
    pub tile_size: u32,
    /// face ids of the non-diffuse faces, in slot order
    pub faces: Vec<u32>,
    /// per face: its index in `faces`, or NO_FACE
    pub face_slot: Vec<u32>,
    /// per (direction, non-diffuse face): [x0 | y0 << 16, w | h << 16, first index, 0] in tiles
    pub rects: Vec<[u32; 4]>,
    /// per tile of each rectangle: its slot, or NO_FACE where the face does not reach
    pub index: Vec<u32>,
    /// per slot: [direction, face, tile x, tile y]
    pub headers: Vec<[u32; 4]>,
}

impl TileLayout {
    pub fn is_empty(&self) -> bool {
        self.headers.is_empty()
    }

    pub fn cells_per_tile(&self) -> u32 {
        self.tile_size * self.tile_size
    }

    /// Number of tile cells (non-diffuse elements).
    pub fn cell_count(&self) -> u64 {
        self.headers.len() as u64 * self.cells_per_tile() as u64
    }

    /// Build the layout. `face_triangles[f]` are face f's triangles in normalised space;
    /// `non_diffuse[f]` says whether face f has a mirror part.
    pub fn build(
        directions: &[GpuDirection],
        face_normals: &[DVec3],
        face_triangles: &[Vec<[DVec3; 3]>],
        non_diffuse: &[bool],
        grid_resolution: u32,
        tile_size: u32,
    ) -> TileLayout {
        let faces: Vec<u32> = (0..non_diffuse.len() as u32)
            .filter(|&f| non_diffuse[f as usize])
            .collect();
        let mut face_slot = vec![NO_FACE; non_diffuse.len()];
        for (i, &f) in faces.iter().enumerate() {
            face_slot[f as usize] = i as u32;
        }
        let mut layout = TileLayout {
            grid_resolution,
            tile_size,
            faces,
            face_slot,
            ..Default::default()
        };
        if layout.faces.is_empty() {
            return layout;
        }
        // each direction's rectangles are independent: build them on all cores
        let threads = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
            .min(16);
        let chunk = directions.len().div_ceil(threads);
        // per direction: (face slot, tile rectangle, which tiles of it are covered)
        type Rects = Vec<(u32, [u32; 4], Vec<bool>)>;
        let per_direction: Vec<Rects> = crossbeam::thread::scope(|s| {
            let handles: Vec<_> = directions
                .chunks(chunk)
                .map(|dirs| {
                    let layout = &layout;
                    s.spawn(move |_| {
                        dirs.iter()
                            .map(|d| {
                                layout
                                    .faces
                                    .iter()
                                    .map(|&f| {
                                        overlapped_tiles(
                                            d,
                                            face_normals[f as usize],
                                            &face_triangles[f as usize],
                                            grid_resolution,
                                            tile_size,
                                        )
                                    })
                                    .map(|(rect, used)| (0, rect, used))
                                    .collect::<Vec<_>>()
                            })
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap())
                .collect()
        })
        .unwrap();
        for (dir, rects) in per_direction.into_iter().enumerate() {
            for (j, (_, rect, used)) in rects.into_iter().enumerate() {
                let first = layout.index.len() as u32;
                let (x0, y0, w) = (rect[0], rect[1], rect[2]);
                for (k, u) in used.iter().enumerate() {
                    if *u {
                        let slot = layout.headers.len() as u32;
                        layout.index.push(slot);
                        let (tx, ty) = (x0 + k as u32 % w.max(1), y0 + k as u32 / w.max(1));
                        layout.headers.push([dir as u32, layout.faces[j], tx, ty]);
                    } else {
                        layout.index.push(NO_FACE);
                    }
                }
                layout
                    .rects
                    .push([rect[0] | rect[1] << 16, rect[2] | rect[3] << 16, first, 0]);
            }
        }
        layout
    }
}

/// The tile rectangle [x0, y0, w, h] of a face's projection along d, and which of its tiles
/// the projection (widened for bilinear lookups) overlaps.
fn overlapped_tiles(
    d: &GpuDirection,
    normal: DVec3,
    triangles: &[[DVec3; 3]],
    n: u32,
    m: u32,
) -> ([u32; 4], Vec<bool>) {
    let w = DVec3::from(d.w.map(|x| x as f64));
    if normal.dot(w).abs() < 1e-6 {
        return ([0; 4], Vec::new());
    }
    let (u, v) = (
        DVec3::from(d.u.map(|x| x as f64)),
        DVec3::from(d.v.map(|x| x as f64)),
    );
    let h = 2.0 / n as f64;
    let to_cells = |p: DVec3| DVec2::new((p.dot(u) + 1.0) / h - 0.5, (p.dot(v) + 1.0) / h - 0.5);
    let tris: Vec<[DVec2; 3]> = triangles.iter().map(|t| t.map(to_cells)).collect();
    const MARGIN: f64 = 1.5;
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in tris.iter().flatten() {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let tiles = (n / m) as i64;
    let tile_of = |c: f64| ((c / m as f64).floor() as i64).clamp(0, tiles - 1);
    let (x0, x1) = (tile_of(lo.x - MARGIN), tile_of(hi.x + MARGIN));
    let (y0, y1) = (tile_of(lo.y - MARGIN), tile_of(hi.y + MARGIN));
    let (tw, th) = ((x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32);
    let mut used = Vec::with_capacity((tw * th) as usize);
    for ty in y0..=y1 {
        for tx in x0..=x1 {
            // cell centres of this tile span [t*m, t*m + m - 1]
            let rlo = DVec2::new(
                (tx * m as i64) as f64 - MARGIN,
                (ty * m as i64) as f64 - MARGIN,
            );
            let rhi = DVec2::new(
                ((tx + 1) * m as i64 - 1) as f64 + MARGIN,
                ((ty + 1) * m as i64 - 1) as f64 + MARGIN,
            );
            used.push(tris.iter().any(|t| triangle_overlaps_rect(t, rlo, rhi)));
        }
    }
    ([x0 as u32, y0 as u32, tw, th], used)
}

/// Separating-axis test of a triangle against an axis-aligned rectangle.
fn triangle_overlaps_rect(t: &[DVec2; 3], lo: DVec2, hi: DVec2) -> bool {
    let (tmin, tmax) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
    if tmax.x < lo.x || tmin.x > hi.x || tmax.y < lo.y || tmin.y > hi.y {
        return false;
    }
    let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    for k in 0..3 {
        let e = t[(k + 1) % 3] - t[k];
        let axis = DVec2::new(-e.y, e.x);
        let tri = t.iter().map(|p| p.dot(axis));
        let (tlo, thi) = tri.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
        let rect = corners.iter().map(|p| p.dot(axis));
        let (rlo, rhi) = rect.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
        if thi < rlo || rhi < tlo {
            return false;
        }
    }
    true
}
