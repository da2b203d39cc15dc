//! What the image area shows besides the shaded colour, and what is drawn over it.
//!
//! - `cost`: the cost heat map; `aov`: the depth, normal, primitive-id and samples views;
//! - `overlay`: the HUD's numbers, the light's marker, the split line, notices.

pub(crate) mod aov;
pub(crate) mod cost;
pub(crate) mod overlay;
