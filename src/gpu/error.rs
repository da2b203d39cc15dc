//! GPU errors, each one sentence a user can act on.

use ash::vk;

/// What went wrong on the Vulkan side.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no Vulkan loader found ({0}): install a Vulkan driver (on a machine without a GPU: Mesa's lavapipe, e.g. `apt install mesa-vulkan-drivers libvulkan1`)")]
    LoaderMissing(String),
    #[error("no Vulkan device found: install a Vulkan driver (on a machine without a GPU: Mesa's lavapipe, `apt install mesa-vulkan-drivers`)")]
    NoDevice,
    #[error("Vulkan device {index} requested but only {count} found (see `meshtracer devices`)")]
    BadDeviceIndex { index: usize, count: usize },
    #[error("the Vulkan validation layer VK_LAYER_KHRONOS_validation is not installed (`apt install vulkan-validationlayers`)")]
    ValidationLayerMissing,
    #[error("the GPU was lost (VK_ERROR_DEVICE_LOST) during {0}: the driver reset it, possibly because one dispatch ran too long; try a smaller resolution or the BVH")]
    DeviceLost(&'static str),
    #[error("the GPU ran out of memory during {0}: try a smaller mesh or resolution")]
    OutOfMemory(&'static str),
    #[error("Vulkan call failed during {what}: {result}")]
    Vulkan { what: &'static str, result: vk::Result },
    #[error("GPU memory allocation failed for {what}: {source}")]
    Allocation { what: &'static str, source: gpu_allocator::AllocationError },
    #[error("the scene does not fit this GPU: the {buffer} buffer needs {bytes} bytes but the device allows {limit} per storage buffer")]
    SceneTooLarge { buffer: &'static str, bytes: u64, limit: u64 },
    /// `--accel vendor` on a device without the extensions: the reason, one sentence.
    #[error("{0}")]
    VendorUnavailable(String),
    #[error("the tracer is not ready: {0}")]
    NotReady(&'static str),
}

impl GpuError {
    /// Classify a failed Vulkan call.
    pub fn vk(what: &'static str, result: vk::Result) -> Self {
        match result {
            vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost(what),
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                GpuError::OutOfMemory(what)
            }
            _ => GpuError::Vulkan { what, result },
        }
    }
}

/// `?`-friendly conversion of `VkResult` with a description of the call.
pub trait VkContext<T> {
    /// Attach what was being done to a Vulkan error.
    fn during(self, what: &'static str) -> Result<T, GpuError>;
}

impl<T> VkContext<T> for Result<T, vk::Result> {
    fn during(self, what: &'static str) -> Result<T, GpuError> {
        self.map_err(|r| GpuError::vk(what, r))
    }
}
