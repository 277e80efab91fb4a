//! Directions in batches: when the visibility lists of every direction do not fit (a memory
//! budget, or one binding: 128 MiB on the software adapter), each iteration builds the lists of
//! one batch at a time and normalises once at the end. The result must be the resident one.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::lightfield::directions::DirectionSet;
use vlf::prepare::PreparedScene;
use vlf::progress::Silent;
use vlf::propagate::transport::Propagator;
use vlf::propagate::{BatchPlan, PropagationParams};
use vlf::scene::Scene;

fn params(n: u32, grid: u32) -> PropagationParams {
    PropagationParams {
        geodesic_frequency: n,
        grid_resolution: grid,
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

/// A room with a ceiling light, a block, and (optionally) a mirror wall: occlusion, several
/// bounces and mirror tiles all take part.
fn room(dir: &std::path::Path, mirror: bool) -> Scene {
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.8, true);
    obj.cube("block", DVec3::new(0.2, -0.5, 0.1), 0.25, false);
    obj.quad(
        "light",
        DVec3::new(0.0, 0.79, 0.0),
        -DVec3::Y,
        [0.4, 0.4],
        0.0,
    );
    obj.quad(
        "glass",
        DVec3::new(-0.79, 0.0, 0.0),
        DVec3::X,
        [1.0, 1.0],
        0.0,
    );
    let extra = if mirror {
        "[materials.glass]\nmirror = [0.8, 0.8, 0.8]\ndiffuse = [0.0, 0.0, 0.0]\n"
    } else {
        ""
    };
    Scene::load(&write_scene(
        dir,
        &obj,
        &[
            Mat {
                name: "wall",
                kd: [0.7, 0.6, 0.5],
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
                ke: [10.0; 3],
            },
            Mat {
                name: "glass",
                kd: [0.4; 3],
                ke: [0.0; 3],
            },
        ],
        extra,
    ))
    .unwrap()
}

/// Totals (texels, tile cells) after `iterations` iterations with the given batch plan.
fn run(
    scene: &Scene,
    p: &PropagationParams,
    plan: &BatchPlan,
    iterations: u32,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<f64>) {
    let prepared = PreparedScene::new(scene, p.texel_density).unwrap();
    let directions = DirectionSet::geodesic(p.geodesic_frequency);
    let mut prop = Propagator::new(gpu(), &prepared, p, &directions, None, Some(plan)).unwrap();
    if plan.resident() {
        prop.build_visibility().unwrap();
    }
    let residuals = (0..iterations)
        .map(|_| prop.iterate().unwrap().residual)
        .collect();
    (
        prop.read_total().unwrap(),
        prop.read_tile_total().unwrap(),
        residuals,
    )
}

fn worst_relative(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b
        .iter()
        .map(|v| v[0].max(v[1]).max(v[2]) as f64)
        .fold(0.0, f64::max)
        .max(1e-30);
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] as f64 - y[k] as f64).abs() / scale))
        .fold(0.0, f64::max)
}

#[test]
fn batched_directions_give_the_resident_result() {
    for mirror in [false, true] {
        let dir = tempfile::tempdir().unwrap();
        let scene = room(dir.path(), mirror);
        let p = params(4, 32);
        let all = p.direction_count();
        let resident = run(&scene, &p, &BatchPlan::single(all), 4);
        // uneven batches, the last one short
        let plan = BatchPlan {
            batch_size: 19,
            batches: all.div_ceil(19),
            reason: Some("test".into()),
        };
        let batched = run(&scene, &p, &plan, 4);
        let texels = worst_relative(&batched.0, &resident.0);
        println!(
            "mirror {mirror}: {} batches, texels worst {texels:.2e} of the maximum",
            plan.batches
        );
        assert!(texels < 1e-5, "texels differ by {texels:.2e}");
        if mirror {
            assert!(!resident.1.is_empty());
            let tiles = worst_relative(&batched.1, &resident.1);
            println!("  tile cells worst {tiles:.2e} of the maximum");
            assert!(tiles < 1e-5, "tile cells differ by {tiles:.2e}");
        }
        for (a, b) in batched.2.iter().zip(&resident.2) {
            assert!((a - b).abs() <= 1e-5 * b.max(1e-30), "residuals {a} vs {b}");
        }
    }
}

