//! vlf: virtual light field global illumination (Mortensen, Khanna & Slater 2007) on wgpu.
//!
//! The modules follow the pipeline: [`scene`] (TOML + OBJ/MTL) -> [`prepare`] (normalise,
//! planar faces, texel atlas) -> [`propagate`] (GPU visibility and shooting) -> [`lightfield`]
//! (the resident result and `.vlf` files) -> [`render`] (views). [`gpu`] holds the device and
//! shared GPU helpers; [`bench`] and [`report`] measure and tell.

pub mod bench;
pub mod color;
pub mod display;
pub mod error;
pub mod export;
pub mod generate;
pub mod gpu;
pub mod lightfield;
pub mod metrics;
pub mod mirrored;
pub mod prepare;
pub mod propagate;
pub mod reference;
pub mod render;
pub mod report;
pub mod scene;
pub mod stats;
pub mod stress;
pub mod suite;
pub mod sweep;

pub use error::{Result, VlfError};
