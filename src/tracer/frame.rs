//! Per-frame parameters: the user's [`RenderSettings`] plus the camera and light of the
//! scene, flattened to the push-constant block that `shaders/scene.glsl` declares.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::contract;
use crate::render_settings::{Accel, BvhLayout, RenderSettings};
use crate::scene::camera::CameraBasis;
use crate::scene::Scene;

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
    /// w: the AO radius (scene units).
    pub light_pos: [f32; 4],
    /// w: AO rays per primary hit (u32 bits).
    pub light_color: [f32; 4],
    /// Width, height, bounces and band lanes (`contract::BOUNCES_MASK`, `FIRST_LANE_SHIFT`,
    /// `LANE_SPAN_SHIFT`: a byte each), flags.
    pub dims: [u32; 4],
    pub misc: [u32; 4],
}

// The bounces share dims.z with the band's lanes: they must fit their byte.
const _: () = assert!(crate::render_settings::MAX_BOUNCES <= contract::BOUNCES_MASK);

impl PushConstants {
    /// Trace only `lanes` of each work group (lane = y * width + x in the group's tile):
    /// a band finer than a group. The shaders skip the other invocations with one compare,
    /// `lane - first > span`, which no lane fails for the whole-group default (first 0,
    /// span `LANE_MASK`) that [`FrameParams::push_constants`] sets.
    pub(crate) fn set_lanes(&mut self, lanes: &std::ops::Range<u32>) {
        assert!(
            !lanes.is_empty() && lanes.end <= contract::LANE_MASK + 1,
            "lanes {lanes:?} of a work group of at most 256"
        );
        let (first, span) = (lanes.start, lanes.end - 1 - lanes.start);
        self.dims[2] = self.dims[2] & contract::BOUNCES_MASK
            | first << contract::FIRST_LANE_SHIFT
            | span << contract::LANE_SPAN_SHIFT;
    }
}

impl FrameParams {
    /// Parameters for `scene` rendered with `settings`.
    pub fn new(scene: &Scene, settings: RenderSettings) -> Self {
        Self::with_bounds(scene, settings, scene.bounds())
    }

    /// [`Self::new`] with the scene's world bounds already known (they set the ray offset).
    pub(crate) fn with_bounds(
        scene: &Scene,
        settings: RenderSettings,
        bounds: crate::geometry::Aabb,
    ) -> Self {
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
        flags_for(&self.settings, self.environment)
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

    /// The push constants for rows starting at `first_row`, every lane of each work group
    /// traced ([`PushConstants::set_lanes`] narrows that). `dims.z` packs the bounces
    /// (low byte, checked against `BOUNCES_MASK`) with the band's lanes.
    pub(crate) fn push_constants(&self, first_row: u32) -> PushConstants {
        let s = &self.settings;
        let c = &self.camera;
        let flags = self.flags();
        // Settings are validated to MAX_BOUNCES; clamp anyway so that no bounce count can
        // spill into the lanes.
        debug_assert!(s.bounces <= crate::render_settings::MAX_BOUNCES, "{} bounces", s.bounces);
        let bounces = s.bounces.min(contract::BOUNCES_MASK);
        let whole_group = contract::LANE_MASK << contract::LANE_SPAN_SHIFT;
        PushConstants {
            cam_origin_eps: c.origin.extend(self.ray_epsilon).to_array(),
            cam_forward_blend: c.forward.extend(s.blend).to_array(),
            cam_right_ambient: c.right.extend(self.ambient).to_array(),
            cam_up: c.up.extend(0.0).to_array(),
            // w: the AO view's radius, and its rays per hit as uint bits.
            light_pos: self.light_position.extend(s.ao_radius).to_array(),
            light_color: self.light_color.extend(f32::from_bits(s.ao_samples)).to_array(),
            dims: [s.width, s.height, bounces | whole_group, flags],
            misc: [self.instance_count, first_row, self.background_rgba8(), self.frame_index],
        }
    }
}

/// The flag word of the push constants for frames of `settings`, with or without an
/// environment map (bits and fields from [`contract`]).
pub(crate) fn flags_for(s: &RenderSettings, environment: bool) -> u32 {
    let mut f = s.aov.code() << contract::AOV_SHIFT
        | s.spp.clamp(1, contract::SPP_MASK) << contract::SPP_SHIFT;
    for (on, bit) in [
        (s.accel == Accel::Bvh, contract::FLAG_BVH),
        (s.accel == Accel::Bvh && s.bvh.is_wide(), contract::FLAG_WIDE),
        (s.accel == Accel::Bvh && s.bvh == BvhLayout::WideRuns, contract::FLAG_LEAF_RUNS),
        (s.smooth, contract::FLAG_SMOOTH),
        (s.textures, contract::FLAG_TEXTURES),
        (environment, contract::FLAG_ENVIRONMENT),
        (s.adaptive, contract::FLAG_ADAPTIVE),
    ] {
        if on {
            f |= bit;
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_constants_are_128_bytes() {
        assert_eq!(std::mem::size_of::<PushConstants>(), 128);
    }

    /// dims.z keeps the bounces whatever lanes a band sets, and the shader's test
    /// `lane - first > span` (wrapping) skips exactly the lanes outside the band.
    #[test]
    fn the_band_lanes_share_dims_z_with_the_bounces() {
        let scene = crate::scene::paper::paper_scene(
            crate::scene::primitives::geosphere(0),
            1,
            Default::default(),
        );
        let settings =
            RenderSettings { bounces: crate::render_settings::MAX_BOUNCES, ..Default::default() };
        let mut pc = FrameParams::new(&scene, settings).push_constants(0);
        let skipped = |pc: &PushConstants, lane: u32| {
            let z = pc.dims[2];
            let first = z >> contract::FIRST_LANE_SHIFT & contract::LANE_MASK;
            let span = z >> contract::LANE_SPAN_SHIFT & contract::LANE_MASK;
            lane.wrapping_sub(first) > span
        };
        assert!((0..256).all(|lane| !skipped(&pc, lane)), "the default traces every lane");
        for lanes in [0..1, 5..12, 100..128, 127..128, 0..128, 0..256] {
            pc.set_lanes(&lanes);
            assert_eq!(pc.dims[2] & contract::BOUNCES_MASK, crate::render_settings::MAX_BOUNCES);
            for lane in 0..256 {
                assert_eq!(skipped(&pc, lane), !lanes.contains(&lane), "{lane} in {lanes:?}");
            }
        }
    }
}
