//! Every WGSL stage parses and validates with naga (errors name the file and line), every GPU
//! struct has the same size and field offsets in Rust and WGSL, and every stage's bind group
//! layouts reflect from its WGSL.

use vlf::gpu::shaders;
use vlf::mirrored::mirrored_structs;

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
fn rust_and_wgsl_structs_agree_field_by_field() {
    // every named WGSL member has a Rust field of the same name at the same offset; fields
    // either side lacks are padding (named `_...`); sizes agree
    let mut problems = Vec::new();
    for m in mirrored_structs() {
        let module = shaders::expand(m.stage).unwrap().validate().unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (handle, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(m.wgsl))
            .unwrap_or_else(|| panic!("WGSL struct {} not found in {}", m.wgsl, m.stage));
        let wgsl_size = layouter[handle].size as usize;
        if m.size != wgsl_size {
            problems.push(format!(
                "{} is {} bytes in Rust, {} is {wgsl_size} in WGSL",
                m.rust, m.size, m.wgsl
            ));
        }
        let naga::TypeInner::Struct { members, .. } = &ty.inner else {
            panic!("{} is not a struct", m.wgsl)
        };
        for member in members {
            let name = member.name.as_deref().unwrap_or("?");
            if name.starts_with('_') {
                continue; // padding: the sizes and the named members' offsets pin it down
            }
            match m.fields.iter().find(|(f, _)| *f == name) {
                Some((_, offset)) if *offset == member.offset as usize => {}
                Some((_, offset)) => problems.push(format!(
                    "{}.{name} at byte {offset} in Rust, {}.{name} at {} in WGSL",
                    m.rust, m.wgsl, member.offset
                )),
                None => problems.push(format!("{}.{name} has no Rust field in {}", m.wgsl, m.rust)),
            }
        }
        for (field, _) in &m.fields {
            if !field.starts_with('_') && !members.iter().any(|x| x.name.as_deref() == Some(field))
            {
                problems.push(format!(
                    "{}.{field} has no WGSL member in {}",
                    m.rust, m.wgsl
                ));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "Rust/WGSL layouts differ:\n{}",
        problems.join("\n")
    );
}

#[test]
fn every_stage_reflects_its_bind_groups() {
    // the layouts the pipelines are built with come from naga; every stage has a group 0
    for stage in shaders::STAGES {
        let entries =
            vlf::gpu::reflect::layout_entries(stage, 0).unwrap_or_else(|e| panic!("{stage}: {e}"));
        let bindings: Vec<u32> = entries.iter().map(|e| e.binding).collect();
        assert!(
            bindings.windows(2).all(|w| w[0] < w[1]),
            "{stage}: bindings {bindings:?}"
        );
    }
    // a known case: render.wgsl's group 0 starts with the View uniform and writes the image
    let render = vlf::gpu::reflect::layout_entries("render.wgsl", 0).unwrap();
    assert!(matches!(
        render[0].ty,
        wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            ..
        }
    ));
    assert!(render.iter().any(|e| matches!(
        e.ty,
        wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            ..
        }
    )));
}

#[test]
fn paged_arrays_have_as_many_bindings_as_rust_plans_pages() {
    // an array that can outgrow one binding is declared as pages `name_0 .. name_{n-1}`; Rust
    // plans at most MAX_TILE_PAGES pages (lightfield::tiles), so every such family must have
    // exactly that many bindings in every stage that declares it
    let pages = vlf::lightfield::tiles::MAX_TILE_PAGES as usize;
    let mut families_seen = 0;
    for stage in shaders::STAGES {
        let module = shaders::expand(stage).unwrap().validate().unwrap();
        let mut families: std::collections::BTreeMap<String, Vec<usize>> = Default::default();
        for (_, var) in module.global_variables.iter() {
            let (Some(name), Some(_)) = (&var.name, &var.binding) else {
                continue;
            };
            if let Some((family, index)) = name.rsplit_once('_') {
                if let Ok(i) = index.parse::<usize>() {
                    families.entry(family.to_string()).or_default().push(i);
                }
            }
        }
        for (family, mut indices) in families {
            indices.sort();
            families_seen += 1;
            assert_eq!(
                indices,
                (0..pages).collect::<Vec<_>>(),
                "{stage}: the pages of `{family}` are {indices:?}, Rust plans {pages}"
            );
        }
    }
    assert!(
        families_seen >= 3,
        "no paged arrays found: the check checks nothing"
    );
}

