//! Visibility against a closed form: a floor under a small square emitter with a black square
//! occluder between them. Lambert's polygon formula is additive, so the irradiance at a floor
//! point x is E(emitter) - E(emitter ∩ the occluder projected from x onto the emitter's plane),
//! exact in umbra, penumbra and full light (f64 here, polygons clipped in the plane). Every
//! texel is checked; unlike a furnace or an unoccluded floor, this fails when visibility is
//! wrong: the same texels against the closed form without the occluder (what a visibility that
//! missed the occluder would give) are off by 100% in the umbra, and the test asserts that too.

use crate::common;

use common::{clip_convex, face_corners, gpu, polygon_irradiance, write_scene, Mat, ObjBuilder};
use glam::{DVec2, DVec3};
use vlf::prepare::PreparedScene;
use vlf::progress::Silent;
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

fn params() -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 6,
        grid_resolution: 64,
        tile_size: 8,
        texel_density: 48.0,
        tolerance: 1e-3,
        max_iterations: 20,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 256,
        mirror_direct: false,
        rim_rays: false,
    }
}

struct Texel {
    measured: f64,
    /// closed form with the occluder
    expected: f64,
    /// closed form as if the occluder were not seen
    unoccluded: f64,
}

fn occluded_floor() -> Vec<Texel> {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [2.0, 2.0], 0.0);
    obj.quad(
        "light",
        DVec3::new(0.1, 0.5, -0.05),
        -DVec3::Y,
        [0.2, 0.2],
        0.3,
    );
    obj.quad(
        "blocker",
        DVec3::new(0.12, 0.3, -0.02),
        DVec3::Y,
        [0.3, 0.3],
        0.5,
    );
    let (rho, le) = (0.5f64, 10.0f32);
    let mat = |name, kd: f32, ke: f32| Mat {
        name,
        kd: [kd; 3],
        ke: [ke; 3],
    };
    let materials = [
        mat("floor", rho as f32, 0.0),
        mat("light", 0.0, le),
        mat("blocker", 0.0, 0.0),
    ];
    let path = write_scene(dir.path(), &obj, &materials, "");
    let scene = Scene::load(&path).unwrap();
    let p = params();
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &p, &Silent).unwrap();
    let prepared = PreparedScene::new(&scene, p.texel_density).unwrap();
    let material = |name: &str| {
        prepared
            .materials
            .iter()
            .position(|m| m.name == name)
            .unwrap() as u32
    };
    let (floor, light, blocker) = (material("floor"), material("light"), material("blocker"));
    let emitter = face_corners(&prepared, light, DVec3::Y);
    let occluder = face_corners(&prepared, blocker, DVec3::Y);
    let plane = emitter[0].y;
    let flat = |v: DVec3| DVec2::new(v.x, v.z);
    let emitter_2d: Vec<DVec2> = emitter.iter().map(|&v| flat(v)).collect();
    let mut texels = Vec::new();
    for (i, point) in prepared.atlas.points.iter().enumerate() {
        let face = point[3].to_bits();
        if face == vlf::gpu::types::NO_FACE || prepared.faces[face as usize].material != floor {
            continue;
        }
        let x = DVec3::new(point[0] as f64, point[1] as f64, point[2] as f64);
        // the occluder seen from x, projected onto the emitter's plane
        let shadow: Vec<DVec2> = occluder
            .iter()
            .map(|&o| flat(x + (o - x) * ((plane - x.y) / (o.y - x.y))))
            .collect();
        let hidden: Vec<DVec3> = clip_convex(&emitter_2d, &shadow)
            .iter()
            .map(|q| DVec3::new(q.x, plane, q.y))
            .collect();
        let k = rho / std::f64::consts::PI * le as f64;
        let full = k * polygon_irradiance(x, DVec3::Y, &emitter);
        let blocked = if hidden.len() >= 3 {
            k * polygon_irradiance(x, DVec3::Y, &hidden)
        } else {
            0.0
        };
        texels.push(Texel {
            measured: lf.total[i][0] as f64,
            expected: (full - blocked).max(0.0),
            unoccluded: full,
        });
    }
    texels
}

