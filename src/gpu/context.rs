//! Vulkan instance, validation, device selection and the memory allocator: the one place
//! that owns the Vulkan objects everything else borrows.

use std::ffi::{c_char, CStr};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};

use ash::ext::debug_utils;
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::error::{GpuError, VkContext};
use super::lock::lock;
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

/// What the chosen device is, for reports and limits checks.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub name: String,
    /// The device's index in the instance's list (`meshtracer devices`, `--device`).
    pub(crate) index: usize,
    pub(crate) device_type: String,
    /// Driver name and version as the driver reports them.
    pub driver: String,
    /// Vulkan version the device supports, "1.3.x".
    pub(crate) api_version: String,
    pub max_storage_buffer_range: u64,
    /// Largest side of a 2D image (egui's texture limit).
    pub(crate) max_image_dimension_2d: u32,
    /// Nanoseconds per timestamp tick.
    pub(crate) timestamp_period_ns: f32,
    /// Valid bits of the queue's timestamps (0 = no timestamps).
    pub(crate) timestamp_valid_bits: u32,
    /// Device-local heap size in bytes (the largest such heap).
    pub(crate) device_local_bytes: u64,
    /// The vendor's ray tracing the device offers (`--accel vendor`), enabled when present.
    pub vendor: VendorSupport,
    /// `VK_KHR_pipeline_executable_properties` is on: the driver reports what it compiled
    /// the trace shader to (registers, local memory; `bench --verbose`).
    pub(crate) shader_statistics: bool,
    /// `VK_KHR_shader_clock` (subgroup clock) is on: `ClockProbe` can measure the shader
    /// clock rate (`bench` reports it per row).
    pub(crate) shader_clock: bool,
}

/// What the device offers for tracing with the driver's own acceleration structures.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VendorSupport {
    /// `VK_KHR_ray_query`: the driver's traversal from a compute shader.
    pub ray_query: bool,
    /// `VK_KHR_ray_tracing_pipeline`: ray generation, closest-hit and miss shaders.
    pub pipeline: bool,
    /// Why the vendor path cannot run here (one sentence), when neither is usable.
    pub missing: Option<String>,
}

impl VendorSupport {
    /// Either way of tracing with the driver's structures is usable.
    pub fn available(&self) -> bool {
        self.ray_query || self.pipeline
    }
}

/// Set to 1, the tool leaves the vendor's ray tracing off even where the device has it (to
/// see the tool as it is on a device without it).
pub(crate) const NO_VENDOR_ENV: &str = "MESHTRACER_NO_VENDOR_RT";

