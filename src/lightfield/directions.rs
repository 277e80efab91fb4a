//! The direction set (ARCHITECTURE.md, "Directions and grids"): a geodesic sphere (icosahedron
//! faces subdivided with frequency n, 10n^2+2 points), of which one point of each antipodal pair
//! stands for the bidirectional pair (+w, -w): 5n^2+1 directions over a hemisphere. Each carries
//! the area of its spherical Voronoi cell, and any unit vector finds the spherical triangle that
//! contains it, with barycentric weights, exactly (central projection maps the flat sub-triangles
//! of an icosahedron face onto the spherical ones).

use glam::DVec3;
use std::collections::HashMap;

const PHI: f64 = 1.618_033_988_749_895;

/// A fixed, generic rotation of the icosahedron so that no direction lies exactly in the
/// coordinate planes that axis-aligned scenes (boxes, rooms) are built from.
fn orientation() -> glam::DQuat {
    glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.113, 0.271, 0.059)
}

const ICOSAHEDRON_FACES: [[usize; 3]; 20] = [
    [0, 11, 5],
    [0, 5, 1],
    [0, 1, 7],
    [0, 7, 10],
    [0, 10, 11],
    [1, 5, 9],
    [5, 11, 4],
    [11, 10, 2],
    [10, 7, 6],
    [7, 1, 8],
    [3, 9, 4],
    [3, 4, 2],
    [3, 2, 6],
    [3, 6, 8],
    [3, 8, 9],
    [4, 9, 5],
    [2, 4, 11],
    [6, 2, 10],
    [8, 6, 7],
    [9, 8, 1],
];

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Direction {
    /// Unit vector; the direction also stands for -w.
    pub w: DVec3,
    /// Solid angle of w's Voronoi cell (the same for -w).
    pub solid_angle: f64,
}

impl Direction {
    /// An orthonormal frame (u, v, w) for this direction's grid.
    pub fn frame(&self) -> (DVec3, DVec3) {
        let w = self.w;
        let helper = if w.x.abs() < 0.6 {
            DVec3::X
        } else if w.y.abs() < 0.6 {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let u = helper.cross(w).normalize();
        let v = w.cross(u);
        (u, v)
    }
}

/// One weighted fixed direction in a lookup: `sign` is +1 for +w, -1 for -w.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionWeight {
    pub index: u32,
    pub sign: f64,
    pub weight: f64,
}

#[derive(Clone, Debug)]
pub struct DirectionSet {
    pub frequency: u32,
    pub directions: Vec<Direction>,
    corners: [DVec3; 12],
    /// Sphere point ids of each icosahedron face's grid, row by row.
    face_points: Vec<Vec<u32>>,
    /// Sphere points and, for each, its hemisphere direction and sign.
    points: Vec<DVec3>,
    point_direction: Vec<(u32, f64)>,
}

