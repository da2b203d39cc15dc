//! The scene spec: one description of what is traced (model, copies, mirror box, light,
//! camera, environment) and how (the frame settings). The command line fills it; the
//! window, `render`, `bench` and the tests build their scene from it, so the paper's
//! scene is assembled in one place.

use glam::{Affine3A, EulerRot, Quat, Vec3};

use super::formats::{is_gltf, load_model, LoadError};
use super::obj::LoadOptions;
use super::paper::{assembled_scene, default_camera, LightOrbit, ModelSource, MODEL_RADIUS};
use super::{Camera, EnvironmentSource, Instance, Model, Scene};
use crate::progress::Progress;
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

/// A transform as a person writes it: scale (per axis; negative mirrors), then rotation
/// (degrees about x, then y, then z), then translation, in the scene's units (a model is
/// fitted to a radius of 1; the mirror box reaches ±4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub translate: Vec3,
    /// Degrees about the x, y and z axes, applied in that order.
    pub rotate: Vec3,
    pub scale: Vec3,
}

impl Default for Placement {
    fn default() -> Self {
        Self { translate: Vec3::ZERO, rotate: Vec3::ZERO, scale: Vec3::ONE }
    }
}

impl Placement {
    /// The object-to-world transform.
    pub fn transform(&self) -> Affine3A {
        let r = self.rotate * (std::f32::consts::PI / 180.0);
        let rotation = Quat::from_euler(EulerRot::ZYX, r.z, r.y, r.x);
        Affine3A::from_scale_rotation_translation(self.scale, rotation, self.translate)
    }
}

/// A model placed beside the copies (a preset's `[[object]]`): several different models
/// make one scene, each mesh stored once however often it is placed.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectSpec {
    /// What is placed: a paper model, a knot or a file, as `--model` spells it.
    pub model: ModelSource,
    pub placement: Placement,
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
    /// Other models placed in the scene, each with its own transform.
    pub objects: Vec<ObjectSpec>,
    /// The paper's six mirror planes around the models.
    pub mirror_box: bool,
    /// The light's orbit and position on it.
    pub light: LightOrbit,
    pub camera: CameraSpec,
    /// Look through the model file's camera N (1: the first of a glTF file's cameras in
    /// its scene), `camera`'s overrides applied over it; None: the opening view.
    pub file_camera: Option<u32>,
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
            objects: Vec::new(),
            mirror_box: true,
            light: LightOrbit::default(),
            camera: CameraSpec::default(),
            file_camera: None,
            environment: None,
            settings: RenderSettings::default(),
            accumulate: 1,
        }
    }
}

impl SceneSpec {
    /// Whether the scene will be one instance (alone or in the mirror box, its closed-box
    /// enclosure: `TopLevel::is_one_instance`), as far as is known before the model is
    /// loaded: one copy of a model made in code or read from an OBJ or PLY file, which is
    /// one mesh; a glTF file's nodes, and placed objects, are known only then (false).
    pub(crate) fn is_one_instance_before_loading(&self) -> bool {
        let gltf = matches!(&self.model, ModelSource::File(p) if is_gltf(p));
        self.models == 1 && !gltf && self.objects.is_empty()
    }

