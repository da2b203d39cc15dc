//! The tool's parameters (everything the panel and the keys change) and the pure logic on
//! them: render resolution, the light's motion, image placement (the keyboard shortcuts
//! are `shortcuts.rs`).

use glam::Vec3;

use crate::app::split::SplitView;
pub(crate) use crate::gpu::present::PixelRect;
use crate::render_settings::{Accel, Aov, RenderSettings, BLEND, BOUNCES, MODELS, RESOLUTION};
use crate::scene::paper::{ModelSource, BOX_HALF_SIZE};
use crate::scene::spec::{CameraSpec, SceneSpec};
use crate::scene::{Camera, EnvironmentSource};

/// Square render-resolution presets.
pub(crate) const PRESETS: [u32; 4] = [256, 512, 1024, 2048];

/// How the render resolution is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Resolution {
    /// A square preset (one of [`PRESETS`]).
    Square(u32),
    /// The image area of the window, in physical pixels.
    MatchWindow,
    /// `custom` width and height.
    Custom,
}

/// What the image area shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ViewMode {
    /// The shaded colour.
    Color,
    /// A heat map of the per-pixel traversal cost.
    Cost(CostMetric),
    /// Primary-hit distance, near bright and far dark.
    Depth,
    /// Primary-hit normal, x, y, z as red, green, blue.
    Normal,
    /// The triangle hit, a colour per triangle.
    PrimId,
    /// Camera samples spent per pixel (adaptive sampling's view), as a heat map.
    Samples,
    /// Ambient occlusion, grey: the share of AO rays from the primary hit left open.
    Ao,
}

impl ViewMode {
    /// Every view, in the panel's order (the cost view with the BVH-node counter).
    pub(crate) const ALL: [ViewMode; 7] = [
        ViewMode::Color,
        ViewMode::Cost(CostMetric::Nodes),
        ViewMode::Depth,
        ViewMode::Normal,
        ViewMode::PrimId,
        ViewMode::Samples,
        ViewMode::Ao,
    ];

    /// The output the tracer writes for this view.
    pub(crate) fn aov(self) -> Aov {
        match self {
            ViewMode::Color => Aov::Color,
            ViewMode::Cost(_) => Aov::Cost,
            ViewMode::Depth => Aov::Depth,
            ViewMode::Normal => Aov::Normal,
            ViewMode::PrimId => Aov::PrimId,
            ViewMode::Samples => Aov::Samples,
            ViewMode::Ao => Aov::Ao,
        }
    }

    /// The name the panel shows.
    pub(crate) fn label(self) -> &'static str {
        match self {
            ViewMode::Color => "colour",
            ViewMode::Cost(_) => "cost heat map",
            ViewMode::Depth => "depth",
            ViewMode::Normal => "normal",
            ViewMode::PrimId => "primitive id",
            ViewMode::Samples => "samples",
            ViewMode::Ao => "ambient occlusion",
        }
    }

    /// Same view, whatever the cost counter.
    pub(crate) fn same_kind(self, other: ViewMode) -> bool {
        std::mem::discriminant(&self) == std::mem::discriminant(&other)
    }
}

/// Which traversal counter the heat map shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CostMetric {
    /// BVH nodes visited by all rays of the pixel.
    Nodes,
    /// Ray-triangle tests by all rays of the pixel.
    Triangles,
}

impl CostMetric {
    pub(crate) fn label(self) -> &'static str {
        match self {
            CostMetric::Nodes => "BVH nodes visited",
            CostMetric::Triangles => "triangles tested",
        }
    }
}

