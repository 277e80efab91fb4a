//! The diffuse texel atlas: each planar face gets a rectangle of texels at a fixed texel
//! density, with one texel of padding on every side so that bilinear lookups never reach a
//! neighbour's texels. Rectangles are packed on shelves into one linear array. Every texel of a
//! rectangle gets a sample point on its face: its centre when that lies on the face, else the
//! nearest point of the face (so the padding carries the rim's light), and a coverage weight
//! (the share of the texel the face covers) for power sums.

use super::buried::{self, ChartTexel, Occluders};
use super::{PlanarFace, PreparedTriangle};
use crate::error::{Result, VlfError};
use crate::gpu::types::NO_FACE;
use crate::scene::{Material, Texture};
use glam::{DVec2, DVec3};

pub const PADDING: u32 = 1;

#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChartRect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

pub struct Atlas {
    pub width: u32,
    pub height: u32,
    /// per texel: sample point (normalised space) and face id bits (NO_FACE for unused texels)
    pub points: Vec<[f32; 4]>,
    /// per texel: share of the texel covered by its face, in [0, 1]
    pub coverage: Vec<f32>,
    /// texels that belong to a chart (padding included)
    pub charted_texels: u64,
    /// per texel: the `map_Kd` factor (only when some face has a diffuse texture)
    pub texture_albedo: Option<Vec<[f32; 4]>>,
    /// per texel: the `map_Ke` factor (only when some face has an emission texture)
    pub texture_emission: Option<Vec<[f32; 4]>>,
    /// per texel: the specular texture's factor on `mirror` (rgb) and GGX alpha (w) (only when
    /// some face has a specular texture, `Material::specular_texture`)
    pub texture_specular: Option<Vec<[f32; 4]>>,
    /// texels whose sample point lay under other geometry and moved to an open point of their
    /// face (src/prepare/buried.rs)
    pub unburied_texels: u64,
    /// rim texels whose sample point lay beyond a surface crossing their face (under the floor
    /// that a skirting board runs through) and moved back to the face's open side (buried.rs)
    pub rejoined_rims: u64,
    /// per texel: the share of its face's area in it that lies open, not under other geometry
    /// (src/prepare/buried.rs; 1 where its sample point is open): the power balance weights
    /// its area by it
    pub open_share: Vec<f32>,
}

impl Atlas {
    pub fn texel_count(&self) -> usize {
        self.points.len()
    }

