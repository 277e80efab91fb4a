//! The module structure stays acyclic: tools/module-cycles.py finds import cycles between the
//! children of every folder of src/, at every depth (the top-level modules; the files of
//! src/display/, src/tracking/, src/xr/; a folder's mod.rs is their parent, not a sibling). Lower modules (scene, params, bvh, stats, color, gpu, prepare) never
//! depend on the pipeline stages above them. The core leaves the lab (src/lab/, feature `lab`)
//! out: no core module names it, and its crates are not the core's. No function is longer than
//! 120 lines.

use crate::common;

use common::repo_path;
use std::process::Command;

#[test]
fn there_are_no_import_cycles() {
    let run = Command::new("python3")
        .arg(repo_path("tools/module-cycles.py"))
        .output()
        .expect("python3 is needed (3.11 or newer) to check the module graph");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "import cycles in src/ (each listed with its edges):\n{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("no import cycles"), "{stdout}");
}

/// The cycle check looks into nested folders: a circle between two files two folders down (and
/// one through a `use super::{...}` group inside an inline `mod tests`) is reported, naming
/// both files, and the check fails.
#[test]
fn the_cycle_check_sees_nested_folders() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    let files = [
        ("lib.rs", "pub mod outer;\n"),
        ("outer/mod.rs", "pub mod inner;\n"),
        ("outer/inner/mod.rs", "mod a;\nmod b;\nmod c;\n"),
        ("outer/inner/a.rs", "use super::b::B;\npub struct A;\n"),
        (
            "outer/inner/b.rs",
            "pub struct B;\n#[cfg(test)]\nmod tests {\n    use super::super::{c::C};\n}\n",
        ),
        (
            "outer/inner/c.rs",
            "pub struct C(crate::outer::inner::a::A);\n",
        ),
    ];
    for (path, text) in files {
        let path = src.join(path);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
    let run = Command::new("python3")
        .arg(repo_path("tools/module-cycles.py"))
        .arg("--src")
        .arg(&src)
        .output()
        .expect("python3 runs");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(!run.status.success(), "a cycle should fail: {stdout}");
    for named in [
        "src/outer/inner/",
        "a -> outer::inner::b",
        "b -> outer::inner::c",
        "c -> outer::inner::a",
    ] {
        assert!(stdout.contains(named), "{named:?} is not in:\n{stdout}");
    }
}

/// Functions do one job: none in src/ is longer than 120 lines (tools/long-functions.py counts
/// from the signature to the closing brace).
#[test]
fn no_function_is_longer_than_120_lines() {
    let run = Command::new("python3")
        .arg(repo_path("tools/long-functions.py"))
        .output()
        .expect("python3 is needed to measure the functions");
    assert!(
        run.status.success(),
        "functions over 120 lines (split them by job):\n{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
}

/// The core (`cargo build --no-default-features`) leaves the lab's crates out: plotters, the
/// lab's charts, comes only with the feature `lab` (src/lab/). (dejavu stays: the window HUD's
/// font is core.)
#[test]
fn the_core_builds_without_the_labs_crates() {
    let tree = |features: &[&str]| {
        let run = Command::new(env!("CARGO"))
            .args(["tree", "-e", "normal", "--prefix", "none", "--offline"])
            .args(features)
            .arg("--manifest-path")
            .arg(repo_path("Cargo.toml"))
            .output()
            .expect("cargo runs");
        assert!(
            run.status.success(),
            "cargo tree {features:?} failed:\n{}",
            String::from_utf8_lossy(&run.stderr)
        );
        String::from_utf8_lossy(&run.stdout)
            .lines()
            .filter_map(|l| l.split_whitespace().next().map(String::from))
            .collect::<std::collections::BTreeSet<String>>()
    };
    const LAB_ONLY: [&str; 1] = ["plotters"];
    let lab = tree(&[]);
    for name in LAB_ONLY {
        assert!(
            lab.contains(name),
            "the default build (with the lab) no longer has {name}: update LAB_ONLY"
        );
    }
    let core = tree(&["--no-default-features"]);
    for name in LAB_ONLY {
        assert!(
            !core.contains(name),
            "the core (--no-default-features) depends on {name}, which only the lab may use: \
             make it optional in Cargo.toml (`lab = [\"dep:{name}\"]`) and keep its users in \
             src/lab/ ({} crates in the core)",
            core.len()
        );
    }
}

/// The demo's `cargo build --features mpi` and the tests' `cargo test --features mpi` build every
/// shared dependency with the same features (cargo unifies the dev-dependencies' features only
/// into builds with tests): otherwise the test command rebuilds those crates and vlf itself
/// after the demo. Cargo.toml names the features the dev-dependencies add.
#[test]
fn the_demo_and_the_tests_build_one_dependency_graph() {
    let tree = |edges: &str| {
        let run = Command::new(env!("CARGO"))
            .args([
                "tree",
                "--features",
                "mpi",
                "-e",
                edges,
                "--prefix",
                "none",
                "--offline",
            ])
            .args(["-f", "{p} {f}", "--manifest-path"])
            .arg(repo_path("Cargo.toml"))
            .output()
            .expect("cargo runs");
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        String::from_utf8_lossy(&run.stdout)
            .lines()
            .map(|l| l.trim_end_matches(" (*)").to_string())
            .collect::<std::collections::BTreeSet<String>>()
    };
    let build = tree("normal,build");
    let test = tree("normal,build,dev");
    let differ: Vec<&String> = build.difference(&test).collect();
    assert!(
        differ.is_empty(),
        "the tests build these dependencies with other features than the demo does, so \
         `bash tools/test.sh` would rebuild them and vlf after `bash tools/demo.sh`: add the \
         features the test build has to Cargo.toml's unifying dependencies:\n{differ:#?}"
    );
}

/// No core module uses the lab: only src/lab/ itself and the binary's lab commands name it.
#[test]
fn no_core_module_uses_the_lab() {
    fn visit(dir: &std::path::Path, found: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let rel = path.strip_prefix(repo_path("src")).unwrap().to_owned();
            if rel.starts_with("lab") || rel == std::path::Path::new("cli/lab.rs") {
                continue;
            }
            if path.is_dir() {
                visit(&path, found);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                for (i, line) in text.lines().enumerate() {
                    let code = line.split("//").next().unwrap_or("");
                    if code.contains("crate::lab") || code.contains("vlf::lab") {
                        found.push(format!("src/{}:{}: {}", rel.display(), i + 1, line.trim()));
                    }
                }
            }
        }
    }
    let mut found = Vec::new();
    visit(&repo_path("src"), &mut found);
    assert!(
        found.is_empty(),
        "the core uses the lab (feature `lab`, off in a core build); move what it needs out of \
         src/lab/ into the core:\n{}",
        found.join("\n")
    );
}