/// Everything the user can change: the scene description the command line, presets and
/// screenshots share (`scene`), and what only the window has (resolution mode, view,
/// the live camera, the light's motion, panel and HUD, the split view).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Params {
    /// The scene as a spec: model asked for, load options, copies, mirror box, light,
    /// environment, and the render settings (bounces, blend, acceleration, shading
    /// features: the one copy of each). Its camera is where the scene opens and R
    /// returns to; width, height and AOV come from `resolution` and `view` when a frame
    /// is made ([`Params::settings_for`]).
    pub(crate) scene: SceneSpec,
    pub(crate) resolution: Resolution,
    pub(crate) custom: [u32; 2],
    pub(crate) view: ViewMode,
    /// Degrees per second along the orbit.
    pub(crate) light_speed: f32,
    pub(crate) light_paused: bool,
    /// The camera now (the spec's camera is where it started).
    pub(crate) camera: Camera,
    pub(crate) vsync: bool,
    pub(crate) panel_visible: bool,
    /// The frame numbers over the image's corner (the HUD).
    pub(crate) hud_visible: bool,
    /// The environment file given with `--env` or chosen in the panel, offered there.
    pub(crate) environment_file: Option<EnvironmentSource>,
    /// Average successive frames while nothing changes (progressive anti-aliasing).
    pub(crate) accumulate: bool,
    /// The A/B split view (S): off, or A left of a line and B right of it.
    pub(crate) split: SplitView,
    /// Pick `scene.settings.bvh` by timing each layout (`tool/auto_layout.rs`).
    pub(crate) bvh_auto: bool,
}

impl Params {
    /// The starting parameters from the scene spec. A scripted run (`--frames`) starts
    /// with the light paused at `--light-angle`, so its screenshots match `render`.
    pub(crate) fn new(spec: &SceneSpec, scripted: bool) -> Self {
        let s = &spec.settings;
        let resolution = if s.width == s.height && PRESETS.contains(&s.width) {
            Resolution::Square(s.width)
        } else {
            Resolution::Custom
        };
        let settings = RenderSettings {
            bounces: BOUNCES.clamp_u32(s.bounces),
            blend: BLEND.clamp_f32(s.blend),
            aov: Aov::Color,
            ..*s
        };
        let scene = SceneSpec { settings, models: MODELS.clamp_u32(spec.models), ..spec.clone() };
        Self {
            resolution,
            custom: [s.width, s.height],
            view: ViewMode::Color,
            light_speed: 30.0,
            light_paused: scripted,
            camera: spec.camera(),
            vsync: true,
            panel_visible: true,
            hud_visible: true,
            environment_file: spec.environment.clone().filter(|e| *e != EnvironmentSource::Sky),
            accumulate: !scripted,
            split: SplitView::default(),
            bvh_auto: false,
            scene,
        }
    }

    /// Render width and height for an image area of `area` physical pixels.
    pub(crate) fn render_size(&self, area: [u32; 2]) -> [u32; 2] {
        let clamp = |v: u32| RESOLUTION.clamp_u32(v);
        match self.resolution {
            Resolution::Square(n) => [n, n],
            Resolution::MatchWindow => [clamp(area[0]), clamp(area[1])],
            Resolution::Custom => [clamp(self.custom[0]), clamp(self.custom[1])],
        }
    }

    /// The frame settings for an image area of `area` physical pixels.
    pub(crate) fn settings_for(&self, area: [u32; 2]) -> RenderSettings {
        let [width, height] = self.render_size(area);
        RenderSettings { width, height, aov: self.view.aov(), ..self.scene.settings }
    }

    /// Move the light along its orbit by `dt` seconds (unless paused).
    pub(crate) fn advance_light(&mut self, dt: f32) {
        if !self.light_paused {
            self.scene.light.angle_deg =
                (self.scene.light.angle_deg + self.light_speed * dt).rem_euclid(360.0);
        }
    }

    /// Put the camera back where the scene opens.
    pub(crate) fn reset_camera(&mut self) {
        self.camera = self.scene.camera();
    }

    /// After the copy count changed from `before`: a camera still at the opening view of
    /// `before` copies takes the opening view of the new count (a field's steps back; the
    /// paper's lattice comes back inside the mirror box, which a field's camera is outside
    /// of). A camera the user moved stays where it is.
    pub(crate) fn follow_field(&mut self, before: u32) {
        if self.camera == (SceneSpec { models: before, ..self.scene.clone() }).camera() {
            self.reset_camera();
        }
    }

