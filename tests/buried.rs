//! Texels buried under other geometry (src/prepare/buried.rs): a floor runs on under a block
//! that stands on it. A floor texel whose sample point lies under the block received no light,
//! and the bilinear lookups of the visible floor beside the block blended that darkness in (on
//! the Wooden Staircase, direct light alone 4.6% dark within two pixels of an edge). Such a
//! texel that borders the open floor now takes the nearest open point of the floor; the power
//! balance weights every texel by the share of its area that lies open.

use crate::common::{write_scene, Mat, ObjBuilder};
use glam::DVec3;
use std::path::PathBuf;
use vlf::prepare::PreparedScene;
use vlf::progress::Silent;
use vlf::scene::Scene;

const DENSITY: f64 = 16.0;
const BLOCK_CENTRE: [f64; 2] = [0.1, 0.05];
const BLOCK_HALF: f64 = 0.25;

/// A 2 x 2 floor (y = 0) with a block of half-size 0.25 whose bottom lies `gap` above it, and an
/// emitter above both.
fn floor_with_block(gap: f64) -> (tempfile::TempDir, PreparedScene) {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [2.0, 2.0], 0.0);
    let [x, z] = BLOCK_CENTRE;
    obj.cube(
        "block",
        DVec3::new(x, gap + BLOCK_HALF, z),
        BLOCK_HALF,
        false,
    );
    obj.quad(
        "light",
        DVec3::new(0.0, 1.5, 0.0),
        -DVec3::Y,
        [0.5, 0.5],
        0.0,
    );
    let mats = [
        Mat {
            name: "floor",
            kd: [0.5; 3],
            ke: [0.0; 3],
        },
        Mat {
            name: "block",
            kd: [0.5; 3],
            ke: [0.0; 3],
        },
        Mat {
            name: "light",
            kd: [0.0; 3],
            ke: [5.0; 3],
        },
    ];
    let scene = Scene::load(&write_scene(dir.path(), &obj, &mats, "")).unwrap();
    let prepared = PreparedScene::new(&scene, DENSITY).unwrap();
    (dir, prepared)
}

/// The floor's face: the one facing up at the lowest height.
fn floor_face(p: &PreparedScene) -> u32 {
    let up = p
        .faces
        .iter()
        .enumerate()
        .filter(|(_, f)| f.normal.y > 0.99);
    up.min_by(|a, b| a.1.plane_offset.total_cmp(&b.1.plane_offset))
        .unwrap()
        .0 as u32
}

/// Whether a unit-space point lies under the block's footprint (shrunk by `inset`, world units).
fn under_block(p: &PreparedScene, point: DVec3, inset: f64) -> bool {
    let world = point / p.normalisation.scale + DVec3::from(p.normalisation.center);
    let h = BLOCK_HALF - inset;
    (world.x - BLOCK_CENTRE[0]).abs() < h && (world.z - BLOCK_CENTRE[1]).abs() < h
}

#[test]
fn a_floor_texel_under_a_block_moves_to_the_open_floor_and_weighs_only_its_open_area() {
    let (_dir, p) = floor_with_block(0.0);
    let floor = floor_face(&p);
    let areas = vlf::propagate::texel_areas(&p);
    let (mut under, mut moved_beside, mut floor_area) = (0, 0, 0.0);
    for (i, pt) in p.atlas.points.iter().enumerate() {
        if pt[3].to_bits() != floor {
            continue;
        }
        floor_area += areas[i];
        let point = DVec3::new(pt[0] as f64, pt[1] as f64, pt[2] as f64);
        let open = p.atlas.open_share[i];
        if under_block(&p, point, 1e-4) {
            under += 1;
            // what a view of the floor reads beside the block must not come from under it
            assert_eq!(
                open, 0.0,
                "texel {i} under the block weighs {open} of its area"
            );
        } else if open < 1.0 {
            moved_beside += 1;
        }
    }
    assert!(
        under > 0,
        "no texel lies deep under the block: the test's geometry is off"
    );
    assert!(
        moved_beside > 0 && p.atlas.unburied_texels as usize >= moved_beside,
        "{moved_beside} texels on the block's rim moved, {} in all",
        p.atlas.unburied_texels
    );
    // the floor's open area: 4 - 0.5^2 (world units), to the 4 x 4 sub-points of the rim texels
    let world_area = floor_area / (p.normalisation.scale * p.normalisation.scale);
    let open_area = 4.0 - (2.0 * BLOCK_HALF) * (2.0 * BLOCK_HALF);
    assert!(
        (world_area / open_area - 1.0).abs() < 0.01,
        "the floor's texels weigh {world_area:.4} of area, its open area is {open_area}"
    );
}

