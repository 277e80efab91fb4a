#![no_main]
//! OBJ text through the whole importer (with a fixed MTL beside it): Ok or an error, no panic.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl a\nKd 0.5 0.5 0.5\nKe 1 1 1\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("m.obj"), data).unwrap();
    std::fs::write(
        dir.path().join("scene.toml"),
        "name = \"f\"\nmesh = \"m.obj\"\n",
    )
    .unwrap();
    let _ = vlf::scene::Scene::load(&dir.path().join("scene.toml"));
});