    /// Orbit the camera by a mouse drag of (`dx`, `dy`) physical pixels.
    pub(crate) fn drag_camera(&mut self, dx: f32, dy: f32) {
        const RADIANS_PER_PIXEL: f32 = 0.008;
        self.camera.orbit(dx * RADIANS_PER_PIXEL, dy * RADIANS_PER_PIXEL, 1.0);
        self.keep_camera_in_view();
    }

    /// Pan by a drag of (`dx`, `dy`) physical pixels over an image `height` pixels high:
    /// the scene follows the cursor.
    pub(crate) fn pan_camera(&mut self, dx: f32, dy: f32, height: f32) {
        let h = height.max(1.0);
        self.camera.pan(dx / h, dy / h);
        self.keep_camera_in_view();
    }

    /// Look at the models from the current direction, at the distance where a sphere of
    /// `radius` around `centre` fills the view.
    pub(crate) fn frame_model(&mut self, centre: Vec3, radius: f32) {
        self.camera.target = centre;
        self.camera = self.camera.framing(radius, 0.9);
        self.keep_camera_in_view();
    }

    /// Zoom by `steps` wheel notches (positive = closer), staying where the scene can be seen.
    pub(crate) fn zoom_camera(&mut self, steps: f32) {
        self.camera.orbit(0.0, 0.0, 0.9f32.powf(steps));
        self.keep_camera_in_view();
    }

    /// The farthest the eye may be from the origin: inside the mirror box when it is on
    /// (outside, the user sees the box's back faces or black), a few box sizes otherwise.
    pub(crate) fn max_eye_distance(&self) -> f32 {
        if self.scene.mirror_box {
            BOX_HALF_SIZE * 0.95
        } else {
            BOX_HALF_SIZE * 4.0
        }
    }

    /// Pull the eye back towards the target until it is within [`Self::max_eye_distance`]
    /// of the origin on every axis (the box is a cube), and no closer to the target than a
    /// hundredth of the model's radius.
    pub(crate) fn keep_camera_in_view(&mut self) {
        let limit = self.max_eye_distance();
        let c = &mut self.camera;
        let offset = c.position - c.target;
        let dist = offset.length();
        if dist < 1e-2 {
            c.position = c.target + offset.normalize_or(Vec3::Z) * 1e-2;
        }
        let far = c.position.abs().max_element();
        if far > limit && dist > 0.0 {
            // The largest t in [0, 1] with target + t * offset inside the cube.
            let dir = offset / dist;
            let t_box = (0..3)
                .filter(|&k| dir[k].abs() > 1e-6)
                .map(|k| (limit * dir[k].signum() - c.target[k]) / dir[k])
                .fold(f32::INFINITY, f32::min);
            c.position = c.target + dir * t_box.clamp(1e-2, dist);
        }
    }

    /// Brute force visits no BVH nodes: the cost view counts triangles there.
    pub(crate) fn fit_cost_metric(&mut self) {
        if let (ViewMode::Cost(metric), Accel::Brute) = (&mut self.view, self.scene.settings.accel)
        {
            *metric = CostMetric::Triangles;
        }
    }

    /// The light's position now.
    pub(crate) fn light_position(&self) -> Vec3 {
        self.scene.light.position()
    }

    /// Take the look a preset holds (everything but the model, which the tool loads):
    /// resolution, shading, copies, load options, box, environment, light, and camera,
    /// which also becomes where R returns. The light is paused at the preset's angle, as
    /// it was saved; what a preset does not hold (view, vsync, panel, light speed, the
    /// split view) stays.
    pub(crate) fn apply_preset(&mut self, spec: &SceneSpec) {
        let fresh = Params::new(spec, true);
        // A preset that names a layout wants it, not the measured choice.
        self.bvh_auto &= spec.settings.bvh == crate::render_settings::BvhLayout::Binary;
        self.resolution = fresh.resolution;
        self.custom = fresh.custom;
        self.scene = SceneSpec { model: self.scene.model.clone(), ..fresh.scene };
        self.light_paused = true;
        self.camera = fresh.camera;
        if fresh.environment_file.is_some() {
            self.environment_file = fresh.environment_file;
        }
        self.fit_cost_metric();
    }