#[test]
fn a_block_above_the_floor_buries_nothing() {
    // 0.1 above the floor: about four times the reach of the test (a quarter of a texel)
    let (_dir, p) = floor_with_block(0.1);
    assert_eq!(p.atlas.unburied_texels, 0);
    assert!(p.atlas.open_share.iter().all(|&s| s == 1.0));
}

/// Writes `obj` into `dir` with matte materials (name, albedo) under a uniform sky of radiance 1.
fn sky_scene(dir: &std::path::Path, obj: &ObjBuilder, albedos: &[(&'static str, f32)]) -> PathBuf {
    let mats: Vec<Mat> = (albedos.iter())
        .map(|&(name, kd)| Mat {
            name,
            kd: [kd; 3],
            ke: [0.0; 3],
        })
        .collect();
    write_scene(dir, obj, &mats, "[sky]\nradiance = [1.0, 1.0, 1.0]\n")
}

/// A scene's light field at texel density 8 unless given (draft settings otherwise), read as the renderer and
/// propagation read it: by the bilinear lookup in the atlas (`atlas_taps`, the CPU twin of
/// common/atlas.wgsl).
struct SkyLit {
    lf: vlf::lightfield::LightField,
    p: PreparedScene,
    faces: Vec<vlf::gpu::types::GpuFace>,
    /// a texel's side in world units
    texel: f64,
}

impl SkyLit {
    fn propagate(toml: &std::path::Path, direct_samples: u32) -> SkyLit {
        SkyLit::at_density(toml, direct_samples, 8.0)
    }

    fn at_density(toml: &std::path::Path, direct_samples: u32, texel_density: f64) -> SkyLit {
        let scene = Scene::load(toml).unwrap();
        let params = vlf::propagate::PropagationParams {
            texel_density,
            direct_samples,
            ..crate::common::draft_params()
        };
        let (lf, _, _) =
            vlf::propagate::propagate(crate::common::gpu(), &scene, &params, &Silent).unwrap();
        let p = PreparedScene::new(&scene, params.texel_density).unwrap();
        let faces = vlf::propagate::gpu_faces(&p, &vec![u32::MAX; p.faces.len()]);
        let texel = 1.0 / (params.texel_density * p.normalisation.scale);
        SkyLit {
            lf,
            p,
            faces,
            texel,
        }
    }

    /// The faces facing +x in the plane x = `x` (world units).
    fn facing_x(&self, x: f32) -> Vec<usize> {
        let at = self.p.normalisation.to_unit([x, 0.0, 0.0]).x;
        (self.p.faces.iter().enumerate())
            .filter(|(_, f)| f.normal.x > 0.99 && (f.plane_offset - at).abs() < 1e-4)
            .map(|(i, _)| i)
            .collect()
    }

    /// The mean green radiance of the texels whose sample point lies on face `face`.
    fn mean_on(&self, face: u32) -> f64 {
        let on_face: Vec<f64> = (self.p.atlas.points.iter().zip(&self.lf.total))
            .filter(|(pt, _)| pt[3].to_bits() == face)
            .map(|(_, t)| t[1] as f64)
            .collect();
        on_face.iter().sum::<f64>() / on_face.len() as f64
    }

    /// The green radiance that a view of face `face` reads at the world point `world`.
    fn read(&self, face: usize, world: [f32; 3]) -> f64 {
        let at = self.p.normalisation.to_unit(world).as_vec3();
        let taps =
            vlf::lightfield::atlas_lookup::atlas_taps(&self.faces[face], at, self.p.atlas.width);
        (0..4)
            .map(|i| self.lf.total[taps.index[i] as usize][1] as f64 * taps.weight[i] as f64)
            .sum()
    }
}

/// A uniform sky over a floor with a black plate 1 cm thick lying on it: the floor beside the
/// plate receives the whole sky but for the plate's sliver (under 1% a texel away), so its light
/// is Kd x sky there, in closed form. It is read as the renderer and propagation read it, by the
/// bilinear lookup in the atlas (`atlas_taps`, the CPU twin of common/atlas.wgsl). Before buried
/// texels moved, the floor texels under the plate's rim were black and the lookup beside the
/// plate blended them in: measured without the move, 0.24 of Kd x sky a tenth of a texel from
/// its edge (0.98 with it, the plate's sliver of sky included).
#[test]
fn the_floor_beside_a_plate_lying_on_it_keeps_the_skys_light() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [2.0, 2.0], 0.0);
    // a box 0.8 x 0.01 x 0.8 standing on the floor: the cube builder's faces, flattened
    let mut plate = ObjBuilder::default();
    plate.cube("plate", DVec3::ZERO, 0.4, false);
    let flat: String = plate
        .text("scene.mtl")
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => {
                let c: Vec<f64> = v.split_whitespace().map(|x| x.parse().unwrap()).collect();
                format!("v {} {} {}", c[0], (c[1] + 0.4) / 80.0, c[2])
            }
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    let toml = sky_scene(dir.path(), &obj, &[("floor", 0.5), ("plate", 0.0)]);
    // the plate's faces refer to their vertices relatively ("f -4 -3 -2 -1"): appended as is
    let plate_lines: Vec<&str> = flat.lines().filter(|l| !l.starts_with("mtllib")).collect();
    let floor_obj = std::fs::read_to_string(dir.path().join("scene.obj")).unwrap();
    let both = format!("{floor_obj}\n{}\n", plate_lines.join("\n"));
    std::fs::write(dir.path().join("scene.obj"), both).unwrap();
    let lit = SkyLit::propagate(&toml, 256);
    let floor = floor_face(&lit.p) as usize;
    let mut worst = (1.0f64, 0.0f64);
    // points beside the plate's -x edge, from a tenth of a texel to two texels away
    for k in 1..=20 {
        let away = lit.texel * k as f64 / 10.0;
        for z in [-0.2, 0.0, 0.2] {
            let radiance = lit.read(floor, [(-0.4 - away) as f32, 0.0, z as f32]);
            // Kd x sky, less the plate's sliver of sky (at most its height over the distance)
            let ratio = radiance / 0.5;
            if (ratio - 1.0).abs() > (worst.0 - 1.0).abs() {
                worst = (ratio, away / lit.texel);
            }
        }
    }
    eprintln!(
        "the floor beside the plate: worst {:.4} of Kd x sky, {:.2} texels from it",
        worst.0, worst.1
    );
    assert!(
        (worst.0 - 1.0).abs() < 0.03,
        "the floor {:.2} texels from the plate holds {:.3} of Kd x sky (closed form)",
        worst.1,
        worst.0
    );
}

