//! The power balance in every propagation report: emitted + sky = absorbed + escaped + unshot,
//! each term measured on its own (src/propagate/transport.rs says how). It closes within 0.5% on
//! closed and open scenes, with and without mirrors; escape is measured at the senders (a lone
//! floor under the sky sends exactly its albedo's share back out); and the two-sided light loss
//! that `facing_side` fixed, switched back on, is flagged in words with the material whose light
//! goes missing.

use crate::common;
use common::{closed_box_with_block, gpu, load_scene, Mat, ObjBuilder};
use glam::DVec3;
use vlf::params::PropagationParams;
use vlf::progress::Silent;
use vlf::propagate::report::{PowerBalance, PropagationReport};
use vlf::propagate::Regression;
use vlf::scene::Scene;

fn params(mirror_direct: bool) -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 6,
        grid_resolution: 64,
        tile_size: 8,
        texel_density: 16.0,
        tolerance: 1e-3,
        max_iterations: 100,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 64,
        mirror_direct,
        rim_rays: false,
    }
}

fn run(scene: &Scene, params: &PropagationParams, regression: Regression) -> PropagationReport {
    let (_, _, report) = vlf::propagate::propagate_with_regression(
        gpu(),
        scene,
        params,
        &Silent,
        Default::default(),
        regression,
    )
    .unwrap();
    let b = balance(&report);
    eprintln!("{}: {}", report.scene, b.verdict);
    for s in &report.per_iteration {
        let p = s.power.expect("every iteration is measured");
        eprintln!(
            "  iteration {}: shot {:.4} received {:.4} absorbed {:.4} escaped {:.4} backs {:.4} unshot {:.4} residue {:+.3e}",
            s.iteration, p.shot, p.received, p.absorbed, p.escaped, p.absorbed_by_backs, p.unshot, p.residue
        );
    }
    report
}

fn balance(report: &PropagationReport) -> &PowerBalance {
    report.power_balance.as_ref().expect("a power balance")
}

fn mat(name: &'static str, kd: f32, ke: f32) -> Mat {
    Mat {
        name,
        kd: [kd; 3],
        ke: [ke; 3],
    }
}

/// A closed box (inward walls), a floating block and an emitter under the ceiling.
fn closed_box() -> (ObjBuilder, Vec<Mat>) {
    let obj = closed_box_with_block();
    let mats = vec![
        mat("wall", 0.7, 0.0),
        mat("block", 0.5, 0.0),
        mat("light", 0.0, 4.0),
    ];
    (obj, mats)
}

const TWO_SIDED: &str = "[materials.wall]\ntwo_sided = true\n[materials.block]\ntwo_sided = true\n";

#[test]
fn a_closed_box_balances_with_one_sided_and_two_sided_walls() {
    let (obj, mats) = closed_box();
    // with and without rim rays (`rim_rays`: texels the lists cannot place cast rays)
    let with_rays = PropagationParams {
        rim_rays: true,
        ..params(false)
    };
    for (toml, settings) in [
        ("", params(false)),
        (TWO_SIDED, params(false)),
        ("", with_rays.clone()),
        (TWO_SIDED, with_rays),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let report = run(
            &load_scene(dir.path(), &obj, &mats, toml),
            &settings,
            Regression::default(),
        );
        let b = balance(&report);
        assert!(!b.off && b.residue_fraction.abs() < 0.005, "{}", b.verdict);
        assert!(b.verdict.contains("closes within 0.5%"), "{}", b.verdict);
        // nothing leaves a closed box; what meets a back is the ceiling's light on the back of
        // the emitter just under it; the rest is absorbed, or still unshot where the geometric
        // tail stopped the iterations
        let injected = b.emitted + b.sky;
        assert!(
            b.escaped < 1e-3 * injected,
            "escaped {:.3e} of {injected:.3e}",
            b.escaped
        );
        assert!(
            b.absorbed_by_backs < 1e-2 * injected,
            "{:.3e}",
            b.absorbed_by_backs
        );
        let kept = b.absorbed + b.absorbed_by_backs + b.unshot;
        assert!(
            kept > 0.995 * injected,
            "absorbed and unshot {kept:.4} of {injected:.4}"
        );
        assert!(!report.warnings.iter().any(|w| w.contains("power balance")));
    }
}

