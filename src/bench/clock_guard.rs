//! Rows measured at the GPU's full clock. The NVIDIA driver lowers an idle GPU's clock (an
//! H100 falls from 1980 to 345 MHz within a second or two of idling, measured with
//! nvidia-smi) and raises it only after some hundreds of milliseconds of steady work. A
//! benchmark idles while it builds the next row's scene on the host, so without a guard the
//! next rows are traced at a sixth of the clock. The guard keeps the GPU busy before each
//! row until [`ClockProbe`] reads a clock near the highest seen in the run.

use std::time::{Duration, Instant};

use crate::gpu::{ClockProbe, GpuError};

/// A row counts as clocked down below this share of the run's highest shader clock.
pub const CLOCKED_DOWN: f64 = 0.8;

/// Busy time between two probes while settling.
const SETTLE_STEP: Duration = Duration::from_millis(50);

/// Settling gives up after this long (a GPU held down by power or heat stays down); the
/// row is then measured and reported with the clock it had.
const SETTLE_LIMIT: Duration = Duration::from_secs(3);

/// Something that reads the GPU's shader clock: [`ClockProbe`], or a scripted clock in tests.
pub trait ClockSource {
    /// One reading, in MHz.
    fn read_mhz(&mut self) -> Result<f64, GpuError>;
}

impl ClockSource for ClockProbe {
    fn read_mhz(&mut self) -> Result<f64, GpuError> {
        Ok(self.measure()?.mhz())
    }
}

/// The clock source and the highest clock it has read in this run.
pub struct ClockGuard<C: ClockSource = ClockProbe> {
    probe: C,
    highest: f64,
    limit: Duration,
    /// The time now: `Instant::now`, or a simulated time in tests (which count steps
    /// instead of timing them).
    now: fn() -> Instant,
}

impl<C: ClockSource> ClockGuard<C> {
    /// A guard around `probe`, after a short burst of readings to wake the GPU: the first
    /// reading of a process may come before the driver raised the clock.
    pub fn new(mut probe: C) -> Result<Self, GpuError> {
        let now: fn() -> Instant = Instant::now;
        let start = now();
        let mut highest: f64 = 0.0;
        while now() - start < Duration::from_millis(300) {
            highest = highest.max(probe.read_mhz()?);
        }
        Ok(Self { probe, highest, limit: SETTLE_LIMIT, now })
    }

    /// Run `busy` (a frame of the row about to be measured) for [`SETTLE_STEP`] at a time
    /// until the clock is at least [`CLOCKED_DOWN`] of the highest seen, or the limit
    /// ([`SETTLE_LIMIT`]) has passed. Returns the clock reached, in MHz.
    pub fn settle(
        &mut self,
        mut busy: impl FnMut() -> Result<(), GpuError>,
    ) -> Result<f64, GpuError> {
        let start = (self.now)();
        loop {
            let mhz = self.read()?;
            if mhz >= CLOCKED_DOWN * self.highest || (self.now)() - start >= self.limit {
                return Ok(mhz);
            }
            let step = (self.now)();
            loop {
                busy()?;
                if (self.now)() - step >= SETTLE_STEP {
                    break;
                }
            }
        }
    }

    /// One reading of the clock, in MHz.
    pub fn read(&mut self) -> Result<f64, GpuError> {
        let mhz = self.probe.read_mhz()?;
        self.highest = self.highest.max(mhz);
        Ok(mhz)
    }
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;

    thread_local! {
        /// The simulated time since [`start`]: frames add to it instead of sleeping, so the
        /// tests count steps and readings exactly.
        static ELAPSED: Cell<Duration> = const { Cell::new(Duration::ZERO) };
        static START: Instant = Instant::now();
    }

    /// The simulated time now.
    fn simulated_now() -> Instant {
        START.with(|s| *s) + ELAPSED.with(Cell::get)
    }

    /// A GPU whose clock sits at `low` until `busy_steps` frames of work have run, then at
    /// `high`; each reading is logged.
    struct ScriptedClock {
        low: f64,
        high: f64,
        busy_steps: u32,
        busy: std::rc::Rc<std::cell::Cell<u32>>,
        readings: u32,
    }

    impl ClockSource for ScriptedClock {
        fn read_mhz(&mut self) -> Result<f64, GpuError> {
            self.readings += 1;
            Ok(if self.busy.get() >= self.busy_steps { self.high } else { self.low })
        }
    }

    fn guard(
        low: f64,
        busy_steps: u32,
    ) -> (ClockGuard<ScriptedClock>, std::rc::Rc<std::cell::Cell<u32>>) {
        let busy = std::rc::Rc::new(std::cell::Cell::new(0));
        let clock =
            ScriptedClock { low, high: 1980.0, busy_steps, busy: busy.clone(), readings: 0 };
        // Start from a run that has already seen the full clock.
        let guard = ClockGuard {
            probe: clock,
            highest: 1980.0,
            limit: Duration::from_millis(400),
            now: simulated_now,
        };
        (guard, busy)
    }

    /// A frame of GPU work as the guard sees it: counted in `counter`, `ms` of simulated time.
    fn frame(
        counter: &std::rc::Rc<std::cell::Cell<u32>>,
        ms: u64,
    ) -> impl FnMut() -> Result<(), GpuError> {
        let counter = counter.clone();
        move || {
            counter.set(counter.get() + 1);
            ELAPSED.with(|e| e.set(e.get() + Duration::from_millis(ms)));
            Ok(())
        }
    }

    #[test]
    fn a_clock_at_full_speed_is_measured_at_once() {
        let (mut g, busy) = guard(1980.0, 0);
        let mhz = g.settle(|| Ok(())).unwrap();
        assert_eq!(mhz, 1980.0);
        assert_eq!(g.probe.readings, 1);
        assert_eq!(busy.get(), 0, "no work needed");
    }

    #[test]
    fn a_clocked_down_gpu_is_kept_busy_until_the_clock_is_back() {
        let (mut g, busy) = guard(345.0, 3);
        let mhz = g.settle(frame(&busy, 20)).unwrap();
        assert_eq!(mhz, 1980.0, "settled at full clock");
        // One step of 50 ms is three frames of 20 ms, then the clock is read again.
        assert_eq!(busy.get(), 3, "frames run");
        assert_eq!(g.probe.readings, 2);
    }

    #[test]
    fn a_clock_that_stays_down_is_given_up_on_after_the_limit() {
        let (mut g, busy) = guard(600.0, u32::MAX);
        let mhz = g.settle(frame(&busy, 5)).unwrap();
        assert_eq!(mhz, 600.0, "reports the clock it had");
        // Given up at the 400 ms limit, not before: eight steps of ten 5 ms frames, a
        // reading before each and one at the limit.
        assert_eq!(busy.get(), 80, "frames run");
        assert_eq!(g.probe.readings, 9);
        assert_eq!(g.highest, 1980.0, "a low reading does not lower the reference");
    }

    #[test]
    fn a_higher_reading_raises_the_reference() {
        let (mut g, _) = guard(1980.0, 0);
        g.probe.high = 2100.0;
        assert_eq!(g.read().unwrap(), 2100.0);
        assert_eq!(g.highest, 2100.0);
    }
}
