//! The window's devices: one presents (the window's surface, the composite, the panel) and
//! one traces. Usually one device does both and the trace is recorded into the frame's own
//! command buffer. A GPU that cannot present (a compute GPU with no display engine, on a
//! server reached through Xvfb and VNC) can still trace: another device that presents
//! (lavapipe) shows its frames, each traced and read back on the tracing device and
//! uploaded to the presenting one. `--trace-device N` asks for that split; it also happens
//! by itself when the device picked for the window fails to set up its swapchain.

use std::sync::Arc;

use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use crate::app::measure::gpu_clock::ClockWatch;
use crate::app::options::ViewOptions;
use crate::gpu::context::list_devices;
use crate::gpu::present::surface::context_for_window;
use crate::gpu::present::Presenter;
use crate::gpu::{ComputeTracer, ContextOptions, GpuContext};

/// The presenting side and the tracing context (the same context when one device does both).
pub(super) struct WindowDevices {
    pub(crate) presenter: Presenter,
    /// The device that presents.
    pub(crate) ctx: Arc<GpuContext>,
    /// The device that traces.
    pub(crate) trace_ctx: Arc<GpuContext>,
}

/// Open the presenter on the device `options` ask for (or the best one that presents), and
/// the tracing context. `extent` is the window's size in physical pixels.
///
/// # Safety
/// The handles must belong to a live window that outlives the returned presenter.
pub(super) unsafe fn open(
    options: &ViewOptions,
    display: RawDisplayHandle,
    window: RawWindowHandle,
    extent: [u32; 2],
    vsync: bool,
) -> anyhow::Result<WindowDevices> {
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
    let count = || list_devices().map(|d| d.len()).unwrap_or(0);
    let ((ctx, presenter), fallback) = choose_presenter(options.device, count, present_on)?;
    let unpresentable = fallback.map(|(failed, why)| {
        log::warn!("{why:#}; it traces and {} shows its frames", ctx.info.name);
        failed
    });
    let trace_ctx = match options.trace_device.or(unpresentable) {
        Some(index) => GpuContext::new(&ContextOptions { device_index: Some(index), ..base })
            .map_err(|e| anyhow::anyhow!("tracing on device {index}: {e}"))?,
        None => ctx.clone(),
    };
    Ok(WindowDevices { presenter, ctx, trace_ctx })
}

/// The presenting side: the device `wanted` (`--device`) or the one picked, or, when a
/// picked device fails to present, the first of the other `count()` devices that can; then
/// also the failed device's index and why it failed (it traces). `present_on` tries one
/// device (None: let the context pick), failing with the index of the device it tried.
fn choose_presenter<P>(
    wanted: Option<usize>,
    count: impl FnOnce() -> usize,
    mut present_on: impl FnMut(Option<usize>) -> Result<P, (Option<usize>, anyhow::Error)>,
) -> anyhow::Result<(P, Option<(usize, anyhow::Error)>)> {
    match present_on(wanted) {
        Ok(p) => Ok((p, None)),
        Err((Some(failed), why)) if wanted.is_none() => match (0..count()).filter(|&i| i != failed).find_map(|i| present_on(Some(i)).ok()) {
            Some(p) => Ok((p, Some((failed, why)))),
            None => Err(anyhow::anyhow!(
                "{why:#}, and no other Vulkan device can (with Mesa's lavapipe installed, `mesa-vulkan-drivers`, this GPU would trace and lavapipe show its frames)"
            )),
        },
        Err((_, why)) => Err(why),
    }
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

/// The GPU side: declared in drop order (before the contexts, the window's surface last).
pub(super) struct Gpu {
    pub(super) presenter: Presenter,
    pub(super) tracer: ComputeTracer,
    /// The tracing device's shader clock.
    pub(super) clock: ClockWatch,
    /// The device that presents.
    pub(super) ctx: Arc<GpuContext>,
    /// The device that traces: `ctx` itself, or another one (see [`open`]).
    pub(super) trace_ctx: Arc<GpuContext>,
}

impl Gpu {
    /// The tracer is on a device other than the window's: each frame is traced and read
    /// back before it is drawn, instead of recorded into the frame's commands.
    pub(super) fn traces_elsewhere(&self) -> bool {
        !Arc::ptr_eq(&self.ctx, &self.trace_ctx)
    }
}

/// The hint every "cannot open the tool" error carries.
const HEADLESS_HINT: &str = "use `meshtracer render -o out.png` on a headless machine";

/// A "cannot open the tool" error: what failed, the OS's message, and the headless hint.
pub(crate) fn headless_error(what: &str, e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("{what} ({}); {HEADLESS_HINT}", os_message(&e.to_string()))
}

/// winit's OS errors read "os error at path/to/file.rs:123: message": keep the message.
fn os_message(s: &str) -> String {
    let message = match s.find("os error at ") {
        Some(i) => s[i + "os error at ".len()..].split_once(": ").map_or(s, |(_, m)| m),
        None => s,
    };
    message.trim().trim_end_matches('.').replace('\n', " ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Devices `0..count` where those in `broken` fail to present; None picks device 0.
    fn presenting(
        broken: &'static [usize],
    ) -> impl FnMut(Option<usize>) -> Result<usize, (Option<usize>, anyhow::Error)> {
        move |index| {
            let i = index.unwrap_or(0);
            if broken.contains(&i) {
                Err((Some(i), anyhow::anyhow!("device {i} cannot show the window")))
            } else {
                Ok(i)
            }
        }
    }

    #[test]
    fn a_picked_device_that_cannot_present_traces_for_another() {
        // One device does both.
        let (p, fallback) = choose_presenter(None, || 2, presenting(&[])).unwrap();
        assert_eq!((p, fallback.is_none()), (0, true));
        // The picked GPU cannot present: device 1 shows, device 0 traces.
        let (p, fallback) = choose_presenter(None, || 2, presenting(&[0])).unwrap();
        let (failed, why) = fallback.unwrap();
        assert_eq!((p, failed), (1, 0));
        assert_eq!(why.to_string(), "device 0 cannot show the window");
        // The next that can, skipping the failed one.
        assert_eq!(choose_presenter(None, || 3, presenting(&[0, 1])).unwrap().0, 2);
    }

    #[test]
    fn a_device_asked_for_or_no_other_is_an_error() {
        // `--device 0` is the user's choice: no quiet fallback.
        let e = choose_presenter(Some(0), || 2, presenting(&[0])).unwrap_err();
        assert_eq!(e.to_string(), "device 0 cannot show the window");
        // Nothing else presents: the first device's reason, and what would help.
        let e = choose_presenter(None, || 2, presenting(&[0, 1])).unwrap_err().to_string();
        assert!(
            e.starts_with("device 0 cannot show the window, and no other Vulkan device can")
                && e.contains("lavapipe"),
            "{e}"
        );
        // No device found at all (no index to exclude): that error as it is.
        let e = choose_presenter(
            None,
            || 2,
            |_| Err::<usize, _>((None, anyhow::anyhow!("no Vulkan device"))),
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "no Vulkan device");
    }

    #[test]
    fn winit_errors_lose_their_source_location() {
        let e = "os error at /home/x/winit-0.30.13/src/platform_impl/linux/mod.rs:788: Failed to open connection to X server";
        assert_eq!(os_message(e), "Failed to open connection to X server");
        assert_eq!(os_message("plain."), "plain");
        let full = headless_error("cannot open a window", e).to_string();
        assert_eq!(
            full,
            format!(
                "cannot open a window (Failed to open connection to X server); {HEADLESS_HINT}"
            )
        );
    }
}
