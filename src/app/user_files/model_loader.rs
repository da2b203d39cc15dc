//! Loading a model off the UI thread: [`LoadedScene::load`] (reading and parsing the file
//! or generating a paper model, building its BVH and packing it, as `bench --load` measures
//! it) runs on a worker thread that reports each phase through a [`Progress`]; the window
//! keeps drawing the old model until the new one is ready, keeps it if loading fails, and
//! can cancel a load (Escape) at the next phase.

use std::sync::mpsc::{channel, Receiver, TryRecvError};
use std::thread;

use crate::gpu::scene_buffers::check_before_build;
use crate::progress::{Progress, Snapshot};
use crate::scene::paper::ModelSource;
use crate::scene::spec::SceneSpec;
use crate::tracer::loaded::LoadedScene;
use crate::tracer::packed::{DeviceFit, Layouts};

/// A loaded model, ready to upload.
pub(crate) struct LoadedModel {
    pub(crate) source: ModelSource,
    /// The scene around it, packed for its upload (with the loader's warnings).
    pub(crate) scene: LoadedScene,
    /// Its phases so far (the upload, on the UI thread, is still to come).
    pub(crate) progress: Progress,
}

/// What a poll of the loader found.
pub(crate) enum Poll {
    /// Nothing running.
    Idle,
    /// Still working.
    Busy,
    /// Finished (the error is one sentence).
    Done(Box<Result<LoadedModel, String>>),
}

/// A running load, if any.
#[derive(Default)]
pub(crate) struct ModelLoader {
    job: Option<Job>,
    /// The tracing device: a model whose triangles pass its storage-buffer range is refused
    /// before its BVH is built, and it builds the BVHs of the biggest meshes itself.
    device: DeviceFit,
}

struct Job {
    label: String,
    progress: Progress,
    rx: Receiver<Result<LoadedModel, String>>,
}

/// What the panel shows of a running load.
pub(crate) struct LoadStatus<'a> {
    /// The model being loaded.
    pub(crate) label: &'a str,
    /// Its phases so far, the running one last.
    pub(crate) snapshot: Snapshot,
}

impl ModelLoader {
    /// Start loading `spec`'s model into the scene it describes (its copies, light and BVH
    /// layout); a load already running is cancelled (its thread stops at its next phase,
    /// its result dropped).
    pub(crate) fn start(&mut self, spec: SceneSpec) {
        self.cancel();
        let device = self.device;
        let (tx, rx) = channel();
        let label = spec.model.label();
        let progress = Progress::default();
        let spawned = thread::Builder::new().name("model loader".into()).spawn({
            let progress = progress.clone();
            move || {
                let result = load(spec, progress, device);
                // The receiver is gone when the load was cancelled: nothing to tell.
                let _ = tx.send(result);
            }
        });
        match spawned {
            Ok(_) => self.job = Some(Job { label, progress, rx }),
            Err(e) => {
                // Report through the same path as a failed load.
                let (tx, rx) = channel();
                let _ = tx.send(Err(format!("could not start the loader thread: {e}")));
                self.job = Some(Job { label, progress, rx });
            }
        }
    }

    /// Load for `device`: refuse models whose triangle buffer would pass its storage-buffer
    /// range before building them, and leave it the trees it builds.
    pub(crate) fn set_device(&mut self, device: DeviceFit) {
        self.device = device;
    }

    /// Stop the running load, if any: the old model stays. Returns the cancelled model's label.
    pub(crate) fn cancel(&mut self) -> Option<String> {
        let job = self.job.take()?;
        job.progress.cancel();
        Some(job.label)
    }

    /// True while a load runs (the tests' check; the tool polls).
    #[cfg(test)]
    pub(crate) fn busy(&self) -> bool {
        self.job.is_some()
    }

    /// The model being loaded and its phases so far.
    pub(crate) fn status(&self) -> Option<LoadStatus<'_>> {
        self.job.as_ref().map(|j| LoadStatus { label: &j.label, snapshot: j.progress.snapshot() })
    }

    /// Take the result when it is there.
    pub(crate) fn poll(&mut self) -> Poll {
        let Some(job) = self.job.as_mut() else { return Poll::Idle };
        let result = match job.rx.try_recv() {
            Ok(result) => result,
            Err(TryRecvError::Empty) => return Poll::Busy,
            Err(TryRecvError::Disconnected) => Err("the loader thread stopped unexpectedly".into()),
        };
        self.job = None;
        Poll::Done(Box::new(result))
    }

    /// Block until the running load finishes (for the tests; the tool polls each frame).
    #[cfg(test)]
    pub(crate) fn wait(&mut self) -> Poll {
        loop {
            match self.poll() {
                Poll::Busy => thread::sleep(std::time::Duration::from_millis(5)),
                other => return other,
            }
        }
    }
}

