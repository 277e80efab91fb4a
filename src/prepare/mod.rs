//! Prepare: from a loaded [`Scene`] to what the GPU stages consume. Normalises the scene into
//! the unit sphere, groups coplanar connected triangles into planar faces (charts), adds the
//! back side of two-sided surfaces as faces of their own, and lays out the diffuse texel atlas
//! (`atlas.rs`).

pub mod atlas;
pub mod buried;
pub mod packing;

use crate::bvh::SceneBvh;
use crate::error::{Result, VlfError};
use crate::parallel::map_indices;
pub use crate::scene::normalise::{normalise, Normalisation, NORMALISED_RADIUS};
use crate::scene::{Material, Scene};
use glam::DVec3;

/// Triangles whose normals differ by less than this from a chart's first triangle join it.
pub const PLANAR_ANGLE_DEG: f64 = 2.0;

/// A planar face: a chart of the atlas, one material, one normal.
#[derive(Clone, Debug)]
pub struct PlanarFace {
    pub normal: DVec3,
    /// n . p for points p on the plane
    pub plane_offset: f64,
    pub axis_a: DVec3,
    pub axis_b: DVec3,
    /// corner of the texel rectangle (padding included)
    pub origin: DVec3,
    pub material: u32,
    pub triangles: Vec<u32>,
    pub area: f64,
    pub atlas: atlas::ChartRect,
    /// the other side of a two-sided surface
    pub twin: Option<u32>,
    /// true for the generated back side of a two-sided surface
    pub is_back: bool,
}

#[derive(Clone, Copy, Debug)]
pub struct PreparedTriangle {
    pub vertices: [u32; 3],
    pub face: u32,
    pub uv: Option<[[f32; 2]; 3]>,
}

pub struct PreparedScene {
    pub normalisation: Normalisation,
    /// vertex positions in normalised space
    pub positions: Vec<DVec3>,
    pub triangles: Vec<PreparedTriangle>,
    pub faces: Vec<PlanarFace>,
    pub materials: Vec<Material>,
    pub atlas: atlas::Atlas,
    pub texel_density: f64,
    pub warnings: Vec<String>,
    /// the scene's textures where some material cuts holes (`Material::cutout`), for the
    /// stages that test surfaces (`lightfield::textures::SurfaceTextures::cutouts`); empty
    /// otherwise
    pub cutout_textures: Vec<crate::scene::Texture>,
    /// the BVH of every triangle (generated backs included), with texture coordinates where
    /// some material cuts holes: the buried-texel test walks it here, and propagation's direct
    /// light and rim rays trace it on the GPU (built once, `scene_bvh`; `propagate` empties it
    /// once it is uploaded)
    pub bvh: SceneBvh,
    /// the preparation's steps and their seconds (the propagation report's setup splits by them)
    pub laps: crate::stats::Laps,
}

impl PreparedScene {
    /// `texel_density` is in texels per unit length of the normalised scene.
    pub fn new(scene: &Scene, texel_density: f64) -> Result<PreparedScene> {
        if !(texel_density.is_finite() && texel_density > 0.0) {
            return Err(VlfError::Parameter {
                name: "texel-density",
                message: format!("{texel_density} must be > 0"),
            });
        }
        let mut laps = crate::stats::Laps::default();
        let normalisation = normalise(&scene.positions);
        let positions: Vec<DVec3> = scene
            .positions
            .iter()
            .map(|&p| normalisation.to_unit(p))
            .collect();
        let mut warnings = scene.warnings.clone();
        let mut faces = group_charts(scene, &positions);
        let mut triangles: Vec<PreparedTriangle> = Vec::new();
        for (fi, f) in faces.iter().enumerate() {
            for &t in &f.triangles {
                let tri = &scene.triangles[t as usize];
                triangles.push(PreparedTriangle {
                    vertices: tri.vertices,
                    face: fi as u32,
                    uv: tri.uv,
                });
            }
        }
        // The back of a two-sided surface is a face of its own, wound the other way.
        let front_count = faces.len();
        for fi in 0..front_count {
            if !scene.materials[faces[fi].material as usize].two_sided {
                continue;
            }
            let back_id = faces.len() as u32;
            let mut back = faces[fi].clone();
            back.normal = -back.normal;
            back.plane_offset = -back.plane_offset;
            back.axis_b = back.normal.cross(back.axis_a);
            back.is_back = true;
            back.twin = Some(fi as u32);
            faces[fi].twin = Some(back_id);
            for &t in &faces[fi].triangles {
                let tri = &scene.triangles[t as usize];
                let [a, b, c] = tri.vertices;
                let uv = tri.uv.map(|[ua, ub, uc]| [ua, uc, ub]);
                triangles.push(PreparedTriangle {
                    vertices: [a, c, b],
                    face: back_id,
                    uv,
                });
            }
            faces.push(back);
        }
        laps.lap("faces");
        let cutouts = scene.materials.iter().any(|m| m.cutout.is_some());
        let bvh = scene_bvh(&positions, &triangles, cutouts);
        laps.lap("BVH");
        let occluders = buried::Occluders::new(&bvh, &faces);
        let atlas = atlas::Atlas::build(
            &mut faces,
            &positions,
            &triangles,
            texel_density,
            &scene.materials,
            &scene.textures,
            Some(&occluders),
        )?;
        laps.lap("atlas");
        let small = faces
            .iter()
            .filter(|f| f.atlas.w <= 3 && f.atlas.h <= 3)
            .count();
        if small > 0 {
            warnings.push(format!(
                "{small} face(s) are smaller than one texel at texel density {texel_density}: their light is held by the padding texels only"
            ));
        }
        Ok(PreparedScene {
            normalisation,
            positions,
            triangles,
            faces,
            materials: scene.materials.clone(),
            atlas,
            texel_density,
            warnings,
            cutout_textures: match cutouts {
                true => scene.textures.clone(),
                false => Vec::new(),
            },
            bvh,
            laps,
        })
    }

