//! The driver's acceleration structures over a packed scene (`VK_KHR_acceleration_structure`):
//! one compacted bottom level per mesh (the model, the mirror box), built from the same
//! triangles in the same order as `triangles[]`, and a top level with an instance per model
//! copy and mirror plane. A new instance list (model count) rebuilds only the top level; a
//! new scene (another model) rebuilds both. The light moving rebuilds nothing.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use crate::gpu::barrier::{self, Access};
use crate::gpu::buffer::GpuBuffer;
use crate::gpu::context::GpuContext;
use crate::gpu::error::{GpuError, VkContext};
use crate::tracer::packed::{GpuInstance, GpuTriangle};

/// What the last change built, for the panel and `bench --compare`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AccelStats {
    /// Bottom levels built by the last scene change (one per mesh), and their wall time.
    pub bottom_count: u32,
    pub bottom_ms: f64,
    /// Wall time of the last top-level build.
    pub top_ms: f64,
    /// Device bytes of all structures (compacted bottom levels and the top level) and of
    /// the slot map (where a mesh is cut).
    pub bytes: u64,
    /// Triangles given to the bottom levels: each once, however many slots it fills.
    pub primitives: u64,
    /// What the last change rebuilt, in words ("bottom and top levels", "top level").
    pub rebuilt: &'static str,
}

/// One acceleration structure and the buffer it lives in.
struct Structure {
    loader: ash::khr::acceleration_structure::Device,
    handle: vk::AccelerationStructureKHR,
    buffer: GpuBuffer,
    address: vk::DeviceAddress,
}

impl Structure {
    /// An empty structure of `kind` and `size` bytes.
    fn new(
        ctx: &Arc<GpuContext>,
        loader: &ash::khr::acceleration_structure::Device,
        kind: vk::AccelerationStructureTypeKHR,
        size: u64,
        name: &'static str,
    ) -> Result<Self, GpuError> {
        let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let buffer = GpuBuffer::new(ctx, size, usage, MemoryLocation::GpuOnly, name)?;
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(buffer.buffer)
            .size(size)
            .ty(kind);
        // SAFETY: the buffer is live, has the storage usage and is at least `size` bytes.
        let handle = unsafe { loader.create_acceleration_structure(&info, None) }
            .during("creating an acceleration structure")?;
        // SAFETY: the structure was just created on this device.
        let address = unsafe {
            loader.get_acceleration_structure_device_address(
                &vk::AccelerationStructureDeviceAddressInfoKHR::default()
                    .acceleration_structure(handle),
            )
        };
        Ok(Self { loader: loader.clone(), handle, buffer, address })
    }
}

impl Drop for Structure {
    fn drop(&mut self) {
        // SAFETY: owners wait for the GPU before dropping structures (see `VendorScene`).
        unsafe { self.loader.destroy_acceleration_structure(self.handle, None) };
    }
}

/// `VkAccelerationStructureInstanceKHR` as plain bytes (64).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct InstanceRecord {
    /// Row-major 3x4 object-to-world matrix.
    transform: [f32; 12],
    /// Custom index (low 24 bits: our instance index) and mask (high 8).
    custom_index_and_mask: u32,
    /// Hit group offset (low 24 bits) and instance flags (high 8).
    sbt_offset_and_flags: u32,
    /// Device address of the bottom level.
    bottom: u64,
}

/// The scene's structures on one device.
pub(crate) struct VendorScene {
    ctx: Arc<GpuContext>,
    loader: ash::khr::acceleration_structure::Device,
    scratch_alignment: u64,
    /// Bottom levels by the mesh's first triangle in `triangles[]` (what instances name).
    bottoms: HashMap<u32, Structure>,
    top: Option<Structure>,
    /// Which of our slots each vendor primitive is (`vendor_slots` in `tlas.glsl`): word 0
    /// is 1 where some mesh has cut triangles, and then word `1 + base + k` is the slot
    /// (relative to the mesh's first, `base`) of its bottom level's primitive `k`; 0 and
    /// nothing more where no mesh does (primitive k is slot k).
    slots: GpuBuffer,
    /// What was built last.
    pub stats: AccelStats,
}

