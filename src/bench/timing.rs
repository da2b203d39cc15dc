//! The one timing summary, shared by `bench` and the window (its live graph, its benchmark
//! run), and million rays per second. One formula each, so the same frames give the same
//! figures anywhere.

use serde::{Deserialize, Serialize};

/// Min, mean, max and the nearest-rank percentiles of a series of milliseconds.
///
/// In JSON every field is optional when read (files written before a field existed hold
/// only `median`/`p10`/`p90` (`bench`) or `min`/`mean`/`max`/`p90` (the window's runs)):
/// a missing one reads as 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Timing {
    pub min: f64,
    pub mean: f64,
    pub max: f64,
    pub median: f64,
    pub p10: f64,
    pub p90: f64,
}

impl Timing {
    /// The summary of `samples` (the mean summed in the order given); None when there are none.
    pub fn of(samples: &[f64]) -> Option<Self> {
        if samples.is_empty() {
            return None;
        }
        let mut sorted = samples.to_vec();
        sorted.sort_by(|a, b| a.total_cmp(b));
        let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        Some(Self {
            min: sorted[0],
            mean,
            max: sorted[sorted.len() - 1],
            median: at(0.5),
            p10: at(0.1),
            p90: at(0.9),
        })
    }
}

/// Million rays per second for `rays` rays traced in `ms` milliseconds (0 without a time).
pub fn mrays_per_second(rays: u64, ms: f64) -> f64 {
    if ms > 0.0 {
        rays as f64 / (ms * 1e-3) / 1e6
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_and_rate() {
        assert_eq!(Timing::of(&[]), None);
        let t = Timing::of(&[2.0, 1.0, 6.0]).unwrap();
        assert_eq!((t.min, t.mean, t.max, t.median), (1.0, 3.0, 6.0, 2.0));
        let t = Timing::of(&(1..=11).map(f64::from).collect::<Vec<_>>()).unwrap();
        assert_eq!((t.median, t.p10, t.p90), (6.0, 2.0, 10.0));
        assert!((mrays_per_second(1_000_000, 10.0) - 100.0).abs() < 1e-9);
        assert_eq!(mrays_per_second(5, 0.0), 0.0);
    }

    #[test]
    fn old_json_reads_with_the_missing_fields_as_zero() {
        let bench: Timing = serde_json::from_str(r#"{"median":6.0,"p10":2.0,"p90":10.0}"#).unwrap();
        assert_eq!((bench.median, bench.mean), (6.0, 0.0));
        let window: Timing =
            serde_json::from_str(r#"{"min":1.0,"mean":2.0,"max":3.0,"p90":2.5}"#).unwrap();
        assert_eq!((window.mean, window.p90, window.median), (2.0, 2.5, 0.0));
    }
}
