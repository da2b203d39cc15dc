//! The figures every timing summary is made of, shared by `bench` and the window (its
//! live graph, its benchmark run): the spread of a series of milliseconds, and million
//! rays per second. One formula each, so the same frames give the same figures anywhere.

/// Min, mean and max of a series of milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spread {
    pub min: f64,
    pub mean: f64,
    pub max: f64,
}

impl Spread {
    /// The spread of `samples`, summed in the order given; None when there are none.
    pub fn of(samples: impl IntoIterator<Item = f64>) -> Option<Self> {
        let (mut min, mut max, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
        for v in samples {
            min = min.min(v);
            max = max.max(v);
            sum += v;
            n += 1;
        }
        (n > 0).then(|| Self { min, mean: sum / n as f64, max })
    }
}

/// Million rays per second for `rays` rays traced in `ms` milliseconds (0 without a time).
pub fn mrays_per_second(rays: u64, ms: f64) -> f64 {
    if ms > 0.0 { rays as f64 / (ms * 1e-3) / 1e6 } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_and_rate() {
        assert_eq!(Spread::of([]), None);
        assert_eq!(Spread::of([2.0, 1.0, 6.0]), Some(Spread { min: 1.0, mean: 3.0, max: 6.0 }));
        assert!((mrays_per_second(1_000_000, 10.0) - 100.0).abs() < 1e-9);
        assert_eq!(mrays_per_second(5, 0.0), 0.0);
    }
}
