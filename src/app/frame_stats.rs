//! Frame-time history for the live graph: GPU trace time (timestamps) and whole-frame
//! time (CPU clock, frame start to frame start), kept for the last few seconds.

use std::collections::VecDeque;

/// Seconds of history the graph shows.
pub const HISTORY_SECONDS: f64 = 10.0;

/// One series of (time in seconds, milliseconds) samples.
#[derive(Clone, Debug, Default)]
pub struct Series {
    pub samples: VecDeque<(f64, f64)>,
}

/// Current, min, mean and max of a series.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    pub current: f64,
    pub min: f64,
    pub mean: f64,
    pub max: f64,
}

impl Series {
    fn push(&mut self, t: f64, ms: f64) {
        self.samples.push_back((t, ms));
        while self.samples.front().is_some_and(|&(t0, _)| t - t0 > HISTORY_SECONDS) {
            self.samples.pop_front();
        }
    }

    /// Statistics over the kept history; None when empty.
    pub fn summary(&self) -> Option<Summary> {
        let &(_, current) = self.samples.back()?;
        let (mut min, mut max, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
        for &(_, v) in &self.samples {
            min = min.min(v);
            max = max.max(v);
            sum += v;
        }
        Some(Summary { current, min, mean: sum / self.samples.len() as f64, max })
    }

    /// Largest value, for the graph's scale.
    pub fn max(&self) -> f64 {
        self.samples.iter().map(|s| s.1).fold(0.0, f64::max)
    }
}

/// The two series the panel plots.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// GPU time of the trace dispatch per frame.
    pub gpu: Series,
    /// Frame-to-frame time on the CPU clock.
    pub frame: Series,
}

impl FrameStats {
    /// Record a frame that started `ms` after the previous one, at time `t` seconds.
    pub fn push_frame(&mut self, t: f64, ms: f64) {
        self.frame.push(t, ms);
    }

    /// Record a GPU trace time that became available at time `t`.
    pub fn push_gpu(&mut self, t: f64, ms: f64) {
        self.gpu.push(t, ms);
    }

    /// Frames per second over the last second of history.
    pub fn fps(&self) -> f64 {
        let Some(&(last, _)) = self.frame.samples.back() else { return 0.0 };
        let recent: Vec<f64> = self.frame.samples.iter().filter(|s| last - s.0 < 1.0).map(|s| s.1).collect();
        let total: f64 = recent.iter().sum();
        if total > 0.0 {
            recent.len() as f64 * 1000.0 / total
        } else {
            0.0
        }
    }
}

/// Million rays per second for `rays` rays traced in `ms` milliseconds.
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
    fn history_is_bounded_and_summarised() {
        let mut s = FrameStats::default();
        assert!(s.frame.summary().is_none());
        for i in 0..200 {
            s.push_frame(i as f64 * 0.1, if i % 2 == 0 { 10.0 } else { 30.0 });
        }
        // 10 s of history at 10 samples per second.
        assert!(s.frame.samples.len() <= 101);
        let sum = s.frame.summary().unwrap();
        assert_eq!(sum.current, 30.0);
        assert_eq!(sum.min, 10.0);
        assert_eq!(sum.max, 30.0);
        assert!((sum.mean - 20.0).abs() < 0.5);
        assert!((s.fps() - 50.0).abs() < 5.0, "{}", s.fps());
    }

    #[test]
    fn mrays() {
        assert!((mrays_per_second(1_000_000, 10.0) - 100.0).abs() < 1e-9);
        assert_eq!(mrays_per_second(5, 0.0), 0.0);
    }
}
