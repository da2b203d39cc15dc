//! Progress and cancellation of loading a model, shared between the thread doing the work
//! and whoever watches it (the window's progress bar, `bench --load`'s table): which phase
//! runs, how far it is, what each finished phase took, and a flag that asks the work to stop.
//!
//! The worker calls [`Progress::begin`] at each phase and [`Progress::checkpoint`] where
//! stopping is safe; the watcher reads [`Progress::snapshot`] and may [`Progress::cancel`].
//! A load that nobody watches passes [`Progress::default`] and pays two atomic loads a phase.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

/// The phases of a load, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Reading the file into memory.
    Read,
    /// Parsing the text or binary into a mesh (or generating a model).
    Parse,
    /// Building the BVH.
    Build,
    /// Packing triangles, shading data and nodes into the GPU's arrays.
    Pack,
    /// Copying the arrays to the device.
    Upload,
}

impl Phase {
    /// Every phase, in order.
    pub const ALL: [Phase; 5] =
        [Phase::Read, Phase::Parse, Phase::Build, Phase::Pack, Phase::Upload];

    /// The phase's name in the panel and the tables.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Read => "read",
            Phase::Parse => "parse",
            Phase::Build => "build",
            Phase::Pack => "pack",
            Phase::Upload => "upload",
        }
    }
}

/// The load was cancelled ([`Progress::cancel`]); Display is the sentence the window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("loading was cancelled")]
pub struct Cancelled;

/// A phase's record: when it started and, once the next began, how long it took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseTime {
    pub phase: Phase,
    /// Seconds it took; for the running phase, seconds so far.
    pub seconds: f64,
    /// False for the phase running now.
    pub done: bool,
    /// The process's peak resident memory during the phase, bytes, when the load asked for
    /// it ([`Progress::track_peak_memory`]) and the system says (Linux).
    pub peak_rss_bytes: Option<u64>,
}

/// What a watcher sees at one moment.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Snapshot {
    /// The phases begun so far, in order; the last is running unless [`Progress::finish`] was called.
    pub phases: Vec<PhaseTime>,
    /// How far the running phase is, 0..=1, where it reports it (else 0).
    pub fraction: f32,
}

impl Snapshot {
    /// Seconds of every phase recorded.
    pub fn total_seconds(&self) -> f64 {
        self.phases.iter().fold(0.0, |sum, p| sum + p.seconds)
    }

    /// Seconds `phase` took (0 when it did not run).
    pub fn seconds(&self, phase: Phase) -> f64 {
        self.phases.iter().filter(|p| p.phase == phase).fold(0.0, |sum, p| sum + p.seconds)
        // not .sum(): an empty f64 sum is -0.0
    }
}

#[derive(Debug, Default)]
struct Shared {
    cancelled: AtomicBool,
    /// The running phase's fraction, as f32 bits.
    fraction: AtomicU32,
    phases: Mutex<Vec<Record>>,
    /// Record each phase's peak memory (`bench --load`).
    track_memory: AtomicBool,
}

/// A phase as recorded: when it began, what it took once closed, its peak memory.
#[derive(Clone, Copy, Debug)]
struct Record {
    phase: Phase,
    start: Instant,
    took: Option<f64>,
    peak_rss: Option<u64>,
}

/// A handle on one load's progress; clones share it.
#[derive(Clone, Debug, Default)]
pub struct Progress {
    shared: Arc<Shared>,
}

impl Progress {
    /// Ask the work to stop at its next checkpoint.
    pub fn cancel(&self) {
        self.shared.cancelled.store(true, Ordering::Relaxed);
    }

    /// True once [`Progress::cancel`] was called.
    pub fn is_cancelled(&self) -> bool {
        self.shared.cancelled.load(Ordering::Relaxed)
    }

    /// Err when cancelled: the worker returns it where stopping is safe.
    pub fn checkpoint(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }

    /// Record from now on each phase's peak resident memory ([`PhaseTime::peak_rss_bytes`]):
    /// the kernel's peak is read and reset at every phase boundary (Linux).
    pub fn track_peak_memory(&self) {
        self.shared.track_memory.store(true, Ordering::Relaxed);
        reset_peak_rss();
    }

