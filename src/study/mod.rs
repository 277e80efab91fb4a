//! What a lab needs around a run to study people with it. `log.rs`: the session log, every
//! frame's poses, what each view was drawn with, its times and events, written as it goes
//! (`vlf cave --log DIR`), and read back by `vlf replay`, which draws the logged frames again
//! exactly as the run drew them.

pub mod log;

pub use log::{FrameRecord, SessionLog, SessionMeta};
