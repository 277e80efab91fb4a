//! Every WGSL stage parses and validates with naga (errors name the file and line), and every
//! GPU struct has the same size in Rust and WGSL.

use vlf::gpu::shaders;
use vlf::gpu::types::mirrored_structs;

#[test]
fn every_shader_parses_and_validates() {
    let mut failures = Vec::new();
    for stage in shaders::STAGES {
        let expanded = shaders::expand(stage).expect("includes resolve");
        if let Err(e) = expanded.validate() {
            failures.push(e);
        }
    }
    assert!(
        failures.is_empty(),
        "shader errors:\n{}",
        failures.join("\n\n")
    );
}

#[test]
fn every_shader_file_is_embedded() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut on_disk = Vec::new();
    for entry in walk(&dir) {
        on_disk.push(
            entry
                .strip_prefix(&dir)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/"),
        );
    }
    on_disk.sort();
    let mut embedded: Vec<String> = shaders::SOURCES
        .iter()
        .map(|(n, _)| n.to_string())
        .collect();
    embedded.sort();
    assert_eq!(
        on_disk, embedded,
        "shaders/ and gpu::shaders::SOURCES must list the same files"
    );
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else if p.extension().is_some_and(|x| x == "wgsl") {
            out.push(p);
        }
    }
    out
}

#[test]
fn an_error_names_the_original_file_and_line() {
    let bad = shaders::ExpandedShader {
        name: "broken.wgsl".into(),
        source: "fn f() -> u32 {\n    return 1.0;\n}\n".into(),
        line_origin: vec![
            ("broken.wgsl".into(), 10),
            ("broken.wgsl".into(), 11),
            ("broken.wgsl".into(), 12),
        ],
    };
    let err = bad.validate().unwrap_err();
    assert!(err.contains("shaders/broken.wgsl:1"), "{err}");
}

#[test]
fn rust_and_wgsl_struct_sizes_agree() {
    for (rust, wgsl, size, stage) in mirrored_structs() {
        let module = shaders::expand(stage).unwrap().validate().unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (handle, _) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(wgsl))
            .unwrap_or_else(|| panic!("WGSL struct {wgsl} not found"));
        let wgsl_size = layouter[handle].size as usize;
        assert_eq!(
            size, wgsl_size,
            "{rust} is {size} bytes in Rust but {wgsl} is {wgsl_size} in WGSL"
        );
    }
}
