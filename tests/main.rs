//! Every integration test in one binary (`cargo test --release --features mpi --test all`;
//! one file's tests: `... --test all xr::`). One binary, not one per file: each binary linked
//! vlf and every dependency again and compiled tests/common again, minutes of a clean 2-core
//! build. Each file is a module here, named as its file; the lab's tests need the `lab` feature
//! and LabRecorder's the `lsl` feature (`cargo test --no-default-features` leaves them out).

mod architecture;
mod avatar;
mod batches;
mod buried;
mod bvh;
mod cli;
mod cluster;
mod common;
mod config;
mod cutouts;
mod displays;
mod docs;
mod edges;
mod extremes;
mod glossy;
mod gltf;
mod gpu_vs_cpu;
#[cfg(feature = "lsl")]
mod labrecorder;
mod lightfield_file;
mod metrics;
mod mirrors;
mod mitsuba;
mod normal_maps;
mod nothing_lost;
mod objects;
mod occlusion;
mod pages;
mod physics;
mod picture;
mod power_balance;
mod raster;
mod readers;
mod reference;
mod scene_errors;
mod shaders;
mod stiff;
#[cfg(feature = "lab")]
mod stress;
mod study;
#[cfg(feature = "lab")]
mod suite;
mod textures;
mod tracking;
mod two_sided;
mod verify;
mod warp;
mod windows;
mod xr;
