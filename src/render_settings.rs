//! What the user sets for a frame ([`RenderSettings`]: resolution, bounces, blend ratio,
//! acceleration, output, shading features) and the accepted [`Range`] of every number a
//! user gives, checked here once for the command line, presets, the panel and the tracers.
//!
//! A leaf of the crate: it imports nothing of ours but the CPU/GPU [`contract`].

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::contract;

/// An accepted range of a number the user gives, written as every error message shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Lowest value.
    pub lo: f64,
    /// Highest value.
    pub hi: f64,
    /// Both ends excluded (`1..179`) instead of included (`0..=1`).
    pub open: bool,
    /// Appended to the range in messages (" degrees").
    pub unit: &'static str,
}

impl Range {
    /// `lo..=hi`.
    pub const fn closed(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self { lo, hi, open: false, unit }
    }

    /// `lo..hi`, both ends excluded.
    pub const fn open(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self { lo, hi, open: true, unit }
    }

    /// Whether `v` is inside (NaN never is).
    pub fn contains(&self, v: f64) -> bool {
        if self.open {
            v > self.lo && v < self.hi
        } else {
            v >= self.lo && v <= self.hi
        }
    }

    /// A flag's text as a number inside the range: "'x' is not a number", or [`Self::check`]'s
    /// message (NaN and infinities are in no range).
    pub fn parse_f32(&self, s: &str) -> Result<f32, String> {
        let v: f32 = s.trim().parse().map_err(|_| format!("'{s}' is not a number"))?;
        self.check(v as f64, s).map(|()| v)
    }

    /// The whole numbers of a closed range, for sliders, clamps and the flags' parsers.
    pub fn u32s(&self) -> std::ops::RangeInclusive<u32> {
        self.lo as u32..=self.hi as u32
    }

    /// [`Self::u32s`] as clap's integer parsers take it.
    pub fn i64s(&self) -> std::ops::RangeInclusive<i64> {
        self.lo as i64..=self.hi as i64
    }

    /// A closed range's ends as `f32`s, for sliders.
    pub fn f32s(&self) -> std::ops::RangeInclusive<f32> {
        self.lo as f32..=self.hi as f32
    }

    /// `v` moved to the nearest whole number of a closed range.
    pub fn clamp_u32(&self, v: u32) -> u32 {
        let r = self.u32s();
        v.clamp(*r.start(), *r.end())
    }

    /// `v` moved into a closed range (NaN stays NaN).
    pub fn clamp_f32(&self, v: f32) -> f32 {
        v.clamp(self.lo as f32, self.hi as f32)
    }

    /// `Ok(())` inside the range, else "`shown` is out of range (0..=180 degrees)".
    pub fn check(&self, v: f64, shown: impl fmt::Display) -> Result<(), String> {
        if self.contains(v) {
            Ok(())
        } else {
            Err(format!("{shown} is out of range ({self})"))
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}{}{}", self.lo, if self.open { ".." } else { "..=" }, self.hi, self.unit)
    }
}

/// Most mirror bounces after the primary hit.
pub const MAX_BOUNCES: u32 = 8;
/// Largest image side accepted.
pub const MAX_RESOLUTION: u32 = 8192;
/// Most camera samples per pixel in one frame.
pub const MAX_SPP: u32 = 64;
/// Most copies of the model (the paper's Table 2 lays 27 out on a 3x3x3 grid; more make a
/// field around it).
pub const MAX_MODELS: u32 = 10_000;

/// Image width and height in pixels.
pub const RESOLUTION: Range = Range::closed(1.0, MAX_RESOLUTION as f64, "");
/// Mirror bounces.
pub const BOUNCES: Range = Range::closed(0.0, MAX_BOUNCES as f64, "");
/// Camera samples per pixel.
pub const SPP: Range = Range::closed(1.0, MAX_SPP as f64, "");
/// Copies of the model (`--models`).
pub const MODELS: Range = Range::closed(1.0, MAX_MODELS as f64, "");
/// The reflection blend ratio.
pub const BLEND: Range = Range::closed(0.0, 1.0, "");
/// The vertical field of view.
pub const FOV_DEGREES: Range = Range::open(1.0, 179.0, " degrees");
/// Frames averaged into one image (progressive accumulation).
pub const ACCUMULATE: Range = Range::closed(1.0, 65536.0, "");
/// The light's distance from the vertical axis its orbit turns around (the box reaches 4).
pub const LIGHT_RADIUS: Range = Range::closed(0.0, 100.0, "");
/// The light's height above the floor plane's centre.
pub const LIGHT_HEIGHT: Range = Range::closed(-100.0, 100.0, "");
/// Most AO rays per primary hit.
pub const MAX_AO_SAMPLES: u32 = 256;
/// AO rays per primary hit (`--ao-samples`).
pub const AO_SAMPLES: Range = Range::closed(1.0, MAX_AO_SAMPLES as f64, "");
/// The AO radius (`--ao-radius`), absolute, in scene units: every model is scaled to radius
/// 1 about the origin (the mirror box reaches 4), so 0.25 is a quarter of the model's
/// radius whatever units its file used, and it stays put when the box is toggled.
pub const AO_RADIUS: Range = Range::open(0.0, 1000.0, " scene units");
/// The crease angle of computed vertex normals (`--crease-angle`, a load option).
pub const CREASE_ANGLE_DEGREES: Range = Range::closed(0.0, 180.0, " degrees");

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

