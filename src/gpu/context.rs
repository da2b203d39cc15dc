//! Vulkan instance, validation, device and the memory allocator: the one place that owns the
//! Vulkan objects everything else borrows. Which device, and what it offers, is
//! `physical_device`'s.

use std::ffi::c_char;
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};

use ash::ext::debug_utils;
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::error::{GpuError, VkContext};
use super::lock::lock;
use super::physical_device::{
    device_info_of, device_type_name, driver_of, has_pipeline_statistics, has_subgroup_clock,
    pick_device, vendor_support,
};
pub use super::physical_device::{DeviceInfo, VendorSupport};
use super::validation::{self, ValidationLog, VALIDATION_LAYER};

/// How to create the context.
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Enable `VK_LAYER_KHRONOS_validation`; also switched on by `MESHTRACER_VALIDATION=1`.
    pub validation: bool,
    /// Also enable the layer's synchronization validation (implies `validation`); also
    /// switched on by `MESHTRACER_SYNC_VALIDATION=1`.
    pub sync_validation: bool,
    /// Extra instance extensions (the window system's surface extensions).
    pub instance_extensions: Vec<*const c_char>,
    /// Enable the swapchain extension and dynamic rendering (for the window).
    pub presentation: bool,
    /// Pick this device (index into `list_devices`) instead of the best one.
    pub device_index: Option<usize>,
}

impl ContextOptions {
    /// Options for tests: validation (with synchronization validation) always on.
    pub fn validated() -> Self {
        Self { validation: true, sync_validation: true, ..Default::default() }
    }

    fn validation_wanted(&self) -> bool {
        self.validation
            || self.sync_validation_wanted()
            || std::env::var("MESHTRACER_VALIDATION").is_ok_and(|v| v == "1")
    }

    fn sync_validation_wanted(&self) -> bool {
        self.sync_validation || std::env::var("MESHTRACER_SYNC_VALIDATION").is_ok_and(|v| v == "1")
    }
}

/// The Vulkan instance, device, queue and allocator.
pub struct GpuContext {
    pub(crate) entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    pub(crate) physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    /// One queue that does compute, transfers and (for the window) graphics and present.
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    pub info: DeviceInfo,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    debug: Option<Messenger>,
    validation: Arc<ValidationLog>,
    one_shot_pool: Mutex<vk::CommandPool>,
    /// Vulkan requires external synchronisation of the queue: every submit and present
    /// goes through this lock, so tracers on several threads can share one context.
    queue_lock: Mutex<()>,
}

/// A surface-creating callback, run between instance and device creation.
pub(crate) type SurfaceFactory<'a> =
    &'a dyn Fn(&ash::Entry, &ash::Instance) -> Result<vk::SurfaceKHR, GpuError>;

fn load_entry() -> Result<ash::Entry, GpuError> {
    // SAFETY: loading the system's Vulkan loader library; no other invariants.
    unsafe { ash::Entry::load() }.map_err(|e| GpuError::LoaderMissing(e.to_string()))
}

/// A failed `vkCreateInstance`: the loader found no driver (ICD) at all, or something else.
fn instance_error(r: vk::Result) -> GpuError {
    match r {
        vk::Result::ERROR_INCOMPATIBLE_DRIVER | vk::Result::ERROR_INITIALIZATION_FAILED => {
            GpuError::NoDevice
        }
        r => GpuError::vk("creating the Vulkan instance", r),
    }
}

/// Names of the Vulkan devices present, in `device_index` order.
pub(crate) fn list_devices() -> Result<Vec<String>, GpuError> {
    let entry = load_entry()?;
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
    // SAFETY: the create info and the application info it points to outlive the call.
    let instance = unsafe {
        entry.create_instance(&vk::InstanceCreateInfo::default().application_info(&app), None)
    }
    .map_err(instance_error)?;
    // SAFETY: the instance was just created and is destroyed only below.
    let names = unsafe {
        let devices = instance.enumerate_physical_devices().unwrap_or_default();
        devices
            .iter()
            .map(|&d| {
                let p = instance.get_physical_device_properties(d);
                // The driver and its version: two lavapipes (Mesa 22 and 25) share one name.
                let name = p.device_name_as_c_str().unwrap_or(c"?").to_string_lossy();
                format!("{name} ({}; {})", device_type_name(p.device_type), driver_of(&instance, d))
            })
            .collect()
    };
    // SAFETY: nothing made from the instance is alive any more.
    unsafe { instance.destroy_instance(None) };
    Ok(names)
}

impl GpuContext {
    /// A headless context (no surface).
    pub fn new(options: &ContextOptions) -> Result<Arc<Self>, GpuError> {
        Self::with_surface(options, None).map(|(ctx, _)| ctx)
    }

