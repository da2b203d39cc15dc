//! The scene spec: one description of what is traced (model, copies, mirror box, light,
//! camera, environment) and how (the frame settings). The command line fills it; the
//! window, `render`, `bench` and the tests build their scene from it, so the paper's
//! scene is assembled in one place.

use glam::Vec3;

use super::formats::load_model;
use super::obj::LoadOptions;
use super::paper::{default_camera, scattered_scene, LightOrbit, ModelSource, MODEL_RADIUS};
use super::{Camera, EnvironmentSource, Mesh, Scene};
use crate::render_settings::{RenderSettings, CREASE_ANGLE_DEGREES};

/// Where the camera is: the scene's default view with optional overrides, or framed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraSpec {
    /// Camera position (the model sits at the origin with radius 1, the box reaches ±4).
    pub eye: Option<Vec3>,
    /// Point the camera looks at.
    pub target: Option<Vec3>,
    /// Vertical field of view in degrees.
    pub fov: Option<f32>,
    /// Move the camera in along its view direction until the model fills the frame
    /// (`bench --framed`, the vendor's comparison).
    pub framed: bool,
}

impl CameraSpec {
    /// `camera` with the overrides applied.
    pub(crate) fn apply(&self, mut camera: Camera) -> Camera {
        if let Some(eye) = self.eye {
            camera.position = eye;
        }
        if let Some(target) = self.target {
            camera.target = target;
        }
        if let Some(fov) = self.fov {
            camera.vfov_deg = fov;
        }
        if self.framed {
            // Overfill a little so that only the model's gaps show the walls.
            camera = camera.framing(MODEL_RADIUS, 1.25);
        }
        camera
    }

    /// The paper's opening camera with the overrides applied.
    pub(crate) fn camera(&self) -> Camera {
        self.apply(default_camera())
    }

    /// The same camera with every value spelled out (eye, target and field of view, the
    /// framing already applied to the eye).
    #[cfg(test)]
    pub(crate) fn resolved(&self) -> CameraSpec {
        let c = self.camera();
        CameraSpec {
            eye: Some(c.position),
            target: Some(c.target),
            fov: Some(c.vfov_deg),
            framed: false,
        }
    }
}

/// Everything that decides one traced image, apart from the device it runs on.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSpec {
    /// The model: one of the paper's, a generated knot, or an .obj file.
    pub model: ModelSource,
    /// How an .obj model is read where the file leaves it open (`--crease-angle`).
    pub load_options: LoadOptions,
    /// Copies of the model: along the axes (the paper's Table 2) up to 27, a field beyond.
    pub models: u32,
    /// Seed of the copies' random rotations and scales (0: identical copies).
    pub scatter: u32,
    /// The paper's six mirror planes around the models.
    pub mirror_box: bool,
    /// The light's orbit and position on it.
    pub light: LightOrbit,
    pub camera: CameraSpec,
    /// What misses see: None (black, the paper), the generated sky, or a file.
    pub environment: Option<EnvironmentSource>,
    /// Resolution, bounces, blend, acceleration, shading features, AOV.
    pub settings: RenderSettings,
    /// Frames averaged into the image, each with its own camera jitter, as the window's
    /// accumulation averages them (1: one frame). A screenshot taken after accumulating
    /// carries its count, so `render --preset` traces the same image.
    pub accumulate: u32,
}

impl Default for SceneSpec {
    fn default() -> Self {
        Self {
            model: ModelSource::default(),
            load_options: LoadOptions::default(),
            models: 1,
            scatter: 0,
            mirror_box: true,
            light: LightOrbit::default(),
            camera: CameraSpec::default(),
            environment: None,
            settings: RenderSettings::default(),
            accumulate: 1,
        }
    }
}