    pub fn build(
        faces: &mut [PlanarFace],
        positions: &[DVec3],
        triangles: &[PreparedTriangle],
        density: f64,
        materials: &[Material],
        textures: &[Texture],
        occluders: Option<&Occluders>,
    ) -> Result<Atlas> {
        let by_face = FaceTriangles::of(faces.len(), positions, triangles);
        let textured = |map: fn(&Material) -> Option<u32>| {
            (0..faces.len())
                .any(|f| by_face.has_uv(f) && map(&materials[faces[f].material as usize]).is_some())
        };
        let albedo_textured = textured(|m| m.diffuse_texture);
        let emission_textured = textured(|m| m.emission_texture);
        let specular_textured = textured(|m| m.specular_texture);
        let local_min = size_charts(faces, &by_face.corners, density)?;
        let (width, height) = pack_shelves(faces);
        let texels = width as u64 * height as u64;
        if texels > u32::MAX as u64 / 2 {
            return Err(VlfError::Parameter {
                name: "texel-density",
                message: format!("the atlas would hold {texels} texels; lower the texel density"),
            });
        }
        let mut atlas = Atlas {
            width,
            height,
            points: vec![[0.0, 0.0, 0.0, f32::from_bits(NO_FACE)]; texels as usize],
            coverage: vec![0.0f32; texels as usize],
            charted_texels: 0,
            texture_albedo: albedo_textured.then(|| vec![[1.0f32; 4]; texels as usize]),
            texture_emission: emission_textured.then(|| vec![[1.0f32; 4]; texels as usize]),
            texture_specular: specular_textured.then(|| vec![[1.0f32; 4]; texels as usize]),
            unburied_texels: 0,
            rejoined_rims: 0,
            open_share: vec![1.0f32; texels as usize],
        };
        for (fi, f) in faces.iter_mut().enumerate() {
            let lo = local_min[fi];
            // origin: the plane point whose face coordinates are `lo`
            f.origin = f.normal * f.plane_offset + f.axis_a * lo.x + f.axis_b * lo.y;
            atlas.charted_texels += f.atlas.w as u64 * f.atlas.h as u64;
        }
        let faces: &[PlanarFace] = faces;
        // charts are sampled in parallel (the buried-point test casts rays), a batch of faces at
        // a time so that the samples in flight stay small, and written in order
        let workers = crate::parallel::threads();
        for batch in (0..faces.len()).step_by(CHART_BATCH) {
            let batch = batch..(batch + CHART_BATCH).min(faces.len());
            let next = std::sync::atomic::AtomicUsize::new(batch.start);
            let mut charts: Vec<(usize, ChartSamples)> = std::thread::scope(|scope| {
                let work = || {
                    let mut done = Vec::new();
                    loop {
                        let fi = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if fi >= batch.end {
                            return done;
                        }
                        done.push((
                            fi,
                            sample_chart(fi, &faces[fi], &by_face, density, occluders),
                        ));
                    }
                };
                let handles: Vec<_> = (0..workers).map(|_| scope.spawn(work)).collect();
                handles
                    .into_iter()
                    .flat_map(|h| h.join().expect("a chart sampler panicked"))
                    .collect()
            });
            charts.sort_by_key(|c| c.0);
            for (fi, chart) in charts {
                let f = &faces[fi];
                let material = &materials[f.material as usize];
                let texture = |which: Option<u32>| {
                    which
                        .filter(|_| by_face.has_uv(fi))
                        .map(|t| &textures[t as usize])
                };
                let maps = [
                    texture(material.diffuse_texture),
                    texture(material.emission_texture),
                    texture(material.specular_texture),
                ];
                atlas.unburied_texels += chart.moved as u64;
                atlas.rejoined_rims += chart.rejoined as u64;
                atlas.write_chart(fi, f, &by_face, maps, chart);
            }
        }
        Ok(atlas)
    }

    /// Writes the sample points, coverage, open share and texture factors of face `fi`'s chart.
    /// `maps`: the face's map_Kd, map_Ke and specular texture (when it has both map and texture
    /// coordinates).
    fn write_chart(
        &mut self,
        fi: usize,
        f: &PlanarFace,
        by_face: &FaceTriangles,
        maps: [Option<&Texture>; 3],
        chart: ChartSamples,
    ) {
        let r = f.atlas;
        let uvs = &by_face.uvs[fi];
        let tris2 = &chart.triangles;
        let to_space = |s: DVec2| f.origin + f.axis_a * s.x + f.axis_b * s.y;
        let texels = chart.texels;
        for j in 0..r.h {
            for i in 0..r.w {
                let (sample, cover, tri) = texels[(j * r.w + i) as usize];
                let p = to_space(sample);
                let idx = ((r.y + j) * self.width + r.x + i) as usize;
                if maps.iter().any(Option::is_some) {
                    let uv = interpolate_uv(&tris2[tri], uvs[tri].unwrap(), sample);
                    let outs = [
                        &mut self.texture_albedo,
                        &mut self.texture_emission,
                        &mut self.texture_specular,
                    ];
                    for (k, (map, out)) in maps.iter().zip(outs).enumerate() {
                        if let (Some(map), Some(out)) = (map, out.as_mut()) {
                            let c = map.sample(uv);
                            // the specular texture's alpha channel is its GGX alpha
                            let w = if k == 2 { map.coverage(uv) } else { 1.0 };
                            out[idx] = [c[0], c[1], c[2], w];
                        }
                    }
                }
                self.points[idx] = [
                    p.x as f32,
                    p.y as f32,
                    p.z as f32,
                    f32::from_bits(fi as u32),
                ];
                self.coverage[idx] = cover as f32;
                self.open_share[idx] = chart.open_share[(j * r.w + i) as usize];
            }
        }
    }
}