/// Which layout of our BVH the traversal reads (`--bvh`). `render` and `bench` pack only
/// the layout they trace; the window packs both once the wide tree is loaded, so that its
/// frames may switch between them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BvhLayout {
    /// Two children per 64-byte node, float boxes (the SAH tree as built).
    Binary,
    /// The compressed wide BVH: eight children per 80-byte node, 8-bit boxes. The default:
    /// on the H100 the fastest layout on every framed and mirror-box row measured.
    #[default]
    Wide,
    /// The wide BVH traversed in leaf runs: a ray tests the leaves pending on top of its
    /// stack back to back, in one round, before its next node visit. The same tests in the
    /// same order: on the H100, 35% faster than `Wide` on Sponza, 2-12% slower on the knots.
    WideRuns,
}

/// What traced a frame, as tables and logs name it: the acceleration ("bvh", "brute",
/// "vendor"), or the wide layout's name for our BVH in a wide layout ("wide", "wide-runs").
pub fn tracer_label(accel: Accel, bvh: BvhLayout) -> String {
    if accel == Accel::Bvh && bvh.is_wide() {
        bvh.to_string()
    } else {
        accel.to_string()
    }
}

impl BvhLayout {
    /// Every layout, in the order the panel lists them.
    pub const ALL: [BvhLayout; 3] = [BvhLayout::Binary, BvhLayout::Wide, BvhLayout::WideRuns];

    /// True for the layouts that read the wide tree (which must be packed for them).
    pub fn is_wide(self) -> bool {
        matches!(self, BvhLayout::Wide | BvhLayout::WideRuns)
    }

    /// The binary layout: what saved presets and reports without a layout mean (they were
    /// written while it was the default), for serde's `default`.
    pub(crate) fn binary() -> BvhLayout {
        BvhLayout::Binary
    }

    /// Whether this is the binary layout (left out when saving, for serde's `skip_serializing_if`).
    pub(crate) fn is_binary(&self) -> bool {
        *self == BvhLayout::Binary
    }

    /// The layout traced for a frame asking for this one, where a scene holds the binary
    /// trees (`has_binary`) and the wide ones (`has_wide`): the one held, where only one is.
    pub fn traced_with(self, has_binary: bool, has_wide: bool) -> BvhLayout {
        match self {
            l if l.is_wide() && !has_wide => BvhLayout::Binary,
            BvhLayout::Binary if !has_binary => BvhLayout::Wide,
            l => l,
        }
    }
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
    /// Ambient occlusion: the share of `ao_samples` cosine-weighted rays from the primary
    /// hit that meet nothing within `ao_radius` (grey, 1 = open; a miss is 1 with alpha 0).
    Ao,
}

impl Aov {
    /// The code the shader switches on (`AOV_*` of the contract).
    pub(crate) fn code(self) -> u32 {
        match self {
            Aov::Color => contract::AOV_COLOR,
            Aov::Depth => contract::AOV_DEPTH,
            Aov::Normal => contract::AOV_NORMAL,
            Aov::PrimId => contract::AOV_PRIM_ID,
            Aov::Cost => contract::AOV_COST,
            Aov::Samples => contract::AOV_SAMPLES,
            Aov::Ao => contract::AOV_AO,
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
name_enum!(BvhLayout, "BVH layout", BvhLayout::Binary => "binary", BvhLayout::Wide => "wide", BvhLayout::WideRuns => "wide-runs");
name_enum!(Aov, "AOV", Aov::Color => "color", Aov::Depth => "depth", Aov::Normal => "normal", Aov::PrimId => "prim-id", Aov::Cost => "cost", Aov::Samples => "samples", Aov::Ao => "ao");

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

/// Saved as its name ("binary", "wide", "wide-runs"), as `Accel` is.
impl Serialize for BvhLayout {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for BvhLayout {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        String::deserialize(deserializer)?.parse().map_err(serde::de::Error::custom)
    }
}

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
    /// The BVH layout `Accel::Bvh` traverses.
    pub bvh: BvhLayout,
    pub aov: Aov,
    /// Interpolate vertex normals (smooth shading) instead of the paper's flat normals.
    pub smooth: bool,
    /// Apply the file's surface colours: `map_Kd` diffuse textures and vertex colours.
    pub textures: bool,
    /// Jittered camera samples per pixel (1 = the paper's ray through the pixel centre).
    pub spp: u32,
    /// Spend the `spp` samples only on pixels whose neighbours hit another triangle.
    pub adaptive: bool,
    /// The AO view: rays per primary hit ([`AO_SAMPLES`]).
    pub ao_samples: u32,
    /// The AO view: how far a ray looks for an occluder, in scene units ([`AO_RADIUS`]).
    pub ao_radius: f32,
}

/// AO rays per primary hit unless set: 8 a frame, more through accumulation.
pub const DEFAULT_AO_SAMPLES: u32 = 8;
/// The AO radius unless set: a quarter of a model's radius.
pub const DEFAULT_AO_RADIUS: f32 = 0.25;

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            bounces: 2,
            blend: 0.5,
            accel: Accel::Bvh,
            bvh: BvhLayout::Wide,
            aov: Aov::Color,
            smooth: false,
            textures: true,
            spp: 1,
            adaptive: false,
            ao_samples: DEFAULT_AO_SAMPLES,
            ao_radius: DEFAULT_AO_RADIUS,
        }
    }
}

