//! What a measurement traced, written the same way by `bench`'s rows ([`super::Row`]) and
//! the window's benchmark summary: one header, flattened into both, so their JSON (and
//! `bench`'s CSV) keep the field names and order they always had.

use serde::{Deserialize, Serialize};

use crate::render_settings::{Accel, BvhLayout};

/// The model, its copies and triangles, the resolution, the bounces and the acceleration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorkloadHeader {
    /// The model's label (a generated mesh's name).
    pub model: String,
    /// Copies of the model traced.
    pub models: u32,
    /// Triangles traced, all copies together.
    pub triangles: u64,
    pub width: u32,
    pub height: u32,
    pub bounces: u32,
    /// Saved as "bvh" or "brute".
    pub accel: Accel,
    /// The BVH layout of a "bvh" row; saved only when wide and binary when absent, so
    /// reports written before wide became the default read the same.
    #[serde(default = "BvhLayout::binary", skip_serializing_if = "BvhLayout::is_binary")]
    pub bvh: BvhLayout,
}

impl WorkloadHeader {
    /// The acceleration as tables print it: "wide" for our wide BVH, else the accel's name.
    pub fn accel_label(&self) -> String {
        crate::render_settings::tracer_label(self.accel, self.bvh)
    }
}
