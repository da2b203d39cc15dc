//! meshtracer: a Vulkan compute-shader ray tracer for triangle meshes.
//!
//! - [`scene`]: meshes (OBJ loader, the paper's generators), the paper's mirror-box scene.
//! - [`bvh`]: the acceleration structure, built on the CPU, traversed on both tracers.
//! - [`tracer`]: the tracing model shared by both tracers: parameters, the packed GPU scene
//!   layout, and the CPU reference tracer that the tests use as their oracle.
//! - [`gpu`]: the Vulkan backend (instance/device, memory, buffers, timestamps) and the
//!   trace pass that runs `shaders/trace.comp`.
//! - [`app`]: the interactive egui tool on top; [`cli`]: the thin command line.

pub mod app;
pub(crate) mod bench;
pub mod bvh;
pub mod cli;
/// The constants the host and the shaders share (flag bits, AOV codes, `EMPTY`): the one
/// source of truth, which build.rs also writes out as the shaders' `contract.glsl`.
pub mod contract;
pub mod files;
pub mod geometry;
pub mod gpu;
pub mod memory;
pub mod progress;
pub mod render_settings;
pub mod scene;
pub mod tracer;