    pub fn material_of(&self, face: usize) -> &Material {
        &self.materials[self.faces[face].material as usize]
    }
}

/// The BVH of the prepared triangles; texture coordinates only where some material cuts holes
/// (for shaders/common/coverage.wgsl's test), zero otherwise.
fn scene_bvh(positions: &[DVec3], triangles: &[PreparedTriangle], cutouts: bool) -> SceneBvh {
    let corners: Vec<[glam::Vec3; 3]> = map_indices(triangles.len(), |i| {
        triangles[i]
            .vertices
            .map(|v| positions[v as usize].as_vec3())
    });
    let uv = |i: usize| match cutouts {
        true => triangles[i].uv.unwrap_or([[0.0; 2]; 3]),
        false => [[0.0; 2]; 3],
    };
    let (nodes, triangles) = crate::bvh::bvh_triangles(&corners, |i| triangles[i].face, uv);
    SceneBvh { nodes, triangles }
}

fn triangle_geometry(positions: &[DVec3], v: [u32; 3]) -> (DVec3, f64) {
    let [a, b, c] = v.map(|i| positions[i as usize]);
    let cross = (b - a).cross(c - a);
    (cross.normalize_or_zero(), cross.length() * 0.5)
}

/// An undirected edge as one sortable key.
fn edge_key(a: u32, b: u32) -> u64 {
    ((a.min(b) as u64) << 32) | a.max(b) as u64
}

/// Flood-fill triangles across shared edges into planar charts of one material.
fn group_charts(scene: &Scene, positions: &[DVec3]) -> Vec<PlanarFace> {
    let cos_tol = PLANAR_ANGLE_DEG.to_radians().cos();
    let edges = EdgeRuns::of(
        &scene.triangles,
        scene.positions.len(),
        crate::parallel::threads(),
    );
    let mut chart_of = vec![u32::MAX; scene.triangles.len()];
    let mut charts: Vec<(u32, Vec<u32>)> = Vec::new();
    for seed in 0..scene.triangles.len() {
        if chart_of[seed] != u32::MAX {
            continue;
        }
        let chart = charts.len() as u32;
        let material = scene.triangles[seed].material;
        let (seed_normal, _) = triangle_geometry(positions, scene.triangles[seed].vertices);
        let mut members = vec![seed as u32];
        chart_of[seed] = chart;
        let mut k = 0;
        while k < members.len() {
            let t = members[k] as usize;
            k += 1;
            for e in 0..3 {
                let sharing = edges.sharing(t, e);
                // an edge that a third surface meets (a wall standing on the line where two
                // floor triangles meet) bounds the chart: one chart across it would blend the
                // texels of both sides of that wall in its lookups, light through the wall
                if sharing.len() > 2 {
                    continue;
                }
                for &other in sharing {
                    let o = other as usize;
                    if chart_of[o] != u32::MAX || scene.triangles[o].material != material {
                        continue;
                    }
                    let (n, _) = triangle_geometry(positions, scene.triangles[o].vertices);
                    if n.dot(seed_normal) >= cos_tol {
                        chart_of[o] = chart;
                        members.push(other);
                    }
                }
            }
        }
        charts.push((material, members));
    }
    make_faces(scene, positions, charts)
}