impl VendorScene {
    /// Bottom levels for every mesh (first triangle, count) of the triangles in `triangles`
    /// (the scene's device buffer, read back: the tracer keeps no host copy), and the top
    /// level over `instances`.
    pub(crate) fn build(
        ctx: &Arc<GpuContext>,
        triangles: &GpuBuffer,
        meshes: &[(u32, u32)],
        instances: &[GpuInstance],
    ) -> Result<Self, GpuError> {
        let loader = ash::khr::acceleration_structure::Device::new(&ctx.instance, &ctx.device);
        let mut properties = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut properties);
        // SAFETY: `props2` and the struct chained to it outlive the call.
        unsafe { ctx.instance.get_physical_device_properties2(ctx.physical_device, &mut props2) };
        let scratch_alignment =
            (properties.min_acceleration_structure_scratch_offset_alignment as u64).max(1);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let slots = GpuBuffer::device_local_with(
            ctx,
            bytemuck::cast_slice(&[0u32]),
            storage,
            "vendor slots",
        )?;
        let mut scene = Self {
            ctx: ctx.clone(),
            loader,
            scratch_alignment,
            bottoms: HashMap::new(),
            top: None,
            slots,
            stats: AccelStats::default(),
        };
        let start = Instant::now();
        let size = std::mem::size_of::<GpuTriangle>() as u64;
        let total = meshes.iter().map(|&(base, count)| base + count).max().unwrap_or(0);
        let mut slot_map = vec![0u32; 1 + total as usize];
        for &(base, count) in meshes {
            if count == 0 || scene.bottoms.contains_key(&base) {
                continue;
            }
            let bytes = triangles.download_range(base as u64 * size, count as u64 * size)?;
            let (bottom, firsts) = scene.build_bottom(bytemuck::cast_slice(&bytes))?;
            if firsts.len() < count as usize {
                slot_map[0] = 1;
            }
            slot_map[1 + base as usize..][..firsts.len()].copy_from_slice(&firsts);
            scene.stats.primitives += firsts.len() as u64;
            scene.bottoms.insert(base, bottom);
        }
        if slot_map[0] != 0 {
            scene.slots = GpuBuffer::device_local_with(
                ctx,
                bytemuck::cast_slice(&slot_map),
                storage,
                "vendor slots",
            )?;
        }
        scene.stats.bottom_count = scene.bottoms.len() as u32;
        scene.stats.bottom_ms = start.elapsed().as_secs_f64() * 1e3;
        scene.set_instances(instances)?;
        scene.stats.rebuilt = "bottom and top levels";
        Ok(scene)
    }

    /// The top level, for the descriptor sets.
    pub(crate) fn top(&self) -> Option<vk::AccelerationStructureKHR> {
        self.top.as_ref().map(|t| t.handle)
    }

    /// The slot map the vendor's shaders read a hit's triangle through, for the descriptor sets.
    pub(crate) fn slots(&self) -> vk::Buffer {
        self.slots.buffer
    }

    /// Rebuild the top level over `instances` (the bottom levels stay).
    pub(crate) fn set_instances(&mut self, instances: &[GpuInstance]) -> Result<(), GpuError> {
        let start = Instant::now();
        self.top = None;
        let records: Vec<InstanceRecord> = instances
            .iter()
            .enumerate()
            .filter_map(|(i, inst)| {
                let bottom = self.bottoms.get(&inst.triangle_base)?;
                Some(InstanceRecord {
                    transform: inst.world_rows(),
                    custom_index_and_mask: (i as u32 & 0x00ff_ffff) | (0xff << 24),
                    // Both faces are hit, as in our tracer.
                    sbt_offset_and_flags:
                        (vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE.as_raw() & 0xff)
                            << 24,
                    bottom: bottom.address,
                })
            })
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&records);
        let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let mut instance_buffer = GpuBuffer::new(
            &self.ctx,
            bytes.len() as u64,
            usage,
            MemoryLocation::CpuToGpu,
            "vendor instances",
        )?;
        instance_buffer.mapped().expect("instance memory is mapped")[..bytes.len()]
            .copy_from_slice(bytes);
        let data = vk::AccelerationStructureGeometryInstancesDataKHR::default()
            .array_of_pointers(false)
            .data(vk::DeviceOrHostAddressConstKHR {
                device_address: instance_buffer.device_address(),
            });
        let geometry = vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::INSTANCES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { instances: data });
        let top = self.build_structure(
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            geometry,
            records.len() as u32,
            false,
            "vendor top level",
        )?;
        drop(instance_buffer);
        self.top = Some(top);
        self.stats.top_ms = start.elapsed().as_secs_f64() * 1e3;
        self.stats.rebuilt = "top level";
        // The slot map is the vendor path's too (4 bytes a slot, where a mesh is cut).
        self.stats.bytes =
            self.bottoms.values().chain(self.top.as_ref()).map(|s| s.buffer.size).sum::<u64>()
                + self.slots.size;
        Ok(())
    }

    /// A compacted bottom level over `triangles` (a mesh's slots), each triangle once: a
    /// triangle our build cut into pieces fills several slots, and the vendor gets its
    /// first. Returns the structure and, for each of its primitives, the slot it is
    /// (relative to the first). Before, the later slots were given as points (three equal
    /// corners), so that primitive k was slot k; the driver kept them (Sponza, H100: 23.0
    /// MB over 307,851 slots, 18 MB over its 236,809 triangles), as it did NaN-inactive
    /// triangles, which Mesa 25's lavapipe also traced into wrong images.
    fn build_bottom(&self, triangles: &[GpuTriangle]) -> Result<(Structure, Vec<u32>), GpuError> {
        let mut seen =
            vec![false; triangles.iter().map(|t| t.prim as usize + 1).max().unwrap_or(0)];
        let firsts: Vec<u32> = (0..triangles.len() as u32)
            .filter(|&k| !std::mem::replace(&mut seen[triangles[k as usize].prim as usize], true))
            .collect();
        // Corners from the packed (v0, e1, e2): the triangles our tracer tests, to rounding.
        let vertices: Vec<[f32; 3]> = firsts
            .iter()
            .flat_map(|&k| {
                let [v0, e1, e2] = triangles[k as usize].edges();
                [v0, v0 + e1, v0 + e2].map(|v| v.to_array())
            })
            .collect();
        let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let vertex_buffer = GpuBuffer::device_local_with(
            &self.ctx,
            bytemuck::cast_slice(&vertices),
            usage,
            "vendor vertices",
        )?;
        let data = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR {
                device_address: vertex_buffer.device_address(),
            })
            .vertex_stride(12)
            .max_vertex(vertices.len() as u32 - 1)
            .index_type(vk::IndexType::NONE_KHR);
        let geometry = vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles: data })
            .flags(vk::GeometryFlagsKHR::OPAQUE);
        let structure = self.build_structure(
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            geometry,
            firsts.len() as u32,
            true,
            "vendor bottom level",
        )?;
        Ok((structure, firsts))
    }

    /// Build one structure of `kind` over `count` primitives of `geometry`, for fast
    /// tracing; `compact` copies it into a structure of its compacted size.
    fn build_structure(
        &self,
        kind: vk::AccelerationStructureTypeKHR,
        geometry: vk::AccelerationStructureGeometryKHR,
        count: u32,
        compact: bool,
        name: &'static str,
    ) -> Result<Structure, GpuError> {
        let geometries = [geometry];
        let mut flags = vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE;
        if compact {
            flags |= vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION;
        }
        let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(kind)
            .flags(flags)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&geometries);
        let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
        // SAFETY: `info` points at live geometry descriptions; `sizes` is written.
        unsafe {
            self.loader.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                &[count],
                &mut sizes,
            )
        };
        let structure =
            Structure::new(&self.ctx, &self.loader, kind, sizes.acceleration_structure_size, name)?;
        let scratch_usage =
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let scratch = GpuBuffer::new(
            &self.ctx,
            sizes.build_scratch_size + self.scratch_alignment,
            scratch_usage,
            MemoryLocation::GpuOnly,
            "vendor build scratch",
        )?;
        let scratch_address = scratch.device_address().next_multiple_of(self.scratch_alignment);
        info = info
            .dst_acceleration_structure(structure.handle)
            .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch_address });
        let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
        let query_pool = if compact {
            let create = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR)
                .query_count(1);
            // SAFETY: plain object creation on the live device; destroyed below.
            Some(
                unsafe { self.ctx.device.create_query_pool(&create, None) }
                    .during("creating a query pool")?,
            )
        } else {
            None
        };
        let device = &self.ctx.device;
        // SAFETY: every buffer, structure and query pool named in the commands lives until
        // one_shot has waited for them.
        let built = self.ctx.one_shot(|cmd| unsafe {
            // Inputs uploaded or written before this submission, read by the build.
            barrier::buffers(
                device,
                cmd,
                &[Access::TransferWrite, Access::HostWrite],
                &[Access::AccelBuildInput, Access::AccelBuildRead],
            );
            self.loader.cmd_build_acceleration_structures(cmd, &[info], &[&ranges]);
            if let Some(pool) = query_pool {
                barrier::buffers(
                    device,
                    cmd,
                    &[Access::AccelBuildWrite],
                    &[Access::AccelBuildRead],
                );
                device.cmd_reset_query_pool(cmd, pool, 0, 1);
                self.loader.cmd_write_acceleration_structures_properties(
                    cmd,
                    &[structure.handle],
                    vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                    pool,
                    0,
                );
            }
            built_for_tracing(&self.ctx, cmd);
        });
        let result = built.and_then(|_| match query_pool {
            Some(pool) => self.compacted(structure, kind, pool, name),
            None => Ok(structure),
        });
        if let Some(pool) = query_pool {
            // SAFETY: the submission that used the pool was waited for.
            unsafe { self.ctx.device.destroy_query_pool(pool, None) };
        }
        result
    }

    /// `built` copied into a structure of the compacted size its query reported.
    fn compacted(
        &self,
        built: Structure,
        kind: vk::AccelerationStructureTypeKHR,
        pool: vk::QueryPool,
        name: &'static str,
    ) -> Result<Structure, GpuError> {
        let mut size = [0u64];
        // SAFETY: the query was written by a submission that has completed.
        unsafe {
            self.ctx.device.get_query_pool_results(
                pool,
                0,
                &mut size,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .during("reading an acceleration structure's compacted size")?;
        if size[0] == 0 || size[0] >= built.buffer.size {
            return Ok(built);
        }
        let compact = Structure::new(&self.ctx, &self.loader, kind, size[0], name)?;
        let copy = vk::CopyAccelerationStructureInfoKHR::default()
            .src(built.handle)
            .dst(compact.handle)
            .mode(vk::CopyAccelerationStructureModeKHR::COMPACT);
        // SAFETY: both structures live until one_shot has waited.
        self.ctx.one_shot(|cmd| unsafe {
            self.loader.cmd_copy_acceleration_structure(cmd, &copy);
            built_for_tracing(&self.ctx, cmd);
        })?;
        Ok(compact)
    }
}

/// After a build or copy: the structure is read by the traces submitted later (ray queries
/// from compute shaders, or the ray tracing pipeline) and by later builds (the top level
/// refers to the bottom ones). `cmd` is recording on `ctx`'s device.
fn built_for_tracing(ctx: &GpuContext, cmd: vk::CommandBuffer) {
    let mut after = vec![Access::AccelBuildRead];
    after.extend(super::structure_reads(&ctx.info.vendor));
    barrier::buffers(&ctx.device, cmd, &[Access::AccelBuildWrite], &after);
}
