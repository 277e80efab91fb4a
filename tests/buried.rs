//! Texels buried under other geometry (src/prepare/buried.rs): a floor runs on under a block
//! that stands on it. A floor texel whose sample point lies under the block received no light,
//! and the bilinear lookups of the visible floor beside the block blended that darkness in (on
//! the Wooden Staircase, direct light alone 4.6% dark within two pixels of an edge). Such a
//! texel that borders the open floor now takes the nearest open point of the floor; the power
//! balance weights every texel by the share of its area that lies open.

use crate::common::{write_scene, Mat, ObjBuilder};
use glam::DVec3;
use vlf::prepare::PreparedScene;
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