#[test]
fn every_stage_file_is_listed_as_a_stage() {
    // files outside shaders/common/ have entry points and must be compiled and validated
    let mut missing = Vec::new();
    for (name, _) in shaders::SOURCES {
        if !name.starts_with("common/") && !shaders::STAGES.contains(name) {
            missing.push(*name);
        }
    }
    assert!(
        missing.is_empty(),
        "not in gpu::shaders::STAGES: {missing:?}"
    );
}

#[test]
fn the_light_field_is_declared_once_and_each_stage_says_where_it_binds_it() {
    use vlf::gpu::reflect;
    // the stages that read a light field include common/light_field.wgsl and name its group;
    // the driver finds it by reflection (render.wgsl at 1, specular.wgsl at 2)
    assert_eq!(reflect::group_of("render.wgsl", "field").unwrap(), 1);
    assert_eq!(reflect::group_of("specular.wgsl", "field").unwrap(), 2);
    // a binding both stages use has the same number and type in both (one declaration)
    let render = reflect::used_layout_entries("render.wgsl", 1).unwrap();
    let specular = reflect::used_layout_entries("specular.wgsl", 2).unwrap();
    let mut shared = 0;
    for s in &specular {
        if let Some(r) = render.iter().find(|r| r.binding == s.binding) {
            assert_eq!(r.ty, s.ty, "binding {} differs", s.binding);
            shared += 1;
        }
    }
    assert!(shared >= 8, "only {shared} bindings shared: {specular:?}");
    // specular transport reads its unshot atlas through its own group: the light field's atlas
    // pages are left out of its layout (which keeps it under 32 storage buffers per stage)
    assert!(specular.iter().all(|e| !(1..=4).contains(&e.binding)));
    assert!((1..=4).all(|b| render.iter().any(|e| e.binding == b)));
    // no stage declares the light field's pages itself: every declaration of them comes from
    // the shared module
    for stage in shaders::STAGES {
        let expanded = shaders::expand(stage).unwrap();
        for (line, (file, _)) in expanded.source.lines().zip(&expanded.line_origin) {
            let declares = line.contains("var<storage, read> tile_radiance_0")
                || line.contains("var<storage, read> tile_rects")
                || line.contains("var<uniform> field:");
            assert!(
                !declares || file == "common/light_field.wgsl",
                "{stage}: {file} declares the light field's bindings itself: {line}"
            );
        }
    }
}

#[test]
fn every_stage_that_reads_faces_reads_their_materials_through_bsdf_wgsl() {
    // the face records hold no material parts: a stage that binds `faces` binds the material
    // table too, and the Material row comes from common/bsdf.wgsl only
    let mut stages_with_faces = 0;
    for stage in shaders::STAGES {
        let expanded = shaders::expand(stage).unwrap();
        let module = expanded.validate().unwrap();
        let bound = |name: &str| {
            (module.global_variables.iter())
                .any(|(_, v)| v.name.as_deref() == Some(name) && v.binding.is_some())
        };
        if !bound("faces") {
            continue;
        }
        stages_with_faces += 1;
        assert!(bound("materials"), "{stage} binds faces but not materials");
        for (line, (file, _)) in expanded.source.lines().zip(&expanded.line_origin) {
            assert!(
                !line.starts_with("struct Material") || file == "common/bsdf.wgsl",
                "{stage}: {file} declares a Material of its own"
            );
        }
    }
    assert!(
        stages_with_faces >= 5,
        "only {stages_with_faces} stages bind faces"
    );
}
