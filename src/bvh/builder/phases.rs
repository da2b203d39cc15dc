//! Where a build's time goes, for the build benchmark (`Bvh::build_timed`): the wall time of
//! each phase in order, and the thread time (summed over threads) spent splitting the big top
//! nodes and building the sequential subtrees below them. The clock is read a few times per
//! big node or subtree only, so every build keeps one.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

pub(super) struct PhaseClock {
    /// When the running phase began, and the phases done (marked from the builder's calling
    /// thread only; the lock just lets the builder share the clock with its tasks).
    marks: Mutex<(Instant, Vec<(&'static str, Duration)>)>,
    top_splits: AtomicU64,
    subtrees: AtomicU64,
}

impl PhaseClock {
    pub(super) fn start() -> Self {
        Self {
            marks: Mutex::new((Instant::now(), Vec::new())),
            top_splits: AtomicU64::new(0),
            subtrees: AtomicU64::new(0),
        }
    }

    /// Ends the phase running since the previous mark (or the start) and names it.
    pub(super) fn mark(&self, phase: &'static str) {
        let now = Instant::now();
        let mut marks = self.marks.lock().unwrap_or_else(|e| e.into_inner());
        let since = now - marks.0;
        marks.1.push((phase, since));
        marks.0 = now;
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
    pub(super) fn finish(self) -> Vec<(&'static str, Duration)> {
        let total = |a: &AtomicU64| Duration::from_nanos(a.load(Ordering::Relaxed));
        let mut phases = self.marks.into_inner().unwrap_or_else(|e| e.into_inner()).1;
        phases.push(("top splits (thread time)", total(&self.top_splits)));
        phases.push(("subtrees (thread time)", total(&self.subtrees)));
        phases
    }
}

fn timed<T>(total: &AtomicU64, f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let r = f();
    total.fetch_add(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
    r
}
