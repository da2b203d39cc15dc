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

/// The probe and the highest clock it has read in this run.
pub struct ClockGuard {
    probe: ClockProbe,
    highest: f64,
}

impl ClockGuard {
    /// A guard around `probe`, after a short burst of probes to wake the GPU: the first
    /// reading of a process may come before the driver raised the clock.
    pub fn new(mut probe: ClockProbe) -> Result<Self, GpuError> {
        let start = Instant::now();
        let mut highest: f64 = 0.0;
        while start.elapsed() < Duration::from_millis(300) {
            highest = highest.max(probe.measure()?.mhz());
        }
        Ok(Self { probe, highest })
    }

    /// Run `busy` (a frame of the row about to be measured) for [`SETTLE_STEP`] at a time
    /// until the clock is at least [`CLOCKED_DOWN`] of the highest seen, or [`SETTLE_LIMIT`]
    /// has passed. Returns the clock reached, in MHz.
    pub fn settle(&mut self, mut busy: impl FnMut() -> Result<(), GpuError>) -> Result<f64, GpuError> {
        let start = Instant::now();
        loop {
            let mhz = self.read()?;
            if mhz >= CLOCKED_DOWN * self.highest || start.elapsed() >= SETTLE_LIMIT {
                return Ok(mhz);
            }
            let step = Instant::now();
            loop {
                busy()?;
                if step.elapsed() >= SETTLE_STEP {
                    break;
                }
            }
        }
    }

    /// One reading of the clock, in MHz.
    pub fn read(&mut self) -> Result<f64, GpuError> {
        let mhz = self.probe.measure()?.mhz();
        self.highest = self.highest.max(mhz);
        Ok(mhz)
    }
}