/// Every triangle edge, grouped with the edges of other triangles between the same two
/// vertices: `sharing(t, e)` lists, in triangle order, the triangles whose edge runs between
/// triangle t's vertices e and e + 1 (t itself included). (A hash map of vectors spent most of
/// its time hashing and allocating at a million triangles; binary searches of the sorted edges
/// most of theirs missing the cache at five million.)
struct EdgeRuns {
    /// the triangles, edge by edge, sorted by edge
    triangles: Vec<u32>,
    /// where each triangle edge's run starts in `triangles` (3 per triangle), and its length
    runs: Vec<(u32, u32)>,
}

impl EdgeRuns {
    /// On the CPU's threads: the edges are bucketed by their lower vertex, one bucket a thread
    /// (it gathers, sorts and finds the runs of its own edges, which no other bucket shares), and
    /// the buckets joined in order: the same runs as one sort of all edges gives, for any
    /// number of `buckets`.
    fn of(triangles: &[crate::scene::Triangle], vertices: usize, buckets: usize) -> EdgeRuns {
        let key_of = |slot: usize| {
            let v = triangles[slot / 3].vertices;
            edge_key(v[slot % 3], v[(slot % 3 + 1) % 3])
        };
        let slots = triangles.len() * 3;
        let buckets = buckets.clamp(1, u16::MAX as usize) as u64;
        let vertices = vertices.max(1) as u64;
        let bucket: Vec<u16> = map_indices(slots, |slot| {
            ((key_of(slot) >> 32) * buckets / vertices).min(buckets - 1) as u16
        });
        let sorted: Vec<Vec<(u64, u32)>> = std::thread::scope(|scope| {
            let sorting: Vec<_> = (0..buckets as u16)
                .map(|b| {
                    let (bucket, key_of) = (&bucket, &key_of);
                    scope.spawn(move || {
                        let mut own: Vec<(u64, u32)> = (0..slots)
                            .filter(|&slot| bucket[slot] == b)
                            .map(|slot| (key_of(slot), slot as u32))
                            .collect();
                        own.sort_unstable();
                        own
                    })
                })
                .collect();
            (sorting.into_iter())
                .map(|h| h.join().expect("an edge sorter panicked"))
                .collect()
        });
        let runs = bucket_runs(&sorted, slots);
        let triangles = sorted.iter().flatten().map(|e| e.1 / 3).collect();
        EdgeRuns { triangles, runs }
    }

    fn sharing(&self, triangle: usize, edge: usize) -> &[u32] {
        let (start, len) = self.runs[triangle * 3 + edge];
        &self.triangles[start as usize..(start + len) as usize]
    }
}

/// Where each triangle edge's run of equal edges starts in the joined `sorted` buckets, and its
/// length, found a bucket a thread (slots are unique, so each is written once).
fn bucket_runs(sorted: &[Vec<(u64, u32)>], slots: usize) -> Vec<(u32, u32)> {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    let packed: Vec<AtomicU64> = (0..slots).map(|_| AtomicU64::new(0)).collect();
    let mut offset = 0;
    std::thread::scope(|scope| {
        for edges in sorted {
            let (packed, first) = (&packed, offset);
            offset += edges.len();
            scope.spawn(move || {
                let mut start = 0;
                while start < edges.len() {
                    let key = edges[start].0;
                    let end = start + edges[start..].iter().take_while(|e| e.0 == key).count();
                    let run = ((first + start) as u64) << 32 | (end - start) as u64;
                    for e in &edges[start..end] {
                        packed[e.1 as usize].store(run, Relaxed);
                    }
                    start = end;
                }
            });
        }
    });
    map_indices(slots, |slot| {
        let run = packed[slot].load(Relaxed);
        ((run >> 32) as u32, run as u32)
    })
}

/// The planar faces of `charts` (material, triangles), made on the CPU's threads, in order.
fn make_faces(scene: &Scene, positions: &[DVec3], charts: Vec<(u32, Vec<u32>)>) -> Vec<PlanarFace> {
    let threads = crate::parallel::threads();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let made: Vec<Vec<(usize, PlanarFace)>> = std::thread::scope(|scope| {
        let work = || {
            let mut done = Vec::new();
            loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some((material, members)) = charts.get(i) else {
                    return done;
                };
                done.push((i, make_face(scene, positions, *material, members.clone())));
            }
        };
        let handles: Vec<_> = (0..threads).map(|_| scope.spawn(work)).collect();
        (handles.into_iter())
            .map(|h| h.join().expect("a face maker panicked"))
            .collect()
    });
    let mut faces: Vec<(usize, PlanarFace)> = made.into_iter().flatten().collect();
    faces.sort_unstable_by_key(|f| f.0);
    faces.into_iter().map(|f| f.1).collect()
}

