//! What the tool saves and reads besides the frame: screenshots (as [`Captures`] asks),
//! presets saved and loaded from the panel, the files a scripted run writes at exit, the
//! frame-time log and the remembered settings.
//!
//! [`Captures`]: super::captures::Captures

use std::path::Path;

use anyhow::{anyhow, Context as _};

use winit::dpi::LogicalSize;

use crate::app::options::DEFAULT_WINDOW;
use crate::app::panel::remembered;
use crate::app::panel::widgets::Status;
use crate::app::tool::Tool;
use crate::app::user_files::screenshot::{self, Kind, NameParts};
use crate::app::views::overlay::Notice;
use crate::render_settings::{BvhLayout, ACCUMULATE};
use crate::scene::preset::{self, Loaded, SaveError};
use crate::scene::spec::SceneSpec;

impl Tool {
    /// The preset of the image seen, for a saved preset and the screenshots' text chunk
    /// alike: with the frames accumulated into it, so that `render --preset` of either
    /// traces the same image, and no layout named while the window picks it (auto).
    fn preset_spec(&self) -> SceneSpec {
        preset_of(self.scene_spec(), self.session.accumulation.frames, self.params.bvh_auto)
    }

    /// The preset text of [`Self::preset_spec`].
    pub(super) fn settings_text(&self) -> String {
        self.preset_spec().to_preset_text()
    }

    /// Save the look as a preset; an existing file is replaced only once the user agreed.
    pub(super) fn save_preset(&mut self, path: &Path, overwrite: bool) {
        let result = preset::save(&self.preset_spec(), path, overwrite);
        let presets = &mut self.ui.panel.presets;
        presets.warnings.clear();
        match result {
            Ok(()) => {
                presets.status =
                    Some(Status::ok(format!("saved {}", crate::files::shown_path(path))));
                presets.used(path);
            }
            Err(SaveError::Exists(p)) => {
                presets.status = None;
                presets.confirm = Some(p);
            }
            Err(e) => presets.status = Some(Status::error(e.to_string())),
        }
    }

    /// Take the look of a preset file; a model other than the one shown is loaded.
    pub(super) fn load_preset(&mut self, path: &Path) {
        match preset::read(path) {
            Ok(Loaded { spec, warnings }) => {
                let options = self.params.scene.load_options;
                let objects = self.params.scene.objects.clone();
                self.params.apply_preset(&spec);
                // Another model or other objects, or the same read another way
                // (--crease-angle): load them.
                let shown = self.session.model.as_ref().map(|m| &m.source);
                if shown != Some(&spec.model)
                    || self.params.scene.load_options != options
                    || self.params.scene.objects != objects
                {
                    self.session.start_load(
                        spec.model.clone(),
                        &mut self.params,
                        &mut self.ui.panel,
                    );
                }
                let presets = &mut self.ui.panel.presets;
                presets.status = Some(Status::ok(format!(
                    "loaded {}{}",
                    crate::files::shown_path(path),
                    if warnings.is_empty() {
                        String::new()
                    } else {
                        format!("; {} warning(s):", warnings.len())
                    }
                )));
                presets.warnings = warnings;
                presets.used(path);
            }
            Err(e) => self.ui.panel.presets.status = Some(Status::error(e)),
        }
    }

    pub(super) fn name_parts(&self) -> NameParts {
        let [width, height] = self.gpu.tracer.resolution().unwrap_or_default();
        NameParts {
            model: self.session.model_label(),
            models: self.params.scene.models,
            width,
            height,
            bounces: self.params.scene.settings.bounces,
            blend: self.params.scene.settings.blend,
        }
    }

    /// The last screenshot's outcome, also over the image for a moment (the panel may be hidden).
    pub(super) fn notice_screenshot(&mut self) {
        if let Some(s) = &self.ui.panel.screenshot.status {
            self.captures.notice = Some(Notice::new(s.text.clone()));
        }
    }