#[test]
fn the_balance_flags_the_two_sided_loss_with_the_fix_switched_off() {
    let (obj, mats) = closed_box();
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(dir.path(), &obj, &mats, TWO_SIDED);
    let fixed = run(&scene, &params(false), Regression::default());
    let old = Regression {
        list_order_sides: true,
    };
    let broken = run(&scene, &params(false), old);
    let (f, b) = (balance(&fixed), balance(&broken));
    assert!(!f.off, "{}", f.verdict);
    assert!(b.off && b.residue_fraction > 0.02, "{}", b.verdict);
    assert!(
        b.verdict.starts_with("power balance off by +"),
        "{}",
        b.verdict
    );
    // the light that went missing is the two-sided walls': named, and most of the residue
    let worst = &b.losses[0];
    eprintln!("losses: {:#?}", b.losses);
    assert_eq!(worst.material, "wall", "{:#?}", b.losses);
    assert!(
        worst.share_of_injected > 0.5 * b.residue_fraction,
        "{worst:#?}"
    );
    assert!(b.verdict.contains("'wall'"), "{}", b.verdict);
    assert!(broken.warnings.iter().any(|w| w == &b.verdict));
    // the fixed run loses none of the walls' light
    assert!(b.absorbed < f.absorbed - 0.02 * f.emitted);
}

#[test]
fn escape_is_measured_at_the_senders_not_taken_as_the_remainder() {
    // a lone floor of albedo 0.5 under a uniform sky: it receives pi L A, absorbs half and sends
    // the other half, all of it, back to the sky
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [2.0, 2.0], 0.0);
    let scene = load_scene(
        dir.path(),
        &obj,
        &[mat("floor", 0.5, 0.0)],
        "[sky]\nradiance = [1.0, 1.0, 1.0]\n",
    );
    let report = run(&scene, &params(false), Regression::default());
    let b = balance(&report);
    let injected = b.emitted + b.sky;
    assert_eq!(b.emitted, 0.0);
    for (what, value, expected) in [("escaped", b.escaped, 0.5), ("absorbed", b.absorbed, 0.5)] {
        assert!(
            (value / injected - expected).abs() < 2e-3,
            "{what}: {:.5} of the injected power",
            value / injected
        );
    }
    assert!(b.residue_fraction.abs() < 2e-3, "{}", b.verdict);
    // repeatable to the bit
    let again = run(&scene, &params(false), Regression::default());
    assert_eq!(balance(&again).residue.to_bits(), b.residue.to_bits());
}

#[test]
fn an_open_box_with_a_mirror_floor_balances() {
    // five inward walls, open at the top; a mirror floor throws the light back up, much of it
    // out through the opening
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    for (c, n) in [
        (DVec3::new(0.0, -1.0, 0.0), DVec3::Y),
        (DVec3::new(-1.0, 0.0, 0.0), DVec3::X),
        (DVec3::new(1.0, 0.0, 0.0), -DVec3::X),
        (DVec3::new(0.0, 0.0, -1.0), DVec3::Z),
        (DVec3::new(0.0, 0.0, 1.0), -DVec3::Z),
    ] {
        obj.quad(
            if n == DVec3::Y { "floor" } else { "wall" },
            c,
            n,
            [2.0, 2.0],
            0.0,
        );
    }
    obj.quad(
        "light",
        DVec3::new(0.2, 0.5, 0.1),
        -DVec3::Y,
        [0.8, 0.8],
        0.3,
    );
    let mats = [
        mat("floor", 0.0, 0.0),
        mat("wall", 0.6, 0.0),
        mat("light", 0.0, 4.0),
    ];
    let toml = "[materials.floor]\nmirror = [0.8, 0.8, 0.8]\ndiffuse = [0.0, 0.0, 0.0]\n";
    let scene = load_scene(dir.path(), &obj, &mats, toml);
    let mut results = Vec::new();
    for mirror_direct in [true, false] {
        let report = run(&scene, &params(mirror_direct), Regression::default());
        let b = balance(&report).clone();
        let injected = b.emitted + b.sky;
        let mirrored: f64 = (report.per_iteration.iter())
            .map(|s| s.power.unwrap().mirrored)
            .sum();
        eprintln!(
            "mirror_direct {mirror_direct}: mirrored {:.3} escaped {:.3} of the injected power",
            mirrored / injected,
            b.escaped / injected
        );
        results.push((b, mirrored / injected));
    }
    for (b, mirrored) in results {
        assert!(!b.off && b.residue_fraction.abs() < 0.005, "{}", b.verdict);
        assert!(mirrored > 0.1 && b.escaped > 0.1 * (b.emitted + b.sky));
    }
}

