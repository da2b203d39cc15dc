//! The tool's clocks: the frame-time history, when the last frame was shown, each split
//! half's GPU time, the benchmark run and the frame-time log.

use std::time::Instant;

use crate::app::measure::benchmark::Runs;
use crate::app::measure::frame_log::Recorder;
use crate::app::measure::frame_stats::FrameStats;
use crate::gpu::PartTimes;

/// What the tool measures as frames go by.
pub(super) struct Timing {
    /// The frame-time history the panel plots.
    pub(super) stats: FrameStats,
    /// When the tool started (the history's time zero).
    pub(super) start: Instant,
    /// When the last frame was shown (None after a frame not drawn).
    pub(super) last_frame: Option<Instant>,
    /// The latest GPU time of each half of the split view (left A, right B).
    pub(super) split_ms: PartTimes,
    /// The benchmark run in progress or asked for.
    pub(super) benchmarks: Runs,
    /// The frame-time log (`--stats-csv`, Record).
    pub(super) recorder: Recorder,
}

impl Timing {
    /// Timing from now on, with the benchmark runs and log the command line asks for.
    pub(super) fn new(benchmarks: Runs, recorder: Recorder) -> Self {
        Self {
            stats: FrameStats::default(),
            start: Instant::now(),
            last_frame: None,
            split_ms: [None; 2],
            benchmarks,
            recorder,
        }
    }
}
