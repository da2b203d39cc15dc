//! Scripted runs and exiting: `--frames N` quits after N traced frames, writing
//! `--screenshot` and `--screenshot-ui`; a close request draws one more frame first.

use std::path::PathBuf;

/// How far a run is from its end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Exit {
    Running,
    /// Draw one more frame (capturing the window if asked), write the files, quit.
    Requested,
}

/// The scripted part of a run: its frame budget, the files to write at exit, the exit state.
pub(crate) struct ScriptedRun {
    /// Quit after this many traced frames.
    pub(crate) frame_limit: Option<u64>,
    /// Frames presented with a traced scene (what `--frames` counts).
    pub(crate) frames: u64,
    /// The traced image at exit.
    pub(crate) screenshot: Option<PathBuf>,
    /// The window as seen at exit.
    pub(crate) screenshot_ui: Option<PathBuf>,
    exit: Exit,
    /// Tries at drawing the final frame (a skipped frame is retried a few times).
    exit_attempts: u32,
}

impl ScriptedRun {
    /// A run ending after `frame_limit` traced frames (never, without one).
    pub(crate) fn new(
        frame_limit: Option<u64>,
        screenshot: Option<PathBuf>,
        screenshot_ui: Option<PathBuf>,
    ) -> Self {
        Self {
            frame_limit,
            frames: 0,
            screenshot,
            screenshot_ui,
            exit: Exit::Running,
            exit_attempts: 0,
        }
    }

    /// Quit after the next frame (window closed, Ctrl+Q).
    pub(crate) fn request_exit(&mut self) {
        self.exit = Exit::Requested;
    }

    /// The frame about to be drawn is the last one (`traced`: it traces the scene).
    pub(crate) fn is_final_frame(&self, traced: bool) -> bool {
        let scripted_last = traced && self.frame_limit.is_some_and(|n| self.frames + 1 >= n);
        scripted_last || self.exit == Exit::Requested
    }

    /// The final frame was drawn (or could not be, `gave_up`): true when the run ends now.
    pub(crate) fn finish_attempt(&mut self, presented: bool, cannot_draw: bool) -> bool {
        if presented || cannot_draw || self.exit_attempts >= 10 {
            return true;
        }
        self.exit_attempts += 1;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripted_runs_end_on_their_last_traced_frame() {
        let mut run = ScriptedRun::new(Some(2), None, None);
        assert!(!run.is_final_frame(true));
        run.frames = 1;
        assert!(!run.is_final_frame(false), "frames without a scene do not count");
        assert!(run.is_final_frame(true));
        let mut open = ScriptedRun::new(None, None, None);
        assert!(!open.is_final_frame(true));
        open.request_exit();
        assert!(open.is_final_frame(false));
        // A skipped final frame is retried, then given up on.
        assert!((0..10).all(|_| !open.finish_attempt(false, false)));
        assert!(open.finish_attempt(false, false));
    }
}
