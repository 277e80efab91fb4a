//! The published figures are generated, and stale ones fail the build: README.md's measured
//! figures come from docs/results/ through tools/figures.py (tools/figures.toml names each
//! one's file and expression), BENCHMARKS.md is assembled from docs/results/h100/bench/ by
//! tools/benchmarks-md.sh. (README's accuracy block has its own check in tests/picture.rs.)

mod common;

use common::repo_path;
use std::process::Command;

#[test]
fn the_readme_figures_are_current() {
    let run = Command::new("python3")
        .arg(repo_path("tools/figures.py"))
        .arg("--check")
        .output()
        .expect("python3 is needed (3.11 or newer) to check README's figures");
    assert!(
        run.status.success(),
        "README.md's figures differ from docs/results/ (run `python3 tools/figures.py`):\n{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn benchmarks_md_is_generated_from_the_committed_results() {
    let run = Command::new("bash")
        .arg(repo_path("tools/benchmarks-md.sh"))
        .arg(repo_path("docs/results/h100/bench"))
        .arg(env!("CARGO_BIN_EXE_vlf"))
        .arg(repo_path("docs/results/xr-h200"))
        .current_dir(repo_path("."))
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "tools/benchmarks-md.sh failed:\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let generated = String::from_utf8(run.stdout).unwrap();
    let committed = std::fs::read_to_string(repo_path("BENCHMARKS.md")).unwrap();
    if generated != committed {
        let out = std::env::temp_dir().join("BENCHMARKS.generated.md");
        std::fs::write(&out, &generated).unwrap();
        let first = generated
            .lines()
            .zip(committed.lines())
            .position(|(a, b)| a != b)
            .map_or(
                generated.lines().count().min(committed.lines().count()),
                |i| i,
            );
        panic!(
            "BENCHMARKS.md is not what tools/benchmarks-md.sh makes of docs/results/h100/bench/ \
             (first difference at line {}); the generated file is {}: \
             `bash tools/benchmarks-md.sh docs/results/h100/bench target/release/vlf > BENCHMARKS.md`",
            first + 1,
            out.display()
        );
    }
}