    /// Create instance, optional surface (via `make_surface`), device and allocator.
    pub(crate) fn with_surface(
        options: &ContextOptions,
        make_surface: Option<SurfaceFactory>,
    ) -> Result<(Arc<Self>, Option<vk::SurfaceKHR>), GpuError> {
        static WARNED: std::sync::Once = std::sync::Once::new();
        WARNED.call_once(warn_of_a_file_size_limit);
        let entry = load_entry()?;
        let validation = options.validation_wanted();
        let validation_log = Arc::new(ValidationLog::default());
        let instance = create_instance(&entry, options, validation)?;
        let debug = match validation {
            true => Some(create_messenger(&entry, &instance, &validation_log)?),
            false => None,
        };
        // The surface comes before the device: the device must be able to present to it.
        let (surface, (physical_device, queue_family, index)) =
            match surface_and_device(&entry, &instance, options.device_index, make_surface) {
                Ok(v) => v,
                Err(e) => {
                    destroy_instance(&instance, &debug);
                    return Err(e);
                }
            };

        // SAFETY: a query on a physical device of this live instance.
        let props = unsafe { instance.get_physical_device_properties(physical_device) };
        let wanted = WantedFeatures {
            presentation: options.presentation,
            // The vendor's ray tracing, enabled wherever the device has it.
            vendor: vendor_support(&instance, physical_device, &props),
            // The driver's own statistics of the compiled shader, where it offers them.
            shader_statistics: has_pipeline_statistics(&instance, physical_device),
            // The shader clock, for measuring the GPU's clock rate (the driver may lower it).
            shader_clock: has_subgroup_clock(&instance, physical_device),
        };
        let device = create_device(&instance, physical_device, queue_family, &wanted)?;
        // SAFETY: the device was created with one queue of this family.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let allocator =
            create_allocator(&instance, &device, physical_device, wanted.vendor.available())?;
        let info = DeviceInfo {
            index,
            vendor: wanted.vendor,
            shader_statistics: wanted.shader_statistics,
            shader_clock: wanted.shader_clock,
            ..device_info_of(&instance, physical_device, queue_family, &props)
        };
        let one_shot_pool = create_one_shot_pool(&device, queue_family)?;

        Ok((
            Arc::new(Self {
                entry,
                instance,
                physical_device,
                device,
                queue,
                queue_family,
                info,
                allocator: ManuallyDrop::new(Mutex::new(allocator)),
                debug,
                validation: validation_log,
                one_shot_pool: Mutex::new(one_shot_pool),
                queue_lock: Mutex::new(()),
            }),
            surface,
        ))
    }
    /// The memory allocator (buffers and images lock it briefly to allocate or free).
    pub fn allocator(&self) -> std::sync::MutexGuard<'_, Allocator> {
        lock(&self.allocator)
    }

    /// Validation messages (warnings and errors) seen so far; empty without validation.
    pub fn validation_messages(&self) -> Vec<String> {
        self.validation.messages()
    }

    /// True when the validation layer is active.
    pub fn validation_enabled(&self) -> bool {
        self.debug.is_some()
    }

    /// Submit to the queue (under the queue lock).
    pub(crate) fn submit(
        &self,
        submits: &[vk::SubmitInfo],
        fence: vk::Fence,
    ) -> Result<(), GpuError> {
        let _guard = lock(&self.queue_lock);
        // SAFETY: the queue lock is held, as Vulkan requires of queue use; the submits and
        // the fence belong to this device.
        unsafe { self.device.queue_submit(self.queue, submits, fence) }
            .during("submitting GPU work")
    }

    /// Hold the queue lock (for `vkQueuePresentKHR` and other direct queue use).
    pub(crate) fn lock_queue(&self) -> std::sync::MutexGuard<'_, ()> {
        lock(&self.queue_lock)
    }

    /// Record commands with `record`, submit them and wait for completion.
    pub(crate) fn one_shot<R>(
        &self,
        record: impl FnOnce(vk::CommandBuffer) -> R,
    ) -> Result<R, GpuError> {
        let pool = lock(&self.one_shot_pool);
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool lock is held, so no other thread uses the pool.
        let cmd = unsafe { self.device.allocate_command_buffers(&alloc) }
            .during("allocating a command buffer")?[0];
        // SAFETY: `cmd` was just allocated and is recorded, submitted and waited for here,
        // under the pool lock; the fence is destroyed after the wait.
        let result = (|| unsafe {
            self.device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .during("recording commands")?;
            let r = record(cmd);
            self.device.end_command_buffer(cmd).during("recording commands")?;
            let fence = self
                .device
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .during("creating a fence")?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            let submitted = self.submit(&submit, fence);
            let waited = submitted.and_then(|_| {
                self.device.wait_for_fences(&[fence], true, u64::MAX).during("waiting for the GPU")
            });
            self.device.destroy_fence(fence, None);
            waited.map(|_| r)
        })();
        // SAFETY: the buffer is not pending (its submission was waited for, or never made)
        // and the pool lock is still held.
        unsafe { self.device.free_command_buffers(*pool, &[cmd]) };
        result
    }

    /// Wait until the GPU is idle (before freeing resources it may still use). Holds the
    /// queue lock: `vkDeviceWaitIdle` needs every queue externally synchronized.
    pub(crate) fn wait_idle(&self) -> Result<(), GpuError> {
        let _guard = lock(&self.queue_lock);
        // SAFETY: the queue lock is held, so no other thread uses the queue meanwhile.
        unsafe { self.device.device_wait_idle() }.during("waiting for the GPU to finish")
    }
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        // SAFETY: every object made from the context holds an Arc to it, so all are gone;
        // after waiting for the device, children are destroyed before their parents.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_command_pool(*self.one_shot_pool.get_mut().unwrap(), None);
            // The allocator frees its memory blocks through the device: drop it first.
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// The debug messenger and the loader that destroys it.
type Messenger = (debug_utils::Instance, vk::DebugUtilsMessengerEXT);