    /// Write the float output of the last traced frame (the view's AOV) as OpenEXR.
    pub(super) fn save_exr(&self, path: &Path) -> Status {
        if !self.frame.traced {
            return Status::error("nothing traced yet: no EXR written");
        }
        match self.gpu.tracer.read_image() {
            Ok(image) => screenshot::status(
                image.save(path, self.params.view.aov(), None).map_err(|e| format!("{e:#}")),
                path,
            ),
            Err(e) => Status::error(format!("reading the traced image failed: {e:#}")),
        }
    }

    /// The traced image as shown (the heat map in the cost view); None before the first frame.
    pub(super) fn read_trace(&self) -> anyhow::Result<Option<image::RgbaImage>> {
        if !self.frame.traced {
            return Ok(None);
        }
        if let Some(h) = &self.frame.picture {
            return Ok(image::RgbaImage::from_raw(h.width, h.height, h.rgba.clone()));
        }
        Ok(Some(self.gpu.tracer.read_rgba8()?))
    }

    pub(super) fn save_trace(&self, path: &Path) -> Status {
        match self.read_trace() {
            Ok(Some(img)) => {
                screenshot::status(screenshot::save_png(&img, &self.settings_text(), path), path)
            }
            Ok(None) => Status::error("nothing traced yet: no screenshot written"),
            Err(e) => Status::error(format!("reading the traced image failed: {e:#}")),
        }
    }

    /// `--screenshot` / `--screenshot-ui` at exit; failures end the run with an error.
    pub(super) fn write_exit_files(
        &mut self,
        window_image: Option<Result<image::RgbaImage, String>>,
    ) -> anyhow::Result<()> {
        if let Some(line) = self.timing.recorder.finish().map_err(anyhow::Error::msg)? {
            println!("{line}");
        }
        if let Some(path) = &self.script.screenshot {
            let img = self.read_trace()?.context("--screenshot: nothing was traced before exit")?;
            screenshot::save_png(&img, &self.settings_text(), path).map_err(anyhow::Error::msg)?;
            println!("wrote {}", crate::files::shown_path(path));
        }
        if let Some(path) = &self.script.screenshot_ui {
            let img = window_image
                .context("--screenshot-ui: the window was not drawn at exit (minimized?)")?
                .map_err(|e| anyhow!("--screenshot-ui: {e}"))?;
            screenshot::save_png(&img, &self.settings_text(), path).map_err(anyhow::Error::msg)?;
            println!("wrote {}", crate::files::shown_path(path));
        }
        Ok(())
    }

    /// Remember the window's size, the panel's sections and the recent presets (unless the
    /// run does not persist), and close a frame-time log still open.
    pub(super) fn remember(&mut self) {
        let _ = self.timing.recorder.finish();
        let size = self.window.inner_size().to_logical::<u32>(self.window.scale_factor());
        let window = (size.width > 0 && size.height > 0).then_some([size.width, size.height]);
        self.store.save(&remembered::snapshot(window, &self.ui.panel, &self.ui.egui_ctx));
    }

    /// "Reset settings": forget the file, and put the window and the panel back as a first run opens.
    pub(super) fn reset_settings(&mut self) {
        remembered::reset(&mut self.ui.panel, &self.ui.egui_ctx);
        let [w, h] = DEFAULT_WINDOW;
        let _ = self.window.request_inner_size(LogicalSize::new(w, h));
        self.ui.panel.display.settings_status = Some(match self.store.reset() {
            Ok(()) => Status::ok("settings reset; the current ones are remembered again at exit"),
            Err(e) => Status::error(e),
        });
    }

