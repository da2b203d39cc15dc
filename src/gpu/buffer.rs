//! Buffers with memory from gpu-allocator, and the paper's upload path (3.2): host data ->
//! host-visible staging buffer -> device-local storage buffer through a recorded copy.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use rayon::prelude::*;

use super::barrier::{self, Access};
use super::context::GpuContext;
use super::error::{GpuError, VkContext};

/// Largest staging buffer an upload uses; bigger uploads go through it in pieces.
const UPLOAD_CHUNK: usize = 64 << 20;

/// A Vulkan buffer and its memory; freed on drop.
pub struct GpuBuffer {
    ctx: Arc<GpuContext>,
    pub(crate) buffer: vk::Buffer,
    allocation: Option<Allocation>,
    /// Size in bytes (at least 16: Vulkan has no empty buffers).
    pub(crate) size: u64,
    /// What the buffer is, for messages and `bench --verbose`.
    pub(crate) name: &'static str,
}

/// The least alignment of every buffer's memory (see [`GpuBuffer::new`]).
const BUFFER_ALIGNMENT: u64 = 256;

impl GpuBuffer {
    /// Create a buffer of `size` bytes in `location`.
    pub fn new(
        ctx: &Arc<GpuContext>,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
        name: &'static str,
    ) -> Result<Self, GpuError> {
        let size = size.max(16);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let device = &ctx.device;
        // SAFETY: plain object creation on a live device; destroyed in Drop or below.
        let buffer = unsafe { device.create_buffer(&info, None) }.during("creating a buffer")?;
        // SAFETY: `buffer` was just created on this device.
        let mut requirements = unsafe { device.get_buffer_memory_requirements(buffer) };
        // Drivers ask for as little as 16-byte alignment, so a buffer of 64-byte BVH nodes could
        // start mid-sector and every node fetch touch one 32-byte sector more: on the H200 that
        // made the 1M knot in the mirror box 15% slower, depending only on what was allocated
        // before it. Every buffer starts on a 256-byte boundary.
        requirements.alignment = requirements.alignment.max(BUFFER_ALIGNMENT);
        let allocation = ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: the buffer was never used.
                unsafe { device.destroy_buffer(buffer, None) };
                return Err(GpuError::Allocation { what: name, source });
            }
        };
        // SAFETY: the allocation satisfies the buffer's requirements and is bound once.
        if let Err(r) =
            unsafe { device.bind_buffer_memory(buffer, allocation.memory(), allocation.offset()) }
        {
            // Free both, as GpuImage does: nothing else owns them yet.
            let _ = ctx.allocator().free(allocation);
            // SAFETY: the buffer was never used.
            unsafe { device.destroy_buffer(buffer, None) };
            return Err(GpuError::vk("binding buffer memory", r));
        }
        Ok(Self { ctx: ctx.clone(), buffer, allocation: Some(allocation), size, name })
    }

    /// Where the memory lives, for `bench --verbose`: name, size, memory flags, dedicated
    /// or sub-allocated, offset in its memory object.
    pub(crate) fn describe(&self) -> String {
        match &self.allocation {
            Some(a) => format!(
                "{}: {:.1} MB, {:?}, {}, offset {}",
                self.name,
                self.size as f64 / 1e6,
                a.memory_properties(),
                if a.is_dedicated() { "dedicated" } else { "sub-allocated" },
                a.offset()
            ),
            None => format!("{}: no memory", self.name),
        }
    }

    /// The buffer's address on the device (created with `SHADER_DEVICE_ADDRESS` usage, on a
    /// context with buffer device addresses: the vendor path).
    pub(crate) fn device_address(&self) -> vk::DeviceAddress {
        // SAFETY: the buffer is live and, by the caller's contract, has the usage.
        unsafe {
            self.ctx.device.get_buffer_device_address(
                &vk::BufferDeviceAddressInfo::default().buffer(self.buffer),
            )
        }
    }

    /// The mapped bytes of a host-visible buffer.
    pub(crate) fn mapped(&mut self) -> Option<&mut [u8]> {
        let size = self.size as usize;
        self.allocation.as_mut().and_then(|a| a.mapped_slice_mut()).map(|s| &mut s[..size])
    }

    /// A device-local storage buffer filled with `data` through a staging copy (paper 3.2).
    pub(crate) fn device_local_with(
        ctx: &Arc<GpuContext>,
        data: &[u8],
        usage: vk::BufferUsageFlags,
        name: &'static str,
    ) -> Result<Self, GpuError> {
        Self::device_local_with_parts(ctx, &[data], usage, name)
    }

    /// A device-local storage buffer holding `parts` back to back, each copied from where it
    /// lies (no joined copy on the host).
    pub(crate) fn device_local_with_parts(
        ctx: &Arc<GpuContext>,
        parts: &[&[u8]],
        usage: vk::BufferUsageFlags,
        name: &'static str,
    ) -> Result<Self, GpuError> {
        let mut offset = 0;
        let mut pieces = Vec::with_capacity(parts.len());
        for part in parts {
            pieces.push((offset, *part));
            offset += part.len();
        }
        Self::device_local_with_pieces(ctx, offset, &pieces, usage, name)
    }

    /// A device-local storage buffer of `size` bytes with each of `pieces` (offset, bytes)
    /// copied to its offset; the bytes between them are left as they are (for the device
    /// to write).
    pub(crate) fn device_local_with_pieces(
        ctx: &Arc<GpuContext>,
        size: usize,
        pieces: &[(usize, &[u8])],
        usage: vk::BufferUsageFlags,
        name: &'static str,
    ) -> Result<Self, GpuError> {
        let dst = GpuBuffer::new(
            ctx,
            size as u64,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
            name,
        )?;
        for &(offset, piece) in pieces {
            dst.upload_in_pieces(piece, offset, UPLOAD_CHUNK)?;
        }
        Ok(dst)
    }

    /// Overwrite the start of this (device-local) buffer with `data` through staging copies.
    pub(crate) fn upload(&self, data: &[u8]) -> Result<(), GpuError> {
        self.upload_in_pieces(data, 0, UPLOAD_CHUNK)
    }

    /// [`Self::upload`] through two staging buffers of at most `chunk` bytes, refilled in
    /// turn: a 10M-triangle scene then needs 128 MB of staging memory beside it instead of a
    /// copy of its largest buffer.
    /// `offset`: where in this buffer `data` goes.
    fn upload_in_pieces(&self, data: &[u8], offset: usize, chunk: usize) -> Result<(), GpuError> {
        self.upload_staged(offset, data.len(), chunk, |at, to| {
            // On every core: one thread filled a 10M-triangle scene's 1.5 GB at a third of
            // the rate the copies to the device ran.
            let from = &data[at..at + to.len()];
            to.par_chunks_mut(1 << 20)
                .zip(from.par_chunks(1 << 20))
                .for_each(|(to, from)| to.copy_from_slice(from));
        })
    }

    /// A device-local buffer of `count` items, item `i` being `make(i)`, made on every core
    /// straight into the staging memory: nothing of it is held on the host. `padding` bytes
    /// follow the items, zeroed.
    pub(crate) fn device_local_made<T: bytemuck::Pod + Send>(
        ctx: &Arc<GpuContext>,
        count: usize,
        padding: usize,
        usage: vk::BufferUsageFlags,
        name: &'static str,
        make: impl Fn(usize) -> T + Sync,
    ) -> Result<Self, GpuError> {
        let item = std::mem::size_of::<T>();
        let dst = GpuBuffer::new(
            ctx,
            (count * item + padding) as u64,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
            name,
        )?;
        dst.upload_staged(count * item, padding, padding, |_, to| to.fill(0))?;
        // Whole items in each piece.
        let chunk = (UPLOAD_CHUNK / item).max(1) * item;
        dst.upload_staged(0, count * item, chunk, |at, to| {
            let items: &mut [T] = bytemuck::cast_slice_mut(to);
            items.par_iter_mut().enumerate().for_each(|(i, out)| *out = make(at / item + i));
        })?;
        Ok(dst)
    }

    /// Write `len` bytes at `offset` of this (device-local) buffer through two staging
    /// buffers of at most `chunk` bytes, one filled while the other is copied:
    /// `fill(at, piece)` writes bytes `at..at + piece.len()` of the data into the mapped
    /// staging memory.
    fn upload_staged(
        &self,
        offset: usize,
        len: usize,
        chunk: usize,
        fill: impl Fn(usize, &mut [u8]) + Sync,
    ) -> Result<(), GpuError> {
        if len == 0 {
            return Ok(());
        }
        assert!((offset + len) as u64 <= self.size, "upload larger than the buffer");
        let chunk = chunk.clamp(1, len);
        let staging = || {
            GpuBuffer::new(
                &self.ctx,
                chunk as u64,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
                "staging",
            )
        };
        // Two staging buffers: the next piece is filled on another thread while the GPU
        // copies this one.
        let pieces: Vec<usize> = (0..len).step_by(chunk).collect();
        let mut stagings =
            if pieces.len() > 1 { vec![staging()?, staging()?] } else { vec![staging()?] };
        let piece_len = |at: usize| chunk.min(len - at);
        fill(0, &mut stagings[0].mapped().expect("staging memory is mapped")[..piece_len(0)]);
        for (i, &at) in pieces.iter().enumerate() {
            let (first, second) = stagings.split_at_mut(1);
            let (current, next) = if i % 2 == 0 {
                (&first[0], second.first_mut())
            } else {
                (&second[0], Some(&mut first[0]))
            };
            let upcoming = pieces.get(i + 1).copied().zip(next);
            std::thread::scope(|s| {
                if let Some((next_at, next)) = upcoming {
                    let fill = &fill;
                    s.spawn(move || {
                        let to = next.mapped().expect("staging memory is mapped");
                        fill(next_at, &mut to[..piece_len(next_at)]);
                    });
                }
                self.copy_from(current, offset + at, piece_len(at))
            })?;
        }
        Ok(())
    }

    /// Copy the first `len` bytes of `staging` to `offset` in this buffer, waiting for it.
    fn copy_from(&self, staging: &GpuBuffer, offset: usize, len: usize) -> Result<(), GpuError> {
        let device = &self.ctx.device;
        self.ctx.one_shot(|cmd| {
            let region =
                [vk::BufferCopy { src_offset: 0, dst_offset: offset as u64, size: len as u64 }];
            // SAFETY: `cmd` is recording; both buffers are alive until one_shot has waited.
            unsafe { device.cmd_copy_buffer(cmd, staging.buffer, self.buffer, &region) };
            // Make the copy visible to the compute shader that reads the buffer next.
            barrier::buffers(device, cmd, &[Access::TransferWrite], &[Access::ComputeRead]);
        })
    }

    /// Read `len` bytes back from this (device-local) buffer through a staging copy.
    pub(crate) fn download(&self, len: u64) -> Result<Vec<u8>, GpuError> {
        self.download_range(0, len)
    }

    /// Read `len` bytes from `offset` on back from this (device-local) buffer.
    pub(crate) fn download_range(&self, offset: u64, len: u64) -> Result<Vec<u8>, GpuError> {
        let mut staging = GpuBuffer::new(
            &self.ctx,
            len,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            "readback",
        )?;
        let device = &self.ctx.device;
        self.ctx.one_shot(|cmd| {
            barrier::buffers(device, cmd, &[Access::ComputeWrite], &[Access::TransferRead]);
            // SAFETY: as in `upload`.
            unsafe {
                device.cmd_copy_buffer(
                    cmd,
                    self.buffer,
                    staging.buffer,
                    &[vk::BufferCopy { src_offset: offset, dst_offset: 0, size: len }],
                )
            };
            barrier::buffers(device, cmd, &[Access::TransferWrite], &[Access::HostRead]);
        })?;
        Ok(staging.mapped().expect("readback memory is mapped")[..len as usize].to_vec())
    }
}

