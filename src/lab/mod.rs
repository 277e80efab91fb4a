//! The lab: the tools that measure, stress and chart vlf, apart from the renderer itself.
//! Behind the cargo feature `lab` (on by default); the core (`cargo build
//! --no-default-features`) compiles without it and without its plotting crate (plotters).
//!
//! - [`bench`]: `vlf bench`, one scene's setup, visibility, propagation and render times;
//! - [`suite`]: `vlf bench --suite`, the benchmark suite over generated scenes, with its chart;
//! - [`stress`]: `vlf stress`, the stability cases written to STABILITY.md;
//! - [`sweep`]: `vlf sweep`, error against run time (light field and path tracer), CSV and
//!   charts (`sweep/plot.rs`);
//! - [`generate`]: `vlf generate`, procedural classroom and gallery scenes.
//!
//! The lab uses the core (scene, propagate, render, reference, metrics, ...); nothing in the
//! core uses the lab. Like the core it draws nothing itself: its runs report through
//! [`crate::progress::Progress`].

pub mod bench;
pub mod generate;
pub mod stress;
pub mod suite;
pub mod sweep;
