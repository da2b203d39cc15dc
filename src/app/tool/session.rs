//! The tool's session: the model on the CPU side, what has been pushed to the GPU tracer,
//! progressive accumulation, and the model loader. Parameter changes reach the tracer
//! here, each on the next frame.

use crate::gpu::{ComputeTracer, FrameTrace};
use crate::progress::Phase;
use crate::render_settings::{Accel, Aov, BvhLayout};
use crate::scene::paper::ModelSource;
use crate::scene::spec::SceneSpec;
use crate::scene::{EnvironmentSource, Scene};
use crate::tracer::frame::FrameParams;
use crate::tracer::packed::PackedTopLevel;
use crate::tracer::packed::SceneHolds;
use crate::tracer::textures::EnvironmentMap;

use crate::app::panel::widgets::{group, Status};
use crate::app::panel::PanelState;
use crate::app::state::{Params, Resolution};
use crate::app::tool::auto_layout::{AutoLayout, Work};
use crate::app::user_files::model_loader::{LoadedModel, ModelLoader, Poll};

/// The current model on the CPU side.
pub(crate) struct Model {
    pub(crate) source: ModelSource,
    pub(crate) scene: Scene,
    /// What the host keeps of the packed scene once uploaded: the mesh table, for
    /// instance rebuilds.
    /// Its `has_wide()`: the wide BVH layout was packed with it (only when asked for: see
    /// `apply`).
    pub(crate) top_level: PackedTopLevel,
}

/// What the tracer holds now; None = not applied yet (or to be applied again).
#[derive(Default)]
struct Applied {
    /// (model count, mirror box) of the instance list.
    instances: Option<(u32, u32, bool)>,
    resolution: Option<[u32; 2]>,
    environment: Option<Option<EnvironmentSource>>,
}

/// Progressive accumulation: the frame last traced (with `frame_index` 0) and how many
/// frames have been averaged into the output since anything changed (either half of a
/// split frame, or the line).
#[derive(Default)]
pub(crate) struct Accumulation {
    last: Option<FrameTrace>,
    /// Frames averaged into the image shown.
    pub(crate) frames: u32,
}

/// The model, the loader and the tracer's state.
#[derive(Default)]
pub(crate) struct Session {
    pub(crate) model: Option<Model>,
    pub(crate) loader: ModelLoader,
    applied: Applied,
    pub(crate) accumulation: Accumulation,
    /// The model shown was sent to be loaded again with the wide layout (once per model).
    wide_asked: bool,
    /// Models installed so far (the measured layout choice starts over at each).
    installs: u64,
    /// The measured choice of BVH layout, when `Params::bvh_auto`.
    pub(crate) auto_layout: AutoLayout,
}

impl Session {
    /// Start loading `source`, now the scene's model (the current one stays on screen
    /// until the new one is ready).
    pub(crate) fn start_load(
        &mut self,
        source: ModelSource,
        params: &mut Params,
        panel: &mut PanelState,
    ) {
        // The measured choice loads binary first (the quickest first frame); the wide tree follows.
        let layout = if params.bvh_auto { BvhLayout::Binary } else { params.scene.settings.bvh };
        self.load_with(source, layout, params, panel);
    }

    /// [`Session::start_load`] with the layouts to pack for `layout`.
    fn load_with(
        &mut self,
        source: ModelSource,
        layout: BvhLayout,
        params: &mut Params,
        panel: &mut PanelState,
    ) {
        panel.model.status = None;
        panel.model.warnings.clear();
        params.scene.model = source.clone();
        let mut spec = SceneSpec { model: source, ..params.scene.clone() };
        spec.settings.bvh = layout;
        // `apply` decodes and uploads the environment as it changes, not with the model.
        spec.environment = None;
        self.loader.start(spec);
    }

    /// Stop the load in progress (Escape, the panel's Cancel): the model shown stays. The
    /// first load has no model to fall back on, so it runs on.
    pub(crate) fn cancel_load(&mut self, panel: &mut PanelState) {
        let Some(shown) = self.model.as_ref().map(|m| m.source.label()) else { return };
        if let Some(label) = self.loader.cancel() {
            panel.model.status =
                Some(Status::ok(format!("stopped loading {label}; keeping {shown}")));
        }
    }

