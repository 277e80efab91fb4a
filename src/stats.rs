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
