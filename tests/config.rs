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
        // (the headset's conditions: `every_shipped_conditions_file_parses`)
        if path.file_name().is_some_and(|n| n == "conditions.toml") {
            continue;
        }
        let file = vlf::xr::body::ObjectsFile::load(&path).unwrap_or_else(|e| panic!("{e}"));
        vlf::dynamic::Objects::load(&file.objects, &path).unwrap_or_else(|e| panic!("{e}"));
        n += 1;
    }
    assert!(n >= 3);
}

/// The headset's shipped conditions (`vlf xr --conditions`) parse and check against the shipped
/// body's objects.
#[test]
fn every_shipped_conditions_file_parses() {
    let body = vlf::xr::body::ObjectsFile::load(&config("headset/body.toml")).unwrap();
    let names: Vec<String> = body.objects.iter().map(|o| o.name.clone()).collect();
    let path = config("headset/conditions.toml");
    let file = vlf::display::conditions::ConditionsFile::load(&path, &names)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(file.default_condition.as_deref(), Some("gi-on"));
    assert!(file.conditions.len() >= 3);
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

/// The shipped conditions example parses with its three conditions; a display with two
/// conditions parses and its default is first for the session; a bad key, a duplicate name, an
/// unknown object, a bad exposure and an unknown default are refused naming the file, the
/// condition and the key.
#[test]
fn display_conditions_parse_and_bad_ones_name_the_condition_and_key() {
    use vlf::display::DisplayConfig;
    let shipped = DisplayConfig::load(&config("displays/cave-4wall-conditions.toml")).unwrap();
    assert_eq!(shipped.condition_names(), ["gi-on", "gi-off", "gi-on-dim"]);
    assert!(!shipped.conditions[1].global_illumination);
    assert_eq!(shipped.conditions[2].exposure, 0.5);

    let base = "name = \"c\"\n[[wall]]\nname = \"front\"\nlower_left = [-1.0, 0.0, -1.0]\n\
                lower_right = [1.0, 0.0, -1.0]\nupper_left = [-1.0, 2.0, -1.0]\n\
                pixels = [32, 32]\noutput = { monitor = 0 }\n\
                [[object]]\nname = \"body\"\nmesh = \"body.obj\"\n";
    let two = format!(
        "default_condition = \"off\"\n{base}[[condition]]\nname = \"on\"\n\
         [[condition]]\nname = \"off\"\nglobal_illumination = false\nexposure = 2.0\n\
         objects_visible = []\nshadows = false\nreflections = false\n\
         start_pose = {{ position = [0.0, 0.0, 1.0], yaw_deg = 90.0 }}\n"
    );
    let path = Path::new("two.toml");
    let d = DisplayConfig::parse(&two, path).unwrap();
    assert_eq!(d.condition_names(), ["on", "off"]);
    let study = d.study_conditions();
    assert_eq!(study[0].0, "off", "the default condition comes first");
    assert_eq!(study[0].1, Some((glam::Vec3::new(0.0, 0.0, 1.0), 90.0)));
    assert_eq!((study[1].0.as_str(), study[1].1), ("on", None));

    for (bad, names) in [
        (
            "[[condition]]\nname = \"on\"\nglobal_ilumination = false\n",
            ["condition[0] (\"on\").global_ilumination", "unknown key"],
        ),
        (
            "[[condition]]\nname = \"on\"\n[[condition]]\nname = \"on\"\n",
            ["condition[1] (\"on\").name", "share"],
        ),
        (
            "[[condition]]\nname = \"on\"\nobjects_visible = [\"chair\"]\n",
            ["condition[0] (\"on\").objects_visible", "chair"],
        ),
        (
            "[[condition]]\nname = \"on\"\nexposure = -1.0\n",
            ["condition[0] (\"on\").exposure", "-1"],
        ),
        (
            "[[condition]]\nname = \"gi off\"\n",
            ["condition[0] (\"gi off\").name", "letters"],
        ),
    ] {
        let e = DisplayConfig::parse(&format!("{base}{bad}"), path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("two.toml"), "{e}");
        for n in names {
            assert!(e.contains(n), "{n:?} not in {e}");
        }
    }
    let e = DisplayConfig::parse(
        &format!("default_condition = \"dark\"\n{base}[[condition]]\nname = \"on\"\n"),
        path,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("default_condition") && e.contains("dark") && e.contains("on"),
        "{e}"
    );
}
