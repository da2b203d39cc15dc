//! GPU timestamps around the trace dispatch: the figure a GPU user compares. One query
//! pair per slot, so frames in flight each keep their own.

use std::sync::Arc;

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuError, VkContext};

/// Timestamp query pairs, read back in milliseconds.
pub(crate) struct GpuTimer {
    ctx: Arc<GpuContext>,
    pool: vk::QueryPool,
    slots: u32,
}

impl GpuTimer {
    /// A timer with `slots` independent begin/end pairs; None when the queue has no timestamps.
    pub(crate) fn new(ctx: &Arc<GpuContext>, slots: u32) -> Result<Option<Self>, GpuError> {
        if ctx.info.timestamp_valid_bits == 0 {
            return Ok(None);
        }
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(slots * 2);
        // SAFETY: plain object creation on the live device; destroyed in Drop.
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }
            .during("creating a timestamp query pool")?;
        Ok(Some(Self { ctx: ctx.clone(), pool, slots }))
    }

    /// Record a reset of `slot` and its begin timestamp (before the work). With
    /// `after_previous` the timestamp waits for the work recorded before it to finish (the
    /// second part of a split frame is timed without the first).
    pub(crate) fn begin(&self, cmd: vk::CommandBuffer, slot: u32, after_previous: bool) {
        assert!(slot < self.slots);
        let stage = if after_previous {
            vk::PipelineStageFlags::BOTTOM_OF_PIPE
        } else {
            vk::PipelineStageFlags::TOP_OF_PIPE
        };
        // SAFETY: `cmd` is recording (the caller's) and both queries of the slot are in the
        // pool (asserted above).
        unsafe {
            self.ctx.device.cmd_reset_query_pool(cmd, self.pool, slot * 2, 2);
            self.ctx.device.cmd_write_timestamp(cmd, stage, self.pool, slot * 2);
        }
    }

    /// Record the end timestamp of `slot` (after the work).
    pub(crate) fn end(&self, cmd: vk::CommandBuffer, slot: u32) {
        assert!(slot < self.slots);
        // SAFETY: as in `begin`.
        unsafe {
            self.ctx.device.cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                self.pool,
                slot * 2 + 1,
            )
        };
    }

    /// Milliseconds between begin and end of `slot`, once the GPU has finished it (None if not yet).
    pub(crate) fn read_ms(&self, slot: u32) -> Option<f64> {
        assert!(slot < self.slots);
        let mut data = [[0u64; 2]; 2];
        let flags = vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WITH_AVAILABILITY;
        // With availability each query yields (value, available).
        // SAFETY: both queries of the slot are in the pool (asserted above) and `data`
        // holds a (value, availability) pair of u64 for each, as the flags ask.
        let ok = unsafe {
            self.ctx.device.get_query_pool_results(self.pool, slot * 2, &mut data, flags)
        };
        if ok.is_err() || data[0][1] == 0 || data[1][1] == 0 {
            return None;
        }
        let bits = self.ctx.info.timestamp_valid_bits;
        let mask = if bits >= 64 { u64::MAX } else { (1u64 << bits) - 1 };
        let ticks = (data[1][0] & mask).wrapping_sub(data[0][0] & mask) & mask;
        Some(ticks as f64 * self.ctx.info.timestamp_period_ns as f64 * 1e-6)
    }
}

impl Drop for GpuTimer {
    fn drop(&mut self) {
        // SAFETY: the owner (`ComputeTracer`) waits for the GPU before its timer is
        // dropped.
        unsafe { self.ctx.device.destroy_query_pool(self.pool, None) };
    }
}
