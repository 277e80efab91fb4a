//! `vlf verify` end to end on the software adapter: the light field of the Cornell box checked
//! against `vlf reference` (figures, the reference's noise, error maps, the verdict in words),
//! and a light field made with settings far too coarse is said to be off.

use crate::common;
use common::repo_path;
use std::process::Command;

fn verify(dir: &std::path::Path, extra: &[&str]) -> (String, serde_json::Value) {
    let json = dir.join("verify.json");
    let out = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("verify")
        .arg(repo_path("scenes/cornell/scene.toml"))
        .args(["--size", "48x48", "--spp", "512", "--out"])
        .arg(dir)
        .arg("--json")
        .arg(&json)
        .args(extra)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (stdout, report)
}

#[test]
fn verify_checks_every_camera_against_the_path_tracer_with_error_maps() {
    let dir = tempfile::tempdir().unwrap();
    // draft settings: what is checked here is the command (figures, noise, maps, a verdict that
    // follows the figures), not the light field's accuracy (tests/mitsuba.rs): the software
    // preset's propagation would take 45 of the test's 64 s on lavapipe
    let (table, json) = verify(dir.path(), &["--quality", "draft"]);
    println!("{table}");
    let views = json["views"].as_array().unwrap();
    assert_eq!(views.len(), 1, "Cornell has one camera");
    let v = &views[0];
    assert_eq!(v["camera"], "front");
    // a draft light field is still close to the path tracer on average
    let ratio = v["mean_ratio"].as_f64().unwrap();
    assert!((ratio - 1.0).abs() < 0.03, "mean ratio {ratio}");
    let noise = v["reference_noise_display_mse"].as_f64().unwrap();
    assert!(noise > 0.0 && noise < 1e-3, "reference noise {noise}");
    for map in v["error_maps"].as_array().unwrap() {
        let path = map.as_str().unwrap();
        let img = image::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
        assert_eq!((img.width(), img.height()), (48, 48));
    }
    assert!(std::path::Path::new(v["reference_image"].as_str().unwrap()).is_file());
    assert!(
        table.contains("mean ratio") && table.contains("targets:"),
        "{table}"
    );
    // the verdict follows the figures against the targets the table states
    let display_mse = v["comparison"]["display_mse"].as_f64().unwrap();
    let rel_mse = v["comparison"]["rel_mse"].as_f64().unwrap();
    let off = (ratio - 1.0).abs() > 0.01 || display_mse > 1e-4 || rel_mse > 2e-3;
    assert_eq!(v["missed"].as_array().unwrap().is_empty(), !off, "{v}");
    let verdict = match off {
        true => "front: THE LIGHT FIELD IS OFF",
        false => "front: within every target",
    };
    assert!(
        table.contains(verdict),
        "mean ratio {ratio}, display MSE {display_mse:.3e}, relMSE {rel_mse:.3e}: expected \
         \"{verdict}\" in\n{table}"
    );
}

#[test]
fn verify_says_when_the_light_field_is_off() {
    let dir = tempfile::tempdir().unwrap();
    // the paper's method through 21 directions and a coarse grid: the emitter's light ripples
    // over every wall
    let coarse = [
        "--directions",
        "21",
        "--grid",
        "16",
        "--texel-density",
        "8",
        "--direct-samples",
        "0",
    ];
    let (table, json) = verify(dir.path(), &coarse);
    println!("{table}");
    let missed = json["views"][0]["missed"].as_array().unwrap();
    assert!(!missed.is_empty(), "{table}");
    assert!(table.contains("front: THE LIGHT FIELD IS OFF"), "{table}");
}