    /// Check the settings and the camera; the error is one sentence naming the knob.
    pub fn validate(&self) -> Result<(), String> {
        self.settings.validate()?;
        crate::render_settings::ACCUMULATE
            .check(self.accumulate as f64, format!("accumulate {}", self.accumulate))?;
        if let Some(angle) = self.load_options.crease_angle {
            CREASE_ANGLE_DEGREES.check(angle as f64, format!("the crease angle {angle}"))?;
        }
        for (i, object) in self.objects.iter().enumerate() {
            let t = object.placement.transform();
            Instance::new(0, t).map_err(|_| {
                format!(
                    "object {} ({}) has a singular or non-finite transform (a scale of zero, \
                     or a value that is not a number)",
                    i + 1,
                    object.model.label()
                )
            })?;
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

    /// The camera for the loaded, prepared `model`: the file camera the spec picks, with
    /// the overrides applied, if the model has it; else [`SceneSpec::camera`].
    pub fn camera_for(&self, model: &Model) -> Camera {
        let picked = self.file_camera.and_then(|n| model.cameras.get((n as usize).checked_sub(1)?));
        match picked {
            Some(camera) => self.camera.apply(*camera),
            None => self.camera(),
        }
    }

    /// The spec with its camera written out as the scene traced it (`camera`) instead of
    /// as a file camera: what a preset records, since it holds no model.
    pub fn with_camera(&self, camera: Camera) -> SceneSpec {
        SceneSpec {
            camera: CameraSpec {
                eye: Some(camera.position),
                target: Some(camera.target),
                fov: Some(camera.vfov_deg),
                framed: false,
            },
            file_camera: None,
            ..self.clone()
        }
    }

    /// Read the environment file now, so a bad one fails before any other work.
    pub(crate) fn check_environment(&self) -> anyhow::Result<()> {
        if let Some(EnvironmentSource::File(p)) = &self.environment {
            crate::files::read_image(p, "environment map").map_err(anyhow::Error::msg)?;
        }
        Ok(())
    }

    /// The models the objects place that are not the main model, each once, in the
    /// order [`SceneSpec::load_models`] loads them and [`SceneSpec::scene_of`] takes them.
    pub fn object_sources(&self) -> Vec<&ModelSource> {
        let mut sources: Vec<&ModelSource> = Vec::new();
        for object in &self.objects {
            if object.model != self.model && !sources.contains(&&object.model) {
                sources.push(&object.model);
            }
        }
        sources
    }

    /// The scene around an already loaded and prepared model (a mesh, or a model of
    /// parts), for a spec without objects of other models.
    pub fn scene_with(&self, model: impl Into<Model>) -> Scene {
        self.scene_of(model.into(), &[])
    }

    /// The scene around the loaded model and `others`, the models of
    /// [`SceneSpec::object_sources`] in that order.
    pub fn scene_of(&self, model: Model, others: &[Model]) -> Scene {
        let sources = self.object_sources();
        // Objects of the main model place it once more; its meshes are not stored again.
        let objects: Vec<(Option<usize>, Affine3A)> = self
            .objects
            .iter()
            .filter_map(|object| {
                let which = sources.iter().position(|s| **s == object.model);
                // A model not handed in (a caller that loaded none) places nothing.
                which
                    .is_none_or(|k| k < others.len())
                    .then(|| (which, object.placement.transform()))
            })
            .collect();
        let camera = self.camera_for(&model);
        let mut scene =
            assembled_scene(model, others, &objects, self.models, self.scatter, self.light);
        if !self.mirror_box {
            scene.remove_box();
        }
        scene.camera = camera;
        scene.environment = self.environment.clone();
        scene
    }

    /// Load (or generate) the main model and each other model the objects place, each
    /// once: the main model, the others (as [`SceneSpec::object_sources`]) and every
    /// loader's warnings.
    pub fn load_models(
        &self,
        progress: Option<&Progress>,
    ) -> Result<(Model, Vec<Model>, Vec<String>), LoadError> {
        let main = load_model(&self.model, &self.load_options, progress)?;
        let mut warnings = main.warnings;
        let mut others = Vec::new();
        for source in self.object_sources() {
            let other = load_model(source, &self.load_options, progress)?;
            warnings.extend(other.warnings);
            others.push(other.model);
        }
        Ok((main.model, others, warnings))
    }

    /// Load (or generate) the models ([`SceneSpec::load_models`]) and build the scene;
    /// the loaders' warnings are returned.
    pub(crate) fn load(&self) -> anyhow::Result<(Scene, Vec<String>)> {
        self.validate().map_err(anyhow::Error::msg)?;
        self.check_environment()?;
        let (model, others, warnings) = self.load_models(None)?;
        if let Some(n) = self.file_camera {
            let count = model.cameras.len();
            if n == 0 || n as usize > count {
                anyhow::bail!(
                    "file camera {n}: {} has {count} cameras (a glTF file's perspective cameras in its scene, numbered from 1)",
                    self.model.label()
                );
            }
        }
        Ok((self.scene_of(model, &others), warnings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_instance_is_known_before_loading_for_one_copy_of_one_mesh() {
        let knot = ModelSource::Generated(1000);
        for (models, mirror_box) in [(1, true), (1, false), (2, false), (27, true)] {
            let spec = SceneSpec { model: knot.clone(), models, mirror_box, ..Default::default() };
            let (scene, _) = spec.load().unwrap();
            let packed = crate::tracer::PackedScene::new(&scene);
            let want = packed.top_level.is_one_instance();
            assert_eq!(spec.is_one_instance_before_loading(), want, "{models}, box {mirror_box}");
        }
        let file = |name: &str| ModelSource::File(name.into());
        let at = |model| SceneSpec { model, ..Default::default() }.is_one_instance_before_loading();
        assert!(at(file("a.OBJ")) && at(file("a.ply")));
        assert!(!at(file("scene.glb")), "a glTF file's nodes");
        assert!(!at(file("scene.GLTF")));
        let object = ObjectSpec { model: knot.clone(), placement: Placement::default() };
        let spec = SceneSpec { model: knot, objects: vec![object], ..Default::default() };
        assert!(!spec.is_one_instance_before_loading(), "placed objects");
    }

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
    fn objects_store_each_model_once_and_place_every_part() {
        let sphere = ModelSource::parse("sphere");
        let at = |x: f32| Placement { translate: Vec3::new(x, 0.0, 0.0), ..Default::default() };
        let spec = SceneSpec {
            models: 2,
            objects: vec![
                ObjectSpec { model: sphere.clone(), placement: at(3.0) },
                ObjectSpec { model: ModelSource::default(), placement: at(-3.0) },
                ObjectSpec { model: sphere.clone(), placement: at(0.0) },
            ],
            ..Default::default()
        };
        assert_eq!(spec.object_sources(), [&sphere], "the main model is not loaded twice");
        let (scene, _) = spec.load().unwrap();
        // The geosphere, the box, the sphere: three meshes for six instances.
        assert_eq!(scene.meshes.len(), 3);
        let meshes: Vec<usize> = scene.instances.iter().map(|i| i.mesh).collect();
        assert_eq!(meshes, [0, 0, 1, 2, 0, 2]);
        assert_eq!(scene.instances[3].transform.translation, Vec3::new(3.0, 0.0, 0.0).into());
        // Placing the copies again keeps the objects and drops the box on request.
        let mut again = scene.clone();
        again.place_copies(1, 0, false);
        let meshes: Vec<usize> = again.instances.iter().map(|i| i.mesh).collect();
        assert_eq!(meshes, [0, 2, 0, 2]);
        // Framing looks at the objects too, not at the box.
        let b = scene.model_bounds();
        assert!(b.min.x < -3.5 && b.max.x > 3.5 && b.max.y < 2.0, "{b:?}");
    }

    #[test]
    fn a_singular_object_is_refused_by_name() {
        let spec = SceneSpec {
            objects: vec![ObjectSpec {
                model: ModelSource::parse("cylinder"),
                placement: Placement { scale: Vec3::new(1.0, 0.0, 1.0), ..Default::default() },
            }],
            ..Default::default()
        };
        let e = spec.validate().unwrap_err();
        assert!(e.starts_with("object 1 (cylinder) has a singular"), "{e}");
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