/// Which ray tracing extensions and features `pd` offers, all of them needed together.
fn vendor_support(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    props: &vk::PhysicalDeviceProperties,
) -> VendorSupport {
    let name = props.device_name_as_c_str().unwrap_or(c"?").to_string_lossy().into_owned();
    let missing = |why: String| VendorSupport { missing: Some(why), ..Default::default() };
    if std::env::var(NO_VENDOR_ENV).is_ok_and(|v| v == "1") {
        return missing(format!("the vendor's ray tracing is switched off ({NO_VENDOR_ENV}=1)"));
    }
    if props.api_version < vk::API_VERSION_1_2 {
        return missing(format!(
            "{name} supports only Vulkan {}.{}; the vendor's ray tracing needs 1.2",
            vk::api_version_major(props.api_version),
            vk::api_version_minor(props.api_version)
        ));
    }
    // SAFETY: a plain query of a physical device of this live instance.
    let extensions =
        unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
    let has = |ext: &CStr| extensions.iter().any(|e| e.extension_name_as_c_str() == Ok(ext));
    let mut rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
    let mut rt = vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default();
    let mut accel = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
    let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut features = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut rq)
        .push_next(&mut rt)
        .push_next(&mut accel)
        .push_next(&mut v12);
    // SAFETY: the feature structs chained to `features` outlive the call.
    unsafe { instance.get_physical_device_features2(pd, &mut features) };
    let structures = has(ash::khr::acceleration_structure::NAME)
        && has(ash::khr::deferred_host_operations::NAME)
        && accel.acceleration_structure == vk::TRUE
        && v12.buffer_device_address == vk::TRUE;
    let ray_query = structures && has(ash::khr::ray_query::NAME) && rq.ray_query == vk::TRUE;
    let pipeline = structures
        && has(ash::khr::ray_tracing_pipeline::NAME)
        && rt.ray_tracing_pipeline == vk::TRUE;
    if ray_query || pipeline {
        return VendorSupport { ray_query, pipeline, missing: None };
    }
    missing(format!(
        "{name} does not offer the vendor's ray tracing (VK_KHR_acceleration_structure with VK_KHR_ray_query or VK_KHR_ray_tracing_pipeline); on a CPU, Mesa 25's lavapipe has them"
    ))
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
    debug: Option<(debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
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

impl DeviceInfo {
    /// The device is a CPU (lavapipe, SwiftShader).
    pub(crate) fn is_cpu(&self) -> bool {
        self.device_type == device_type_name(vk::PhysicalDeviceType::CPU)
    }
}

fn device_type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
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
        let instance = unsafe { entry.create_instance(&create, None) }.map_err(instance_error)?;

        let debug = if validation {
            let loader = debug_utils::Instance::new(&entry, &instance);
            let info = validation::messenger_info(&validation_log);
            // SAFETY: the instance is live; the user data is the `ValidationLog` the
            // context keeps until it destroys the messenger.
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }
                .during("creating the debug messenger")?;
            Some((loader, messenger))
        } else {
            None
        };

        // From here on, failures must tear down what exists: wrap in a guard-like closure.
        let result = (|| {
            let surface = match make_surface {
                Some(f) => Some(f(&entry, &instance)?),
                None => None,
            };
            let surface_loader = ash::khr::surface::Instance::new(&entry, &instance);
            let picked = pick_device(
                &instance,
                options.device_index,
                surface.map(|s| (&surface_loader, s)),
            )?;
            Ok::<_, GpuError>((surface, picked))
        })();
        let (surface, (physical_device, queue_family, index)) = match result {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: the messenger and the instance were made above and nothing else
                // uses them on this error path.
                unsafe {
                    if let Some((loader, m)) = &debug {
                        loader.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
                return Err(e);
            }
        };

        // SAFETY: a query on a physical device of this live instance.
        let props = unsafe { instance.get_physical_device_properties(physical_device) };
        let presentation = options.presentation;
        let priorities = [1.0];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut device_extensions: Vec<*const c_char> = Vec::new();
        let mut features13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true);
        let mut device_info = vk::DeviceCreateInfo::default().queue_create_infos(&queue_info);
        if presentation {
            device_extensions.push(ash::khr::swapchain::NAME.as_ptr());
            device_info = device_info.push_next(&mut features13);
        }
        // The vendor's ray tracing, enabled wherever the device has it.
        let vendor = vendor_support(&instance, physical_device, &props);
        let mut features12 =
            vk::PhysicalDeviceVulkan12Features::default().buffer_device_address(true);
        let mut accel_features = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
            .acceleration_structure(true);
        let mut query_features = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
        let mut pipeline_features =
            vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default().ray_tracing_pipeline(true);
        if vendor.available() {
            device_extensions.push(ash::khr::acceleration_structure::NAME.as_ptr());
            device_extensions.push(ash::khr::deferred_host_operations::NAME.as_ptr());
            device_info = device_info.push_next(&mut features12).push_next(&mut accel_features);
        }
        if vendor.ray_query {
            device_extensions.push(ash::khr::ray_query::NAME.as_ptr());
            device_info = device_info.push_next(&mut query_features);
        }
        if vendor.pipeline {
            device_extensions.push(ash::khr::ray_tracing_pipeline::NAME.as_ptr());
            device_info = device_info.push_next(&mut pipeline_features);
        }
        // The driver's own statistics of the compiled shader, where it offers them.
        let shader_statistics = has_pipeline_statistics(&instance, physical_device);
        let mut statistics_features =
            vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
                .pipeline_executable_info(true);
        if shader_statistics {
            device_extensions.push(ash::khr::pipeline_executable_properties::NAME.as_ptr());
            device_info = device_info.push_next(&mut statistics_features);
        }
        // The shader clock, for measuring the GPU's clock rate (the driver may lower it).
        let shader_clock = has_subgroup_clock(&instance, physical_device);
        let mut clock_features =
            vk::PhysicalDeviceShaderClockFeaturesKHR::default().shader_subgroup_clock(true);
        if shader_clock {
            device_extensions.push(ash::khr::shader_clock::NAME.as_ptr());
            device_info = device_info.push_next(&mut clock_features);
        }
        device_info = device_info.enabled_extension_names(&device_extensions);
        // SAFETY: the create info and the queue info, priorities, extension names and
        // features it points to outlive the call.
        let device = unsafe { instance.create_device(physical_device, &device_info, None) }
            .during("creating the Vulkan device")?;
        // SAFETY: the device was created with one queue of this family.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device,
            debug_settings: Default::default(),
            // Acceleration structures are built from and referred to by device addresses.
            buffer_device_address: vendor.available(),
            allocation_sizes: Default::default(),
        })
        .map_err(|source| GpuError::Allocation { what: "the allocator", source })?;

        let info = DeviceInfo {
            index,
            vendor,
            shader_statistics,
            shader_clock,
            ..device_info_of(&instance, physical_device, queue_family, &props)
        };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: plain object creation on the live device; destroyed in Drop.
        let one_shot_pool = unsafe { device.create_command_pool(&pool_info, None) }
            .during("creating a command pool")?;

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

