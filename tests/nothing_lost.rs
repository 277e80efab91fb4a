//! Nothing lost: a save killed midway leaves the previous file intact and loadable; a
//! propagation resumed from a checkpoint ends exactly where an uninterrupted one does.

use crate::common;
use common::*;
use std::process::Command;
use std::time::{Duration, Instant};
use vlf::lightfield::file;
use vlf::progress::Silent;
use vlf::propagate::checkpoint::CheckpointPlan;
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

const SMALL: &[&str] = &["--directions", "21", "--grid", "32", "--texel-density", "8"];

#[test]
fn killing_propagate_mid_save_keeps_the_previous_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cornell.vlf");
    let scene = repo_path("scenes/cornell/scene.toml");
    let first = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("propagate")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(SMALL)
        .output()
        .unwrap();
    assert!(first.status.success());
    let before = std::fs::read(&out).unwrap();
    // a second run with other settings, held between writing its temporary file and renaming
    let mut child = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("propagate")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(["--directions", "81", "--grid", "32", "--texel-density", "8"])
        .env("VLF_SAVE_DELAY_MS", "30000")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let temporary = loop {
        let tmp = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.path())
            .find(|p| p.to_string_lossy().contains(".tmp-"));
        if let Some(t) = tmp {
            break t;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the save never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        temporary.exists(),
        "killed mid-save: the temporary file is what is left"
    );
    assert_eq!(
        std::fs::read(&out).unwrap(),
        before,
        "the previous file changed"
    );
    file::load(&out).expect("the previous file still loads");
}

#[test]
fn a_resumed_propagation_ends_where_an_uninterrupted_one_does() {
    let ctx = gpu();
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let params = PropagationParams {
        geodesic_frequency: 3,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 8.0,
        tolerance: 1e-4,
        max_iterations: 200,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 16,
        mirror_direct: false,
        rim_rays: false,
    };
    let (whole, _, whole_report) =
        vlf::propagate::propagate(ctx.clone(), &scene, &params, &Silent).unwrap();
    assert!(whole_report.iterations >= 4);

    let dir = tempfile::tempdir().unwrap();
    let plan = CheckpointPlan {
        path: dir.path().join("run.checkpoint"),
        every: 1,
        resume: true,
    };
    // "interrupted" after two iterations (the cap), checkpointing each one
    let cut = PropagationParams {
        max_iterations: 2,
        ..params.clone()
    };
    let fresh = CheckpointPlan {
        resume: false,
        ..plan.clone()
    };
    vlf::propagate::propagate_with(ctx.clone(), &scene, &cut, &Silent, checkpoints(&fresh))
        .unwrap();
    // the cap is part of the settings: resume with the original ones
    let cp = vlf::propagate::checkpoint::Checkpoint::load(&plan.path).unwrap();
    assert_eq!(cp.meta.iteration, 2);
    let mut patched = cp.clone();
    patched.meta.params = params.clone();
    patched.save(&plan.path).unwrap();
    let (resumed, _, report) =
        vlf::propagate::propagate_with(ctx.clone(), &scene, &params, &Silent, checkpoints(&plan))
            .unwrap();
    assert_eq!(report.iterations, whole_report.iterations);
    assert!(report.warnings.iter().any(|w| w.contains("resumed")));
    let bits = |t: &[[f32; 4]]| t.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(
        bits(&resumed.total),
        bits(&whole.total),
        "resumed and uninterrupted results differ"
    );

    // a checkpoint of other settings is refused
    let other = PropagationParams {
        texel_density: 9.0,
        ..params
    };
    let e = vlf::propagate::propagate_with(ctx, &scene, &other, &Silent, checkpoints(&plan))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("run.checkpoint") && e.contains("other settings"),
        "{e}"
    );
}

/// A propagation's outputs: checkpoints as `plan` says, the light field left to the caller.
fn checkpoints(plan: &CheckpointPlan) -> vlf::propagate::Outputs<'_> {
    vlf::propagate::Outputs {
        checkpoints: Some(plan),
        light_field: None,
    }
}