impl DirectionSet {
    /// Geodesic set of frequency `n` >= 1: 5n^2+1 directions.
    pub fn geodesic(n: u32) -> DirectionSet {
        assert!(n >= 1, "geodesic frequency must be at least 1");
        let rot = orientation();
        let raw = [
            (-1.0, PHI, 0.0),
            (1.0, PHI, 0.0),
            (-1.0, -PHI, 0.0),
            (1.0, -PHI, 0.0),
            (0.0, -1.0, PHI),
            (0.0, 1.0, PHI),
            (0.0, -1.0, -PHI),
            (0.0, 1.0, -PHI),
            (PHI, 0.0, -1.0),
            (PHI, 0.0, 1.0),
            (-PHI, 0.0, -1.0),
            (-PHI, 0.0, 1.0),
        ];
        let corners = raw.map(|(x, y, z)| rot * DVec3::new(x, y, z).normalize());
        // A point is identified exactly by its integer barycentric weights on icosahedron corners.
        let mut ids: HashMap<Vec<(usize, u32)>, u32> = HashMap::new();
        let mut points = Vec::new();
        let mut face_points = Vec::with_capacity(20);
        for f in ICOSAHEDRON_FACES {
            let mut grid = Vec::new();
            for j in 0..=n {
                for i in 0..=(n - j) {
                    let weights = [(f[0], n - i - j), (f[1], i), (f[2], j)];
                    let mut key: Vec<(usize, u32)> =
                        weights.iter().copied().filter(|&(_, w)| w > 0).collect();
                    key.sort();
                    let id = *ids.entry(key).or_insert_with(|| {
                        let p = weights
                            .iter()
                            .fold(DVec3::ZERO, |acc, &(c, w)| acc + corners[c] * w as f64);
                        points.push(p.normalize());
                        points.len() as u32 - 1
                    });
                    grid.push(id);
                }
            }
            face_points.push(grid);
        }
        let mut set = DirectionSet {
            frequency: n,
            directions: Vec::new(),
            corners,
            face_points,
            points: points.clone(),
            point_direction: vec![(u32::MAX, 0.0); points.len()],
        };
        let areas = set.voronoi_areas();
        // Pair antipodes; the upper one of each pair represents it.
        let mut by_bits: HashMap<[i64; 3], u32> = HashMap::new();
        let quant = |p: DVec3| {
            [
                (p.x * 1e9).round() as i64,
                (p.y * 1e9).round() as i64,
                (p.z * 1e9).round() as i64,
            ]
        };
        for (i, p) in points.iter().enumerate() {
            by_bits.insert(quant(*p), i as u32);
        }
        for (i, p) in points.iter().enumerate() {
            if set.point_direction[i].0 != u32::MAX || !is_upper(*p) {
                continue;
            }
            let anti = by_bits[&quant(-*p)] as usize;
            let index = set.directions.len() as u32;
            set.directions.push(Direction {
                w: *p,
                solid_angle: areas[i],
            });
            set.point_direction[i] = (index, 1.0);
            set.point_direction[anti] = (index, -1.0);
        }
        debug_assert_eq!(set.directions.len() as u32, 5 * n * n + 1);
        set
    }

    pub fn len(&self) -> usize {
        self.directions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.directions.is_empty()
    }

    /// The spherical triangles of the geodesic sphere (point ids, counter-clockwise outside).
    fn triangles(&self) -> Vec<[u32; 3]> {
        let n = self.frequency as usize;
        let mut tris = Vec::new();
        for grid in &self.face_points {
            let at = |i: usize, j: usize| grid[row_start(n, j) + i];
            for j in 0..n {
                for i in 0..(n - j) {
                    tris.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                    if i + j + 1 < n {
                        tris.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                    }
                }
            }
        }
        tris
    }

    /// Area of each point's spherical Voronoi cell: every spherical triangle is split at its
    /// circumcentre into three parts, one per corner (signed, so obtuse triangles still add up).
    fn voronoi_areas(&self) -> Vec<f64> {
        let mut areas = vec![0.0; self.points.len()];
        for t in self.triangles() {
            let [a, b, c] = t.map(|i| self.points[i as usize]);
            let mut o = (b - a).cross(c - a).normalize();
            if o.dot(a + b + c) < 0.0 {
                o = -o;
            }
            let (mab, mbc, mca) = (
                (a + b).normalize(),
                (b + c).normalize(),
                (c + a).normalize(),
            );
            areas[t[0] as usize] += signed_area(a, mab, o) + signed_area(a, o, mca);
            areas[t[1] as usize] += signed_area(b, mbc, o) + signed_area(b, o, mab);
            areas[t[2] as usize] += signed_area(c, mca, o) + signed_area(c, o, mbc);
        }
        areas
    }

    /// The three fixed directions around unit vector `d`, with barycentric weights (>= 0,
    /// summing to 1). A fixed direction finds itself with weight 1.
    pub fn lookup(&self, d: DVec3) -> [DirectionWeight; 3] {
        let d = d.normalize();
        let n = self.frequency as f64;
        // the icosahedron face whose cone holds d: its barycentrics are all >= 0
        let mut best = (0usize, f64::NEG_INFINITY, DVec3::ZERO);
        for (fi, f) in ICOSAHEDRON_FACES.iter().enumerate() {
            let bary = solve3(
                self.corners[f[0]],
                self.corners[f[1]],
                self.corners[f[2]],
                d,
            );
            let worst = bary.min_element();
            if worst > best.1 {
                best = (fi, worst, bary);
            }
        }
        let (face, _, bary) = best;
        let planar = bary.max(DVec3::ZERO) / bary.max(DVec3::ZERO).element_sum();
        let gi = planar.y * n;
        let gj = planar.z * n;
        let nn = self.frequency as i64;
        let i0 = (gi.floor() as i64).clamp(0, nn - 1);
        let j0 = (gj.floor() as i64).clamp(0, nn - 1 - i0);
        let (fi, fj) = (gi - i0 as f64, gj - j0 as f64);
        let grid = &self.face_points[face];
        let at = |i: i64, j: i64| grid[row_start(self.frequency as usize, j as usize) + i as usize];
        let tri = if fi + fj <= 1.0 || i0 + j0 + 1 >= nn {
            [at(i0, j0), at(i0 + 1, j0), at(i0, j0 + 1)]
        } else {
            [at(i0 + 1, j0), at(i0 + 1, j0 + 1), at(i0, j0 + 1)]
        };
        let [p0, p1, p2] = tri.map(|i| self.points[i as usize]);
        let w = solve3(p0, p1, p2, d).max(DVec3::ZERO);
        let w = w / w.element_sum();
        let mut out = [DirectionWeight {
            index: 0,
            sign: 1.0,
            weight: 0.0,
        }; 3];
        for k in 0..3 {
            let (index, sign) = self.point_direction[tri[k] as usize];
            out[k] = DirectionWeight {
                index,
                sign,
                weight: w[k],
            };
        }
        out
    }