#[test]
fn batched_directions_and_perturbed_sets_measure_the_same_balance() {
    // with batches the per-texel terms are raw sums normalised with next; perturbed sets
    // average theirs: the same box measures the same
    let (obj, mats) = closed_box();
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(dir.path(), &obj, &mats, TWO_SIDED);
    let coarse = PropagationParams {
        geodesic_frequency: 6,
        grid_resolution: 48,
        texel_density: 8.0,
        max_iterations: 4,
        accelerate: false,
        ..params(false)
    };
    let plain = run(&scene, &coarse, Regression::default());
    let budget = PropagationParams {
        memory_budget_mib: Some(2),
        ..coarse.clone()
    };
    let batched = run(&scene, &budget, Regression::default());
    assert!(batched.direction_batches > 1, "not batched");
    for (a, b) in plain.per_iteration.iter().zip(&batched.per_iteration) {
        let (a, b) = (a.power.unwrap(), b.power.unwrap());
        for (what, x, y) in [
            ("received", a.received, b.received),
            ("absorbed", a.absorbed, b.absorbed),
            ("backs", a.absorbed_by_backs, b.absorbed_by_backs),
            ("unshot", a.unshot, b.unshot),
        ] {
            assert!(
                (x - y).abs() <= 1e-4 * a.shot,
                "{what}: {x} resident, {y} batched"
            );
        }
    }
    let perturbed = PropagationParams {
        perturb: 2,
        ..coarse
    };
    // other directions, the same balance to a tenth of a percent
    let b = run(&scene, &perturbed, Regression::default());
    let (p, q) = (
        balance(&plain).residue_fraction,
        balance(&b).residue_fraction,
    );
    assert!(
        (p - q).abs() < 1e-3,
        "residue {p:.5} with one set, {q:.5} with two"
    );
}

/// A two-sided emitter's own light never reaches its back: a tilted two-sided emitting panel
/// (reflecting too, so its back's intake is measured as next / albedo) in a closed box. Its
/// back texels lie in its plane; before the fix, where rounding put one a hair in front, the
/// panel's own triangle filled that texel's hemisphere and iteration 1 received more than was
/// emitted (the Space Ship Hallway: 121.75%). Iteration 1 must receive no more than what was
/// shot, and the balance close within 0.5%.
#[test]
fn a_two_sided_emitter_does_not_light_its_own_back() {
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 1.0, true);
    obj.quad(
        "light",
        DVec3::new(0.137, 0.213, -0.091),
        DVec3::new(0.3, -0.9, 0.31),
        [0.41, 0.37],
        0.3,
    );
    let mats = vec![mat("wall", 0.6, 0.0), mat("light", 0.5, 3.0)];
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(
        dir.path(),
        &obj,
        &mats,
        "[materials.light]\ntwo_sided = true\n",
    );
    let report = run(&scene, &params(false), Regression::default());
    let first = report.per_iteration[0].power.expect("measured");
    assert!(
        first.received <= 1.005 * first.shot,
        "iteration 1 received {:.4} of {:.4} shot",
        first.received,
        first.shot
    );
    let b = balance(&report);
    assert!(!b.off && b.residue_fraction.abs() < 0.005, "{}", b.verdict);
}
