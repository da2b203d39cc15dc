//! Screenshot files: where they go, what they are called, and writing them without ever
//! taking the tool down (a failure is one sentence for the panel).

use std::path::{Path, PathBuf};

use image::RgbaImage;

use crate::app::status::Status;

/// Environment variable naming the screenshot folder (default: the current directory).
pub(crate) const DIR_VAR: &str = "MESHTRACER_SCREENSHOT_DIR";

/// Which picture a screenshot holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// The traced image at render resolution.
    Trace,
    /// The window as seen, panel included.
    Window,
}

/// The parameters a file name carries.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct NameParts {
    pub(crate) model: String,
    pub(crate) models: u32,
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) bounces: u32,
    pub(crate) blend: f32,
}

/// The folder screenshots go to.
pub(crate) fn screenshot_dir() -> PathBuf {
    std::env::var_os(DIR_VAR)
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn sanitize(s: &str) -> String {
    let cleaned: String =
        s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    if cleaned.is_empty() {
        "model".into()
    } else {
        cleaned
    }
}

/// `meshtracer_20250102-030405-678_geosphere_x1_512x512_b2_blend0.50[_window].png`
pub(crate) fn file_name(kind: Kind, parts: &NameParts, stamp: &str) -> String {
    let suffix = match kind {
        Kind::Trace => "",
        Kind::Window => "_window",
    };
    format!(
        "meshtracer_{stamp}_{}_x{}_{}x{}_b{}_blend{:.2}{suffix}.png",
        sanitize(&parts.model),
        parts.models,
        parts.width,
        parts.height,
        parts.bounces,
        parts.blend
    )
}

/// The local time as used in file names.
pub(crate) fn timestamp() -> String {
    chrono::Local::now().format("%Y%m%d-%H%M%S-%3f").to_string()
}

/// A fresh path in `dir` for a screenshot of `kind` (a counter is added if the name exists).
pub(crate) fn new_path(dir: &Path, kind: Kind, parts: &NameParts) -> PathBuf {
    let name = file_name(kind, parts, &timestamp());
    let mut path = dir.join(&name);
    let mut n = 2;
    while path.exists() {
        path = dir.join(name.replace(".png", &format!("_{n}.png")));
        n += 1;
    }
    path
}

/// Write `image` as PNG to `path` with `settings` (`SceneSpec::to_preset_text`) in its
/// `meshtracer` text chunk (through `files::write_atomic`: a watcher never sees half a file,
/// a failed write keeps the old one). The error is one sentence.
pub(crate) fn save_png(image: &RgbaImage, settings: &str, path: &Path) -> Result<(), String> {
    crate::files::image_files::save_png(image, Some(settings), path).map_err(|e| {
        format!("could not write {}: {}", crate::files::shown_path(path), e.root_cause())
    })
}

/// The panel's line for a file written (its full path) or not (why).
pub(crate) fn status(result: Result<(), String>, path: &Path) -> Status {
    match result {
        Ok(()) => {
            let shown: PathBuf = crate::files::canonical_or_given(path);
            Status::ok(format!("wrote {}", crate::files::shown_path(&shown)))
        }
        Err(e) => Status::error(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parts() -> NameParts {
        NameParts {
            model: "my model.v2".into(),
            models: 3,
            width: 640,
            height: 480,
            bounces: 2,
            blend: 0.5,
        }
    }

    #[test]
    fn names_carry_the_parameters() {
        let n = file_name(Kind::Trace, &parts(), "20250102-030405-678");
        assert_eq!(n, "meshtracer_20250102-030405-678_my_model_v2_x3_640x480_b2_blend0.50.png");
        assert!(file_name(Kind::Window, &parts(), "t").ends_with("_window.png"));
    }

    #[test]
    fn screenshots_carry_the_settings() {
        let dir = std::env::temp_dir().join(format!("meshtracer-shot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("shot.png");
        let spec = crate::scene::spec::SceneSpec::default();
        save_png(&RgbaImage::new(3, 2), &spec.to_preset_text(), &path).unwrap();
        let text = crate::files::image_files::png_settings(&std::fs::read(&path).unwrap())
            .unwrap()
            .unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(text, spec.to_preset_text());
    }

    #[test]
    fn writing_to_a_missing_folder_is_one_sentence() {
        let img = RgbaImage::new(2, 2);
        let err = save_png(&img, "", Path::new("/nonexistent/folder/x.png")).unwrap_err();
        assert!(err.starts_with("could not write /nonexistent/folder/x.png"), "{err}");
        assert!(!err.contains('\n'));
    }
}