    /// Take a finished load: upload it, or keep the old model and say why not. With no
    /// model to fall back on, a failed load ends the run (the error is returned).
    pub(crate) fn poll_loader(
        &mut self,
        tracer: &mut ComputeTracer,
        panel: &mut PanelState,
    ) -> anyhow::Result<Option<String>> {
        let result = match self.loader.poll() {
            Poll::Idle | Poll::Busy => return Ok(None),
            Poll::Done(result) => *result,
        };
        let first = self.model.is_none();
        match result
            .and_then(|loaded| self.install(loaded, tracer, panel).map_err(|e| format!("{e:#}")))
        {
            Ok(title) => Ok(Some(title)),
            Err(e) if first => Err(anyhow::anyhow!("{e}")),
            Err(e) => {
                let keeping = self.model.as_ref().map_or(String::new(), |m| m.source.label());
                panel.model.status = Some(Status::error(format!("{e}; keeping {keeping}")));
                Ok(None)
            }
        }
    }

    /// Upload a loaded model; returns the window title it asks for.
    fn install(
        &mut self,
        loaded: LoadedModel,
        tracer: &mut ComputeTracer,
        panel: &mut PanelState,
    ) -> anyhow::Result<String> {
        let LoadedModel { source, scene: mut loaded, progress } = loaded;
        // Not cancelled: the loader hands over only loads it still wants.
        let _ = progress.begin(Phase::Upload);
        tracer.set_loaded_scene(&loaded)?;
        progress.finish();
        let phases = progress.snapshot();
        let seconds = phases.total_seconds();
        let each: Vec<String> =
            phases.phases.iter().map(|p| format!("{} {:.2}", p.phase.name(), p.seconds)).collect();
        // The GPU has the geometry now: keep only what instance changes need.
        let warnings = std::mem::take(&mut loaded.warnings);
        let (scene, top_level) = loaded.uploaded();
        // The same model again, now with the wide tree: the wide layout's (or auto's) load.
        let again =
            self.model.as_ref().is_some_and(|m| m.source == source && !m.top_level.has_wide())
                && top_level.has_wide();
        let what = if again { "loaded the wide BVH layout of" } else { "loaded" };
        // The loader's and the packing's warnings (textures that could not be read) are shown
        // in the panel, and printed once on the terminal: not again with the wide tree.
        if !again {
            for w in &warnings {
                log::warn!("{w}");
            }
        }
        let text = format!(
            "{what} {} ({} triangles) in {seconds:.2} s ({} s)",
            source.label(),
            group(scene.meshes[0].triangle_count() as u64),
            each.join(", ")
        );
        panel.model.status = Some(match warnings.first() {
            Some(w) => Status::ok(format!("{text}; {} warning(s), the first: {w}", warnings.len())),
            None => Status::ok(text),
        });
        panel.model.warnings = warnings;
        if let ModelSource::File(path) = &source {
            panel.model.loaded(&std::path::absolute(path).unwrap_or_else(|_| path.clone()));
        }
        let title = format!("meshtracer — {}", source.label());
        // The new scene's instance list and environment are the loader's defaults: apply ours.
        self.applied.instances = None;
        self.applied.environment = None;
        self.accumulation = Accumulation::default();
        self.wide_asked = false;
        self.installs += 1;
        self.model = Some(Model { source, scene, top_level });
        Ok(title)
    }

    /// Push parameter changes to the tracer (each takes effect this frame); `area` is the
    /// image area in physical pixels.
    pub(crate) fn apply(
        &mut self,
        params: &mut Params,
        area: [u32; 2],
        tracer: &mut ComputeTracer,
        panel: &mut PanelState,
    ) -> anyhow::Result<()> {
        // The wide layout is packed only on request (its collapse takes as long as the
        // build): a model loaded without it is loaded again, once; binary frames meanwhile.
        let settings = &params.scene.settings;
        let wants_wide = settings.bvh.is_wide() || params.bvh_auto;
        if settings.accel == Accel::Bvh
            && wants_wide
            && !self.wide_asked
            && self.loader.status().is_none()
        {
            if let Some(source) =
                self.model.as_ref().filter(|m| !m.top_level.has_wide()).map(|m| m.source.clone())
            {
                self.wide_asked = true;
                self.load_with(source, BvhLayout::Wide, params, panel);
            }
        }
        let size = params.render_size(area);
        if self.applied.resolution != Some(size) {
            match tracer.set_resolution(size[0], size[1]) {
                Ok(()) => panel.render.status = None,
                Err(e) => {
                    // Too big for this device: say so and go back to what worked.
                    let [w, h] = size;
                    panel.render.status = Some(Status::error(format!("{w} x {h} failed: {e:#}")));
                    params.resolution = Resolution::Custom;
                    params.custom = self.applied.resolution.unwrap_or([256, 256]);
                    tracer.set_resolution(params.custom[0], params.custom[1])?;
                }
            }
            self.applied.resolution = tracer.resolution();
        }
        let Some(model) = &mut self.model else { return Ok(()) };
        let want = (params.scene.models, params.scene.scatter, params.scene.mirror_box);
        if self.applied.instances != Some(want) {
            let s = &params.scene;
            model.scene.place_copies(s.models, s.scatter, s.mirror_box);
            model.top_level.set_instances(&model.scene.instances);
            tracer.set_instances(&model.top_level.top_level)?;
            if let Some((before, _, _)) = self.applied.instances {
                params.follow_field(before);
            }
            self.applied.instances = Some(want);
            self.accumulation = Accumulation::default();
        }
        // A's misses see `params.scene.environment`; the split's B may ask for one when A has
        // none: the sky is uploaded then (A's frames do not sample it).
        model.scene.environment = params.scene.environment.clone();
        let b_sky = params.split.enabled && params.split.b.wants_environment();
        let upload =
            params.scene.environment.clone().or_else(|| b_sky.then_some(EnvironmentSource::Sky));
        if self.applied.environment.as_ref() != Some(&upload) {
            let (map, warning) = EnvironmentMap::from_source(upload.as_ref());
            if let Some(w) = warning {
                panel.render.status = Some(Status::error(w));
            }
            tracer.set_environment(map.as_ref())?;
            self.applied.environment = Some(upload);
            self.accumulation = Accumulation::default();
        }
        Ok(())
    }