#[test]
fn a_memory_budget_batches_the_directions_and_keeps_the_result() {
    const BUDGET_MIB: u64 = 4;
    let dir = tempfile::tempdir().unwrap();
    let scene = room(dir.path(), false);
    // 81 directions x 128^2 cells: 10.6 MiB of cell tables alone
    let p = params(4, 128);
    let (free, _, free_report) = vlf::propagate::propagate(gpu(), &scene, &p, &Silent).unwrap();
    let budget = PropagationParams {
        memory_budget_mib: Some(BUDGET_MIB),
        ..p.clone()
    };
    let (tight, _, report) = vlf::propagate::propagate(gpu(), &scene, &budget, &Silent).unwrap();
    println!(
        "free: {} batch(es), {:.1} MiB; {BUDGET_MIB} MiB budget: {} batches of {}, {:.1} MiB",
        free_report.direction_batches,
        free_report.propagation_memory_bytes as f64 / 1048576.0,
        report.direction_batches,
        report.directions_per_batch,
        report.propagation_memory_bytes as f64 / 1048576.0
    );
    assert_eq!(free_report.direction_batches, 1);
    assert!(free_report.visibility_kept_resident);
    assert!(report.direction_batches > 1 && !report.visibility_kept_resident);
    assert!(
        report.propagation_memory_bytes <= BUDGET_MIB << 20,
        "{} bytes used",
        report.propagation_memory_bytes
    );
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains(&format!("--memory-budget {BUDGET_MIB} MiB"))),
        "{:?}",
        report.warnings
    );
    assert_eq!(report.iterations, free_report.iterations);
    let worst = worst_relative(&tight.total, &free.total);
    assert!(worst < 1e-5, "budgeted result differs by {worst:.2e}");
}

#[test]
fn visibility_larger_than_one_binding_is_split_into_batches() {
    // 181 directions x 512^2 cells: the cell tables alone are 181 MiB each, beyond the software
    // adapter's 128 MiB binding. Before batching this scene was refused; now it must run and be
    // right (a furnace: every texel Le / (1 - rho)).
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.5, true);
    let rho = 0.5f32;
    let scene = Scene::load(&write_scene(
        dir.path(),
        &obj,
        &[Mat {
            name: "wall",
            kd: [rho; 3],
            ke: [1.0; 3],
        }],
        "",
    ))
    .unwrap();
    let p = PropagationParams {
        texel_density: 4.0,
        ..params(6, 512)
    };
    let ctx = gpu();
    let cell_table = p.direction_count() as u64 * 512 * 512 * 4;
    let (lf, _, report) = vlf::propagate::propagate(ctx.clone(), &scene, &p, &Silent).unwrap();
    println!(
        "{} directions x 512^2: {} batch(es) of {} (binding limit {} MiB)",
        report.directions,
        report.direction_batches,
        report.directions_per_batch,
        ctx.limits().max_storage_buffer_binding_size >> 20
    );
    if cell_table > ctx.limits().max_storage_buffer_binding_size {
        assert!(report.direction_batches > 1);
        assert!(
            report.directions_per_batch as u64 * 512 * 512 * 4
                <= ctx.limits().max_storage_buffer_binding_size
        );
    }
    let expected = 1.0 / (1.0 - rho as f64);
    let points = PreparedScene::new(&scene, p.texel_density)
        .unwrap()
        .atlas
        .points;
    let mut worst = 0.0f64;
    for (t, pt) in lf.total.iter().zip(&points) {
        if pt[3].to_bits() != u32::MAX {
            worst = worst.max((t[0] as f64 - expected).abs() / expected);
        }
    }
    assert!(worst < 0.01, "furnace texel {:.2}% off", worst * 100.0);
}

#[test]
fn a_budget_too_small_for_the_radiance_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let scene = room(dir.path(), false);
    let p = PropagationParams {
        texel_density: 200.0,
        memory_budget_mib: Some(1),
        ..params(4, 32)
    };
    let Err(err) = vlf::propagate::propagate(gpu(), &scene, &p, &Silent) else {
        panic!("a 1 MiB budget was accepted")
    };
    let err = err.to_string();
    println!("{err}");
    assert!(
        err.contains("memory budget of 1 MiB") && err.contains("raise --memory-budget"),
        "{err}"
    );
}

#[test]
fn too_many_pages_are_refused_with_advice() {
    let e = vlf::lightfield::tiles::TilePages::plan(1 << 26, 64, 64 << 20)
        .unwrap_err()
        .to_string();
    println!("{e}");
    assert!(
        e.contains(&format!(
            "at most {}",
            vlf::lightfield::tiles::MAX_TILE_PAGES
        )) && e.contains("fewer directions"),
        "{e}"
    );
    let ok = vlf::lightfield::tiles::TilePages::plan(1 << 24, 64, 128 << 20).unwrap();
    assert_eq!((ok.pages, ok.page_cells), (2, 1 << 23));
    assert_eq!(ok.ranges(), vec![(0, 1 << 23), (1 << 23, 1 << 23)]);
}
