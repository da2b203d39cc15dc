//! The Vulkan backend: instance and device (`context`; which device and what it offers:
//! `physical_device`) with the validation layer's messages
//! (`validation`) and the one way a lock is taken (`lock`), memory and buffers ([`buffer`]),
//! named pipeline barriers (`barrier`), the objects a pass is made of (`pipeline`: set
//! layouts, pools, pipeline layouts, compute pipelines), GPU timestamps (`timer`), the
//! shader clock rate (`clock_probe`), the scene's device buffers ([`scene_buffers`]), the
//! shapes a trace is dispatched in (`dispatch`: work group, band, split frame), the trace
//! compute pass (`trace_pass`) with what its shader declares (`shader_layout`) and the
//! order it takes the frame's tiles in (`tile_order`), the compute tracer
//! built from them (`compute_tracer`), and presentation to a window (`present`: surface,
//! swapchain, composite, egui pass), and the vendor's ray tracing beside ours through the
//! driver's Vulkan KHR ray tracing (`khr_rt`: the driver's acceleration structures, ray
//! queries, a ray tracing pipeline). Nothing outside this folder calls Vulkan.

pub(crate) mod barrier;
pub mod buffer;
pub(crate) mod bvh_build;
pub(crate) mod clock_probe;
pub(crate) mod compute_tracer;
pub(crate) mod context;
pub(crate) mod dispatch;
pub mod error;
pub mod headless;
pub(crate) mod image;
pub mod khr_rt;
pub(crate) mod lock;
pub(crate) mod physical_device;
pub(crate) mod pipeline;
pub(crate) mod present;
pub mod scene_buffers;
pub(crate) mod shader_compile;
pub(crate) mod shader_layout;
pub(crate) mod tile_order;
pub(crate) mod timer;
pub(crate) mod trace_kernels;
pub(crate) mod trace_pass;
pub(crate) mod validation;

pub(crate) use clock_probe::ClockProbe;
pub(crate) use compute_tracer::PartTimes;
pub use compute_tracer::{ComputeTracer, TraceTiming};
pub use context::{ContextOptions, DeviceInfo, GpuContext, VendorSupport};
pub(crate) use dispatch::Band;
pub use dispatch::{FrameTrace, GroupSize, SplitTrace, GROUP};
pub use error::GpuError;
