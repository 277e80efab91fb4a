//! vlf: virtual light field global illumination (Mortensen, Khanna & Slater 2007) on wgpu.
//!
//! The modules follow the pipeline: [`scene`] (TOML + OBJ/MTL) -> [`prepare`] (normalise,
//! planar faces, texel atlas) -> [`propagate`] (GPU visibility and shooting) -> [`lightfield`]
//! (the resident result and `.vlf` files) -> [`render`] (views). [`gpu`] holds the device and
//! shared GPU helpers; `propagate::report` tells what a propagation did. The views leave through
//! [`display`] (CAVE walls, windows), [`cluster`] (one CAVE over several processes, locked by
//! [`framelock`]) and [`xr`] (an OpenXR headset), all posed by [`tracking`]. `lab` (feature `lab`,
//! on by default) holds the tools that measure it: bench, suite, stress, sweep, generate.

pub mod bvh;
pub mod cluster;
pub mod color;
pub mod display;
pub mod dynamic;
pub mod error;
pub mod export;
pub mod framelock;
pub mod gpu;
#[cfg(feature = "lab")]
pub mod lab;
pub mod lightfield;
pub mod material;
pub mod metrics;
pub mod mirrored;
pub mod parallel;
pub mod params;
pub mod prepare;
pub mod progress;
pub mod propagate;
pub mod reference;
pub mod render;
pub mod scene;
pub mod stats;
pub mod study;
pub mod tracking;
pub mod verify;
pub mod xr;

pub use error::{Result, VlfError};
