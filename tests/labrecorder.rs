//! LabRecorder's XDF file of vlf's LSL outlets, loaded with pyxdf (tools/study/labrecorder_check.py):
//! the three streams with their declared rates and channels, every pose sample equal to its
//! frame's row of the session log, the event marker on vlf.events. Ignored by default: it needs
//! LabRecorderCLI, which `bash tools/study/get-labrecorder.sh` builds from LabRecorder's source
//! (a clone from GitHub), and pyxdf; run it with `cargo test --release --features mpi --test
//! labrecorder -- --ignored`.

use crate::common;

use common::{draft_params, gpu, repo_path};
use vlf::progress::Silent;

#[test]
#[ignore = "needs LabRecorderCLI (bash tools/study/get-labrecorder.sh) and pyxdf (pip install pyxdf)"]
fn labrecorder_records_the_outlets_into_an_xdf_file_that_pyxdf_loads_as_the_log_has_them() {
    let recorder = repo_path("target/labrecorder/LabRecorderCLI");
    assert!(
        recorder.exists(),
        "no {}: `bash tools/study/get-labrecorder.sh` builds it",
        recorder.display()
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    let vlf_path = dir.path().join("cornell.vlf");
    vlf::lightfield::file::save(&lf, &vlf_path).unwrap();
    let out = std::process::Command::new("python3")
        .arg(repo_path("tools/study/labrecorder_check.py"))
        .arg(env!("CARGO_BIN_EXE_vlf"))
        .arg(&vlf_path)
        .arg(dir.path().join("check"))
        .arg("--labrecorder")
        .arg(&recorder)
        .output()
        .expect("python3 runs tools/study/labrecorder_check.py");
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{summary}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got: serde_json::Value = serde_json::from_str(&summary).unwrap();
    assert_eq!(got["pose"]["mismatched_against_frames_csv"], 0);
    assert!(got["pose"]["samples"].as_u64().unwrap() >= 20, "{summary}");
    eprintln!("{summary}");
}