/// A sealed room (a cube of side 3, its faces inward) under a uniform sky, with a panel 0.8
/// high standing free in it whose foot runs 1 cm under the floor, as the skirting boards of the
/// Grey & White Room run 0.4 mm under its floor, and a cornice strip 5 cm high (less than a
/// texel: no texel's centre lies on it) whose top runs 1 cm above the ceiling. No light gets in:
/// every point a viewer can see is black. The rim texels beyond the floor and the ceiling had
/// their sample point (the face's nearest point) in the sky, and the bilinear lookup of the
/// visible panel and strip blended that in. Measured on the software adapter without the rims
/// moved back (`rejoin_cut_rims` left out): the panel a tenth of a texel above the floor 0.21 of
/// the sky's radiance, the room's floor 1.8e-3 of it on average (what those rims shot in);
/// with the panel's rims moved but not the strip's (before the middle of a rim point's own
/// triangle stood for a face with no interior texel), the strip 0.093; with both, 0. A third
/// board, a skirting whose rim points land 3 micrometres above the floor once moved into their
/// face (closer than the shadow rays' shortest hit), read 0.18 of the sky a tenth of a texel
/// above the floor until the crossing search started a hair before the point (`BLIND_BAND` in
/// src/prepare/buried.rs); now 0.
#[test]
fn a_panel_and_a_cornice_running_through_a_sealed_room_bring_no_sky_in() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.cube("room", DVec3::new(0.0, 1.5, 0.0), 1.5, true);
    obj.quad(
        "panel",
        DVec3::new(-1.0, 0.39, 0.0),
        DVec3::X,
        [0.8, 1.5],
        0.0,
    );
    obj.quad(
        "strip",
        DVec3::new(-1.2, 2.985, 0.0),
        DVec3::X,
        [0.05, 1.5],
        0.0,
    );
    // a skirting whose foot runs under the floor by a hundredth of a texel (the inset of a rim
    // point, src/prepare/atlas.rs) less 3 micrometres: its rim points land that far above the
    // floor, inside the band where shadow rays do not see it (the Grey & White Room's skirting
    // runs 0.4 mm under its floor, and its texels are 4 cm). The room's bounding sphere (radius
    // 1.5 x sqrt 3) sets the scale: a texel at density 8 is 1 / (8 x 0.99 / 2.598) m.
    let texel = 1.0 / (8.0 * 0.99 / (1.5 * 3f64.sqrt()));
    let foot = 0.01 * texel - 3e-6;
    obj.quad(
        "skirting",
        DVec3::new(-0.6, 0.4 - foot, 0.0),
        DVec3::X,
        [0.8, 1.5],
        0.0,
    );
    let toml = sky_scene(
        dir.path(),
        &obj,
        &[
            ("room", 0.5),
            ("panel", 0.5),
            ("strip", 0.5),
            ("skirting", 0.5),
        ],
    );
    let lit = SkyLit::propagate(&toml, 64);
    let p = &lit.p;
    assert!(
        (lit.texel - texel).abs() < 1e-6 * texel,
        "{} {texel}",
        lit.texel
    );
    let (panel, strip, skirting) = (lit.facing_x(-1.0), lit.facing_x(-1.2), lit.facing_x(-0.6));
    assert_eq!(
        (panel.len(), strip.len(), skirting.len()),
        (1, 1, 1),
        "the panel, the strip and the skirting are a face each"
    );
    let (panel, strip, skirting) = (panel[0], strip[0], skirting[0]);
    // the brightest that a view reads on the panel above the floor and on the strip below the
    // ceiling, a tenth of a texel to a texel (the strip's height) away
    let mut worst = [(0.0f64, 0.0f64); 3];
    for k in 1..=10 {
        let away = lit.texel * k as f64 / 10.0;
        for z in [-0.5f32, 0.0, 0.5] {
            let strip_y = (3.0 - away).max(2.96);
            let reads = [
                lit.read(panel, [-1.0, away as f32, z]),
                lit.read(strip, [-1.2, strip_y as f32, z]),
                lit.read(skirting, [-0.6, away as f32, z]),
            ];
            for (w, r) in worst.iter_mut().zip(reads) {
                if r > w.0 {
                    *w = (r, away / lit.texel);
                }
            }
        }
    }
    let floor_mean = lit.mean_on(floor_face(p));
    eprintln!(
        "at most {:.2e} of the sky on the panel ({:.1} texels above the floor), {:.2e} on the \
         strip ({:.1} texels below the ceiling), {:.2e} on the skirting ({:.1} texels above the \
         floor); the floor's mean {floor_mean:.2e}",
        worst[0].0, worst[0].1, worst[1].0, worst[1].1, worst[2].0, worst[2].1
    );
    assert!(
        worst.iter().all(|w| w.0 < 1e-4) && floor_mean < 1e-5,
        "sky light in a sealed room: the panel holds up to {:.3e} of the sky's radiance, the \
         strip {:.3e}, the skirting {:.3e}, the floor {floor_mean:.3e} on average",
        worst[0].0,
        worst[1].0,
        worst[2].0
    );
    assert!(
        p.atlas.rejoined_rims > 0,
        "no rim moved back over the floor or the ceiling"
    );
}

