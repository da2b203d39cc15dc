//! The tracing GPU's shader clock, read twice a second in the window. A GPU that idles
//! between frames (vsync at 60 Hz, or frames shown through a slow presenting device) is
//! clocked down by its driver and traces that much slower than `bench`, which keeps it busy
//! (docs/BENCHMARKS.md, "the slow mode is the GPU's clock"): the panel and the frame log
//! show the clock beside the times so that such numbers are read for what they are.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::gpu::{ClockProbe, GpuContext};

/// How often the clock is read. The H100's clock falls within a second of idling, so
/// readings seconds apart missed it; each reading waits for about a millisecond of GPU
/// work at full clock (six at the idle clock), a fraction of a percent at this interval.
pub(crate) const INTERVAL: Duration = Duration::from_millis(500);

/// The probe and its readings.
#[derive(Default)]
pub(crate) struct ClockWatch {
    probe: Option<ClockProbe>,
    last: Option<Instant>,
    /// The latest reading, MHz.
    pub(crate) latest: Option<f64>,
    /// The highest reading so far, MHz.
    pub(crate) highest: Option<f64>,
}

impl ClockWatch {
    /// A watch on `ctx`'s device; it reads nothing on CPU devices (the host's clock, and a
    /// probe there would hold up the frames) or where the device has no shader clock.
    pub(crate) fn new(ctx: &Arc<GpuContext>) -> Self {
        let probe = if ctx.info.is_cpu() { None } else { ClockProbe::new(ctx).ok().flatten() };
        Self { probe, ..Default::default() }
    }

    /// Read the clock if [`INTERVAL`] has passed since the last reading. A probe that fails
    /// is dropped with a warning: the clock is a read-out, not worth stopping the tool.
    pub(crate) fn poll(&mut self, now: Instant) {
        let Some(probe) = self.probe.as_mut() else { return };
        if self.last.is_some_and(|t| now.duration_since(t) < INTERVAL) {
            return;
        }
        // The first dispatch pays for the pipeline's first use: it is not a reading.
        let first = if self.last.is_none() { probe.measure().map(|_| ()) } else { Ok(()) };
        match first.and_then(|()| probe.measure()) {
            Ok(reading) => {
                let mhz = reading.mhz();
                self.latest = Some(mhz);
                self.highest = Some(self.highest.map_or(mhz, |h| h.max(mhz)));
            }
            Err(e) => {
                log::warn!(
                    "reading the GPU's shader clock failed ({e}); the panel will not show it"
                );
                self.probe = None;
            }
        }
        self.last = Some(now);
    }
}
