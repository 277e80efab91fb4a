//! Every shipped config parses; the defaults in code and in config/ agree; errors name the key.

use std::path::Path;
use vlf::propagate::PropagationParams;

fn config(rel: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config")
        .join(rel)
}

#[test]
fn every_shipped_config_parses() {
    let mut n = 0;
    for entry in std::fs::read_dir(config("propagation")).unwrap() {
        let path = entry.unwrap().path();
        PropagationParams::from_toml_file(&path).unwrap_or_else(|e| panic!("{e}"));
        n += 1;
    }
    assert!(n >= 3);
}

#[test]
fn code_defaults_match_the_shipped_files() {
    assert_eq!(
        PropagationParams::from_toml_file(&config("propagation/default.toml")).unwrap(),
        PropagationParams::default()
    );
    assert_eq!(
        PropagationParams::from_toml_file(&config("propagation/software.toml")).unwrap(),
        PropagationParams::software()
    );
}

#[test]
fn errors_name_the_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(config("propagation/default.toml"))
        .unwrap()
        .replace("tile_size", "tile_sise");
    std::fs::write(&path, text).unwrap();
    let e = PropagationParams::from_toml_file(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.toml") && e.contains("tile_sise"), "{e}");

    let text = std::fs::read_to_string(config("propagation/default.toml"))
        .unwrap()
        .replace("tile_size = 8", "tile_size = 7");
    std::fs::write(&path, text).unwrap();
    let e = PropagationParams::from_toml_file(&path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.toml") && e.contains("tile size 7 must divide"),
        "{e}"
    );
}

/// Every shipped file of objects (config/headset/, `vlf xr --objects`; config/objects/, `vlf
/// render --objects`) parses and its meshes load.
#[test]
fn every_shipped_objects_file_parses_and_loads() {
    let mut n = 0;
    let files = (std::fs::read_dir(config("headset")).unwrap())
        .chain(std::fs::read_dir(config("objects")).unwrap());
    for entry in files {
        let path = entry.unwrap().path();
        let file = vlf::xr::body::ObjectsFile::load(&path).unwrap_or_else(|e| panic!("{e}"));
        vlf::dynamic::Objects::load(&file.objects, &path).unwrap_or_else(|e| panic!("{e}"));
        n += 1;
    }
    assert!(n >= 3);
}

/// The display TOML's `first_hits`: "rays" (the default) or "raster"; any other value is
/// refused naming the key and the file.
#[test]
fn a_display_takes_first_hits_and_refuses_an_unknown_value_naming_the_key() {
    use vlf::display::DisplayConfig;
    use vlf::render::raster::FirstHits;
    let shipped = config("displays/cave-4wall-walk.toml");
    let text = std::fs::read_to_string(&shipped).unwrap();
    let path = Path::new("cave-first-hits.toml");
    let with = |value: &str| {
        // a top-level key, before the file's first table
        let (head, tables) = text.split_at(text.find("\n[").unwrap());
        format!("{head}\nfirst_hits = {value}\n{tables}")
    };
    let first_hits = |value: &str| DisplayConfig::parse(&with(value), path).map(|c| c.first_hits);
    assert_eq!(
        DisplayConfig::parse(&text, path).unwrap().first_hits,
        FirstHits::Rays
    );
    assert_eq!(first_hits("\"rays\"").unwrap(), FirstHits::Rays);
    assert_eq!(first_hits("\"raster\"").unwrap(), FirstHits::Raster);
    for bad in ["\"bvh\"", "\"Raster\"", "4"] {
        let e = first_hits(bad).unwrap_err().to_string();
        assert!(
            e.contains("cave-first-hits.toml") && e.contains("first_hits"),
            "{bad}: {e}"
        );
    }
}
