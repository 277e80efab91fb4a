//! The terminal's progress bars (indicatif, on stderr; hidden when stderr is not a terminal):
//! the `vlf` binary's [`Progress`], for propagation, the path tracer and the lab's runs.

use indicatif::{ProgressBar, ProgressStyle};
use std::sync::{Mutex, MutexGuard, PoisonError};
use vlf::progress::Progress;

/// One bar at a time, made by `begin` and cleared by `finish`. A bar an error left behind
/// goes with this value (indicatif leaves it on the screen, stopped).
#[derive(Default)]
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
}

impl Bars {
    fn bar(&self) -> MutexGuard<'_, Option<ProgressBar>> {
        self.bar.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl Progress for Bars {
    fn begin(&self, total: u64, unit: &str, message: &str) {
        let template = match unit {
            "" => "{spinner} {elapsed_precise} [{bar:40}] {msg}".to_string(),
            unit => format!(
                "{{spinner}} {{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {unit} ({{msg}})"
            ),
        };
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(&template)
                .expect("a valid template")
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        if let Some(old) = self.bar().replace(bar) {
            old.finish_and_clear();
        }
    }

    fn advance_to(&self, done: u64, message: &str) {
        if let Some(bar) = self.bar().as_ref() {
            bar.set_position(done);
            bar.set_message(message.to_string());
        }
    }

    fn note(&self, line: &str) {
        match self.bar().as_ref() {
            Some(bar) => bar.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }

    fn finish(&self) {
        if let Some(bar) = self.bar().take() {
            bar.finish_and_clear();
        }
    }
}
