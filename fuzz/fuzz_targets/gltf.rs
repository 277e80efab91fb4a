#![no_main]
//! Bytes as a .glb and as a .gltf through the whole glTF importer: Ok or an error, no panic.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().unwrap();
    for name in ["m.glb", "m.gltf"] {
        std::fs::write(dir.path().join(name), data).unwrap();
        let _ = vlf::scene::Scene::load(&dir.path().join(name));
    }
});
