//! What a lab needs around a run to study people with it. `log.rs`: the session log, every
//! frame's poses, what each view was drawn with, its times and events, written as it goes
//! (`vlf cave --log DIR`; `log/parquet.rs`: the same rows as Parquet), and read back by `vlf
//! replay`, which draws the logged frames again exactly as the run drew them. `control.rs`: an
//! experiment script's commands over TCP (`vlf cave --control ADDR`), each acknowledged with
//! the frame it took effect in. `lsl.rs`: the frames' poses, times and events on Lab Streaming
//! Layer outlets (`vlf cave --lsl`). `session.rs`: all of them, frame by frame, as the display
//! loops call them.

pub mod control;
pub mod log;
pub mod lsl;
pub mod session;

pub use control::ControlServer;
pub use log::{FrameRecord, SessionLog, SessionMeta};
pub use lsl::LslOutlets;
pub use session::{MotionToPhoton, Session};
