#![no_main]
//! scene.toml text: parsing and validation must return Ok or a clear error, never panic.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = vlf::scene::SceneFile::parse(text, std::path::Path::new("fuzz/scene.toml"));
    }
});
