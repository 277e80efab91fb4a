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

/// The picture manifest (docs/images/pictures.toml, tools/pictures.py): every picture the
/// documents show is listed with the command that makes it, no picture lies unused, and none
/// shows inputs that changed since it was made.
#[test]
fn every_picture_is_made_by_a_command_and_current() {
    let manifest: toml::Table =
        toml::from_str(&std::fs::read_to_string(repo_path("docs/images/pictures.toml")).unwrap())
            .expect("docs/images/pictures.toml parses");
    let pictures = manifest["pictures"].as_table().expect("a [pictures] table");
    let mut shown = std::collections::BTreeSet::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        for (i, _) in text.match_indices("docs/images/") {
            let name: String = text[i + "docs/images/".len()..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || "-_.".contains(*c))
                .collect();
            if name.ends_with(".png") || name.ends_with(".jpg") {
                shown.insert((name, doc.display().to_string()));
            }
        }
    }
    let listed: Vec<&str> = (pictures.values())
        .map(|p| p["image"].as_str().expect("image is a file name"))
        .collect();
    for (image, doc) in &shown {
        assert!(
            listed.contains(&image.as_str()),
            "{doc} shows docs/images/{image}, which docs/images/pictures.toml does not list: add what makes it"
        );
    }
    for entry in std::fs::read_dir(repo_path("docs/images")).unwrap() {
        let file = entry.unwrap().file_name().to_string_lossy().to_string();
        assert!(
            file == "pictures.toml" || shown.iter().any(|(image, _)| *image == file),
            "docs/images/{file} is shown nowhere: remove it, or show it"
        );
    }
    let mut stale = Vec::new();
    for (name, p) in pictures {
        let image = p["image"].as_str().unwrap();
        assert!(
            repo_path("docs/images").join(image).is_file(),
            "docs/images/{image} ({name}) is missing"
        );
        let made_by = p["made_by"].as_str().unwrap();
        assert!(
            repo_path(made_by).is_file(),
            "{name}: made_by {made_by:?} is not a file of the repository"
        );
        let shows: Vec<&str> = (p["shows"].as_array().unwrap().iter())
            .map(|s| s.as_str().unwrap())
            .collect();
        let now = inputs_hash(&shows);
        let then = p.get("inputs_sha256").and_then(|h| h.as_str());
        if then != Some(now.as_str()) {
            let machine = p["machine"].as_str().unwrap();
            stale.push(format!(
                "  {image}: made by {made_by} ({machine}); it shows {shows:?}, changed since it was made"
            ));
        }
    }
    assert!(
        stale.is_empty(),
        "pictures older than what they show (regenerate each with its command, then stamp it: \
         `bash tools/pictures.sh target/release/vlf OUT NAME` and `python3 tools/pictures.py stamp OUT`, \
         or for pictures made by another script `python3 tools/pictures.py restamp NAME` once it ran):\n{}",
        stale.join("\n")
    );
}

/// The documents whose pictures the manifest must list.
fn documents() -> Vec<std::path::PathBuf> {
    let mut docs: Vec<_> = [
        "README.md",
        "BENCHMARKS.md",
        "ARCHITECTURE.md",
        "STABILITY.md",
    ]
    .iter()
    .map(|d| repo_path(d))
    .collect();
    if let Ok(dir) = std::fs::read_dir(repo_path("docs")) {
        docs.extend(
            dir.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "md")),
        );
    }
    docs
}

/// tools/pictures.py's `inputs_hash`: sha256 over the files below each path, in order; within a
/// folder sorted by relative path; each file's path ('/'-separated), a NUL, its bytes, a NUL.
fn inputs_hash(shows: &[&str]) -> String {
    use sha2::{Digest, Sha256};
    let root = repo_path(".");
    let mut hasher = Sha256::new();
    for entry in shows {
        let path = root.join(entry);
        let mut files = Vec::new();
        if path.is_dir() {
            collect_files(&path, &mut files);
        } else {
            assert!(
                path.is_file(),
                "{entry} (in a picture's `shows`) does not exist"
            );
            files.push(path);
        }
        let relative = |f: &std::path::Path| {
            let r = f.strip_prefix(&root).unwrap();
            (r.components())
                .map(|c| c.as_os_str().to_string_lossy().to_string())
                .collect::<Vec<_>>()
                .join("/")
        };
        files.sort_by_key(|f| relative(f));
        for f in files {
            hasher.update(relative(&f).as_bytes());
            hasher.update([0u8]);
            hasher.update(std::fs::read(&f).unwrap());
            hasher.update([0u8]);
        }
    }
    hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn collect_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            collect_files(&path, out);
        } else if path.is_file() {
            out.push(path);
        }
    }
}
