//! Distributions of measured times (median, p95, p99, ...): shared by the benches, the display
//! loops' frame-time reports and the lab tools, so none of them depends on another for it.

use serde::{Deserialize, Serialize};

/// Order statistics of a sample (nearest rank), and its mean.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Distribution {
    pub samples: usize,
    pub median: f64,
    pub p95: f64,
    pub p99: f64,
    pub min: f64,
    pub max: f64,
    pub mean: f64,
}

impl Distribution {
    pub fn of(values: &[f64]) -> Distribution {
        let mut v = values.to_vec();
        v.sort_by(|a, b| a.total_cmp(b));
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        Distribution {
            samples: v.len(),
            median: at(0.5),
            p95: at(0.95),
            p99: at(0.99),
            min: v[0],
            max: v[v.len() - 1],
            mean: v.iter().sum::<f64>() / v.len() as f64,
        }
    }
}

/// The seconds each step of a longer job took, in order (the propagation report's setup is
/// split by them): `lap(name)` closes the step that ran since the last lap.
#[derive(Clone, Debug)]
pub struct Laps {
    start: std::time::Instant,
    pub steps: Vec<(String, f64)>,
}

impl Default for Laps {
    fn default() -> Self {
        Laps {
            start: std::time::Instant::now(),
            steps: Vec::new(),
        }
    }
}

impl Laps {
    pub fn lap(&mut self, step: &str) {
        let before: f64 = self.steps.iter().map(|s| s.1).sum();
        let seconds = self.start.elapsed().as_secs_f64() - before;
        self.steps.push((step.to_string(), seconds));
    }
}

/// Tests' random numbers: below `n`, from a fixed seed (a linear congruential generator: the
/// same sequence on every machine).
#[cfg(test)]
pub(crate) fn seeded(mut seed: u64) -> impl FnMut(u64) -> u64 {
    move |n| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) % n
    }
}
