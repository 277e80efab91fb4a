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
//!
//! Rims cut off by a crossing surface. A face that runs on through another one (the Grey &
//! White Room's skirting boards reach 0.4 mm under its floor, its cornice 0.1 mm above its
//! ceiling) has rim texels, whose centre lies off the face, with their sample point (the face's
//! nearest point) beyond that surface: under the floor or above the ceiling, where the sky
//! shines and no viewer is. The bilinear lookups of the visible face beside them blended that
//! light half a texel deep into what is seen: a bright line along the skirting and the cornice,
//! 15% of the room's direct light in the bottom third of Bitterli's view. Such a point is moved
//! back along the segment to the nearest texel point of the face that lies at its centre (for a
//! face thinner than a texel, the cornice's 1 cm strip, which has none: the middle of the
//! point's triangle), to just past the surface that the segment crosses, when the sliver of the
//! face beyond that surface is thinner than a cover's reach (a quarter of a texel): then nearly
//! all that the rim's lookups read lies on the other side. A face that runs on further is seen
//! beyond the surface too, and its rim keeps its point (moving those made the Space Ship
//! Hallway worse).

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
/// How close to a surface (normalised units) a point counts as lying in it: four times the
/// shortest hit of the shadow and crossing rays (1e-5, shaders/common/ray.wgsl and src/bvh.rs).
/// A rim point this close past a crossing surface is moved clear of it like one beyond it: its
/// shadow rays would not see the surface and pass behind it.
const BLIND_BAND: f64 = 4e-5;

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

