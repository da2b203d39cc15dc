//! The window's devices: one presents (the window's surface, the composite, the panel) and
//! one traces. Usually one device does both and the trace is recorded into the frame's own
//! command buffer. A GPU that cannot present (a compute GPU with no display engine, on a
//! server reached through Xvfb and VNC) can still trace: another device that presents
//! (lavapipe) shows its frames, each traced and read back on the tracing device and
//! uploaded to the presenting one. `--trace-device N` asks for that split; it also happens
//! by itself when the device picked for the window fails to set up its swapchain.

use std::sync::Arc;

use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use super::super::{headless_error, ViewOptions};
use crate::gpu::present::surface::context_for_window;
use crate::gpu::present::Presenter;
use crate::gpu::context::list_devices;
use crate::gpu::{ContextOptions, GpuContext};

/// The presenting side and the tracing context (the same context when one device does both).
pub(super) struct WindowDevices {
    pub presenter: Presenter,
    /// The device that presents.
    pub ctx: Arc<GpuContext>,
    /// The device that traces.
    pub trace_ctx: Arc<GpuContext>,
}

/// Open the presenter on the device `options` ask for (or the best one that presents), and
/// the tracing context. `extent` is the window's size in physical pixels.
///
/// # Safety
/// The handles must belong to a live window that outlives the returned presenter.
pub(super) unsafe fn open(options: &ViewOptions, display: RawDisplayHandle, window: RawWindowHandle, extent: [u32; 2], vsync: bool) -> anyhow::Result<WindowDevices> {
    let base = ContextOptions { validation: options.validation, ..Default::default() };
    // On failure: the error, and the index of the device that was tried (if one was found).
    let present_on = |index: Option<usize>| -> Result<(Arc<GpuContext>, Presenter), (Option<usize>, anyhow::Error)> {
        let opts = ContextOptions { device_index: index, ..base.clone() };
        // SAFETY: the caller promises the handles outlive the presenter owning the surface.
        let (ctx, surface) = unsafe { context_for_window(&opts, display, window) }.map_err(|e| (index, headless_error("no Vulkan device for the window", e)))?;
        match Presenter::new(&ctx, surface, extent, vsync) {
            Ok(presenter) => Ok((ctx, presenter)),
            Err(e) => Err((Some(ctx.info.index), e.context(format!("{} cannot show the window", ctx.info.name)))),
        }
    };
    let (ctx, presenter, unpresentable) = match present_on(options.device) {
        Ok((ctx, presenter)) => (ctx, presenter, None),
        // A device picked by us that cannot present: another device shows its frames.
        Err((Some(failed), error)) if options.device.is_none() => {
            let count = list_devices().map(|d| d.len()).unwrap_or(0);
            let other = (0..count).filter(|&i| i != failed).find_map(|i| present_on(Some(i)).ok());
            let Some((ctx, presenter)) = other else { return Err(error) };
            log::warn!("{error:#}; it traces and {} shows its frames", ctx.info.name);
            (ctx, presenter, Some(failed))
        }
        Err((_, error)) => return Err(error),
    };
    let trace_ctx = match options.trace_device.or(unpresentable) {
        Some(index) => GpuContext::new(&ContextOptions { device_index: Some(index), ..base }).map_err(|e| anyhow::anyhow!("--trace-device {index}: {e}"))?,
        None => ctx.clone(),
    };
    Ok(WindowDevices { presenter, ctx, trace_ctx })
}

/// The panel's device line: the tracing device, and the presenting one where it differs.
pub(super) fn describe(ctx: &GpuContext, trace_ctx: &GpuContext) -> String {
    let validation = if trace_ctx.validation_enabled() { ", validation on" } else { "" };
    let traced = format!("{} ({}){validation}", trace_ctx.info.name, trace_ctx.info.device_type);
    if std::ptr::eq(ctx, trace_ctx) {
        traced
    } else {
        format!("{traced}; shown through {} ({})", ctx.info.name, ctx.info.device_type)
    }
}
