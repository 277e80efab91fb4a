#![no_main]
//! .vlf bytes: decoding must return Ok or a clear error, never panic or over-allocate.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = vlf::lightfield::file::decode(data);
});
