//! CPU twin of `shaders/visibility.wgsl` and `shaders/propagate.wgsl`, written to read like
//! them (same names, same f32 arithmetic, same order), for tiny scenes only. Tests compare it
//! with the GPU: layer lists must be equal and gathered radiosity equal within 1e-5. The mirror
//! parts (`shaders/specular.wgsl`, `common/light_field.wgsl`) have their twin in `cpu/specular.rs`.

pub mod specular;

use crate::bvh::{intersect, GpuTriangle};
use crate::gpu::types::{
    GpuDirection, GpuFace, GpuGrid, GpuMaterial, GRID_FLAG_RIM_RAYS, GRID_FLAG_SKY, NO_FACE,
    UNRESOLVED,
};
use crate::material::propagated_diffuse;
use glam::{Vec2, Vec3};

pub struct CpuVisibility {
    pub cell_offset: Vec<u32>,
    pub cell_count: Vec<u32>,
    pub layers: Vec<[u32; 2]>,
}

pub(super) fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from(a)
}

/// common/ray.wgsl's tie: hits this close (relative) are tied.
const TIE: f32 = 1.000001;

fn to_cell_units(grid: &GpuGrid, p: Vec3, d: &GpuDirection) -> Vec3 {
    let inv_h = 1.0 / grid.cell_size;
    Vec3::new(
        (p.dot(v3(d.u)) + 1.0) * inv_h - 0.5,
        (p.dot(v3(d.v)) + 1.0) * inv_h - 0.5,
        p.dot(v3(d.w)),
    )
}

