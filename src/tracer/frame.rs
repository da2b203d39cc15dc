//! Per-frame parameters: resolution, bounces, blend ratio, acceleration mode, output
//! (AOV), plus the camera and light of the scene, flattened to the push-constant block
//! that `shaders/scene.glsl` declares.

use std::fmt;
use std::str::FromStr;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::contract;
use crate::scene::camera::CameraBasis;
use crate::scene::Scene;

/// How closest hits are found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Accel {
    /// The paper's method: every ray against every triangle.
    Brute,
    /// Bounding volume hierarchy per mesh, instances listed on top.
    #[default]
    Bvh,
    /// The GPU vendor's acceleration structures and traversal (Vulkan ray tracing), where
    /// the device has them; the CPU reference traces these frames with our BVH.
    Vendor,
}

impl Accel {
    /// Every mode, in the order the panel and the A key cycle through them.
    pub const ALL: [Accel; 3] = [Accel::Bvh, Accel::Brute, Accel::Vendor];
}

/// What a render writes: the shaded colour or one of the primary-hit buffers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Aov {
    /// Shaded colour (PNG).
    #[default]
    Color,
    /// Primary-hit distance, -1 on a miss.
    Depth,
    /// Primary-hit normal facing the camera, 0 on a miss.
    Normal,
    /// Index of the triangle hit (mesh file order), -1 on a miss.
    PrimId,
    /// BVH nodes visited (x) and triangles tested (y) over all rays of the pixel.
    Cost,
    /// Camera samples spent on the pixel (adaptive sampling's view).
    Samples,
}

impl Aov {
    /// The code the shader switches on (`AOV_*` of the contract).
    fn code(self) -> u32 {
        match self {
            Aov::Color => contract::AOV_COLOR,
            Aov::Depth => contract::AOV_DEPTH,
            Aov::Normal => contract::AOV_NORMAL,
            Aov::PrimId => contract::AOV_PRIM_ID,
            Aov::Cost => contract::AOV_COST,
            Aov::Samples => contract::AOV_SAMPLES,
        }
    }
}

macro_rules! name_enum {
    ($ty:ty, $what:literal, $($variant:path => $name:literal),+) => {
        impl fmt::Display for $ty {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                // `pad`, not `write_str`: `{:<5}` in a table pads the name.
                f.pad(match self { $($variant => $name),+ })
            }
        }
        impl FromStr for $ty {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                match s.to_ascii_lowercase().as_str() {
                    $($name => Ok($variant),)+
                    _ => Err(format!(concat!("unknown ", $what, " '{}' (expected one of: {})"), s, [$($name),+].join(", "))),
                }
            }
        }
    };
}
name_enum!(Accel, "acceleration", Accel::Brute => "brute", Accel::Bvh => "bvh", Accel::Vendor => "vendor");
name_enum!(Aov, "AOV", Aov::Color => "color", Aov::Depth => "depth", Aov::Normal => "normal", Aov::PrimId => "prim-id", Aov::Cost => "cost", Aov::Samples => "samples");

/// Saved as its name ("bvh", "brute"), as in `bench --json` reports.
impl Serialize for Accel {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Accel {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        String::deserialize(deserializer)?.parse().map_err(serde::de::Error::custom)
    }
}

/// Limits on the user-facing parameters (checked by the CLI and the panel).
pub(crate) const MAX_BOUNCES: u32 = 8;
/// Largest image side accepted.
pub const MAX_RESOLUTION: u32 = 8192;
/// Most camera samples per pixel in one frame.
pub(crate) const MAX_SPP: u32 = 64;