/// A sealed room (inward walls) under a uniform sky whose -x wall has a slot 2 cm high open to
/// the outside, covered on the room's side by a moulding (a board 3 cm in front of the wall,
/// capped above and below): the cavity behind the moulding sees the sky, the room does not, so
/// the visible wall just below the moulding must be black, and the room's floor nearly so. The
/// caps' rim texels take the nearest point of their face, on the edge where a cap meets the
/// wall. That point used to move a hair toward its triangle's middle, which for the cap's long
/// thin triangles lies almost along that edge: it stayed a millionth of a metre from the wall,
/// closer than the shadow rays' shortest hit, and the sky's shadow rays from it passed behind
/// the wall to the sky. The caps' rims then held a quarter of the sky's light, and the wall
/// below and the room took it in. Measured on the software adapter before the rim points moved
/// straight away from their edge (`inset` in src/prepare/atlas.rs): the wall a tenth of a texel
/// below the moulding 5.9e-3 of the sky's radiance, the floor's mean 3.7e-4, the caps' 0.095;
/// after: 5.3e-6, 7.7e-6 and 2.8e-5 (what is left comes from the side walls' texels inside the
/// cavity, which do see the sky through the slot). The Grey & White Room's window sills, six
/// times too bright in their indirect light, are mouldings of that kind.
#[test]
fn a_cavity_open_to_the_sky_behind_a_moulding_brings_no_light_into_a_sealed_room() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    let c = DVec3::new(0.0, 1.5, 0.0);
    for n in [DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z, -DVec3::X] {
        obj.quad("room", c - n * 1.5, n, [3.0, 3.0], 0.0);
    }
    // the -x wall (facing +x) in two parts around the slot y 0.81..0.83
    obj.quad(
        "room",
        DVec3::new(-1.5, 0.405, 0.0),
        DVec3::X,
        [0.81, 3.0],
        0.0,
    );
    obj.quad(
        "room",
        DVec3::new(-1.5, 1.915, 0.0),
        DVec3::X,
        [2.17, 3.0],
        0.0,
    );
    // the moulding: a board 3 cm in front of the wall from y 0.78 to 0.86, capped
    obj.quad(
        "moulding",
        DVec3::new(-1.47, 0.82, 0.0),
        DVec3::X,
        [0.08, 3.0],
        0.0,
    );
    obj.quad(
        "moulding",
        DVec3::new(-1.485, 0.78, 0.0),
        -DVec3::Y,
        [0.03, 3.0],
        0.0,
    );
    obj.quad(
        "moulding",
        DVec3::new(-1.485, 0.86, 0.0),
        DVec3::Y,
        [0.03, 3.0],
        0.0,
    );
    let toml = sky_scene(dir.path(), &obj, &[("room", 0.5), ("moulding", 0.5)]);
    let lit = SkyLit::at_density(&toml, 64, 128.0);
    let p = &lit.p;
    // the lower part of the wall: of the two faces in its plane, the one whose points lie lowest
    let mean_y = |face: &usize| {
        let ys: Vec<f64> = (p.atlas.points.iter())
            .filter(|pt| pt[3].to_bits() == *face as u32)
            .map(|pt| pt[1] as f64)
            .collect();
        ys.iter().sum::<f64>() / ys.len().max(1) as f64
    };
    let wall = lit.facing_x(-1.5);
    assert_eq!(wall.len(), 2, "the wall is two faces around the slot");
    let lower = *wall
        .iter()
        .min_by(|a, b| mean_y(a).total_cmp(&mean_y(b)))
        .unwrap();
    let mut worst = (0.0f64, 0.0f64);
    for k in 1..=10 {
        let below = lit.texel * k as f64 / 10.0;
        for z in [-0.5f32, 0.0, 0.5] {
            let radiance = lit.read(lower, [-1.5, (0.78 - below) as f32, z]);
            if radiance > worst.0 {
                worst = (radiance, below / lit.texel);
            }
        }
    }
    let floor_mean = lit.mean_on(floor_face(p));
    eprintln!(
        "the wall below the moulding: at most {:.2e} of the sky ({:.1} texels below it; a texel is {:.3} m); the floor's mean {floor_mean:.2e}",
        worst.0, worst.1, lit.texel
    );
    assert!(
        worst.0 < 1e-4 && floor_mean < 3e-5,
        "sky light in a sealed room: the wall {:.1} texels below the moulding holds {:.3e} of \
         the sky's radiance, the floor {floor_mean:.3e} on average",
        worst.1,
        worst.0
    );
}