/// Faces whose charts are sampled at once (in parallel), before they are written.
const CHART_BATCH: usize = 8192;

/// One chart's texels (row-major), their open shares (buried.rs) and how many moved.
struct ChartSamples {
    texels: Vec<ChartTexel>,
    open_share: Vec<f32>,
    moved: usize,
    /// rim points moved back across a surface that crosses the face (buried.rs)
    rejoined: usize,
    /// the face's triangles in chart coordinates (`FaceTriangles::chart_triangles`)
    triangles: Vec<[DVec2; 3]>,
}

/// Sample point, coverage and triangle of every texel of face `fi`'s chart; with `occluders`,
/// buried points moved (src/prepare/buried.rs).
fn sample_chart(
    fi: usize,
    f: &PlanarFace,
    by_face: &FaceTriangles,
    density: f64,
    occluders: Option<&Occluders>,
) -> ChartSamples {
    let tris2 = by_face.chart_triangles(fi, f);
    let bounds: Vec<(DVec2, DVec2)> = tris2
        .iter()
        .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
        .collect();
    let r = f.atlas;
    let mut texels: Vec<ChartTexel> = (0..r.h)
        .flat_map(|j| (0..r.w).map(move |i| (i, j)))
        .map(|(i, j)| {
            let centre = DVec2::new((i as f64 + 0.5) / density, (j as f64 + 0.5) / density);
            sample_texel(&tris2, &bounds, centre, 0.5 / density)
        })
        .collect();
    let mut open_share = vec![1.0f32; texels.len()];
    let (moved, rejoined) = occluders.map_or((0, 0), |occluders| {
        let inside = |p: DVec2| {
            (0..tris2.len()).find(|&t| {
                bounds[t].0.cmple(p).all() && bounds[t].1.cmpge(p).all() && inside(&tris2[t], p)
            })
        };
        let chart = buried::Chart {
            size: (r.w, r.h),
            face: fi as u32,
            f,
            density,
        };
        let to_space = |s: DVec2| f.origin + f.axis_a * s.x + f.axis_b * s.y;
        let moved = buried::unbury(
            &mut texels,
            &mut open_share,
            &chart,
            occluders,
            inside,
            to_space,
        );
        let rejoined = buried::rejoin_cut_rims(
            &mut texels,
            &open_share,
            &chart,
            &tris2,
            occluders,
            inside,
            to_space,
        );
        (moved, rejoined)
    });
    ChartSamples {
        texels,
        open_share,
        moved,
        rejoined,
        triangles: tris2,
    }
}

/// Each face's triangles: corners and texture coordinates (None where a triangle has none).
struct FaceTriangles {
    corners: Vec<Vec<[DVec3; 3]>>,
    uvs: Vec<Vec<Option<[[f32; 2]; 3]>>>,
}

impl FaceTriangles {
    fn of(faces: usize, positions: &[DVec3], triangles: &[PreparedTriangle]) -> FaceTriangles {
        let mut by_face = FaceTriangles {
            corners: vec![Vec::new(); faces],
            uvs: vec![Vec::new(); faces],
        };
        for t in triangles {
            by_face.corners[t.face as usize].push(t.vertices.map(|i| positions[i as usize]));
            by_face.uvs[t.face as usize].push(t.uv);
        }
        by_face
    }

    /// Face `fi`'s triangles in its chart's coordinates (along its axes from its origin).
    fn chart_triangles(&self, fi: usize, f: &PlanarFace) -> Vec<[DVec2; 3]> {
        self.corners[fi]
            .iter()
            .map(|t| t.map(|p| DVec2::new(f.axis_a.dot(p - f.origin), f.axis_b.dot(p - f.origin))))
            .collect()
    }