impl Occluders<'_> {
    /// Whether a surface lies over point `p` of face `face` along its normal within a cover's
    /// reach, at texel density `density`: for a rim point, which serves the lookups of the open
    /// face beside it, a slot behind a frame's overhanging lip is cover enough (`unbury`).
    pub fn overhung(&self, p: DVec3, face: u32, f: &PlanarFace, density: f64) -> bool {
        let reach = REACH_TEXELS / density;
        let twin = f.twin.unwrap_or(face);
        let origin = (p + f.normal * (reach * 1e-3)).as_vec3();
        let skip = |g: u32| g == face || g == twin || self.is_back[g as usize];
        let (nodes, tris) = (&self.bvh.nodes, &self.bvh.triangles);
        let dir = f.normal.as_vec3();
        crate::bvh::closest_hit(nodes, tris, origin, dir, reach as f32, skip).is_some()
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
    // where a moved point may go: open, and not under an overhang
    let clear = |c: DVec2| open(c) && !occluders.overhung(to_space(c), face, f, density);
    let (w, h) = (chart.size.0 as i64, chart.size.1 as i64);
    let centre_of = |k: i64| {
        DVec2::new(
            ((k % w) as f64 + 0.5) / density,
            ((k / w) as f64 + 0.5) / density,
        )
    };
    // a rim point (off its texel's centre) under an overhang is buried too: its lookups serve
    // the open face beside it (a frame's flat face whose top runs into the slot behind its lip)
    let buried: Vec<bool> = (texels.iter().enumerate())
        .map(|(k, t)| {
            let rim = t.0 != centre_of(k as i64);
            !open(t.0) || (rim && occluders.overhung(to_space(t.0), face, f, density))
        })
        .collect();
    if !buried.iter().any(|&b| b) {
        return 0;
    }
    let mut offsets: Vec<DVec2> = (-SEARCH_STEPS..=SEARCH_STEPS)
        .flat_map(|y| (-SEARCH_STEPS..=SEARCH_STEPS).map(move |x| DVec2::new(x as f64, y as f64)))
        .filter(|o| *o != DVec2::ZERO)
        .map(|o| o / (SEARCH_STEPS as f64 * density))
        .collect();
    offsets.sort_by(|a, b| a.length_squared().total_cmp(&b.length_squared()));
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
                clear(c).then_some((c, tri))
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

/// Moves each rim texel of `chart` (its centre off the face) whose sample point a surface cuts
/// off from the rest of the face, where the sliver beyond it is thinner than a quarter of a
/// texel, to the other side of that surface, a hundredth of a texel past it (module doc). The
/// rest of the face is the nearest of the texel's neighbours whose point is their centre (an
/// open one, `open_share` above 0), the surface within a quarter of a texel along the way to
/// it; for a face thinner than a texel, with no such neighbour, the middle of the point's own
/// triangle (`triangles`), the surface's plane within a quarter of a texel of the point.
/// `inside` and `to_space` as for [`unbury`]. Returns how many moved.
pub fn rejoin_cut_rims(
    texels: &mut [ChartTexel],
    open_share: &[f32],
    chart: &Chart,
    triangles: &[[DVec2; 3]],
    occluders: &Occluders,
    inside: impl Fn(DVec2) -> Option<usize>,
    to_space: impl Fn(DVec2) -> DVec3,
) -> usize {
    let density = chart.density;
    let (w, h) = (chart.size.0 as i64, chart.size.1 as i64);
    let centre =
        |i: i64, j: i64| DVec2::new((i as f64 + 0.5) / density, (j as f64 + 0.5) / density);
    // the texels whose point is their centre, on the face and open
    let interior: Vec<bool> = (0..texels.len() as i64)
        .map(|k| {
            let c = centre(k % w, k / w);
            texels[k as usize].0 == c && open_share[k as usize] > 0.0
        })
        .collect();
    let mut moved = 0;
    for j in 0..h {
        for i in 0..w {
            let idx = (j * w + i) as usize;
            if inside(centre(i, j)).is_some() {
                continue;
            }
            let (p, tri) = (texels[idx].0, texels[idx].2);
            let neighbour = (-1..=1)
                .flat_map(|dy| (-1..=1).map(move |dx| (i + dx, j + dy)))
                .filter(|&(x, y)| (0..w).contains(&x) && (0..h).contains(&y))
                .filter(|&(x, y)| interior[(y * w + x) as usize])
                .map(|(x, y)| centre(x, y))
                .min_by(|a, b| a.distance_squared(p).total_cmp(&b.distance_squared(p)));
            let target = match neighbour {
                Some(q) => Target::Neighbour(q),
                None => Target::Middle(triangles[tri].iter().sum::<DVec2>() / 3.0),
            };
            let across = cut_off(p, target, chart, occluders, &to_space);
            if let Some((moved_to, tri)) = across.and_then(|c| Some((c, inside(c)?))) {
                texels[idx].0 = moved_to;
                texels[idx].2 = tri;
                moved += 1;
            }
        }
    }
    moved
}

/// Where a rim point looks for the rest of its face (`rejoin_cut_rims`), in face coordinates.
#[derive(Clone, Copy)]
enum Target {
    /// an open neighbour's centre: the crossing counts within a quarter of a texel along the way
    Neighbour(DVec2),
    /// the middle of the point's triangle: the crossing surface's plane within a quarter of a
    /// texel of the point (the way there may run nearly along it)
    Middle(DVec2),
}

/// The point just past the surface that separates rim point `p` from `target`, if one does
/// within a cover's reach (`rejoin_cut_rims`).
fn cut_off(
    p: DVec2,
    target: Target,
    chart: &Chart,
    occluders: &Occluders,
    to_space: impl Fn(DVec2) -> DVec3,
) -> Option<DVec2> {
    let (face, f, density) = (chart.face, chart.f, chart.density);
    let twin = f.twin.unwrap_or(face);
    let skip = |g: u32| g == face || g == twin || occluders.is_back[g as usize];
    let q = match target {
        Target::Neighbour(q) | Target::Middle(q) => q,
    };
    let (from, to) = (to_space(p), to_space(q));
    let length = from.distance(to);
    let dir = (to - from) / length;
    let (nodes, tris) = (&occluders.bvh.nodes, &occluders.bvh.triangles);
    // from a hair before the point, so that a surface it lies on or just past counts too
    let (origin, ray) = ((from - dir * BLIND_BAND).as_vec3(), dir.as_vec3());
    let span = (length + BLIND_BAND) as f32;
    let (t, hit) = crate::bvh::closest_hit(nodes, tris, origin, ray, span, skip)?;
    let t = t as f64 - BLIND_BAND;
    let tri = &tris[hit];
    let normal = Vec3::from(tri.e1)
        .cross(Vec3::from(tri.e2))
        .normalize()
        .as_dvec3();
    let depth = (from - Vec3::from(tri.v0).as_dvec3()).dot(normal).abs();
    let reach = REACH_TEXELS / density;
    let thin = match target {
        Target::Neighbour(_) => t < reach,
        Target::Middle(_) => depth < reach,
    };
    // a hundredth of a texel clear of the surface's plane, short of the target
    let slant = dir.dot(normal).abs().max(1e-3);
    let past = (0.01 / density / slant).min((length - t) * 0.5);
    thin.then(|| p + (q - p) * ((t + past) / length))
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
