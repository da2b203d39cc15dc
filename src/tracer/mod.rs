//! The tracing model both tracers share: what one frame is asked for ([`FrameParams`]),
//! the scene packed into flat arrays ([`PackedScene`], the GPU's buffer layout), the
//! shading maths, the traced [`Image`], and the CPU reference tracer ([`cpu`]).

pub(crate) mod budget;
// Transitional: the contract moved to the crate root; old paths still name it here.
pub(crate) use crate::contract;
pub mod cpu;
pub mod frame;
pub(crate) mod heat_map;
pub mod image;
pub mod packed;
pub(crate) mod prepare;
pub(crate) mod shading;
pub mod textures;

pub use frame::{Accel, Aov, FrameParams, RenderSettings};
pub use image::Image;
pub use packed::PackedScene;