    /// Whether every triangle of face `f` has texture coordinates.
    fn has_uv(&self, f: usize) -> bool {
        self.uvs[f].iter().all(|u| u.is_some())
    }
}

/// Sets each face's chart size (its extent at `density`, padding included) and returns the
/// face coordinates of each chart's corner. A chart over 2^15 texels a side is an error.
fn size_charts(
    faces: &mut [PlanarFace],
    corners: &[Vec<[DVec3; 3]>],
    density: f64,
) -> Result<Vec<DVec2>> {
    let mut local_min = Vec::with_capacity(faces.len());
    for (f, tris) in faces.iter_mut().zip(corners) {
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for p in tris.iter().flatten() {
            let q = DVec2::new(f.axis_a.dot(*p), f.axis_b.dot(*p));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let size = ((hi - lo) * density).ceil().max(DVec2::ONE);
        let w = size.x as u64 + 2 * PADDING as u64;
        let h = size.y as u64 + 2 * PADDING as u64;
        if w > 1 << 15 || h > 1 << 15 {
            return Err(VlfError::Parameter {
                name: "texel-density",
                message: format!("a face would need {w} x {h} texels; lower the texel density"),
            });
        }
        f.atlas.w = w as u32;
        f.atlas.h = h as u32;
        local_min.push(lo - DVec2::splat(PADDING as f64 / density));
    }
    Ok(local_min)
}

/// Shelf packing, tallest first. Returns the atlas size and sets each face's rectangle.
fn pack_shelves(faces: &mut [PlanarFace]) -> (u32, u32) {
    let area: u64 = faces
        .iter()
        .map(|f| f.atlas.w as u64 * f.atlas.h as u64)
        .sum();
    let widest = faces.iter().map(|f| f.atlas.w).max().unwrap_or(1);
    let width = ((area as f64 * 1.1).sqrt().ceil() as u32).max(widest);
    let mut order: Vec<usize> = (0..faces.len()).collect();
    order.sort_by_key(|&i| (std::cmp::Reverse(faces[i].atlas.h), i));
    let (mut x, mut y, mut shelf_h) = (0u32, 0u32, 0u32);
    for i in order {
        let r = &mut faces[i].atlas;
        if x + r.w > width {
            y += shelf_h;
            x = 0;
            shelf_h = 0;
        }
        r.x = x;
        r.y = y;
        x += r.w;
        shelf_h = shelf_h.max(r.h);
    }
    (width, (y + shelf_h).max(1))
}

fn inside(t: &[DVec2; 3], p: DVec2) -> bool {
    let cross = |a: DVec2, b: DVec2| a.x * b.y - a.y * b.x;
    let d0 = cross(t[1] - t[0], p - t[0]);
    let d1 = cross(t[2] - t[1], p - t[1]);
    let d2 = cross(t[0] - t[2], p - t[2]);
    (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)
}

fn closest_on_segment(a: DVec2, b: DVec2, p: DVec2) -> DVec2 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(1e-300)).clamp(0.0, 1.0);
    a + ab * t
}

/// Texture coordinates at point p of triangle t (barycentric interpolation).
fn interpolate_uv(t: &[DVec2; 3], uv: [[f32; 2]; 3], p: DVec2) -> [f32; 2] {
    let cross = |a: DVec2, b: DVec2| a.x * b.y - a.y * b.x;
    let area = cross(t[1] - t[0], t[2] - t[0]);
    if area.abs() < 1e-300 {
        return uv[0];
    }
    let l1 = cross(p - t[0], t[2] - t[0]) / area;
    let l2 = cross(t[1] - t[0], p - t[0]) / area;
    let l0 = 1.0 - l1 - l2;
    std::array::from_fn(|k| {
        (uv[0][k] as f64 * l0 + uv[1][k] as f64 * l1 + uv[2][k] as f64 * l2) as f32
    })
}