impl RenderSettings {
    /// Check every knob against its range; the error names the knob and the range.
    pub(crate) fn validate(&self) -> Result<(), String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            RESOLUTION.check(v as f64, format!("{name} {v}"))?;
        }
        BOUNCES.check(self.bounces as f64, format!("bounces {}", self.bounces))?;
        BLEND.check(self.blend as f64, format!("blend {}", self.blend))?;
        SPP.check(self.spp as f64, format!("spp {}", self.spp))?;
        AO_SAMPLES.check(self.ao_samples as f64, format!("ao samples {}", self.ao_samples))?;
        AO_RADIUS.check(self.ao_radius as f64, format!("ao radius {}", self.ao_radius))?;
        Ok(())
    }

    /// Rays traced per frame at most: per camera sample, one primary ray and `bounces`
    /// reflected rays, or in the AO view one primary ray and `ao_samples` AO rays
    /// (adaptive sampling traces fewer).
    pub(crate) fn max_rays(&self) -> u64 {
        let per_sample =
            if self.aov == Aov::Ao { 1 + self.ao_samples as u64 } else { self.bounces as u64 + 1 };
        self.width as u64 * self.height as u64 * per_sample * self.spp as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_list_choices() {
        for a in
            [Aov::Color, Aov::Depth, Aov::Normal, Aov::PrimId, Aov::Cost, Aov::Samples, Aov::Ao]
        {
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
        assert!(serde_json::from_str::<Accel>("\"kd\"")
            .unwrap_err()
            .to_string()
            .contains("brute, bvh"));
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
        assert!(RenderSettings { ao_samples: 0, ..ok }.validate().unwrap_err().contains("1..=256"));
        assert!(RenderSettings { ao_radius: -1.0, ..ok }
            .validate()
            .unwrap_err()
            .contains("ao radius -1 is out of range (0..1000 scene units)"));
        assert!(RenderSettings { ao_radius: f32::NAN, ..ok }.validate().is_err());
        let ao = RenderSettings { aov: Aov::Ao, ao_samples: 16, bounces: 2, ..ok };
        assert_eq!(ao.max_rays(), 512 * 512 * 17, "the AO view traces no bounces");
    }

    #[test]
    fn ranges_read_as_their_messages_say() {
        assert_eq!(
            CREASE_ANGLE_DEGREES.check(180.5, "180.5").unwrap_err(),
            "180.5 is out of range (0..=180 degrees)"
        );
        assert_eq!(
            FOV_DEGREES.check(179.0, "fov 179").unwrap_err(),
            "fov 179 is out of range (1..179 degrees)"
        );
        assert!(
            FOV_DEGREES.check(90.0, "").is_ok()
                && BLEND.check(1.0, "").is_ok()
                && CREASE_ANGLE_DEGREES.check(0.0, "").is_ok()
        );
        assert!(BLEND.check(f64::NAN, "NaN").is_err(), "NaN is in no range");
        assert_eq!(BOUNCES.to_string(), "0..=8");
        assert_eq!(AO_RADIUS.parse_f32("0.5"), Ok(0.5));
        assert_eq!(
            AO_RADIUS.parse_f32("-1").unwrap_err(),
            "-1 is out of range (0..1000 scene units)"
        );
        assert_eq!(AO_RADIUS.parse_f32("wide").unwrap_err(), "'wide' is not a number");
        assert!(AO_RADIUS.parse_f32("nan").is_err() && AO_RADIUS.parse_f32("inf").is_err());
    }
}