/// The worker's part: read and parse (or generate), check the triangles against the
/// `device`'s storage-buffer range, build, pack; stops between phases when cancelled.
fn load(spec: SceneSpec, progress: Progress, device: DeviceFit) -> Result<LoadedModel, String> {
    let (model, others, warnings) = spec.load_models(Some(&progress)).map_err(|e| e.to_string())?;
    let world = spec.scene_of(model, &others);
    if let Some(limit) = device.storage_range {
        check_before_build(&world, &spec.model.label(), limit)?;
    }
    let layouts = Layouts::switchable(spec.settings.bvh);
    let mut scene =
        LoadedScene::pack(world, layouts, &progress, device).map_err(|e| e.to_string())?;
    scene.warnings.splice(0..0, warnings);
    progress.checkpoint().map_err(|e| e.to_string())?;
    // The pack phase ends here, not when the window takes the model: the first frame's
    // kernels may keep the window busy for seconds, which is no packing (issue #43).
    progress.finish();
    Ok(LoadedModel { source: spec.model, scene, progress })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Phase;
    use crate::scene::primitives::PaperModel;

    /// The default scene around `model`, with `models` copies.
    fn spec(model: ModelSource, models: u32) -> SceneSpec {
        SceneSpec { model, models, ..Default::default() }
    }

    #[test]
    fn loads_on_a_thread_and_reports_errors_as_one_sentence() {
        let mut loader = ModelLoader::default();
        assert!(matches!(loader.poll(), Poll::Idle));
        loader.start(spec(ModelSource::Paper(PaperModel::Sphere), 2));
        assert!(loader.busy());
        let Poll::Done(result) = loader.wait() else { panic!("no result") };
        let loaded = result.unwrap();
        assert_eq!(loaded.scene.scene().instances.len(), 3);
        assert_eq!(
            loaded.scene.triangle_count(),
            loaded.scene.scene().meshes.iter().map(|m| m.triangle_count()).sum::<usize>()
        );
        assert!(!loader.busy());

        loader.start(spec(ModelSource::File("/nonexistent/model.obj".into()), 1));
        let Poll::Done(result) = loader.wait() else { panic!("no result") };
        let err = result.err().unwrap();
        assert!(!err.contains('\n'), "{err}");
    }

    #[test]
    fn a_cancelled_load_keeps_the_old_model_and_starts_no_phase() {
        let mut loader = ModelLoader::default();
        loader.start(spec(ModelSource::Generated(2_000), 1));
        assert!(loader.cancel().is_some_and(|label| label.starts_with("torusknot")));
        assert!(matches!(loader.poll(), Poll::Idle), "the old model stays: nothing to take");
        assert!(loader.cancel().is_none());

        // The worker checks the flag before each phase.
        let progress = Progress::default();
        progress.cancel();
        let err = load(spec(ModelSource::Generated(2_000), 1), progress.clone(), DeviceFit::NONE)
            .err()
            .unwrap();
        assert_eq!(err, "loading was cancelled");
        assert!(progress.snapshot().phases.is_empty());
    }

    #[test]
    fn a_finished_load_lists_its_phases_in_order() {
        let mut loader = ModelLoader::default();
        loader.start(spec(ModelSource::Generated(2_000), 1));
        let status = loader.status().unwrap();
        assert!(status.label.starts_with("torusknot"), "{}", status.label);
        let Poll::Done(result) = loader.wait() else { panic!("no result") };
        let phases: Vec<Phase> =
            result.unwrap().progress.snapshot().phases.iter().map(|p| p.phase).collect();
        assert_eq!(phases, [Phase::Parse, Phase::Build, Phase::Pack]);
    }

    /// Issue #43, point 10: the worker closes its last phase when it is done, so the time
    /// the window takes to pick the model up (the first frame's kernels) is not counted as
    /// packing; the upload is a phase of its own after it.
    #[test]
    fn the_pack_phase_ends_with_the_worker() {
        let progress = Progress::default();
        let loaded =
            load(spec(ModelSource::Generated(2_000), 1), progress.clone(), DeviceFit::NONE)
                .unwrap();
        let snapshot = loaded.progress.snapshot();
        assert!(snapshot.phases.iter().all(|p| p.done), "{:?}", snapshot.phases);
        let pack = snapshot.seconds(Phase::Pack);
        // What the window does next: the upload begins later, as its own phase.
        progress.begin(Phase::Upload).unwrap();
        progress.finish();
        let after = progress.snapshot();
        assert_eq!(after.seconds(Phase::Pack), pack, "the pack phase went on after the worker");
        assert_eq!(after.phases.last().map(|p| p.phase), Some(Phase::Upload));
    }

    /// Issue #43: a model whose triangle buffer passes the device's storage-buffer limit is
    /// refused with the upload's message before its BVH is built (no build phase begins).
    #[test]
    fn a_model_past_the_storage_limit_is_refused_before_its_build() {
        use crate::gpu::scene_buffers::check_triangle_count;
        let item = std::mem::size_of::<crate::tracer::packed::GpuTriangle>() as u64;
        assert!(check_triangle_count(1000, 1000 * item + 48).is_ok());
        let err = check_triangle_count(1001, 1000 * item + 48).unwrap_err().to_string();
        assert_eq!(
            err,
            format!(
                "the scene does not fit this GPU: the triangle buffer needs {} bytes but the \
                 device allows {} per storage buffer",
                1001 * item + 48,
                1000 * item + 48
            )
        );
        // 4M triangles on lavapipe's 128 MiB: the numbers.
        let err = check_triangle_count(4_000_012, 134_217_728).unwrap_err().to_string();
        assert!(err.contains("needs 160000528 bytes but the device allows 134217728"), "{err}");

        let within = |bytes| DeviceFit { storage_range: Some(bytes), builds_from: None };
        let progress = Progress::default();
        let knot = spec(ModelSource::Generated(2_000), 1);
        let err = load(knot.clone(), progress.clone(), within(2_000 * item)).err().unwrap();
        assert!(err.contains("the triangle buffer needs"), "{err}");
        assert!(err.contains("triangles, before its BVH is built"), "{err}");
        let phases: Vec<Phase> = progress.snapshot().phases.iter().map(|p| p.phase).collect();
        assert_eq!(phases, [Phase::Parse], "refused before the build");
        assert!(load(knot, Progress::default(), within(1 << 30)).is_ok());

        let mut loader = ModelLoader::default();
        loader.set_device(within(2_000 * item));
        loader.start(spec(ModelSource::Generated(2_000), 1));
        let Poll::Done(result) = loader.wait() else { panic!("no result") };
        assert!(result.err().unwrap().contains("the triangle buffer needs"));
    }
}