/// The instance, with the validation layer (and its synchronization checks) when wanted.
fn create_instance(
    entry: &ash::Entry,
    options: &ContextOptions,
    validation: bool,
) -> Result<ash::Instance, GpuError> {
    let mut layers: Vec<*const c_char> = Vec::new();
    if validation {
        // SAFETY: a plain query of the loaded entry.
        let available = unsafe { entry.enumerate_instance_layer_properties() }
            .during("listing instance layers")?;
        if !available.iter().any(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER)) {
            return Err(GpuError::ValidationLayerMissing);
        }
        layers.push(VALIDATION_LAYER.as_ptr());
    }
    let mut extensions = options.instance_extensions.clone();
    if validation {
        extensions.push(debug_utils::NAME.as_ptr());
    }
    let app = vk::ApplicationInfo::default()
        .application_name(c"meshtracer")
        .engine_name(c"meshtracer")
        .api_version(vk::API_VERSION_1_3);
    let sync_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features =
        vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync_features);
    let mut create = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    if validation && options.sync_validation_wanted() {
        create = create.push_next(&mut features);
    }
    // SAFETY: every pointer in the create info (application info, layer and extension
    // names, validation features) outlives the call.
    unsafe { entry.create_instance(&create, None) }.map_err(instance_error)
}

/// The messenger that passes the validation layer's messages to `log`.
fn create_messenger(
    entry: &ash::Entry,
    instance: &ash::Instance,
    log: &Arc<ValidationLog>,
) -> Result<Messenger, GpuError> {
    let loader = debug_utils::Instance::new(entry, instance);
    let info = validation::messenger_info(log);
    // SAFETY: the instance is live; the user data is the `ValidationLog` the context keeps
    // until it destroys the messenger.
    let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }
        .during("creating the debug messenger")?;
    Ok((loader, messenger))
}

/// A physical device, the queue family picked on it and its index among the devices.
type PickedDevice = (vk::PhysicalDevice, u32, usize);

/// The surface (when a factory is given) and the physical device, queue family and device
/// index picked to use it.
fn surface_and_device(
    entry: &ash::Entry,
    instance: &ash::Instance,
    device_index: Option<usize>,
    make_surface: Option<SurfaceFactory>,
) -> Result<(Option<vk::SurfaceKHR>, PickedDevice), GpuError> {
    let surface = match make_surface {
        Some(f) => Some(f(entry, instance)?),
        None => None,
    };
    let surface_loader = ash::khr::surface::Instance::new(entry, instance);
    let picked = pick_device(instance, device_index, surface.map(|s| (&surface_loader, s)))?;
    Ok((surface, picked))
}

/// Tear down the messenger and the instance when creating the context fails after them.
fn destroy_instance(instance: &ash::Instance, debug: &Option<Messenger>) {
    // SAFETY: the messenger and the instance were made by `with_surface` and nothing else
    // uses them on its error path.
    unsafe {
        if let Some((loader, m)) = debug {
            loader.destroy_debug_utils_messenger(*m, None);
        }
        instance.destroy_instance(None);
    }
}

/// What the device is created with beyond compute: each is enabled only where offered.
struct WantedFeatures {
    /// The swapchain extension and dynamic rendering (for the window).
    presentation: bool,
    vendor: VendorSupport,
    shader_statistics: bool,
    shader_clock: bool,
}

