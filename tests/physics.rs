//! Physics on the GPU (the software adapter is enough): the furnace and form factors, each with
//! its stated tolerance.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::lightfield::directions::DirectionSet;
use vlf::prepare::PreparedScene;
use vlf::progress::Silent;
use vlf::propagate::transport::Propagator;
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

fn small_params() -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 4,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 8.0,
        tolerance: 1e-4,
        max_iterations: 200,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 64,
        mirror_direct: false,
        rim_rays: false,
    }
}

fn furnace(rho: f32, le: f32) -> (tempfile::TempDir, Scene) {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.5, true);
    let path = write_scene(
        dir.path(),
        &obj,
        &[Mat {
            name: "wall",
            kd: [rho; 3],
            ke: [le; 3],
        }],
        "",
    );
    let scene = Scene::load(&path).unwrap();
    (dir, scene)
}

/// Largest relative deviation of any covered texel's radiance (all channels) from `expected`.
fn worst_deviation(prepared: &PreparedScene, total: &[[f32; 4]], expected: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for (i, p) in prepared.atlas.points.iter().enumerate() {
        if p[3].to_bits() == u32::MAX {
            continue;
        }
        for v in &total[i][..3] {
            worst = worst.max((*v as f64 - expected).abs() / expected);
        }
    }
    worst
}

#[test]
fn furnace_matches_le_over_one_minus_rho_per_bounce_and_converged() {
    let ctx = gpu();
    let le = 1.5f64;
    for rho in [0.3f64, 0.5, 0.8] {
        let (_dir, scene) = furnace(rho as f32, le as f32);
        let params = small_params();
        let prepared = PreparedScene::new(&scene, params.texel_density).unwrap();
        let directions = DirectionSet::geodesic(params.geodesic_frequency);
        let mut prop =
            Propagator::new(ctx.clone(), &prepared, &params, &directions, None, None).unwrap();
        prop.build_visibility().unwrap();
        for k in 1..=4u32 {
            prop.iterate().unwrap();
            let expected = le * (1.0 - rho.powi(k as i32 + 1)) / (1.0 - rho);
            let worst = worst_deviation(&prepared, &prop.read_total().unwrap(), expected);
            assert!(
                worst < 0.01,
                "rho {rho}, after {k} iterations: worst texel off by {:.3}% from {expected}",
                worst * 100.0
            );
        }
        // plain shooting here: its residual after k iterations is rho^k
        let plain = PropagationParams {
            accelerate: false,
            ..params.clone()
        };
        let (_, _, report) =
            vlf::propagate::propagate(ctx.clone(), &scene, &plain, &Silent).unwrap();
        assert!(
            report.converged,
            "rho {rho}: residual {}",
            report.final_residual
        );
        let (lf, _, _) = vlf::propagate::propagate(ctx.clone(), &scene, &params, &Silent).unwrap();
        let expected = le / (1.0 - rho);
        let worst = worst_deviation(&prepared, &lf.total, expected);
        assert!(
            worst < 0.01,
            "rho {rho} converged: worst texel off by {:.3}% from {expected}",
            worst * 100.0
        );
        // the residual after k iterations is rho^k in a furnace
        let k = report.iterations as i32;
        assert!(
            (report.final_residual - rho.powi(k)).abs() < 0.02 * rho.powi(k),
            "residual {} vs rho^k {}",
            report.final_residual,
            rho.powi(k)
        );
    }
}

/// Mean irradiance on the receiver, in units of pi * Le (i.e. the form factor).
fn received_form_factor(obj: &ObjBuilder, params: &PropagationParams) -> f64 {
    let ctx = gpu();
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.5f32;
    let path = write_scene(
        dir.path(),
        obj,
        &[
            Mat {
                name: "emitter",
                kd: [0.0; 3],
                ke: [1.0; 3],
            },
            Mat {
                name: "receiver",
                kd: [rho; 3],
                ke: [0.0; 3],
            },
        ],
        "",
    );
    let scene = Scene::load(&path).unwrap();
    let prepared = PreparedScene::new(&scene, params.texel_density).unwrap();
    let directions = DirectionSet::geodesic(params.geodesic_frequency);
    let mut prop = Propagator::new(ctx, &prepared, params, &directions, None, None).unwrap();
    prop.build_visibility().unwrap();
    prop.iterate().unwrap();
    // after one bounce the receiver's radiance is rho * E / pi, and E = pi * Le * F
    let receiver = scene
        .materials
        .iter()
        .position(|m| m.name == "receiver")
        .unwrap() as u32;
    let total = prop.read_total().unwrap();
    face_mean(
        &prepared,
        &total,
        |f| prepared.faces[f].material == receiver,
        1,
    ) / rho as f64
}

fn form_factor_params() -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 10,
        grid_resolution: 64,
        tile_size: 8,
        texel_density: 24.0,
        tolerance: 1e-3,
        max_iterations: 1,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 64,
        mirror_direct: false,
        rim_rays: false,
    }
}

