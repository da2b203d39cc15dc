//! Timing the tool as it runs.
//!
//! - `frame_stats`: the frame-time history the Performance section plots;
//! - `gpu_clock`: the GPU's shader clock beside the times;
//! - `frame_log`: the frame-time CSV (`--stats-csv`, Record);
//! - `benchmark`: the in-window benchmark (a camera orbit at fixed settings, its summary
//!   and JSON line).

pub(crate) mod benchmark;
pub(crate) mod frame_log;
pub(crate) mod frame_stats;
pub(crate) mod gpu_clock;
