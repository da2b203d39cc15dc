//! Which physical device the context runs on: the queue family it uses, the best device when
//! none is named, and what the device offers (limits, driver, the vendor's ray tracing, shader
//! statistics, the shader clock) as `DeviceInfo`.

use crate::tracer::packed::{BvhBuilder, DeviceFit};
use std::ffi::CStr;

use ash::vk;

use super::error::{GpuError, VkContext};

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
    /// Compute shaders have the subgroup operations the BVH build's collapse uses
    /// (arithmetic and ballot): without, every tree is built on the CPU.
    pub(crate) builds_bvhs: bool,
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
pub(super) fn vendor_support(
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

impl DeviceInfo {
    /// The device is a CPU (lavapipe, SwiftShader).
    pub(crate) fn is_cpu(&self) -> bool {
        self.device_type == device_type_name(vk::PhysicalDeviceType::CPU)
    }

    /// What a scene packed for this device must fit, and the trees it builds as `builder`
    /// says (`gpu::bvh_build`; none where its shaders lack the subgroup operations).
    pub(crate) fn fit(&self, builder: BvhBuilder) -> DeviceFit {
        let builder = if self.builds_bvhs { builder } else { BvhBuilder::Cpu };
        DeviceFit::new(self.max_storage_buffer_range, builder, !self.is_cpu())
    }
}

pub(super) fn device_type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

pub(super) fn pick_device(
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
pub(super) fn driver_of(instance: &ash::Instance, pd: vk::PhysicalDevice) -> String {
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

pub(super) fn device_info_of(
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
        builds_bvhs: has_build_subgroup_ops(instance, pd),
    }
}

/// Whether compute shaders on `pd` have subgroup arithmetic and ballot (Vulkan 1.1's
/// subgroup properties), which the BVH build's collapse uses.
fn has_build_subgroup_ops(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup);
    // SAFETY: `props2` and the subgroup properties chained to it outlive the call.
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let ops = vk::SubgroupFeatureFlags::BASIC
        | vk::SubgroupFeatureFlags::ARITHMETIC
        | vk::SubgroupFeatureFlags::BALLOT;
    subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
        && subgroup.supported_operations.contains(ops)
}

/// Whether `pd` offers the device extension `name`.
fn has_extension(instance: &ash::Instance, pd: vk::PhysicalDevice, name: &CStr) -> bool {
    // SAFETY: a plain query of a physical device of this live instance.
    let extensions =
        unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
    extensions.iter().any(|e| e.extension_name_as_c_str() == Ok(name))
}

/// Whether `pd` reports compiled pipelines' statistics (`VK_KHR_pipeline_executable_properties`).
pub(super) fn has_pipeline_statistics(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
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
pub(super) fn has_subgroup_clock(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    if !has_extension(instance, pd, ash::khr::shader_clock::NAME) {
        return false;
    }
    let mut clock = vk::PhysicalDeviceShaderClockFeaturesKHR::default();
    let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut clock);
    // SAFETY: the feature struct chained to `features` outlives the call.
    unsafe { instance.get_physical_device_features2(pd, &mut features) };
    clock.shader_subgroup_clock == vk::TRUE
}
