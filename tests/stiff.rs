//! Stiff scenes: furnaces with albedo near 1 converge, with the geometric-tail acceleration, in
//! a few iterations instead of about ln(tol)/ln(rho), and nothing goes negative, NaN or Inf.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::lightfield::directions::DirectionSet;
use vlf::prepare::PreparedScene;
use vlf::progress::Silent;
use vlf::propagate::transport::Propagator;
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

fn furnace(dir: &std::path::Path, rho: f32) -> Scene {
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.5, true);
    Scene::load(&write_scene(
        dir,
        &obj,
        &[Mat {
            name: "wall",
            kd: [rho; 3],
            ke: [1.0; 3],
        }],
        "",
    ))
    .unwrap()
}

fn params() -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 4,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 8.0,
        tolerance: 1e-3,
        max_iterations: 100,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 16,
        mirror_direct: false,
        rim_rays: false,
    }
}

#[test]
fn stiff_furnaces_converge_fast_with_acceleration() {
    for rho in [0.95f32, 0.99, 0.999] {
        let dir = tempfile::tempdir().unwrap();
        let scene = furnace(dir.path(), rho);
        let (lf, _, report) = vlf::propagate::propagate(gpu(), &scene, &params(), &Silent).unwrap();
        let expected = 1.0 / (1.0 - rho as f64);
        let plain = (params().tolerance.ln() / (rho as f64).ln()).ceil() as u32;
        let mut worst = 0.0f64;
        for (t, p) in lf
            .total
            .iter()
            .zip(&PreparedScene::new(&scene, 8.0).unwrap().atlas.points)
        {
            if p[3].to_bits() == u32::MAX {
                continue;
            }
            assert!(t.iter().all(|x| x.is_finite() && *x >= 0.0));
            worst = worst.max((t[0] as f64 - expected).abs() / expected);
        }
        println!(
            "rho {rho}: {} iterations with acceleration (report: plain shooting about {:?}; ln(tol)/ln(rho) = {plain}), worst texel {:.3}% off {expected:.1}",
            report.iterations, report.plain_iterations_estimate, worst * 100.0
        );
        assert!(
            worst < 0.01,
            "rho {rho}: worst texel {:.2}% off",
            worst * 100.0
        );
        assert!(report.converged && report.tail.is_some());
        assert!(
            report.iterations * 10 <= plain,
            "rho {rho}: {} iterations, plain needs {plain}",
            report.iterations
        );
    }
}

#[test]
fn no_value_goes_negative_or_non_finite_on_the_way() {
    let dir = tempfile::tempdir().unwrap();
    let scene = furnace(dir.path(), 0.999);
    let p = params();
    let prepared = PreparedScene::new(&scene, p.texel_density).unwrap();
    let mut prop = Propagator::new(
        gpu(),
        &prepared,
        &p,
        &DirectionSet::geodesic(p.geodesic_frequency),
        None,
        None,
    )
    .unwrap();
    prop.build_visibility().unwrap();
    for _ in 0..6 {
        let stats = prop.iterate().unwrap();
        assert!(stats.residual.is_finite() && stats.residual >= 0.0);
        for v in prop
            .read_total()
            .unwrap()
            .iter()
            .chain(prop.read_unshot().unwrap().iter())
        {
            assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0), "{v:?}");
        }
    }
}