    /// The screenshots asked for: the traced image (PNG or EXR) once no frame is half traced
    /// in bands, the window once a frame was presented (`window_image`, unless the scripted
    /// run's last frame takes it).
    pub(super) fn take_screenshots(
        &mut self,
        presented: bool,
        window_image: Option<&Result<image::RgbaImage, String>>,
        final_frame: bool,
    ) {
        let wanted = self.captures.want_trace_shot || self.captures.want_exr_shot;
        if wanted && self.frame.progressive.is_some() {
            // A frame traced in bands holds its new bands over the last frame's rows: the
            // shot waits for its last band, so it is one whole frame (issue #43: seams).
            self.ui.panel.screenshot.status =
                Some(Status::ok("the screenshot waits for the frame being traced in bands"));
            return self.take_window_shot(presented, window_image, final_frame);
        }
        if std::mem::take(&mut self.captures.want_trace_shot) {
            let path = screenshot::new_path(
                &screenshot::screenshot_dir(),
                Kind::Trace,
                &self.name_parts(),
            );
            self.ui.panel.screenshot.status = Some(self.save_trace(&path));
            self.notice_screenshot();
        }
        if std::mem::take(&mut self.captures.want_exr_shot) {
            let path = screenshot::new_path(
                &screenshot::screenshot_dir(),
                Kind::Trace,
                &self.name_parts(),
            )
            .with_extension("exr");
            self.ui.panel.screenshot.status = Some(self.save_exr(&path));
            self.notice_screenshot();
        }
        self.take_window_shot(presented, window_image, final_frame);
    }

    /// Shift+F12's shot of the window as presented, once a frame is.
    fn take_window_shot(
        &mut self,
        presented: bool,
        window_image: Option<&Result<image::RgbaImage, String>>,
        final_frame: bool,
    ) {
        if self.captures.want_window_shot && presented {
            self.captures.want_window_shot = false;
            if let Some(image) =
                window_image.filter(|_| !final_frame || self.script.screenshot_ui.is_none())
            {
                let path = screenshot::new_path(
                    &screenshot::screenshot_dir(),
                    Kind::Window,
                    &self.name_parts(),
                );
                self.ui.panel.screenshot.status = Some(match image {
                    Ok(img) => screenshot::status(
                        screenshot::save_png(img, &self.settings_text(), &path),
                        &path,
                    ),
                    Err(e) => Status::error(e.clone()),
                });
                self.notice_screenshot();
            }
        }
    }
}

/// What a preset saves of the window's `spec`: the `frames` accumulated into the image, and,
/// while the layout is `auto`, the binary layout a preset leaves unnamed (the window loading
/// it keeps measuring; a named wide layout would pin it).
fn preset_of(mut spec: SceneSpec, frames: u32, auto: bool) -> SceneSpec {
    spec.accumulate = frames.clamp(1, ACCUMULATE.hi as u32);
    if auto {
        spec.settings.bvh = BvhLayout::Binary;
    }
    spec
}

#[cfg(test)]
mod tests {
    use super::preset_of;
    use crate::app::state::Params;
    use crate::render_settings::BvhLayout;
    use crate::scene::preset;
    use crate::scene::spec::SceneSpec;

    #[test]
    fn a_saved_preset_keeps_the_accumulated_frames_and_the_auto_layout() {
        // #43: a TOML preset saved from the window left out `accumulate` (the PNG's had it)
        // and pinned `wide` while the layout was auto.
        let mut window = SceneSpec::default();
        window.settings.bvh = BvhLayout::Wide; // what auto measured
        let text = preset_of(window.clone(), 16, true).to_preset_text();
        let (read, unknown) = preset::from_text(&text).expect("the saved preset reads back");
        assert!(unknown.is_empty(), "{unknown:?}");
        assert_eq!(read.accumulate, 16, "{text}");
        let mut params = Params::new(&SceneSpec::default(), false);
        params.bvh_auto = true;
        params.apply_preset(&read);
        assert!(params.bvh_auto, "the preset keeps the window measuring: {text}");

        let pinned = preset_of(window, 1, false).to_preset_text();
        let (read, _) = preset::from_text(&pinned).expect("the saved preset reads back");
        assert_eq!(read.settings.bvh, BvhLayout::Wide, "a chosen layout is kept: {pinned}");
    }
}