    /// The lookup tables of `shaders/common/directions.wgsl`: points (the 12 corners, then every
    /// sphere point) and indices (20 x 3 corner ids, each face's grid of point ids, then per
    /// point its direction index with bit 31 set for -w).
    pub fn gpu_tables(&self) -> (Vec<[f32; 4]>, Vec<u32>) {
        let f = |p: DVec3| [p.x as f32, p.y as f32, p.z as f32, 0.0];
        let points: Vec<[f32; 4]> = self
            .corners
            .iter()
            .map(|&c| f(c))
            .chain(self.points.iter().map(|&p| f(p)))
            .collect();
        let mut index: Vec<u32> = ICOSAHEDRON_FACES
            .iter()
            .flat_map(|t| t.map(|c| c as u32))
            .collect();
        for grid in &self.face_points {
            index.extend_from_slice(grid);
        }
        index.extend(
            self.point_direction
                .iter()
                .map(|&(d, sign)| d | if sign < 0.0 { 1 << 31 } else { 0 }),
        );
        (points, index)
    }

    /// Perturbed ("virtual") direction set `k` >= 1: each direction moved to a point of its own
    /// cell (a cap of the same solid angle), the same for every run. Set 0 is the fixed set.
    pub fn perturbed(&self, k: u32) -> Vec<Direction> {
        if k == 0 {
            return self.directions.clone();
        }
        self.directions
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let mut state = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                    ^ (k as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)
                    ^ 0x2545_F491_4F6C_DD1D;
                let mut next = || {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 11) as f64 / (1u64 << 53) as f64
                };
                let (u, v) = d.frame();
                // uniform in a cap of the cell's solid angle: 1 - cos(theta) = dw / (2 pi)
                let cos_max = 1.0 - d.solid_angle / (2.0 * std::f64::consts::PI);
                let cos_t = 1.0 - next() * (1.0 - cos_max);
                let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                let phi = 2.0 * std::f64::consts::PI * next();
                let w = (d.w * cos_t + (u * phi.cos() + v * phi.sin()) * sin_t).normalize();
                Direction {
                    w,
                    solid_angle: d.solid_angle,
                }
            })
            .collect()
    }

    /// Sum over directions of |n.w_i| dw_i: pi for an exact quadrature.
    pub fn cosine_sum(&self, normal: DVec3) -> f64 {
        self.directions
            .iter()
            .map(|d| normal.dot(d.w).abs() * d.solid_angle)
            .sum()
    }
}

fn row_start(n: usize, j: usize) -> usize {
    // rows j = 0.. have n+1, n, n-1, ... points
    j * (n + 1) - j * j.saturating_sub(1) / 2
}

fn is_upper(p: DVec3) -> bool {
    const EPS: f64 = 1e-12;
    p.z > EPS || (p.z.abs() <= EPS && (p.y > EPS || (p.y.abs() <= EPS && p.x > 0.0)))
}

/// Signed area of the spherical triangle (a, b, c): positive when counter-clockwise seen from
/// outside (Van Oosterom & Strackee).
fn signed_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let det = a.dot(b.cross(c));
    let denom = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * det.atan2(denom)
}

