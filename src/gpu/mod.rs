//! The Vulkan backend: instance and device ([`context`]), memory and buffers ([`buffer`]),
//! GPU timestamps ([`timer`]), the scene's device buffers ([`scene_buffers`]), the trace
//! compute pass ([`trace_pass`]) with what its shader declares ([`shader_layout`]) and the
//! headless tracer built from them ([`tracer`]).
//! Nothing here knows about windows; the app adds the swapchain on top.

pub mod buffer;
pub mod context;
pub mod error;
pub mod scene_buffers;
pub mod shader_layout;
pub mod swapchain;
pub mod timer;
pub mod trace_pass;
pub mod tracer;

pub use context::{ContextOptions, DeviceInfo, GpuContext};
pub use error::GpuError;
pub use tracer::{GpuTracer, TraceTiming};
