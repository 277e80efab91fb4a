//! CPU twin of the mirror parts of transport, written to read like `shaders/specular.wgsl` and
//! `shaders/common/light_field.wgsl` (same names, same f32 arithmetic, same order): a mirror sender's
//! tile lookup (`sender_specular`) and the gather of one tile cell (`gather_tile`). The three
//! directions around a mirrored direction come from `DirectionSet::lookup`, the f64 twin of
//! the shader's geodesic lookup. Tests compare it with the GPU on tiny scenes.

use super::{v3, GatherInputs};
use crate::gpu::types::{GpuDirection, GpuFace, GRID_FLAG_SKY, NO_FACE, UNRESOLVED};
use crate::lightfield::directions::DirectionSet;
use crate::material::material_of;
use glam::{Vec2, Vec3};

/// The mirror tiles as the transport binds them.
pub struct TileInputs<'a> {
    /// per (direction, non-diffuse face): [x0 | y0 << 16, w | h << 16, first index, 0]
    pub rects: &'a [[u32; 4]],
    pub index: &'a [u32],
    /// per tile: [direction, face, tile x, tile y]; with specular textures, their factors after
    /// them (from `grid.specular_words`: `transport::specular_factor_words`)
    pub headers: &'a [[u32; 4]],
    /// the fixed directions the tiles live in
    pub tile_directions: &'a [GpuDirection],
    pub set: &'a DirectionSet,
    /// unshot mirror radiance per tile cell
    pub radiance: &'a [[f32; 4]],
}

