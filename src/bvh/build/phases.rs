//! Where a build's time goes, for the build benchmark (`Bvh::build_timed`): the wall time of
//! each phase in order, and the thread time (summed over threads) spent splitting the big top
//! nodes and building the sequential subtrees below them. The clock is read a few times per
//! big node or subtree only, so every build keeps one.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

pub(super) struct PhaseClock {
    last: Instant,
    phases: Vec<(&'static str, Duration)>,
    top_splits: AtomicU64,
    subtrees: AtomicU64,
}

impl PhaseClock {
    pub(super) fn start() -> Self {
        Self { last: Instant::now(), phases: Vec::new(), top_splits: AtomicU64::new(0), subtrees: AtomicU64::new(0) }
    }

    /// Ends the phase running since the previous mark (or the start) and names it.
    pub(super) fn mark(&mut self, phase: &'static str) {
        let now = Instant::now();
        self.phases.push((phase, now - self.last));
        self.last = now;
    }

    /// Runs `f`, adding its time to the top-split total.
    pub(super) fn top_split<T>(&self, f: impl FnOnce() -> T) -> T {
        timed(&self.top_splits, f)
    }

    /// Runs `f`, adding its time to the sequential-subtree total.
    pub(super) fn subtree<T>(&self, f: impl FnOnce() -> T) -> T {
        timed(&self.subtrees, f)
    }

    /// The wall-time phases, then the two thread-time totals.
    pub(super) fn finish(mut self) -> Vec<(&'static str, Duration)> {
        let total = |a: &AtomicU64| Duration::from_nanos(a.load(Ordering::Relaxed));
        self.phases.push(("top splits (thread time)", total(&self.top_splits)));
        self.phases.push(("subtrees (thread time)", total(&self.subtrees)));
        self.phases
    }
}

fn timed<T>(total: &AtomicU64, f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let r = f();
    total.fetch_add(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
    r
}