impl SceneSpec {
    /// Check the settings and the camera; the error is one sentence naming the knob.
    pub fn validate(&self) -> Result<(), String> {
        self.settings.validate()?;
        crate::render_settings::ACCUMULATE
            .check(self.accumulate as f64, format!("accumulate {}", self.accumulate))?;
        if let Some(angle) = self.load_options.crease_angle {
            CREASE_ANGLE_DEGREES.check(angle as f64, format!("the crease angle {angle}"))?;
        }
        let camera = self.camera();
        if camera.position.distance(camera.target) < 1e-6 {
            return Err(
                "the camera's eye and target are the same point: it has no direction".into()
            );
        }
        Ok(())
    }

    /// The camera: the overrides applied to the opening view, which steps back with the
    /// mirror box when the copies grow into a field, so the whole set is in view.
    pub fn camera(&self) -> Camera {
        let mut home = default_camera();
        home.position *= super::paper::camera_scale(self.models);
        self.camera.apply(home)
    }

    /// Read the environment file now, so a bad one fails before any other work.
    pub(crate) fn check_environment(&self) -> anyhow::Result<()> {
        if let Some(EnvironmentSource::File(p)) = &self.environment {
            crate::files::read_image(p, "environment map").map_err(anyhow::Error::msg)?;
        }
        Ok(())
    }

    /// The scene around an already loaded and prepared model mesh.
    pub fn scene_with(&self, model: Mesh) -> Scene {
        let mut scene = scattered_scene(model, self.models, self.scatter, self.light);
        if !self.mirror_box {
            scene = scene.without_box();
        }
        scene.camera = self.camera();
        scene.environment = self.environment.clone();
        scene
    }

    /// Load (or generate) the model ([`load_model`]) and build the scene; the loader's
    /// warnings are returned.
    pub(crate) fn load(&self) -> anyhow::Result<(Scene, Vec<String>)> {
        self.validate().map_err(anyhow::Error::msg)?;
        self.check_environment()?;
        let loaded = load_model(&self.model, &self.load_options, None)?;
        Ok((self.scene_with(loaded.mesh), loaded.warnings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_spec_is_the_papers_scene() {
        let spec = SceneSpec::default();
        let (scene, warnings) = spec.load().unwrap();
        assert!(warnings.is_empty());
        assert_eq!(scene.meshes.len(), 2);
        assert_eq!(scene.instances.len(), 2, "one model and the mirror box");
        assert_eq!(scene.camera, default_camera());
    }

    #[test]
    fn overrides_reach_the_scene() {
        let spec = SceneSpec {
            models: 4,
            mirror_box: false,
            camera: CameraSpec {
                eye: Some(Vec3::new(0.0, 0.0, 3.0)),
                fov: Some(40.0),
                ..Default::default()
            },
            ..Default::default()
        };
        let (scene, _) = spec.load().unwrap();
        assert_eq!(scene.instances.len(), 4, "no mirror box");
        assert_eq!(scene.camera.position, Vec3::new(0.0, 0.0, 3.0));
        assert_eq!(scene.camera.vfov_deg, 40.0);
    }

    #[test]
    fn a_camera_without_direction_is_refused() {
        let spec = SceneSpec {
            camera: CameraSpec {
                eye: Some(Vec3::ZERO),
                target: Some(Vec3::ZERO),
                ..Default::default()
            },
            ..Default::default()
        };
        assert!(spec.validate().unwrap_err().contains("same point"));
    }

    #[test]
    fn a_crease_angle_outside_a_half_turn_is_refused() {
        let with = |angle: f32| {
            SceneSpec {
                load_options: LoadOptions { crease_angle: Some(angle) },
                ..Default::default()
            }
            .validate()
        };
        assert!(with(0.0).is_ok() && with(180.0).is_ok());
        for bad in [-1.0, 181.0, f32::NAN] {
            assert!(with(bad).unwrap_err().contains("crease angle"), "{bad}");
        }
    }

    #[test]
    fn framing_moves_the_camera_in() {
        let framed = CameraSpec { framed: true, ..Default::default() }.camera();
        let home = default_camera();
        assert!(framed.position.length() < home.position.length());
        assert_eq!(framed.target, home.target);
    }
}
