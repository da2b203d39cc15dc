//! Frame-time history for the live graph: GPU trace time (timestamps) and whole-frame
//! time (CPU clock, frame start to frame start), kept for the longest window the graph
//! offers.

use std::collections::VecDeque;

use crate::bench::timing::Timing;
use crate::render_settings::RenderSettings;

/// Seconds of history kept: the longest window the graph offers.
pub(crate) const HISTORY_SECONDS: f64 = 60.0;

/// One series of (time in seconds, milliseconds) samples.
#[derive(Clone, Debug, Default)]
pub(crate) struct Series {
    pub(crate) samples: VecDeque<(f64, f64)>,
}

impl Series {
    fn push(&mut self, t: f64, ms: f64) {
        self.samples.push_back((t, ms));
        while self.samples.front().is_some_and(|&(t0, _)| t - t0 > HISTORY_SECONDS) {
            self.samples.pop_front();
        }
    }

    /// The latest sample, ms; None when empty.
    pub(crate) fn current(&self) -> Option<f64> {
        self.samples.back().map(|&(_, ms)| ms)
    }

    /// The summary of the last `seconds` of history; None when empty.
    pub(crate) fn summary_over(&self, seconds: f64) -> Option<Timing> {
        let &(last, _) = self.samples.back()?;
        let recent: Vec<f64> =
            self.samples.iter().filter(|&&(t, _)| last - t <= seconds).map(|&(_, v)| v).collect();
        Timing::of(&recent)
    }

    /// The samples of the last `seconds`, as (seconds before the latest sample of `now`, ms).
    pub(crate) fn recent(&self, seconds: f64, now: f64) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.samples
            .iter()
            .filter(move |&&(t, _)| now - t <= seconds)
            .map(move |&(t, ms)| [t - now, ms])
    }
}

/// The two series the panel plots.
#[derive(Clone, Debug, Default)]
pub(crate) struct FrameStats {
    /// GPU time of the trace dispatch per frame.
    pub(crate) gpu: Series,
    /// Frame-to-frame time on the CPU clock.
    pub(crate) frame: Series,
    /// The settings of the frame the latest GPU time belongs to (its rays give Mrays/s).
    pub(crate) gpu_settings: Option<RenderSettings>,
}

impl FrameStats {
    /// Record a frame that started `ms` after the previous one, at time `t` seconds.
    pub(crate) fn push_frame(&mut self, t: f64, ms: f64) {
        self.frame.push(t, ms);
    }

    /// Record a GPU trace time that became available at time `t`.
    pub(crate) fn push_gpu(&mut self, t: f64, ms: f64, settings: Option<RenderSettings>) {
        self.gpu.push(t, ms);
        self.gpu_settings = settings;
    }

    /// The latest GPU time and its Mrays/s, if it belongs to a frame of `now`'s settings: a
    /// time from before a change of resolution, bounces or acceleration says nothing of
    /// what is traced now (a long frame in bands shows none until its last band is in).
    pub(crate) fn gpu_now(&self, now: &RenderSettings) -> Option<(f64, f64)> {
        // Every knob alike: the same work.
        let settings = self.gpu_settings.filter(|s| s == now)?;
        let ms = self.gpu.samples.back()?.1;
        Some((ms, mrays_per_second(settings.max_rays(), ms)))
    }

    /// Time of the latest sample of either series (0 before any).
    pub(crate) fn latest(&self) -> f64 {
        [&self.gpu, &self.frame]
            .iter()
            .filter_map(|s| s.samples.back().map(|v| v.0))
            .fold(0.0, f64::max)
    }

    /// Frames per second over the last second of history.
    pub(crate) fn fps(&self) -> f64 {
        let Some(&(last, _)) = self.frame.samples.back() else { return 0.0 };
        let recent: Vec<f64> =
            self.frame.samples.iter().filter(|s| last - s.0 < 1.0).map(|s| s.1).collect();
        let total: f64 = recent.iter().sum();
        if total > 0.0 {
            recent.len() as f64 * 1000.0 / total
        } else {
            0.0
        }
    }
}

/// The one Mrays/s formula, `bench`'s.
pub(crate) use crate::bench::timing::mrays_per_second;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gpu_time_is_shown_only_for_a_frame_of_the_settings_traced_now() {
        // After width 8192 the panel showed the old frame's time over the new rays (2258.5
        // Mrays/s), and the HUD a BVH frame's time while brute-force bands ran (#30).
        let bvh = RenderSettings { width: 512, height: 512, ..Default::default() };
        let mut stats = FrameStats::default();
        stats.push_gpu(1.0, 2.0, Some(bvh));
        let (ms, mrays) = stats.gpu_now(&bvh).unwrap();
        assert_eq!(ms, 2.0);
        assert!((mrays - bvh.max_rays() as f64 / 2.0 / 1e3).abs() < 1e-9, "{mrays}");
        assert_eq!(
            stats.gpu_now(&RenderSettings { width: 8192, ..bvh }),
            None,
            "a new resolution has no time yet"
        );
        assert_eq!(
            stats.gpu_now(&RenderSettings { accel: crate::render_settings::Accel::Brute, ..bvh }),
            None
        );
        stats.push_gpu(2.0, 3.0, None);
        assert_eq!(stats.gpu_now(&bvh), None, "a time of an unknown frame is shown with no rays");
    }

    #[test]
    fn history_is_bounded_and_summarised() {
        let mut s = FrameStats::default();
        assert!(s.frame.summary_over(HISTORY_SECONDS).is_none());
        for i in 0..200 {
            s.push_frame(i as f64 * 0.1, if i % 2 == 0 { 10.0 } else { 30.0 });
        }
        // 60 s of history at 10 samples per second.
        for i in 200..1000 {
            s.push_frame(i as f64 * 0.1, if i % 2 == 0 { 10.0 } else { 30.0 });
        }
        assert!(s.frame.samples.len() <= 601);
        let sum = s.frame.summary_over(HISTORY_SECONDS).unwrap();
        assert_eq!(s.frame.current(), Some(30.0));
        assert_eq!(sum.min, 10.0);
        assert_eq!(sum.max, 30.0);
        assert!((sum.mean - 20.0).abs() < 0.5);
        assert!((s.fps() - 50.0).abs() < 5.0, "{}", s.fps());
        // A window: only its samples count.
        s.push_frame(101.5, 100.0);
        let last_second = s.frame.summary_over(1.0).unwrap();
        assert_eq!(last_second.max, 100.0);
        assert_eq!(last_second.min, 100.0, "the others are older than a second");
        let points: Vec<[f64; 2]> = s.frame.recent(5.0, 101.5).collect();
        assert_eq!(points.last(), Some(&[0.0, 100.0]));
        assert!(points.iter().all(|p| (-5.0..=0.0).contains(&p[0])));
    }

    #[test]
    fn mrays() {
        assert!((mrays_per_second(1_000_000, 10.0) - 100.0).abs() < 1e-9);
        assert_eq!(mrays_per_second(5, 0.0), 0.0);
    }
}