#[test]
fn parallel_unit_squares_at_distance_one() {
    let mut obj = ObjBuilder::default();
    obj.quad(
        "emitter",
        DVec3::new(0.0, 0.5, 0.0),
        -DVec3::Y,
        [1.0, 1.0],
        0.0,
    );
    obj.quad(
        "receiver",
        DVec3::new(0.0, -0.5, 0.0),
        DVec3::Y,
        [1.0, 1.0],
        0.0,
    );
    let f = received_form_factor(&obj, &form_factor_params());
    let exact = 0.1998;
    assert!(
        (f - exact).abs() / exact < 0.02,
        "F = {f:.4}, exact {exact}"
    );
}

#[test]
fn perpendicular_unit_squares_sharing_an_edge() {
    let mut obj = ObjBuilder::default();
    // receiver in the plane y = 0 (x, z in [0, 1]); emitter in the plane x = 0 (y, z in [0, 1])
    obj.quad(
        "receiver",
        DVec3::new(0.5, 0.0, 0.5),
        DVec3::Y,
        [1.0, 1.0],
        0.0,
    );
    obj.quad(
        "emitter",
        DVec3::new(0.0, 0.5, 0.5),
        DVec3::X,
        [1.0, 1.0],
        0.0,
    );
    let f = received_form_factor(&obj, &form_factor_params());
    let exact = 0.2000;
    assert!(
        (f - exact).abs() / exact < 0.02,
        "F = {f:.4}, exact {exact}"
    );
}

#[test]
fn a_floor_under_a_uniform_sky_reflects_rho_times_the_sky() {
    // an upward floor sees only sky: E = pi * Ls, so L = rho * Ls after the one bounce there is
    let ctx = gpu();
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [1.0, 1.0], 0.3);
    let rho = 0.6f32;
    let sky = [0.5f32, 1.0, 2.0];
    let path = write_scene(
        dir.path(),
        &obj,
        &[Mat {
            name: "floor",
            kd: [rho; 3],
            ke: [0.0; 3],
        }],
        &format!("[sky]\nradiance = [{}, {}, {}]\n", sky[0], sky[1], sky[2]),
    );
    let scene = Scene::load(&path).unwrap();
    let params = small_params();
    let (lf, _, report) = vlf::propagate::propagate(ctx, &scene, &params, &Silent).unwrap();
    assert!(report.sky && report.converged);
    let prepared = PreparedScene::new(&scene, params.texel_density).unwrap();
    for (c, s) in sky.iter().enumerate() {
        let l = face_mean(&prepared, &lf.total, |_| true, c);
        let expected = (rho * s) as f64;
        assert!(
            (l - expected).abs() / expected < 0.01,
            "channel {c}: {l} vs {expected}"
        );
    }
}

#[test]
fn perturbed_directions_keep_the_furnace_and_the_memory() {
    let ctx = gpu();
    let (_dir, scene) = furnace(0.5, 1.0);
    let base = small_params();
    let perturbed = PropagationParams {
        perturb: 3,
        ..base.clone()
    };
    let (_, _, one) = vlf::propagate::propagate(ctx.clone(), &scene, &base, &Silent).unwrap();
    let (lf, _, three) =
        vlf::propagate::propagate(ctx.clone(), &scene, &perturbed, &Silent).unwrap();
    let prepared = PreparedScene::new(&scene, base.texel_density).unwrap();
    let worst = worst_deviation(&prepared, &lf.total, 2.0);
    assert!(
        worst < 0.01,
        "perturbed furnace off by {:.2}%",
        worst * 100.0
    );
    // one visibility set resident at a time: memory within 10% of the fixed set's
    let (m1, m3) = (
        one.propagation_memory_bytes as f64,
        three.propagation_memory_bytes as f64,
    );
    assert!((m3 - m1).abs() / m1 < 0.1, "memory {m1} -> {m3}");
    assert_eq!(one.iterations, three.iterations);
}

#[test]
fn perturbed_directions_change_an_open_scene() {
    let ctx = gpu();
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let base = PropagationParams {
        geodesic_frequency: 3,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 8.0,
        tolerance: 1e-2,
        max_iterations: 30,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 64,
        mirror_direct: false,
        rim_rays: false,
    };
    let (a, _, _) = vlf::propagate::propagate(ctx.clone(), &scene, &base, &Silent).unwrap();
    let (b, _, _) = vlf::propagate::propagate(
        ctx.clone(),
        &scene,
        &PropagationParams { perturb: 4, ..base },
        &Silent,
    )
    .unwrap();
    let differing = a
        .total
        .iter()
        .zip(&b.total)
        .filter(|(x, y)| (x[1] - y[1]).abs() > 1e-4 * (1.0 + x[1].abs()))
        .count();
    assert!(
        differing > a.total.len() / 10,
        "perturbation changed only {differing} texels"
    );
}