    /// With `Params::bvh_auto`, set the layout the next frame traces: binary until the wide
    /// tree is loaded and the tracer's kernels are made (`kernels_ready`: the trial neither
    /// waits for one nor times a layout on a stand-in), then each in turn until all are
    /// timed, then the fastest. Not while the split view is on (its halves would share the
    /// frame's time).
    pub(crate) fn pick_layout(&mut self, params: &mut Params, area: [u32; 2], kernels_ready: bool) {
        let Some(model) = self.model.as_ref().filter(|_| params.bvh_auto && !params.split.enabled)
        else {
            return;
        };
        let work = Work::new(
            params.settings_for(area),
            params.scene.models,
            params.scene.mirror_box,
            self.installs,
        );
        if let Some(layout) =
            self.auto_layout.next_layout(work, model.top_level.has_wide() && kernels_ready)
        {
            params.scene.settings.bvh = layout;
        }
    }

    /// This frame's parameters (None without a model), split or not, counting accumulated
    /// frames; with `hold`, an unchanged frame keeps its index (a long frame still being
    /// traced).
    pub(crate) fn frame_params(
        &mut self,
        params: &Params,
        area: [u32; 2],
        hold: bool,
    ) -> Option<FrameTrace> {
        let model = self.model.as_mut()?;
        model.scene.camera = params.camera;
        model.scene.light.position = params.light_position();
        let mesh_bounds: Vec<_> = model.top_level.meshes.iter().map(|m| m.bounds).collect();
        let bounds = model.scene.bounds_with(&mesh_bounds);
        let mut frame = params.split.frame(FrameParams::with_bounds(
            &model.scene,
            params.settings_for(area),
            bounds,
        ));
        // Average frames while nothing changes; any change starts afresh.
        let acc = &mut self.accumulation;
        let still = params.accumulate
            && matches!(frame.params.settings.aov, Aov::Color | Aov::Ao)
            && acc.last == Some(frame);
        if hold && acc.last == Some(frame) {
            set_index(&mut frame, acc.frames.max(1) - 1);
            return Some(frame);
        }
        acc.frames = if still { acc.frames.saturating_add(1).min(1 << 20) } else { 1 };
        acc.last = Some(frame);
        set_index(&mut frame, acc.frames - 1);
        Some(frame)
    }

    /// The model's label, for file names ("none" before the first load).
    pub(crate) fn model_label(&self) -> String {
        self.model.as_ref().map_or("none".into(), |m| m.source.label())
    }

    /// What the scene shown holds (None before the first load).
    pub(crate) fn holds(&self) -> Option<SceneHolds> {
        self.model.as_ref().map(|m| m.top_level.holds(&m.scene))
    }

    /// Triangles and vertices in the world (all instances).
    pub(crate) fn counts(&self) -> (u64, u64) {
        self.model
            .as_ref()
            .map_or((0, 0), |m| (m.scene.triangle_count() as u64, m.scene.vertex_count() as u64))
    }
}

/// Both halves of a frame accumulate in step: each pixel's running mean is its own half's.
fn set_index(frame: &mut FrameTrace, index: u32) {
    frame.params.frame_index = index;
    if let Some(split) = &mut frame.split {
        split.params.frame_index = index;
    }
}
