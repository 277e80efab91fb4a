//! Texels buried under other geometry. A model's wall runs on behind the picture frames, the
//! skirting and the stairs' stringer that stand on it; a painting runs on under its frame. A
//! texel whose sample point lies there receives no light, and the bilinear lookups of the
//! visible surface beside it (the renderer's and propagation's) blend that darkness a texel
//! deep into what is seen: on the Wooden Staircase (every junction of that kind, texels of
//! 10 cm) direct light alone came out 4.6% dark within two pixels of an edge.
//!
//! A point is buried when every one of five rays from it (along its face's normal, and four
//! tilted 60 degrees from it) meets a cover: other geometry within a quarter of a texel (half a
//! texel along the tilted ones), a cover lying on the face; or the inside of a surface within
//! eight texels (sixteen), the face lying under a solid object that stands on it (a stair on the
//! wall, a block on the floor: its bottom lies in the face's plane, where no ray meets it).
//! Sides are the modelled ones: the generated backs of two-sided surfaces are passed by. A
//! corner, where a floor meets a wall, is open above and is not buried; nor is a point under a
//! table. A buried texel that borders an
//! open one takes instead the nearest open point of its face within a texel of its centre, as
//! a texel whose centre lies off its face takes the face's nearest point: it then carries the
//! light of the visible surface it is read for. Texels deeper under a cover keep their point:
//! no visible point reads them.

use super::PlanarFace;
use crate::bvh::SceneBvh;
use glam::{DVec2, DVec3, Vec3};

/// How far above a face (in texels) a cover counts as lying on it.
const REACH_TEXELS: f64 = 0.25;
/// How far above a face (in texels) the inside of a solid object counts as standing on it.
const SOLID_TEXELS: f64 = 8.0;
/// The tilted rays' angle from the normal: tan(60 degrees).
const TILT: f64 = 1.732_050_8;
/// Where a buried texel looks for an open point: offsets in thirds of a texel, up to one texel.
const SEARCH_STEPS: i32 = 3;

/// The scene's BVH (`PreparedScene::bvh`), for the buried-point test, and which faces are the
/// generated backs of two-sided surfaces.
pub struct Occluders<'a> {
    bvh: &'a SceneBvh,
    is_back: Vec<bool>,
}

impl<'a> Occluders<'a> {
    pub fn new(bvh: &'a SceneBvh, faces: &[PlanarFace]) -> Occluders<'a> {
        let is_back = faces.iter().map(|f| f.is_back).collect();
        Occluders { bvh, is_back }
    }

    /// Whether point `p` of face `face` lies under a cover or a solid object (module doc), at
    /// texel density `density`.
    pub fn buried(&self, p: DVec3, face: u32, f: &PlanarFace, density: f64) -> bool {
        let (reach, solid) = (REACH_TEXELS / density, SOLID_TEXELS / density);
        let twin = f.twin.unwrap_or(face);
        let origin = (p + f.normal * (reach * 1e-3)).as_vec3();
        let skip = |g: u32| g == face || g == twin || self.is_back[g as usize];
        let tilted = [f.axis_a, -f.axis_a, f.axis_b, -f.axis_b];
        let mut rays = std::iter::once((f.normal, 1.0)).chain(
            tilted
                .iter()
                .map(|&a| ((f.normal + a * TILT).normalize(), 2.0)),
        );
        rays.all(|(dir, stretch)| {
            let dir = dir.as_vec3();
            let hit = crate::bvh::closest_hit(
                &self.bvh.nodes,
                &self.bvh.triangles,
                origin,
                dir,
                (solid * stretch) as f32,
                skip,
            );
            hit.is_some_and(|(t, i)| {
                let tri = &self.bvh.triangles[i];
                let inside = Vec3::from(tri.e1).cross(Vec3::from(tri.e2)).dot(dir) > 0.0;
                inside || (t as f64) < reach * stretch
            })
        })
    }
}

/// One texel of a chart: its sample point in face coordinates, the share of it the face covers,
/// and the face's triangle that holds the point.
pub type ChartTexel = (DVec2, f64, usize);

/// A face's chart: its size in texels (w x h), the face (id and geometry), the texel density.
pub struct Chart<'a> {
    pub size: (u32, u32),
    pub face: u32,
    pub f: &'a PlanarFace,
    pub density: f64,
}

/// Moves the sample points of `chart`'s `texels` (row-major) that are buried and border an
/// open texel to the nearest open point of the face within a texel of their centre, and sets
/// `open_share` of every buried texel: the open share of its 4 x 4 sub-points on the face for
/// one that moved, 0 for one deeper under the cover. `inside` names the face's triangle holding
/// a point of face coordinates, if any; `to_space` maps face coordinates to the scene. Returns
/// how many moved.
pub fn unbury(
    texels: &mut [ChartTexel],
    open_share: &mut [f32],
    chart: &Chart,
    occluders: &Occluders,
    inside: impl Fn(DVec2) -> Option<usize>,
    to_space: impl Fn(DVec2) -> DVec3,
) -> usize {
    let (face, f, density) = (chart.face, chart.f, chart.density);
    let open = |c: DVec2| !occluders.buried(to_space(c), face, f, density);
    let buried: Vec<bool> = texels.iter().map(|t| !open(t.0)).collect();
    if !buried.iter().any(|&b| b) {
        return 0;
    }
    let mut offsets: Vec<DVec2> = (-SEARCH_STEPS..=SEARCH_STEPS)
        .flat_map(|y| (-SEARCH_STEPS..=SEARCH_STEPS).map(move |x| DVec2::new(x as f64, y as f64)))
        .filter(|o| *o != DVec2::ZERO)
        .map(|o| o / (SEARCH_STEPS as f64 * density))
        .collect();
    offsets.sort_by(|a, b| a.length_squared().total_cmp(&b.length_squared()));
    let (w, h) = (chart.size.0 as i64, chart.size.1 as i64);
    let open_beside = |i: i64, j: i64| {
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (x, y) = (i + dx, j + dy);
                (0..w).contains(&x) && (0..h).contains(&y) && !buried[(y * w + x) as usize]
            })
        })
    };
    let mut moved = 0;
    for j in 0..h {
        for i in 0..w {
            let idx = (j * w + i) as usize;
            if !buried[idx] {
                continue;
            }
            open_share[idx] = 0.0;
            if !open_beside(i, j) {
                continue;
            }
            let centre = DVec2::new((i as f64 + 0.5) / density, (j as f64 + 0.5) / density);
            let found = offsets.iter().find_map(|&o| {
                let c = centre + o;
                let tri = inside(c)?;
                open(c).then_some((c, tri))
            });
            if let Some((c, tri)) = found {
                texels[idx].0 = c;
                texels[idx].2 = tri;
                open_share[idx] = sub_point_share(centre, density, &inside, open);
                moved += 1;
            }
        }
    }
    moved
}

/// The open share of the 4 x 4 sub-points of the texel at `centre` that lie on the face.
fn sub_point_share(
    centre: DVec2,
    density: f64,
    inside: impl Fn(DVec2) -> Option<usize>,
    open: impl Fn(DVec2) -> bool,
) -> f32 {
    let (mut on_face, mut opened) = (0, 0);
    for sj in 0..4 {
        for si in 0..4 {
            let p = centre + (DVec2::new(si as f64, sj as f64) - 1.5) / (4.0 * density);
            if inside(p).is_some() {
                on_face += 1;
                opened += open(p) as u32;
            }
        }
    }
    match on_face {
        0 => 1.0,
        n => opened as f32 / n as f32,
    }
}