    /// End the running phase and start `phase` (Err, and nothing started, when cancelled).
    pub fn begin(&self, phase: Phase) -> Result<(), Cancelled> {
        self.checkpoint()?;
        // Before taking the lock, which the window's frames wait for. Trimming lowers the
        // memory in use, never the peak read below.
        crate::memory::return_freed_memory();
        let now = Instant::now();
        let mut phases = self.phases();
        self.close_running(&mut phases, now);
        if self.shared.track_memory.load(Ordering::Relaxed) {
            reset_peak_rss();
        }
        phases.push(Record { phase, start: now, took: None, peak_rss: None });
        self.shared.fraction.store(0f32.to_bits(), Ordering::Relaxed);
        Ok(())
    }

    /// How far the running phase is, 0..=1 (clamped).
    pub fn set_fraction(&self, fraction: f32) {
        self.shared.fraction.store(fraction.clamp(0.0, 1.0).to_bits(), Ordering::Relaxed);
    }

    /// End the running phase: the load is over.
    pub fn finish(&self) {
        self.close_running(&mut self.phases(), Instant::now());
    }

    /// The phases and the running one's fraction now.
    pub fn snapshot(&self) -> Snapshot {
        let now = Instant::now();
        let phases = self
            .phases()
            .iter()
            .map(|r| PhaseTime {
                phase: r.phase,
                seconds: r.took.unwrap_or_else(|| (now - r.start).as_secs_f64()),
                done: r.took.is_some(),
                peak_rss_bytes: r.peak_rss,
            })
            .collect();
        Snapshot { phases, fraction: f32::from_bits(self.shared.fraction.load(Ordering::Relaxed)) }
    }

    fn phases(&self) -> std::sync::MutexGuard<'_, Vec<Record>> {
        // A watcher that panicked leaves a list that is still whole: keep using it.
        self.shared.phases.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Close the running phase at `now`, with its peak memory when tracked.
    fn close_running(&self, phases: &mut [Record], now: Instant) {
        if let Some(r @ Record { took: None, .. }) = phases.last_mut() {
            r.took = Some((now - r.start).as_secs_f64());
            if self.shared.track_memory.load(Ordering::Relaxed) {
                r.peak_rss = read_peak_rss();
            }
        }
    }
}

/// Wall times of a computation's steps, logged at debug level as each ends (`RUST_LOG=
/// meshtracer=debug`): for finding where a load's time goes on a machine without a profiler.
pub(crate) struct Laps {
    what: &'static str,
    last: Instant,
}

impl Laps {
    /// Starts the clock for `what` (named in every line).
    pub(crate) fn start(what: &'static str) -> Self {
        Self { what, last: Instant::now() }
    }

    /// Logs the time since the previous lap (or the start) as `step`'s.
    pub(crate) fn lap(&mut self, step: &str) {
        let now = Instant::now();
        log::debug!("{} {step}: {:.1} ms", self.what, (now - self.last).as_secs_f64() * 1e3);
        self.last = now;
    }
}

/// Reset the kernel's record of this process's peak resident memory (Linux: writing 5 to
/// /proc/self/clear_refs); false where that is not possible, so the next reading is the
/// process's peak so far.
pub(crate) fn reset_peak_rss() -> bool {
    crate::files::write_proc_file(Path::new("/proc/self/clear_refs"), "5").is_ok()
}

/// The process's peak resident memory (VmHWM), bytes; None off Linux.
pub(crate) fn read_peak_rss() -> Option<u64> {
    let status = crate::files::read_proc_file(Path::new("/proc/self/status"))?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phases_are_recorded_in_order_and_closed() {
        let p = Progress::default();
        p.begin(Phase::Read).unwrap();
        p.set_fraction(0.5);
        assert_eq!(p.snapshot().fraction, 0.5);
        p.begin(Phase::Parse).unwrap();
        assert_eq!(p.snapshot().fraction, 0.0, "a new phase starts at 0");
        let s = p.snapshot();
        assert_eq!(
            s.phases.iter().map(|t| (t.phase, t.done)).collect::<Vec<_>>(),
            [(Phase::Read, true), (Phase::Parse, false)]
        );
        p.finish();
        assert!(p.snapshot().phases.iter().all(|t| t.done));
        assert!(p.snapshot().total_seconds() >= p.snapshot().seconds(Phase::Read));
    }

    #[test]
    fn a_cancelled_load_starts_no_phase() {
        let p = Progress::default();
        let watcher = p.clone();
        p.begin(Phase::Read).unwrap();
        watcher.cancel();
        assert_eq!(p.checkpoint(), Err(Cancelled));
        assert_eq!(p.begin(Phase::Parse), Err(Cancelled));
        assert_eq!(p.snapshot().phases.len(), 1);
        p.set_fraction(7.0);
        assert_eq!(p.snapshot().fraction, 1.0, "clamped");
    }
}