impl Drop for GpuBuffer {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator().free(a);
        }
        // SAFETY: owners drop buffers only after the GPU finished with them (they wait
        // on a fence or for idle first).
        unsafe { self.ctx.device.destroy_buffer(self.buffer, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::ContextOptions;

    #[test]
    fn an_upload_in_pieces_arrives_whole() {
        let ctx = GpuContext::new(&ContextOptions::validated())
            .expect("Vulkan with the validation layer");
        let data: Vec<u8> = (0..10_000u32).map(|i| (i * 7 + i / 256) as u8).collect();
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST;
        let buffer =
            GpuBuffer::new(&ctx, data.len() as u64, usage, MemoryLocation::GpuOnly, "pieces")
                .unwrap();
        // 3,000-byte pieces: three whole ones and a short last one.
        buffer.upload_in_pieces(&data, 0, 3000).unwrap();
        assert_eq!(buffer.download(data.len() as u64).unwrap(), data);
        drop(buffer);
        // Parts back to back, each in pieces of its own.
        let (a, b) = data.split_at(4321);
        let joined = GpuBuffer::device_local_with_parts(&ctx, &[a, b], usage, "parts").unwrap();
        assert_eq!(joined.download(data.len() as u64).unwrap(), data);
        drop(joined);
        let messages = ctx.validation_messages();
        assert!(messages.is_empty(), "validation: {messages:?}");
    }
}
