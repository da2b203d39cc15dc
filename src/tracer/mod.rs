//! The tracing model both tracers share: what one frame is asked for ([`FrameParams`]),
//! the scene packed into flat arrays ([`PackedScene`], the GPU's buffer layout; a load's
//! [`LoadedScene`], whose triangles its upload writes), the shading maths, the traced
//! [`Image`], and the CPU reference tracer ([`cpu`]).

pub(crate) mod budget;
pub(crate) mod convex;
pub mod cpu;
pub(crate) mod enclosure;
pub mod frame;
pub(crate) mod heat_map;
pub mod image;
pub mod loaded;
pub mod packed;
pub(crate) mod prepare;
mod records;
pub(crate) mod shading;
pub mod textures;
pub mod top_level;

pub use frame::FrameParams;
pub use image::Image;
pub use loaded::LoadedScene;
pub use packed::PackedScene;
pub use prepare::{DEVICE_BUILD_FROM, DEVICE_LEAF_SIZES};