    /// Trace with the environment map `path` (the Open dialog's pick), and offer it in the
    /// panel from now on; a file that cannot be read is reported when it is uploaded.
    pub(crate) fn use_environment_file(&mut self, path: std::path::PathBuf) {
        let file = EnvironmentSource::File(path);
        self.environment_file = Some(file.clone());
        self.scene.environment = Some(file);
    }

    /// The scene spec of what is shown now (`model`, traced with `settings`, seen from
    /// the camera now): what the screenshots carry as their preset, so `render --preset`
    /// repeats it.
    pub(crate) fn scene_spec(&self, model: ModelSource, settings: RenderSettings) -> SceneSpec {
        let c = &self.camera;
        SceneSpec {
            model,
            camera: CameraSpec {
                eye: Some(c.position),
                target: Some(c.target),
                fov: Some(c.vfov_deg),
                framed: false,
            },
            settings,
            accumulate: 1,
            ..self.scene.clone()
        }
    }
}

/// The largest rectangle of the image's aspect centred in `area` (letterbox).
pub(crate) fn fit_rect(image: [u32; 2], area: PixelRect) -> PixelRect {
    if image[0] == 0 || image[1] == 0 || area.width == 0 || area.height == 0 {
        return PixelRect { x: area.x, y: area.y, width: 0, height: 0 };
    }
    let scale = (area.width as f64 / image[0] as f64).min(area.height as f64 / image[1] as f64);
    let width = ((image[0] as f64 * scale).round() as u32).clamp(1, area.width);
    let height = ((image[1] as f64 * scale).round() as u32).clamp(1, area.height);
    PixelRect {
        x: area.x + ((area.width - width) / 2) as i32,
        y: area.y + ((area.height - height) / 2) as i32,
        width,
        height,
    }
}

#[cfg(test)]
pub(crate) mod tests {

    #[test]
    fn the_opening_camera_follows_the_copy_count_and_a_moved_one_stays() {
        let mut p = Params::new(&SceneSpec { models: 200, ..SceneSpec::default() }, false);
        let field = p.camera;
        p.scene.models = 25;
        p.follow_field(200);
        assert_eq!(p.camera, SceneSpec::default().camera(), "back inside the paper's box");
        assert_ne!(p.camera, field);
        p.drag_camera(40.0, 10.0);
        let moved = p.camera;
        p.scene.models = 1000;
        p.follow_field(25);
        assert_eq!(p.camera, moved, "the user's camera stays");
    }
    use super::*;
    use crate::scene::paper::LightOrbit;

    /// The tool's parameters for the default spec changed by `edit` (an interactive run);
    /// the shortcuts' tests start from it too.
    pub(crate) fn params(edit: impl FnOnce(&mut SceneSpec)) -> Params {
        let mut spec = SceneSpec::default();
        edit(&mut spec);
        Params::new(&spec, false)
    }

    #[test]
    fn command_line_sets_the_start() {
        let p = params(|s| {
            s.settings = RenderSettings { width: 512, height: 512, bounces: 3, ..s.settings }
        });
        assert_eq!(p.resolution, Resolution::Square(512));
        assert_eq!(p.scene.settings.bounces, 3);
        assert!(!p.light_paused);
        let spec = SceneSpec {
            settings: RenderSettings { width: 128, height: 96, ..Default::default() },
            ..Default::default()
        };
        let p = Params::new(&spec, true);
        assert_eq!(p.resolution, Resolution::Custom);
        assert_eq!(p.render_size([10, 10]), [128, 96]);
        assert!(p.light_paused, "scripted runs keep the light still");
    }