/// Sample point, coverage and the triangle holding the sample point, for the texel centred at
/// `centre` with half-size `half`.
/// `bounds` holds each triangle's bounding box (min, max): only triangles whose box meets the
/// texel are tested for coverage, which keeps faces of many triangles cheap.
fn sample_texel(
    tris: &[[DVec2; 3]],
    bounds: &[(DVec2, DVec2)],
    centre: DVec2,
    half: f64,
) -> (DVec2, f64, usize) {
    const SUB: usize = 4;
    let (texel_lo, texel_hi) = (centre - DVec2::splat(half), centre + DVec2::splat(half));
    let near: Vec<usize> = (0..tris.len())
        .filter(|&t| bounds[t].0.cmple(texel_hi).all() && bounds[t].1.cmpge(texel_lo).all())
        .collect();
    let mut covered = 0;
    for sj in 0..SUB {
        for si in 0..SUB {
            let off = DVec2::new(
                (si as f64 + 0.5) / SUB as f64 * 2.0 - 1.0,
                (sj as f64 + 0.5) / SUB as f64 * 2.0 - 1.0,
            );
            let p = centre + off * half;
            if near.iter().any(|&t| inside(&tris[t], p)) {
                covered += 1;
            }
        }
    }
    let cover = covered as f64 / (SUB * SUB) as f64;
    if let Some(&t) = near.iter().find(|&&t| inside(&tris[t], centre)) {
        return (centre, cover, t);
    }
    // nearest point of the face, moved inside it (`inset`)
    let mut best = (f64::INFINITY, centre, 0, 0);
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let q = closest_on_segment(t[k], t[(k + 1) % 3], centre);
            let d = q.distance_squared(centre);
            if d < best.0 {
                best = (d, q, ti, k);
            }
        }
    }
    let (_, q, tri, edge) = best;
    let holding = |p: DVec2| {
        (0..tris.len()).find(|&t| {
            bounds[t].0.cmple(p).all() && bounds[t].1.cmpge(p).all() && inside(&tris[t], p)
        })
    };
    let (p, holder) = inset(&tris[tri], edge, q, half * 0.02, holding);
    (p, cover, holder.unwrap_or(tri))
}

/// Point `q` on edge `edge` (from corner `edge` to the next) of triangle `t`, moved `by` into the
/// face, and the face's triangle that holds it (`holding`; None for `t`): straight away from the
/// edge, and along it too where `q` is one of its ends; where that leaves the face (a sharp
/// corner), toward `t`'s middle. Away from the edge, not toward the middle as before: the point
/// must lie clear of a surface standing on the edge (a moulding's cap on the wall it meets),
/// farther than the shadow rays' shortest hit (1e-5 of the normalised scene), or those rays
/// start behind that surface. A long thin triangle's middle lies almost along its long edge: a
/// cap's rim points, moved toward it, stayed a millionth of a metre from the wall behind them,
/// and their shadow rays passed behind the wall to the sky (`tests/buried.rs`, the cavity).
fn inset(
    t: &[DVec2; 3],
    edge: usize,
    q: DVec2,
    by: f64,
    holding: impl Fn(DVec2) -> Option<usize>,
) -> (DVec2, Option<usize>) {
    let (a, b, c) = (t[edge], t[(edge + 1) % 3], t[(edge + 2) % 3]);
    let along = (b - a).normalize_or_zero();
    let mut inward = along.perp();
    if inward.dot(c - a) < 0.0 {
        inward = -inward;
    }
    let mut p = q + inward * by;
    if q.distance_squared(a) < 1e-24 {
        p += along * by;
    } else if q.distance_squared(b) < 1e-24 {
        p -= along * by;
    }
    match holding(p) {
        Some(holder) => (p, Some(holder)),
        None => {
            let to_c = (a + b + c) / 3.0 - q;
            (
                q + to_c.normalize_or_zero() * by.min(to_c.length() * 0.5),
                None,
            )
        }
    }
}
