//! `view --watch-shaders DIR`: shader hot reload for tuning the tracer itself. The files'
//! modification times are polled (twice a second is quick enough for an edit-save loop and
//! needs no file-watching crate); on a change `DIR/trace.comp` is recompiled and the trace
//! pipeline swapped. A compile error leaves the last good pipeline tracing and is shown in
//! the panel's Render section.

use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime};

use crate::app::status::Status;
use crate::gpu::shader_compile::shader_files;
use crate::gpu::trace_pass::compile_trace_shader;
use crate::gpu::ComputeTracer;

/// How often the files' modification times are read.
const POLL_EVERY: Duration = Duration::from_millis(500);

/// The watched folder and what it looked like at the last compile.
pub(crate) struct ShaderWatch {
    dir: PathBuf,
    /// (file, modified) of every shader file at the last look; None before the first.
    seen: Option<Vec<(PathBuf, Option<SystemTime>)>>,
    next_poll: Instant,
}

impl ShaderWatch {
    /// Watch `dir`; its current shaders are compiled on the first poll (so a folder that
    /// differs from the built-in shaders takes effect at once).
    pub(crate) fn new(dir: PathBuf) -> Self {
        Self { dir, seen: None, next_poll: Instant::now() }
    }

    /// Reload the shader if a file changed since the last look, and put the outcome in
    /// `shown` (the panel's shader status); true when a new shader now traces. Never fails:
    /// errors become the status.
    pub(crate) fn poll(&mut self, tracer: &mut ComputeTracer, shown: &mut Option<Status>) -> bool {
        match self.check(tracer) {
            Some(status) => {
                let reloaded = !status.error;
                *shown = Some(status);
                reloaded
            }
            None => false,
        }
    }

    fn check(&mut self, tracer: &mut ComputeTracer) -> Option<Status> {
        let now = Instant::now();
        if now < self.next_poll {
            return None;
        }
        self.next_poll = now + POLL_EVERY;
        let files = match shader_files(&self.dir) {
            Ok(files) => files,
            Err(e) => {
                return self.changed(vec![]).then(|| {
                    Status::error(format!(
                        "cannot read the shader folder {}: {e}",
                        crate::files::shown_path(&self.dir)
                    ))
                })
            }
        };
        let stamps = files.into_iter().map(|f| {
            let modified = crate::files::modified(&f);
            (f, modified)
        });
        if !self.changed(stamps.collect()) {
            return None;
        }
        let result = compile_trace_shader(&self.dir, tracer.kernel())
            .and_then(|spirv| tracer.reload_shader(&spirv).map_err(|e| format!("{e:#}")));
        Some(match result {
            Ok(()) => Status::ok("shaders reloaded"),
            // The first line names file:line; naga's full report goes to the terminal.
            Err(e) => {
                eprintln!("shader reload failed: {e}");
                let first = e.lines().next().unwrap_or_default();
                Status::error(format!("shader error (keeping the last good one): {first}"))
            }
        })
    }

    /// Record `stamps`; true when they differ from the last ones.
    fn changed(&mut self, stamps: Vec<(PathBuf, Option<SystemTime>)>) -> bool {
        let changed = self.seen.as_ref() != Some(&stamps);
        self.seen = Some(stamps);
        changed
    }
}
