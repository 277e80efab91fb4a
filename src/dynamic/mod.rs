//! Dynamic objects (placeholder on this branch).
pub mod avatar;