    #[test]
    fn resolution_modes() {
        let mut p = params(|_| {});
        p.resolution = Resolution::MatchWindow;
        assert_eq!(p.render_size([800, 600]), [800, 600]);
        assert_eq!(p.render_size([0, 600]), [1, 600]);
        assert_eq!(p.render_size([100_000, 5]), [crate::render_settings::MAX_RESOLUTION, 5]);
        p.resolution = Resolution::Square(2048);
        assert_eq!(p.settings_for([1, 1]).width, 2048);
    }

    #[test]
    fn light_moves_unless_paused() {
        let mut p = params(|s| s.light.angle_deg = 350.0);
        p.light_speed = 20.0;
        p.advance_light(1.0);
        assert!((p.scene.light.angle_deg - 10.0).abs() < 1e-3);
        p.light_paused = true;
        p.advance_light(1.0);
        assert!((p.scene.light.angle_deg - 10.0).abs() < 1e-3);
    }

    #[test]
    fn twenty_notches_out_keep_the_eye_inside_the_box() {
        let mut p = params(|_| {});
        for _ in 0..20 {
            p.zoom_camera(-1.0);
        }
        assert!(
            p.camera.position.abs().max_element() <= BOX_HALF_SIZE * 0.95 + 1e-4,
            "{:?}",
            p.camera.position
        );
        assert!(
            (p.camera.position - p.camera.target).length() > 1.0,
            "the eye still sees the model from afar"
        );
        // Without the box, farther is allowed but bounded.
        p.scene.mirror_box = false;
        for _ in 0..100 {
            p.zoom_camera(-1.0);
        }
        assert!(p.camera.position.abs().max_element() <= BOX_HALF_SIZE * 4.0 + 1e-3);
        // Zooming in stops short of the target.
        for _ in 0..200 {
            p.zoom_camera(1.0);
        }
        assert!((p.camera.position - p.camera.target).length() >= 1e-2 - 1e-6);
    }

    #[test]
    fn a_loaded_preset_saves_as_itself() {
        let spec = SceneSpec {
            models: 3,
            mirror_box: false,
            light: LightOrbit { angle_deg: 99.0, radius: 1.5, height: -0.5 },
            camera: CameraSpec {
                eye: Some(Vec3::new(1.0, 2.0, 3.0)),
                target: Some(Vec3::new(0.0, 0.5, 0.0)),
                fov: Some(35.0),
                framed: false,
            },
            environment: Some(EnvironmentSource::Sky),
            settings: RenderSettings {
                width: 320,
                height: 200,
                bounces: 4,
                blend: 0.7,
                accel: Accel::Brute,
                smooth: true,
                spp: 8,
                adaptive: true,
                textures: false,
                ..Default::default()
            },
            ..SceneSpec::default()
        };
        let mut p = params(|_| {});
        p.vsync = false;
        p.apply_preset(&spec);
        assert!(
            p.light_paused && !p.vsync,
            "the light stops at the preset's angle; the display stays"
        );
        let saved = p.scene_spec(spec.model.clone(), p.settings_for([800, 600]));
        assert_eq!(saved, spec);
        p.camera.position = Vec3::ONE;
        p.reset_camera();
        assert_eq!(p.camera.position, Vec3::new(1.0, 2.0, 3.0), "R returns to the preset's camera");
    }

    #[test]
    fn letterbox_keeps_aspect_and_centres() {
        let area = PixelRect { x: 200, y: 0, width: 400, height: 300 };
        assert_eq!(fit_rect([100, 100], area), PixelRect { x: 250, y: 0, width: 300, height: 300 });
        assert_eq!(
            fit_rect([800, 200], area),
            PixelRect { x: 200, y: 100, width: 400, height: 100 }
        );
        assert_eq!(fit_rect([10, 10], PixelRect { width: 0, ..area }).width, 0);
    }
}