fn make_face(scene: &Scene, positions: &[DVec3], material: u32, triangles: Vec<u32>) -> PlanarFace {
    let mut weighted = DVec3::ZERO;
    let mut centroid = DVec3::ZERO;
    let mut area = 0.0;
    // boundary edges (used by one triangle of the chart) orient the chart: the longest one
    // gives the first axis, so rectangles map to axis-aligned texel rectangles
    let mut edge_use: Vec<u64> = Vec::with_capacity(triangles.len() * 3);
    for &t in &triangles {
        let v = scene.triangles[t as usize].vertices;
        for k in 0..3 {
            edge_use.push(edge_key(v[k], v[(k + 1) % 3]));
        }
    }
    edge_use.sort_unstable();
    let boundary = |key: u64| {
        let first = edge_use.partition_point(|&e| e < key);
        edge_use.get(first + 1) != Some(&key)
    };
    let mut longest = (0.0, DVec3::X);
    for &t in &triangles {
        let v = scene.triangles[t as usize].vertices;
        let (n, a) = triangle_geometry(positions, v);
        weighted += n * a;
        area += a;
        let [p0, p1, p2] = v.map(|i| positions[i as usize]);
        centroid += (p0 + p1 + p2) / 3.0 * a;
        for k in 0..3 {
            let (i, j) = (v[k], v[(k + 1) % 3]);
            if !boundary(edge_key(i, j)) {
                continue;
            }
            let (x, y) = (positions[i as usize], positions[j as usize]);
            let l = (y - x).length();
            if l > longest.0 {
                longest = (l, (y - x) / l);
            }
        }
    }
    let normal = weighted.normalize();
    let centroid = centroid / area;
    let axis_a = (longest.1 - normal * normal.dot(longest.1)).normalize();
    let axis_b = normal.cross(axis_a);
    PlanarFace {
        normal,
        plane_offset: normal.dot(centroid),
        axis_a,
        axis_b,
        origin: centroid,
        material,
        triangles,
        area,
        atlas: atlas::ChartRect::default(),
        twin: None,
        is_back: false,
    }
}

#[cfg(test)]
mod tests {
    use super::{edge_key, EdgeRuns};
    use crate::scene::Triangle;

    /// The edge runs made in buckets on threads list, for every triangle edge, the triangles
    /// that one sorted list of all edges gives (in triangle order, itself included), on 1, 3
    /// and 8 buckets: a mesh of random triangles over few vertices, so that edges are shared
    /// by two, three and more triangles.
    #[test]
    fn the_edge_runs_are_those_of_one_sort_on_any_number_of_buckets() {
        let mut random = crate::stats::seeded(99);
        let mut next = |n: u64| random(n) as u32;
        let vertices = 400;
        let triangles: Vec<Triangle> = (0..30_000)
            .map(|_| Triangle {
                vertices: [next(vertices), next(vertices), next(vertices)],
                material: 0,
                uv: None,
            })
            .collect();
        let mut all: Vec<(u64, u32)> = (0..triangles.len() * 3)
            .map(|slot| {
                let v = triangles[slot / 3].vertices;
                (edge_key(v[slot % 3], v[(slot % 3 + 1) % 3]), slot as u32)
            })
            .collect();
        all.sort_unstable();
        let shared = |key: u64| -> Vec<u32> {
            (all.iter())
                .filter(|e| e.0 == key)
                .map(|e| e.1 / 3)
                .collect()
        };
        for buckets in [1, 3, 8] {
            let runs = EdgeRuns::of(&triangles, vertices as usize, buckets);
            for slot in (0..triangles.len() * 3).step_by(97) {
                let v = triangles[slot / 3].vertices;
                let key = edge_key(v[slot % 3], v[(slot % 3 + 1) % 3]);
                assert_eq!(
                    runs.sharing(slot / 3, slot % 3),
                    shared(key).as_slice(),
                    "{buckets} buckets, edge slot {slot}"
                );
            }
        }
        assert!(
            all.windows(3).any(|w| w[0].0 == w[2].0),
            "no edge shared three times"
        );
    }
}