fn pick_device(
    instance: &ash::Instance,
    index: Option<usize>,
    surface: Option<(&ash::khr::surface::Instance, vk::SurfaceKHR)>,
) -> Result<(vk::PhysicalDevice, u32, usize), GpuError> {
    // SAFETY: a plain query of the live instance.
    let devices =
        unsafe { instance.enumerate_physical_devices() }.during("listing Vulkan devices")?;
    if devices.is_empty() {
        return Err(GpuError::NoDevice);
    }
    let queue_for = |pd: vk::PhysicalDevice| -> Option<u32> {
        // SAFETY: a query on a physical device of this instance.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        families.iter().enumerate().find_map(|(i, f)| {
            let i = i as u32;
            let mut ok = f.queue_flags.contains(vk::QueueFlags::COMPUTE);
            if let Some((loader, s)) = surface {
                ok &= f.queue_flags.contains(vk::QueueFlags::GRAPHICS)
                    // SAFETY: the surface belongs to this instance and family `i` exists.
                    && unsafe { loader.get_physical_device_surface_support(pd, i, s) }.unwrap_or(false);
            }
            ok.then_some(i)
        })
    };
    if let Some(i) = index {
        let pd =
            *devices.get(i).ok_or(GpuError::BadDeviceIndex { index: i, count: devices.len() })?;
        return queue_for(pd).map(|q| (pd, q, i)).ok_or(GpuError::NoDevice);
    }
    // SAFETY: a query on a physical device of this instance.
    let rank = |pd: vk::PhysicalDevice| match unsafe { instance.get_physical_device_properties(pd) }
        .device_type
    {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    };
    let mut candidates: Vec<(i32, vk::PhysicalDevice, u32, usize)> = devices
        .iter()
        .enumerate()
        .filter_map(|(i, &pd)| queue_for(pd).map(|q| (rank(pd), pd, q, i)))
        .collect();
    candidates.sort_by_key(|c| c.0);
    candidates.first().map(|&(_, pd, q, i)| (pd, q, i)).ok_or(GpuError::NoDevice)
}

/// The driver's name and version as it reports them ("llvmpipe Mesa 25.0.7 (LLVM 15.0.6)").
fn driver_of(instance: &ash::Instance, pd: vk::PhysicalDevice) -> String {
    let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver_props);
    // SAFETY: `props2` and the driver properties chained to it outlive the call.
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let driver_name = driver_props
        .driver_name_as_c_str()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let driver_info = driver_props
        .driver_info_as_c_str()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    format!("{driver_name} {driver_info}").trim().to_string()
}

fn device_info_of(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    queue_family: u32,
    props: &vk::PhysicalDeviceProperties,
) -> DeviceInfo {
    // SAFETY: queries on a physical device of this instance.
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    // SAFETY: as above.
    let memory = unsafe { instance.get_physical_device_memory_properties(pd) };
    let device_local_bytes = memory.memory_heaps[..memory.memory_heap_count as usize]
        .iter()
        .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .max()
        .unwrap_or(0);
    let v = props.api_version;
    DeviceInfo {
        index: 0,
        name: props.device_name_as_c_str().unwrap_or(c"?").to_string_lossy().into_owned(),
        device_type: device_type_name(props.device_type).into(),
        driver: driver_of(instance, pd),
        api_version: format!(
            "{}.{}.{}",
            vk::api_version_major(v),
            vk::api_version_minor(v),
            vk::api_version_patch(v)
        ),
        max_storage_buffer_range: props.limits.max_storage_buffer_range as u64,
        max_image_dimension_2d: props.limits.max_image_dimension2_d,
        timestamp_period_ns: props.limits.timestamp_period,
        timestamp_valid_bits: families[queue_family as usize].timestamp_valid_bits,
        device_local_bytes,
        vendor: VendorSupport::default(),
        shader_statistics: false,
        shader_clock: false,
    }
}

/// Whether `pd` offers the device extension `name`.
fn has_extension(instance: &ash::Instance, pd: vk::PhysicalDevice, name: &CStr) -> bool {
    // SAFETY: a plain query of a physical device of this live instance.
    let extensions =
        unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
    extensions.iter().any(|e| e.extension_name_as_c_str() == Ok(name))
}

/// Whether `pd` reports compiled pipelines' statistics (`VK_KHR_pipeline_executable_properties`).
fn has_pipeline_statistics(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    if !has_extension(instance, pd, ash::khr::pipeline_executable_properties::NAME) {
        return false;
    }
    let mut statistics = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default();
    let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut statistics);
    // SAFETY: the feature struct chained to `features` outlives the call.
    unsafe { instance.get_physical_device_features2(pd, &mut features) };
    statistics.pipeline_executable_info == vk::TRUE
}

/// Whether shaders on `pd` can read their subgroup's clock (`VK_KHR_shader_clock`).
fn has_subgroup_clock(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    if !has_extension(instance, pd, ash::khr::shader_clock::NAME) {
        return false;
    }
    let mut clock = vk::PhysicalDeviceShaderClockFeaturesKHR::default();
    let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut clock);
    // SAFETY: the feature struct chained to `features` outlives the call.
    unsafe { instance.get_physical_device_features2(pd, &mut features) };
    clock.shader_subgroup_clock == vk::TRUE
}

/// Under a file-size limit (`ulimit -f`), the system stops the process when a file grows past
/// it, and the Vulkan driver grows files of its own (lavapipe backs GPU memory with them, and
/// drivers keep a shader cache): the shell then says only "File size limit exceeded". Ignoring
/// the signal does not help (lavapipe then dies of a bus error), so the limit is named first.
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