/// The user's knobs for one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Mirror bounces after the primary hit (0..=8); the paper used 2.
    pub bounces: u32,
    /// Reflection blend ratio in [0, 1]: 0 = no reflection, 1 = pure mirror.
    pub blend: f32,
    pub accel: Accel,
    pub aov: Aov,
    /// Interpolate vertex normals (smooth shading) instead of the paper's flat normals.
    pub smooth: bool,
    /// Apply `map_Kd` diffuse textures.
    pub textures: bool,
    /// Jittered camera samples per pixel (1 = the paper's ray through the pixel centre).
    pub spp: u32,
    /// Spend the `spp` samples only on pixels whose neighbours hit another triangle.
    pub adaptive: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self { width: 512, height: 512, bounces: 2, blend: 0.5, accel: Accel::Bvh, aov: Aov::Color, smooth: false, textures: true, spp: 1, adaptive: false }
    }
}

impl RenderSettings {
    /// Check every knob against its range; the error names the knob and the range.
    pub(crate) fn validate(&self) -> Result<(), String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_RESOLUTION).contains(&v) {
                return Err(format!("{name} {v} is out of range (1..={MAX_RESOLUTION})"));
            }
        }
        if self.bounces > MAX_BOUNCES {
            return Err(format!("bounces {} is out of range (0..={MAX_BOUNCES})", self.bounces));
        }
        if !(0.0..=1.0).contains(&self.blend) {
            return Err(format!("blend {} is out of range (0..=1)", self.blend));
        }
        if !(1..=MAX_SPP).contains(&self.spp) {
            return Err(format!("spp {} is out of range (1..={MAX_SPP})", self.spp));
        }
        Ok(())
    }

    /// Rays traced per frame at most: per camera sample, one primary ray and `bounces`
    /// reflected rays (adaptive sampling traces fewer).
    pub(crate) fn max_rays(&self) -> u64 {
        self.width as u64 * self.height as u64 * (self.bounces as u64 + 1) * self.spp as u64
    }
}

/// Everything one frame needs besides the scene's geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameParams {
    pub(crate) settings: RenderSettings,
    pub camera: CameraBasis,
    pub light_position: Vec3,
    pub(crate) light_color: Vec3,
    pub(crate) background: Vec3,
    pub(crate) ambient: f32,
    /// Offset of a bounce ray's origin along the normal, relative to the scene's size.
    pub(crate) ray_epsilon: f32,
    /// Instances to trace (the first `instance_count` of the packed list).
    pub instance_count: u32,
    /// Misses see the scene's environment map instead of the background colour.
    pub(crate) environment: bool,
    /// Frames already accumulated into the output (0 = start afresh).
    pub frame_index: u32,
}

/// The push-constant block of `shaders/scene.glsl` (128 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct PushConstants {
    pub cam_origin_eps: [f32; 4],
    pub cam_forward_blend: [f32; 4],
    pub cam_right_ambient: [f32; 4],
    /// w: the frame slot's first entry of the tile order (u32 bits), set by the trace pass.
    pub cam_up: [f32; 4],
    pub light_pos: [f32; 4],
    pub light_color: [f32; 4],
    pub dims: [u32; 4],
    pub misc: [u32; 4],
}

impl FrameParams {
    /// Parameters for `scene` rendered with `settings`.
    pub fn new(scene: &Scene, settings: RenderSettings) -> Self {
        Self::with_bounds(scene, settings, scene.bounds())
    }

    /// [`Self::new`] with the scene's world bounds already known (they set the ray offset).
    pub(crate) fn with_bounds(scene: &Scene, settings: RenderSettings, bounds: crate::geometry::Aabb) -> Self {
        let extent = bounds.extent().max_element();
        Self {
            settings,
            camera: scene.camera.basis(settings.width, settings.height),
            light_position: scene.light.position,
            light_color: scene.light.color,
            background: scene.background,
            ambient: scene.ambient,
            ray_epsilon: (extent * 1e-4).max(1e-6),
            instance_count: scene.instances.len() as u32,
            environment: scene.environment.is_some(),
            frame_index: 0,
        }
    }