fn cross2(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

fn canonical_edge(pa: Vec2, ia: u32, pb: Vec2, ib: u32, p: Vec2) -> f32 {
    if ia < ib {
        cross2(pb - pa, p - pa)
    } else {
        -cross2(pa - pb, p - pb)
    }
}

fn edge_admits(value: f32, orient: f32, ia: u32, ib: u32) -> bool {
    let sigma = if ia > ib { -orient } else { orient };
    let canonical = if ia < ib { value } else { -value };
    sigma * canonical > 0.0 || (canonical == 0.0 && sigma > 0.0)
}

fn row_span(ps: [Vec2; 3], y: f32) -> Vec2 {
    let mut lo = 1e30f32;
    let mut hi = -1e30f32;
    for e in 0..3 {
        let p = ps[e];
        let q = ps[(e + 1) % 3];
        if (p.y <= y && y <= q.y) || (q.y <= y && y <= p.y) {
            if p.y == q.y {
                lo = lo.min(p.x.min(q.x));
                hi = hi.max(p.x.max(q.x));
            } else {
                let x = p.x + (y - p.y) * (q.x - p.x) / (q.y - p.y);
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    Vec2::new(lo, hi)
}

/// Every (cell, face, depth) fragment of one triangle in one direction.
fn visit_triangle(
    grid: &GpuGrid,
    d: &GpuDirection,
    dir_index: u32,
    vertices: &[[f32; 4]],
    tri: [u32; 4],
    out: &mut Vec<(u32, [u32; 2])>,
) {
    let p = |i: u32| {
        Vec3::new(
            vertices[i as usize][0],
            vertices[i as usize][1],
            vertices[i as usize][2],
        )
    };
    let a3 = to_cell_units(grid, p(tri[0]), d);
    let b3 = to_cell_units(grid, p(tri[1]), d);
    let c3 = to_cell_units(grid, p(tri[2]), d);
    let (a, b, c) = (a3.truncate(), b3.truncate(), c3.truncate());
    let area = cross2(b - a, c - a);
    if area.abs() < 1e-9 {
        return;
    }
    let n = grid.resolution as i32;
    for row in 0..grid.resolution {
        let y = row as f32;
        if y < a.y.min(b.y.min(c.y)) || y > a.y.max(b.y.max(c.y)) {
            continue;
        }
        let span = row_span([a, b, c], y);
        let first = ((span.x.ceil() as i32) - 1).clamp(0, n - 1);
        let last = ((span.y.floor() as i32) + 1).clamp(0, n - 1);
        let orient = area.signum();
        let row_base = dir_index * grid.resolution * grid.resolution + row * grid.resolution;
        for col in first..=last {
            let q = Vec2::new(col as f32, y);
            let e_ab = canonical_edge(a, tri[0], b, tri[1], q);
            let e_bc = canonical_edge(b, tri[1], c, tri[2], q);
            let e_ca = canonical_edge(c, tri[2], a, tri[0], q);
            if !(edge_admits(e_ab, orient, tri[0], tri[1])
                && edge_admits(e_bc, orient, tri[1], tri[2])
                && edge_admits(e_ca, orient, tri[2], tri[0]))
            {
                continue;
            }
            let depth = (e_bc * a3.z + e_ca * b3.z + e_ab * c3.z) / area;
            out.push((row_base + col as u32, [tri[3], depth.to_bits()]));
        }
    }
}

fn layer_less(a: [u32; 2], b: [u32; 2]) -> bool {
    let (da, db) = (f32::from_bits(a[1]), f32::from_bits(b[1]));
    da < db || (da == db && a[0] < b[0])
}

pub fn build_visibility(
    grid: &GpuGrid,
    directions: &[GpuDirection],
    vertices: &[[f32; 4]],
    triangles: &[[u32; 4]],
) -> CpuVisibility {
    let cells = (grid.resolution * grid.resolution * grid.direction_count) as usize;
    let mut fragments = Vec::new();
    for (di, d) in directions.iter().enumerate() {
        for t in triangles {
            visit_triangle(grid, d, di as u32, vertices, *t, &mut fragments);
        }
    }
    let mut cell_count = vec![0u32; cells];
    for (cell, _) in &fragments {
        cell_count[*cell as usize] += 1;
    }
    let mut cell_offset = vec![0u32; cells];
    let mut running = 0;
    for i in 0..cells {
        cell_offset[i] = running;
        running += cell_count[i];
    }
    let mut cursor = vec![0u32; cells];
    let mut layers = vec![[0u32; 2]; running as usize];
    for (cell, layer) in fragments {
        layers[(cell_offset[cell as usize] + cursor[cell as usize]) as usize] = layer;
        cursor[cell as usize] += 1;
    }
    for i in 0..cells {
        let list = &mut layers[cell_offset[i] as usize..(cell_offset[i] + cell_count[i]) as usize];
        list.sort_by(|a, b| {
            if layer_less(*a, *b) {
                std::cmp::Ordering::Less
            } else if layer_less(*b, *a) {
                std::cmp::Ordering::Greater
            } else {
                std::cmp::Ordering::Equal
            }
        });
    }
    CpuVisibility {
        cell_offset,
        cell_count,
        layers,
    }
}

/// Inputs of one gather pass.
pub struct GatherInputs<'a> {
    pub grid: &'a GpuGrid,
    pub directions: &'a [GpuDirection],
    pub faces: &'a [GpuFace],
    /// the material table the faces index (`crate::material`)
    pub materials: &'a [GpuMaterial],
    pub visibility: &'a CpuVisibility,
    pub texel_points: &'a [[f32; 4]],
    pub unshot: &'a [[f32; 4]],
    /// the mirror tiles, for scenes with mirrors (sender_specular, gather_tile)
    pub tiles: Option<&'a specular::TileInputs<'a>>,
    /// the scene's triangles as the GPU binds them (`PreparedScene::bvh`): the texels' rim
    /// rays, cast here through every triangle (the GPU walks the BVH; the tie rule makes the
    /// closest hit the same)
    pub triangles: &'a [GpuTriangle],
}

impl GatherInputs<'_> {
    fn layer_depth(l: [u32; 2]) -> f32 {
        f32::from_bits(l[1])
    }

    fn find_in_cell(&self, cell: u32, face: u32) -> i32 {
        let start = self.visibility.cell_offset[cell as usize];
        let n = self.visibility.cell_count[cell as usize];
        (0..n)
            .find(|&k| self.visibility.layers[(start + k) as usize][0] == face)
            .map_or(-1, |k| k as i32)
    }

    fn upstream_of_entry(&self, cell: u32, k: u32, forward: bool) -> u32 {
        let start = self.visibility.cell_offset[cell as usize];
        let n = self.visibility.cell_count[cell as usize];
        let layers = &self.visibility.layers;
        let own_depth = Self::layer_depth(layers[(start + k) as usize]);
        let eps = self.grid.depth_epsilon;
        if forward {
            (0..k)
                .rev()
                .map(|j| layers[(start + j) as usize])
                .find(|l| (Self::layer_depth(*l) - own_depth).abs() > eps)
                .map_or(NO_FACE, |l| l[0])
        } else {
            (k + 1..n)
                .map(|j| layers[(start + j) as usize])
                .find(|l| (Self::layer_depth(*l) - own_depth).abs() > eps)
                .map_or(NO_FACE, |l| l[0])
        }
    }

    fn upstream_of_depth(&self, cell: u32, depth: f32, forward: bool) -> u32 {
        let start = self.visibility.cell_offset[cell as usize];
        let n = self.visibility.cell_count[cell as usize];
        let eps = self.grid.depth_epsilon;
        let mut found = NO_FACE;
        for k in 0..n {
            let l = self.visibility.layers[(start + k) as usize];
            let ld = Self::layer_depth(l);
            if forward {
                if ld < depth - eps {
                    found = l[0];
                }
            } else if ld > depth + eps {
                return l[0];
            }
        }
        found
    }

    fn clamp_cell(&self, c: [i32; 2]) -> [u32; 2] {
        let n = self.grid.resolution as i32 - 1;
        [c[0].clamp(0, n) as u32, c[1].clamp(0, n) as u32]
    }

    /// The side of a two-sided surface that faces the light's way of travel (upstream.wgsl's
    /// `facing_side`): list order between the two coplanar sides is an accident of rounding.
    fn facing_side(&self, sender: u32, travel: Vec3) -> u32 {
        if sender >= UNRESOLVED {
            return sender;
        }
        let s = &self.faces[sender as usize];
        if s.twin != NO_FACE && v3(s.normal).dot(travel) <= 1e-6 {
            return s.twin;
        }
        sender
    }

    /// The rim fallback of a texel's gather (upstream.wgsl's `rim_ray_sender`): what a ray from
    /// x against the light's way meets first, x's face and its twin skipped, on its side facing
    /// the light; the sky where it meets nothing.
    fn rim_ray_sender(&self, x: Vec3, travel: Vec3, face: u32) -> u32 {
        let skip_twin = self.faces[face as usize].twin;
        let dir = -travel;
        // (t, triangle): common/ray.wgsl's Hit, starting at t_max 4 with no triangle
        let mut hit = (4.0f32, NO_FACE);
        for (i, tri) in self.triangles.iter().enumerate() {
            if tri.face == face || tri.face == skip_twin {
                continue;
            }
            let t = intersect(x, dir, tri, hit.0 * TIE);
            if self.closer(t, i as u32, hit) {
                hit = (t, i as u32);
            }
        }
        if hit.1 == NO_FACE {
            return NO_FACE;
        }
        self.facing_side(self.triangles[hit.1 as usize].face, travel)
    }

    /// common/ray.wgsl's `closer`: nearer by more than the tie, or tied and of the lower face
    /// (then the lower triangle).
    fn closer(&self, t: f32, tri: u32, hit: (f32, u32)) -> bool {
        if t <= 0.0 {
            return false;
        }
        if hit.1 == NO_FACE || t * TIE < hit.0 {
            return true;
        }
        if t > hit.0 * TIE {
            return false;
        }
        let (face, other) = (
            self.triangles[tri as usize].face,
            self.triangles[hit.1 as usize].face,
        );
        face < other || (face == other && tri < hit.1)
    }

    /// The lists' rim fallback (upstream.wgsl's `rim_sender`, mirror tile cells): the original
    /// side of what was met (a generated back's twin has the lower id), if it faces the light.
    fn rim_sender(&self, found: u32, travel: Vec3) -> u32 {
        if found >= UNRESOLVED {
            return UNRESOLVED;
        }
        let twin = self.faces[found as usize].twin;
        let original = if twin < found { twin } else { found };
        if v3(self.faces[original as usize].normal).dot(travel) > 1e-6 {
            return original;
        }
        UNRESOLVED
    }

    pub(super) fn find_upstream(
        &self,
        dir_index: u32,
        d: &GpuDirection,
        x: Vec3,
        face: u32,
        forward: bool,
        rim_rays: bool,
    ) -> u32 {
        let travel = if forward { v3(d.w) } else { -v3(d.w) };
        let inv_h = 1.0 / self.grid.cell_size;
        let q = Vec2::new(
            (x.dot(v3(d.u)) + 1.0) * inv_h - 0.5,
            (x.dot(v3(d.v)) + 1.0) * inv_h - 0.5,
        );
        let base = dir_index * self.grid.resolution * self.grid.resolution;
        let nearest = [q.x.round_ties_even() as i32, q.y.round_ties_even() as i32];
        let c0 = self.clamp_cell(nearest);
        let cell0 = base + c0[1] * self.grid.resolution + c0[0];
        let k0 = self.find_in_cell(cell0, face);
        if k0 >= 0 {
            return self.facing_side(self.upstream_of_entry(cell0, k0 as u32, forward), travel);
        }
        for i in 0..9 {
            let c = self.clamp_cell([nearest[0] + i % 3 - 1, nearest[1] + i / 3 - 1]);
            if c == c0 {
                continue;
            }
            let cell = base + c[1] * self.grid.resolution + c[0];
            let k = self.find_in_cell(cell, face);
            if k >= 0 {
                return self.facing_side(self.upstream_of_entry(cell, k as u32, forward), travel);
            }
        }
        if rim_rays {
            return self.rim_ray_sender(x, travel, face);
        }
        let depth = x.dot(v3(d.w));
        for i in -1..9 {
            let c = if i >= 0 {
                self.clamp_cell([nearest[0] + i % 3 - 1, nearest[1] + i / 3 - 1])
            } else {
                c0
            };
            let cell = base + c[1] * self.grid.resolution + c[0];
            if self.visibility.cell_count[cell as usize] == 0 {
                continue;
            }
            return self.rim_sender(self.upstream_of_depth(cell, depth, forward), travel);
        }
        NO_FACE
    }

    pub(super) fn sender_radiance(
        &self,
        sender: u32,
        x: Vec3,
        dir_index: u32,
        travel: Vec3,
    ) -> Vec3 {
        let s = &self.faces[sender as usize];
        let facing = v3(s.normal).dot(travel);
        if facing <= 1e-6 {
            return Vec3::ZERO;
        }
        let t = (v3(s.normal).dot(x) - s.plane_offset) / facing;
        let taps =
            crate::lightfield::atlas_lookup::atlas_taps(s, x - travel * t, self.grid.atlas_width);
        let mut b = Vec3::ZERO;
        for k in 0..4 {
            let u = self.unshot[taps.index[k] as usize];
            b += Vec3::new(u[0], u[1], u[2]) * taps.weight[k];
        }
        b / std::f32::consts::PI + self.sender_specular(s, x - travel * t, dir_index)
    }

    /// The gather kernel for one texel: next radiosity (rgb) and the sky's share (w).
    pub fn gather(&self, texel: usize) -> [f32; 4] {
        let point = self.texel_points[texel];
        let face_id = point[3].to_bits();
        if face_id == NO_FACE {
            return [0.0; 4];
        }
        let f = &self.faces[face_id as usize];
        let x = Vec3::new(point[0], point[1], point[2]);
        let sky_on = self.grid.flags & GRID_FLAG_SKY != 0;
        let mut irradiance = Vec3::ZERO;
        let mut sky_irradiance = Vec3::ZERO;
        let mut weight_sum = 0.0f32;
        // rim rays in diffuse-only scenes (propagate.wgsl), not with mirrors (specular.wgsl)
        let rim_rays = self.tiles.is_none() && self.grid.flags & GRID_FLAG_RIM_RAYS != 0;
        for (i, d) in self.directions.iter().enumerate() {
            let cos_w = v3(f.normal).dot(v3(d.w));
            if cos_w.abs() < 1e-6 {
                continue;
            }
            let forward = cos_w < 0.0;
            let travel = if forward { v3(d.w) } else { -v3(d.w) };
            let weight = cos_w.abs() * d.solid_angle;
            let sender = self.find_upstream(i as u32, d, x, face_id, forward, rim_rays);
            if sender == UNRESOLVED {
                continue;
            }
            weight_sum += weight;
            if sender == NO_FACE {
                if sky_on {
                    sky_irradiance += v3(self.grid.sky) * weight;
                }
            } else {
                irradiance += self.sender_radiance(sender, x, i as u32, travel) * weight;
            }
        }
        let norm = if weight_sum > 0.0 {
            std::f32::consts::PI / weight_sum
        } else {
            0.0
        };
        let e = (irradiance + sky_irradiance) * norm;
        let sky_share = (sky_irradiance.x + sky_irradiance.y + sky_irradiance.z) * norm;
        let next = propagated_diffuse(self.materials, f) * e;
        [next.x, next.y, next.z, sky_share]
    }
}