/// The logical device with one queue of `queue_family` and the `wanted` extensions and
/// features.
fn create_device(
    instance: &ash::Instance,
    physical_device: vk::PhysicalDevice,
    queue_family: u32,
    wanted: &WantedFeatures,
) -> Result<ash::Device, GpuError> {
    let priorities = [1.0];
    let queue_info = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let mut device_extensions: Vec<*const c_char> = Vec::new();
    let mut device_info = vk::DeviceCreateInfo::default().queue_create_infos(&queue_info);
    // The feature structs live to the end of this function: the create info points to them.
    let mut features13 = vk::PhysicalDeviceVulkan13Features::default()
        .dynamic_rendering(true)
        .synchronization2(true);
    if wanted.presentation {
        device_extensions.push(ash::khr::swapchain::NAME.as_ptr());
        device_info = device_info.push_next(&mut features13);
    }
    let mut features12 = vk::PhysicalDeviceVulkan12Features::default().buffer_device_address(true);
    let mut accel_features =
        vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
    let mut query_features = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
    let mut pipeline_features =
        vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default().ray_tracing_pipeline(true);
    if wanted.vendor.available() {
        device_extensions.push(ash::khr::acceleration_structure::NAME.as_ptr());
        device_extensions.push(ash::khr::deferred_host_operations::NAME.as_ptr());
        device_info = device_info.push_next(&mut features12).push_next(&mut accel_features);
    }
    if wanted.vendor.ray_query {
        device_extensions.push(ash::khr::ray_query::NAME.as_ptr());
        device_info = device_info.push_next(&mut query_features);
    }
    if wanted.vendor.pipeline {
        device_extensions.push(ash::khr::ray_tracing_pipeline::NAME.as_ptr());
        device_info = device_info.push_next(&mut pipeline_features);
    }
    let mut statistics_features =
        vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
            .pipeline_executable_info(true);
    if wanted.shader_statistics {
        device_extensions.push(ash::khr::pipeline_executable_properties::NAME.as_ptr());
        device_info = device_info.push_next(&mut statistics_features);
    }
    let mut clock_features =
        vk::PhysicalDeviceShaderClockFeaturesKHR::default().shader_subgroup_clock(true);
    if wanted.shader_clock {
        device_extensions.push(ash::khr::shader_clock::NAME.as_ptr());
        device_info = device_info.push_next(&mut clock_features);
    }
    device_info = device_info.enabled_extension_names(&device_extensions);
    // SAFETY: the create info and the queue info, priorities, extension names and features
    // it points to outlive the call.
    unsafe { instance.create_device(physical_device, &device_info, None) }
        .during("creating the Vulkan device")
}

/// The memory allocator, with device addresses where acceleration structures need them.
fn create_allocator(
    instance: &ash::Instance,
    device: &ash::Device,
    physical_device: vk::PhysicalDevice,
    buffer_device_address: bool,
) -> Result<Allocator, GpuError> {
    Allocator::new(&AllocatorCreateDesc {
        instance: instance.clone(),
        device: device.clone(),
        physical_device,
        debug_settings: Default::default(),
        // Acceleration structures are built from and referred to by device addresses.
        buffer_device_address,
        allocation_sizes: Default::default(),
    })
    .map_err(|source| GpuError::Allocation { what: "the allocator", source })
}

/// The pool `one_shot` allocates its command buffers from.
fn create_one_shot_pool(
    device: &ash::Device,
    queue_family: u32,
) -> Result<vk::CommandPool, GpuError> {
    let pool_info = vk::CommandPoolCreateInfo::default()
        .queue_family_index(queue_family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
    // SAFETY: plain object creation on the live device; destroyed in Drop.
    unsafe { device.create_command_pool(&pool_info, None) }.during("creating a command pool")
}

/// Under a file-size limit (`ulimit -f`), the system stops the process when a file grows past
/// it, and the Vulkan driver grows files of its own (lavapipe backs GPU memory with them, and
/// drivers keep a shader cache). `main` ignores the signal, so that our own writes fail as an
/// error, but lavapipe then dies of a bus error, which says nothing: the limit is named first.
fn warn_of_a_file_size_limit() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
        // SAFETY: getrlimit writes the limit into `limit` and nothing else.
        let read = unsafe { libc::getrlimit(libc::RLIMIT_FSIZE, &mut limit) } == 0;
        if read && limit.rlim_cur != libc::RLIM_INFINITY {
            log::warn!(
                "the file-size limit (ulimit -f) is {} bytes; the Vulkan driver's own files (GPU memory on a CPU driver, its shader cache) may outgrow it, and the system then stops the program",
                limit.rlim_cur
            );
        }
    }
}
