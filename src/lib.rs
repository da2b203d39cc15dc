//! meshtracer: a Vulkan compute-shader ray tracer for triangle meshes. The modules from the
//! bottom up (a module imports only those before it; ARCHITECTURE.md is the map):
//!
//! - [`contract`], [`geometry`], [`memory`]: the constants the shaders share, rays and
//!   triangles, host memory requests;
//! - [`render_settings`]: what a frame is asked for, its defaults and every range a user
//!   gives; [`files`]: the one place a file is read or written; [`progress`]: a load's phases;
//! - [`bvh`]: the binary and the compressed wide BVH, built on the CPU, traversed by both
//!   tracers;
//! - [`scene`]: meshes (OBJ, PLY and glTF loaders, the paper's generators), the paper's
//!   mirror-box scene, the camera, the scene spec and presets;
//! - [`tracer`]: the tracing model shared by both tracers: parameters, the packed GPU scene
//!   layout, and the CPU reference tracer that the tests use as their oracle;
//! - [`gpu`]: the Vulkan backend and the compute tracer, the driver's ray tracing beside it,
//!   and presentation;
//! - `bench`: benchmarks and their reports; [`app`]: the interactive egui tool; [`cli`]: the
//!   command line.

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
