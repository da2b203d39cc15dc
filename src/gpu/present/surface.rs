//! A Vulkan context with a surface for a window, from the window system's raw handles.

use std::sync::Arc;

use ash::vk;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use crate::gpu::context::{ContextOptions, GpuContext};
use crate::gpu::error::GpuError;

/// Why the window cannot get a Vulkan context: the window system lacks surface support,
/// or no device can present to it.
#[derive(Debug, thiserror::Error)]
pub(crate) enum SurfaceError {
    #[error("this window system has no Vulkan surface support ({0})")]
    Unsupported(vk::Result),
    #[error("{0}")]
    Gpu(#[from] GpuError),
}

/// Create a context able to present to the window behind `display` and `window`, and the
/// window's surface. `options` says everything else (validation, device index).
///
/// # Safety
/// The handles must belong to a live window that outlives the returned surface (whoever
/// owns the surface must be dropped before the window).
pub(crate) unsafe fn context_for_window(
    options: &ContextOptions,
    display: RawDisplayHandle,
    window: RawWindowHandle,
) -> Result<(Arc<GpuContext>, vk::SurfaceKHR), SurfaceError> {
    let extensions =
        ash_window::enumerate_required_extensions(display).map_err(SurfaceError::Unsupported)?;
    let options = ContextOptions {
        instance_extensions: extensions.to_vec(),
        presentation: true,
        ..options.clone()
    };
    let make_surface = |entry: &ash::Entry, instance: &ash::Instance| {
        // SAFETY: the caller promises the handles outlive the surface.
        unsafe { ash_window::create_surface(entry, instance, display, window, None) }
            .map_err(|r| GpuError::vk("creating the window surface", r))
    };
    let (ctx, surface) = GpuContext::with_surface(&options, Some(&make_surface))?;
    let surface = surface.ok_or(GpuError::NotReady("no window surface was created"))?;
    Ok((ctx, surface))
}