/// A wall whose top edge runs into the slot behind a frame's lip, as the Wooden Staircase's
/// large painting frame does: the lip, 3.5 mm in front of the wall, overhangs the wall's top
/// 1.6 mm. The wall's rim points, moved a hundredth of a texel into the wall, lie in that slot,
/// where the buried-point test's ray tilted down escapes below the lip; the bilinear lookups of
/// the visible wall just below the lip must still read points outside the slot (else they
/// blend its shade in: on the staircase a dark line along the frame, 0.34 against 0.75). A rim
/// point with a surface along its normal within a cover's reach counts as buried and moves
/// (`Occluders::overhung`). Checked without it (`overhung` answering false): the lookups read
/// points in the slot and this test fails.
#[test]
fn the_visible_wall_below_a_frames_lip_reads_no_point_from_the_slot_behind_it() {
    let dir = tempfile::tempdir().unwrap();
    let lip_bottom = 0.9984;
    let mut obj = ObjBuilder::default();
    obj.quad("wall", DVec3::new(0.0, 0.5, 0.0), DVec3::X, [1.0, 2.0], 0.0);
    obj.quad(
        "lip",
        DVec3::new(0.0035, (lip_bottom + 1.05) / 2.0, 0.0),
        DVec3::X,
        [1.05 - lip_bottom, 2.0],
        0.0,
    );
    // its underside, 3 mm thick in front of the board: the slot behind the lip stays open below
    obj.quad(
        "lip",
        DVec3::new(0.005, lip_bottom, 0.0),
        -DVec3::Y,
        [0.003, 2.0],
        0.0,
    );
    let toml = sky_scene(dir.path(), &obj, &[("wall", 0.5), ("lip", 0.5)]);
    let p = PreparedScene::new(&Scene::load(&toml).unwrap(), DENSITY).unwrap();
    let faces = vlf::propagate::gpu_faces(&p, &vec![u32::MAX; p.faces.len()]);
    let n = p.normalisation;
    let at = n.to_unit([0.0, 0.5, 0.0]);
    let wall = (p.faces.iter())
        .position(|f| f.normal.x > 0.99 && (f.plane_offset - at.x).abs() < 1e-6)
        .expect("the wall is a face") as u32;
    let texel = 1.0 / (DENSITY * n.scale);
    let world_y = |k: usize| p.atlas.points[k][1] as f64 / n.scale + n.center[1];
    let mut in_slot = Vec::new();
    for k in 1..=5 {
        let y = lip_bottom - texel * k as f64 / 10.0;
        for z in [-0.5f32, 0.0, 0.5] {
            let point = n.to_unit([0.0, y as f32, z]).as_vec3();
            let taps = vlf::lightfield::atlas_lookup::atlas_taps(
                &faces[wall as usize],
                point,
                p.atlas.width,
            );
            for i in 0..4 {
                let k = taps.index[i] as usize;
                if taps.weight[i] > 0.0 && world_y(k) > lip_bottom {
                    in_slot.push((y, world_y(k)));
                }
            }
        }
    }
    assert!(
        in_slot.is_empty(),
        "the visible wall below the lip (at {lip_bottom} m) reads texels whose point lies in the \
         slot behind it (the read's height, the point's): {in_slot:?}"
    );
}