impl GatherInputs<'_> {
    fn tile_cell(&self, t: &TileInputs, dir_index: u32, slot: u32, col: i32, row: i32) -> [f32; 4] {
        let rect = t.rects[(dir_index * self.grid.tile_face_count + slot) as usize];
        let m = self.grid.tile_size as i32;
        if col < 0 || row < 0 {
            return [0.0; 4];
        }
        let tx = col / m - (rect[0] & 0xffff) as i32;
        let ty = row / m - (rect[0] >> 16) as i32;
        let (tw, th) = ((rect[1] & 0xffff) as i32, (rect[1] >> 16) as i32);
        if tx < 0 || ty < 0 || tx >= tw || ty >= th {
            return [0.0; 4];
        }
        let tile = t.index[(rect[2] + (ty * tw + tx) as u32) as usize];
        if tile == NO_FACE {
            return [0.0; 4];
        }
        let cell = tile * (m * m) as u32 + ((row % m) * m + col % m) as u32;
        let r = t.radiance[cell as usize];
        [r[0], r[1], r[2], 1.0]
    }

    fn tile_bilinear(
        &self,
        t: &TileInputs,
        dir_index: u32,
        d: &GpuDirection,
        slot: u32,
        p: Vec3,
    ) -> [f32; 4] {
        let cell_size = self.grid.cell_size;
        let q = Vec2::new(
            (p.dot(v3(d.u)) + 1.0) / cell_size - 0.5,
            (p.dot(v3(d.v)) + 1.0) / cell_size - 0.5,
        );
        let c0 = [q.x.floor() as i32, q.y.floor() as i32];
        let f = q - q.floor();
        let a = self.tile_cell(t, dir_index, slot, c0[0], c0[1]);
        let b = self.tile_cell(t, dir_index, slot, c0[0] + 1, c0[1]);
        let c = self.tile_cell(t, dir_index, slot, c0[0], c0[1] + 1);
        let e = self.tile_cell(t, dir_index, slot, c0[0] + 1, c0[1] + 1);
        let wa = (1.0 - f.x) * (1.0 - f.y) * a[3];
        let wb = f.x * (1.0 - f.y) * b[3];
        let wc = (1.0 - f.x) * f.y * c[3];
        let we = f.x * f.y * e[3];
        let total = wa + wb + wc + we;
        if total <= 0.0 {
            return [0.0; 4];
        }
        let v = |k: usize| (a[k] * wa + b[k] * wb + c[k] * wc + e[k] * we) / total;
        [v(0), v(1), v(2), total]
    }

    /// A mirror sender's radiance along its fixed direction `dir_index` at `xs` (zero for a
    /// diffuse-only sender, or without tiles).
    pub(super) fn sender_specular(&self, s: &GpuFace, xs: Vec3, dir_index: u32) -> Vec3 {
        let Some(t) = self.tiles else {
            return Vec3::ZERO;
        };
        if s.tile_slot == NO_FACE {
            return Vec3::ZERO;
        }
        let d = &t.tile_directions[dir_index as usize];
        let v = self.tile_bilinear(t, dir_index, d, s.tile_slot, xs);
        Vec3::new(v[0], v[1], v[2])
    }

    /// The gather kernel for one tile cell: next mirror radiance (rgb) and the sky's share (w).
    pub fn gather_tile(&self, index: u32) -> [f32; 4] {
        let t = self.tiles.expect("tile inputs");
        let m = self.grid.tile_size;
        let header = t.headers[(index / (m * m)) as usize];
        let local = index % (m * m);
        let (dir_index, face_id) = (header[0], header[1]);
        let col = header[2] * m + local % m;
        let row = header[3] * m + local / m;
        let d = &t.tile_directions[dir_index as usize];
        let f = &self.faces[face_id as usize];
        let cos_w = v3(f.normal).dot(v3(d.w));
        if cos_w.abs() < 1e-6 {
            return [0.0; 4];
        }
        let h = self.grid.cell_size;
        let line =
            v3(d.u) * ((col as f32 + 0.5) * h - 1.0) + v3(d.v) * ((row as f32 + 0.5) * h - 1.0);
        let on_plane = line + v3(d.w) * ((f.plane_offset - v3(f.normal).dot(line)) / cos_w);
        let rel = on_plane - v3(f.origin);
        let st = Vec2::new(rel.dot(v3(f.axis_a)), rel.dot(v3(f.axis_b))) * f.texel_density - 0.5;
        let texel = [
            st.x.round_ties_even().clamp(0.0, (f.atlas_w - 1) as f32) as u32,
            st.y.round_ties_even().clamp(0.0, (f.atlas_h - 1) as f32) as u32,
        ];
        let sp = self.texel_points
            [((f.atlas_y + texel[1]) * self.grid.atlas_width + f.atlas_x + texel[0]) as usize];
        let sample = Vec3::new(sp[0], sp[1], sp[2]);
        let centre = v3(f.origin)
            + (v3(f.axis_a) * (texel[0] as f32 + 0.5) + v3(f.axis_b) * (texel[1] as f32 + 0.5))
                / f.texel_density;
        let off = st - Vec2::new(texel[0] as f32, texel[1] as f32);
        let inside = off.x.abs() <= 0.5 && off.y.abs() <= 0.5 && sample.distance(centre) < 1e-5;
        let x = if inside { on_plane } else { sample };
        let out_dir = v3(d.w) * cos_w.signum();
        let n = v3(f.normal);
        let arriving = out_dir - 2.0 * out_dir.dot(n) * n;
        let taps = t.set.lookup(glam::DVec3::new(
            arriving.x as f64,
            arriving.y as f64,
            arriving.z as f64,
        ));
        let sky_on = self.grid.flags & GRID_FLAG_SKY != 0;
        let (mut radiance, mut sky, mut found) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
        for tap in taps {
            let (w, j, sign) = (tap.weight as f32, tap.index, tap.sign as f32);
            let dj = &self.directions[j as usize];
            let travel = v3(dj.w) * sign;
            if w <= 0.0 || n.dot(travel) > -1e-6 {
                continue;
            }
            let sender = self.find_upstream(j, dj, x, face_id, sign > 0.0, false);
            if sender == UNRESOLVED {
                continue;
            }
            found += w;
            if sender == NO_FACE {
                if sky_on {
                    sky += v3(self.grid.sky) * w;
                }
            } else {
                radiance += self.sender_radiance(sender, x, j, travel) * w;
            }
        }
        if found > 0.0 {
            radiance /= found;
            sky /= found;
        }
        let factor = self.specular_factor(t, face_id, f, texel);
        let out = material_of(self.materials, f).carried_reflectance() * factor * (radiance + sky);
        [out.x, out.y, out.z, sky.x + sky.y + sky.z]
    }

    /// specular.wgsl's `specular_factor`: the specular texture's factor on face `face_id`'s
    /// mirror colour at its atlas texel `texel`, 1 where the face has none.
    fn specular_factor(&self, t: &TileInputs, face_id: u32, f: &GpuFace, texel: [u32; 2]) -> Vec3 {
        let start = self.grid.specular_words as usize;
        if start == 0 {
            return Vec3::ONE;
        }
        let word = |i: u32| t.headers[start + (i / 4) as usize][(i % 4) as usize];
        let base = word(face_id);
        if base == NO_FACE {
            return Vec3::ONE;
        }
        let k = base + 2 * (texel[1] * f.atlas_w + texel[0]);
        let half = |h: u32| half::f16::from_bits((h & 0xffff) as u16).to_f32();
        let rg = word(k);
        Vec3::new(half(rg), half(rg >> 16), half(word(k + 1)))
    }
}