#[test]
fn a_floor_shadowed_by_an_occluder_matches_the_closed_form_in_umbra_penumbra_and_light() {
    let texels = occluded_floor();
    let brightest = texels.iter().map(|t| t.unoccluded).fold(0.0, f64::max);
    // where the emitter is well above the horizon (a tenth of the brightest), by region
    let near: Vec<&Texel> = texels
        .iter()
        .filter(|t| t.unoccluded > 0.1 * brightest)
        .collect();
    let worst = |pick: &dyn Fn(&Texel) -> bool| {
        near.iter()
            .filter(|t| pick(t))
            .map(|t| (t.measured - t.expected).abs() / brightest)
            .fold(0.0, f64::max)
    };
    let count = |pick: &dyn Fn(&Texel) -> bool| near.iter().filter(|t| pick(t)).count();
    let lit = |t: &Texel| t.expected >= t.unoccluded * (1.0 - 1e-9);
    let umbra = |t: &Texel| t.expected <= 1e-9 * brightest;
    let penumbra = |t: &Texel| !lit(t) && !umbra(t);
    let (w_lit, w_umbra, w_pen) = (worst(&lit), worst(&umbra), worst(&penumbra));
    eprintln!(
        "texels: {} lit, {} umbra, {} penumbra; worst error / brightest: lit {w_lit:.2e}, \
         umbra {w_umbra:.2e}, penumbra {w_pen:.2e}",
        count(&lit),
        count(&umbra),
        count(&penumbra)
    );
    assert!(
        count(&umbra) >= 10 && count(&penumbra) >= 50,
        "the shadow is not in the test"
    );
    // measured (lavapipe, 256 shadow rays per texel; 545 lit, 116 umbra, 1295 penumbra texels):
    // lit 4.4e-6, umbra 0, penumbra 1.1e-2 (the visibility ratio from stratified shadow rays)
    assert!(
        w_lit < 1.5e-5,
        "fully lit texels off by {w_lit:.2e} of the brightest"
    );
    assert!(
        w_umbra < 1e-5,
        "umbra texels get light: {w_umbra:.2e} of the brightest"
    );
    assert!(
        w_pen < 0.035,
        "penumbra texels off by {w_pen:.2e} of the brightest"
    );
    // the check can fail: a visibility blind to the occluder would be this far off
    let blind = near
        .iter()
        .map(|t| (t.unoccluded - t.expected).abs() / brightest)
        .fold(0.0, f64::max);
    assert!(
        blind > 20.0 * w_pen.max(w_lit),
        "ignoring the occluder would be only {blind:.2e} off: the scene does not test visibility"
    );
}

#[test]
fn texels_under_a_box_standing_on_the_floor_are_marked_and_no_others() {
    // the renderer leaves marked texels (w = 0 in the totals) out of its bilinear lookups, so
    // the floor under a box must be marked and the visible floor, walls and box must not be
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [2.0, 2.0], 0.0);
    obj.quad(
        "light",
        DVec3::new(0.0, 0.9, 0.0),
        -DVec3::Y,
        [0.3, 0.3],
        0.0,
    );
    let (c, h) = (DVec3::new(0.23, 0.2, -0.11), 0.2);
    obj.cube("box", c, h, false);
    let mat = |name, kd: f32, ke: f32| Mat {
        name,
        kd: [kd; 3],
        ke: [ke; 3],
    };
    let materials = [
        mat("floor", 0.5, 0.0),
        mat("light", 0.0, 10.0),
        mat("box", 0.5, 0.0),
    ];
    let path = write_scene(dir.path(), &obj, &materials, "");
    let scene = Scene::load(&path).unwrap();
    let p = params();
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &p, &Silent).unwrap();
    let prepared = PreparedScene::new(&scene, p.texel_density).unwrap();
    let floor = prepared
        .materials
        .iter()
        .position(|m| m.name == "floor")
        .unwrap() as u32;
    // the box's footprint in normalised space
    let n = &prepared.normalisation;
    let to_normalised = |v: DVec3| n.to_unit(v.as_vec3().into());
    let (lo, hi) = (
        to_normalised(c - DVec3::splat(h)),
        to_normalised(c + DVec3::splat(h)),
    );
    let texel = 1.0 / p.texel_density;
    let (mut under, mut outside, mut wrong) = (0, 0, Vec::new());
    for (i, point) in prepared.atlas.points.iter().enumerate() {
        let face = point[3].to_bits();
        if face == vlf::gpu::types::NO_FACE {
            continue;
        }
        let x = DVec3::new(point[0] as f64, point[1] as f64, point[2] as f64);
        let w = lf.total[i][3];
        if prepared.faces[face as usize].material != floor {
            // box faces and the emitter are visible; the box's bottom lies in the floor's plane
            // (its rays start just below the floor and escape: either mark would do, nobody
            // sees it)
            let bottom = (x.y - lo.y).abs() < 1e-6;
            if !bottom && w != 1.0 {
                wrong.push(format!("texel {i} at {x:?} (box or light): w {w}"));
            }
            continue;
        }
        let inside = x.x > lo.x && x.x < hi.x && x.z > lo.z && x.z < hi.z;
        let clear =
            x.x < lo.x - texel || x.x > hi.x + texel || x.z < lo.z - texel || x.z > hi.z + texel;
        if inside {
            under += 1;
            if w != 0.0 {
                wrong.push(format!("floor texel {i} under the box at {x:?}: w {w}"));
            }
        } else if clear {
            outside += 1;
            if w != 1.0 {
                wrong.push(format!("floor texel {i} in the open at {x:?}: w {w}"));
            }
        }
    }
    eprintln!(
        "{under} floor texels under the box, {outside} in the open, {} wrong",
        wrong.len()
    );
    assert!(
        under > 20 && outside > 500,
        "the scene does not test the marks"
    );
    assert!(
        wrong.is_empty(),
        "{}",
        wrong[..wrong.len().min(10)].join("\n")
    );
}
