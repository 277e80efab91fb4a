//! How long work reports how far it is: propagation, the path tracer and the lab's runs call a
//! [`Progress`]; the library draws nothing itself. The `vlf` binary implements it with
//! terminal bars; library callers that want no output pass [`Silent`].

/// Progress of one stage of work at a time: `begin`, any number of `advance_to` and `note`,
/// then `finish`. Calls come from the thread doing the work.
pub trait Progress: Send + Sync {
    /// A stage of `total` steps starts. `unit` names a step ("passes") where the count means
    /// something to a reader, "" where only the fraction done does; `message` says what runs.
    fn begin(&self, total: u64, unit: &str, message: &str);
    /// `done` of the stage's steps are complete; `message` says where it stands now.
    fn advance_to(&self, done: u64, message: &str);
    /// A line worth keeping (one finished run's result), unlike the passing `message`.
    fn note(&self, line: &str);
    /// The stage is over: whatever showed its progress goes away.
    fn finish(&self);
}

/// No output: for tests, benchmarks and callers that report in their own way.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn begin(&self, _total: u64, _unit: &str, _message: &str) {}
    fn advance_to(&self, _done: u64, _message: &str) {}
    fn note(&self, _line: &str) {}
    fn finish(&self) {}
}