    /// The flag word of the push constants (bits and fields from [`contract`]).
    pub(crate) fn flags(&self) -> u32 {
        let s = &self.settings;
        let mut f = s.aov.code() << contract::AOV_SHIFT | s.spp.clamp(1, contract::SPP_MASK) << contract::SPP_SHIFT;
        for (on, bit) in [
            (s.accel == Accel::Bvh, contract::FLAG_BVH),
            (s.smooth, contract::FLAG_SMOOTH),
            (s.textures, contract::FLAG_TEXTURES),
            (self.environment, contract::FLAG_ENVIRONMENT),
            (s.adaptive, contract::FLAG_ADAPTIVE),
        ] {
            if on {
                f |= bit;
            }
        }
        f
    }

    /// The background as the shader sees it (quantised to 8 bits per channel).
    pub(crate) fn background_rgba8(&self) -> u32 {
        let c = self.background.clamp(Vec3::ZERO, Vec3::ONE) * 255.0;
        (c.x.round() as u32) | (c.y.round() as u32) << 8 | (c.z.round() as u32) << 16 | 255 << 24
    }

    /// The background after that quantisation, for the CPU tracer to match the GPU exactly.
    pub(crate) fn background_quantized(&self) -> Vec3 {
        let v = self.background_rgba8();
        Vec3::new((v & 255) as f32, (v >> 8 & 255) as f32, (v >> 16 & 255) as f32) / 255.0
    }

    /// The push constants for rows starting at `first_row`.
    pub(crate) fn push_constants(&self, first_row: u32) -> PushConstants {
        let s = &self.settings;
        let c = &self.camera;
        let flags = self.flags();
        PushConstants {
            cam_origin_eps: c.origin.extend(self.ray_epsilon).to_array(),
            cam_forward_blend: c.forward.extend(s.blend).to_array(),
            cam_right_ambient: c.right.extend(self.ambient).to_array(),
            cam_up: c.up.extend(0.0).to_array(),
            light_pos: self.light_position.extend(1.0).to_array(),
            light_color: self.light_color.extend(1.0).to_array(),
            dims: [s.width, s.height, s.bounces, flags],
            misc: [self.instance_count, first_row, self.background_rgba8(), self.frame_index],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_list_choices() {
        for a in [Aov::Color, Aov::Depth, Aov::Normal, Aov::PrimId, Aov::Cost, Aov::Samples] {
            assert_eq!(a.to_string().parse::<Aov>().unwrap(), a);
        }
        assert_eq!("BVH".parse::<Accel>().unwrap(), Accel::Bvh);
        let err = "kd".parse::<Accel>().unwrap_err();
        assert!(err.contains("brute, bvh"), "{err}");
    }

    #[test]
    fn accel_is_saved_as_its_lowercase_name() {
        for (accel, json) in [(Accel::Bvh, "\"bvh\""), (Accel::Brute, "\"brute\"")] {
            assert_eq!(serde_json::to_string(&accel).unwrap(), json);
            assert_eq!(serde_json::from_str::<Accel>(json).unwrap(), accel);
        }
        assert!(serde_json::from_str::<Accel>("\"kd\"").unwrap_err().to_string().contains("brute, bvh"));
        assert_eq!(format!("[{:<5}]", Accel::Bvh), "[bvh  ]");
    }

    #[test]
    fn settings_ranges_are_enforced() {
        let ok = RenderSettings::default();
        assert!(ok.validate().is_ok());
        assert!(RenderSettings { width: 0, ..ok }.validate().unwrap_err().contains("width 0"));
        assert!(RenderSettings { height: 100_000, ..ok }.validate().is_err());
        assert!(RenderSettings { bounces: 1000, ..ok }.validate().unwrap_err().contains("0..=8"));
        assert!(RenderSettings { blend: 7.0, ..ok }.validate().is_err());
        assert!(RenderSettings { blend: f32::NAN, ..ok }.validate().is_err());
        assert!(RenderSettings { spp: 0, ..ok }.validate().unwrap_err().contains("1..=64"));
    }

    #[test]
    fn push_constants_are_128_bytes() {
        assert_eq!(std::mem::size_of::<PushConstants>(), 128);
    }
}
