//! Loading a model off the UI thread: parsing the .obj (or generating a paper model) and
//! building its BVH run on a worker thread that reports its stage; the window keeps
//! drawing the old model until the new one is ready, and keeps it if loading fails.

use std::sync::mpsc::{channel, Receiver, TryRecvError};
use std::thread;
use std::time::Instant;

use crate::scene::Scene;
use crate::scene::obj::LoadOptions;
use crate::scene::paper::{paper_scene, LightOrbit, ModelSource};
use crate::tracer::packed::PackedScene;

/// A loaded model, ready to upload.
pub(crate) struct LoadedModel {
    pub(crate) source: ModelSource,
    pub(crate) scene: Scene,
    pub(crate) packed: PackedScene,
    pub(crate) warnings: Vec<String>,
    pub(crate) seconds: f64,
}

enum Message {
    Stage(String),
    Done(Box<Result<LoadedModel, String>>),
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
}

struct Job {
    label: String,
    stage: String,
    started: Instant,
    rx: Receiver<Message>,
}

impl ModelLoader {
    /// Start loading `source` (a file with `options`) for `model_count` copies; a load
    /// already running is abandoned (its thread finishes on its own and its result is dropped).
    pub(crate) fn start(&mut self, source: ModelSource, options: LoadOptions, model_count: u32, light: LightOrbit) {
        let (tx, rx) = channel();
        let label = source.label();
        let first_stage = match &source {
            ModelSource::File(p) => format!("reading {}", p.display()),
            ModelSource::Paper(m) => format!("generating the {}", m.name()),
            ModelSource::Generated(n) => format!("generating a torus knot of {n} triangles"),
        };
        let spawned = thread::Builder::new().name("model loader".into()).spawn({
            let first_stage = first_stage.clone();
            move || {
                let started = Instant::now();
                let _ = tx.send(Message::Stage(first_stage));
                let result = source.check_name().and_then(|()| source.load_with(&options).map_err(|e| e.to_string())).and_then(|(mesh, warnings)| {
                    let _ = tx.send(Message::Stage(format!("building the BVH ({} triangles)", mesh.triangle_count())));
                    if mesh.triangle_count() == 0 {
                        return Err(format!("{} has no triangles", source.label()));
                    }
                    let scene = paper_scene(mesh, model_count, light);
                    let mut packed = PackedScene::new(&scene);
                    // Textures that could not be read join the loader's warnings in the panel,
                    // and each is printed once on the terminal.
                    let warnings: Vec<String> = warnings.into_iter().chain(packed.warnings.drain(..)).collect();
                    for w in &warnings {
                        log::warn!("{w}");
                    }
                    Ok(LoadedModel { source, scene, packed, warnings, seconds: started.elapsed().as_secs_f64() })
                });
                let _ = tx.send(Message::Done(Box::new(result)));
            }
        });
        match spawned {
            Ok(_) => self.job = Some(Job { label, stage: first_stage, started: Instant::now(), rx }),
            Err(e) => {
                // Report through the same path as a failed load.
                let (tx, rx) = channel();
                let _ = tx.send(Message::Done(Box::new(Err(format!("could not start the loader thread: {e}")))));
                self.job = Some(Job { label, stage: String::new(), started: Instant::now(), rx });
            }
        }
    }

    /// True while a load runs (the tests' check; the tool polls).
    #[cfg(test)]
    pub(crate) fn busy(&self) -> bool {
        self.job.is_some()
    }

    /// The model being loaded, its current stage and seconds so far.
    pub(crate) fn status(&self) -> Option<(&str, &str, f64)> {
        self.job.as_ref().map(|j| (j.label.as_str(), j.stage.as_str(), j.started.elapsed().as_secs_f64()))
    }

    /// Take any progress and the result when it is there.
    pub(crate) fn poll(&mut self) -> Poll {
        let Some(job) = self.job.as_mut() else { return Poll::Idle };
        loop {
            match job.rx.try_recv() {
                Ok(Message::Stage(s)) => job.stage = s,
                Ok(Message::Done(result)) => {
                    self.job = None;
                    return Poll::Done(result);
                }
                Err(TryRecvError::Empty) => return Poll::Busy,
                Err(TryRecvError::Disconnected) => {
                    self.job = None;
                    return Poll::Done(Box::new(Err("the loader thread stopped unexpectedly".into())));
                }
            }
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::primitives::PaperModel;

    #[test]
    fn loads_on_a_thread_and_reports_errors_as_one_sentence() {
        let mut loader = ModelLoader::default();
        assert!(matches!(loader.poll(), Poll::Idle));
        loader.start(ModelSource::Paper(PaperModel::Sphere), LoadOptions::default(), 2, LightOrbit::default());
        assert!(loader.busy());
        let Poll::Done(result) = loader.wait() else { panic!("no result") };
        let loaded = result.unwrap();
        assert_eq!(loaded.scene.instances.len(), 3);
        assert!(!loaded.packed.triangles.is_empty());
        assert!(!loader.busy());

        loader.start(ModelSource::File("/nonexistent/model.obj".into()), LoadOptions::default(), 1, LightOrbit::default());
        let Poll::Done(result) = loader.wait() else { panic!("no result") };
        let err = result.err().unwrap();
        assert!(!err.contains('\n'), "{err}");
    }
}