/// Solve d = x a + y b + z c (Cramer's rule).
fn solve3(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> DVec3 {
    let det = a.dot(b.cross(c));
    DVec3::new(d.dot(b.cross(c)), a.dot(d.cross(c)), a.dot(b.cross(d))) / det
}

/// The direction set packed for the GPU (`GpuDirection`: w, its solid angle, and the grid axes u, v).
pub fn gpu_directions(
    directions: &[crate::lightfield::directions::Direction],
) -> Vec<crate::gpu::types::GpuDirection> {
    directions
        .iter()
        .map(|d| {
            let (u, v) = d.frame();
            crate::gpu::types::GpuDirection {
                w: [d.w.x as f32, d.w.y as f32, d.w.z as f32],
                solid_angle: d.solid_angle as f32,
                u: [u.x as f32, u.y as f32, u.z as f32],
                _pad0: 0.0,
                v: [v.x as f32, v.y as f32, v.z as f32],
                _pad1: 0.0,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_geodesic_formula() {
        for n in [1, 2, 5, 10] {
            let set = DirectionSet::geodesic(n);
            assert_eq!(set.points.len() as u32, 10 * n * n + 2);
            assert_eq!(set.len() as u32, 5 * n * n + 1);
        }
    }

    #[test]
    fn weights_sum_to_four_pi_over_both_hemispheres() {
        for n in [1, 3, 10, 20] {
            let set = DirectionSet::geodesic(n);
            let sum: f64 = set.directions.iter().map(|d| 2.0 * d.solid_angle).sum();
            let rel = (sum - 4.0 * std::f64::consts::PI).abs() / (4.0 * std::f64::consts::PI);
            assert!(rel < 1e-6, "n={n}: sum {sum} rel error {rel}");
            assert!(set.directions.iter().all(|d| d.solid_angle > 0.0));
        }
    }

    #[test]
    fn lookup_weights_are_a_partition_of_unity() {
        let set = DirectionSet::geodesic(6);
        let mut state = 0x2545F4914F6CDD1Du64;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..5000 {
            let d = DVec3::new(rnd(), rnd(), rnd());
            if d.length() < 1e-3 {
                continue;
            }
            let taps = set.lookup(d);
            let sum: f64 = taps.iter().map(|t| t.weight).sum();
            assert!(taps.iter().all(|t| t.weight >= 0.0));
            assert!((sum - 1.0).abs() < 1e-12);
            // the weighted fixed directions reproduce d's direction closely
            let mix: DVec3 = taps
                .iter()
                .map(|t| set.directions[t.index as usize].w * t.sign * t.weight)
                .sum();
            assert!(
                mix.normalize().dot(d.normalize()) > 0.99,
                "lookup of {d} is not local"
            );
        }
    }

    #[test]
    fn a_fixed_direction_looks_itself_up_with_weight_one() {
        let set = DirectionSet::geodesic(10);
        for (i, dir) in set.directions.iter().enumerate() {
            for sign in [1.0, -1.0] {
                let taps = set.lookup(dir.w * sign);
                let own = taps
                    .iter()
                    .find(|t| t.index == i as u32 && t.sign == sign)
                    .expect("finds itself");
                assert!(
                    (own.weight - 1.0).abs() < 1e-6,
                    "direction {i}: weight {}",
                    own.weight
                );
            }
        }
    }

    #[test]
    fn perturbed_sets_stay_in_their_cells_and_differ() {
        let set = DirectionSet::geodesic(8);
        let a = set.perturbed(1);
        let b = set.perturbed(2);
        assert_eq!(set.perturbed(0), set.directions);
        assert_eq!(a, set.perturbed(1), "perturbation is repeatable");
        for ((d, p), q) in set.directions.iter().zip(&a).zip(&b) {
            assert!((p.w.length() - 1.0).abs() < 1e-12);
            let cap = (1.0 - d.solid_angle / (2.0 * std::f64::consts::PI)).acos();
            assert!(d.w.dot(p.w).clamp(-1.0, 1.0).acos() <= cap + 1e-9);
            assert!(p.w != q.w);
        }
    }

    #[test]
    fn cosine_quadrature_is_close_to_pi() {
        let set = DirectionSet::geodesic(10);
        for n in [DVec3::X, DVec3::Y, DVec3::new(0.3, -0.5, 0.8).normalize()] {
            let s = set.cosine_sum(n);
            assert!(
                (s / std::f64::consts::PI - 1.0).abs() < 0.02,
                "cosine sum {s}"
            );
        }
    }
}
