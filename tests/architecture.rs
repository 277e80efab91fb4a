//! The module structure stays acyclic: tools/module-cycles.py finds import cycles between the
//! top-level modules of src/ and between the files of one module (a folder's mod.rs is their
//! parent, not a sibling). Lower modules (scene, params, bvh, stats, color, gpu, prepare) never
//! depend on the pipeline stages above them.

mod common;

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
