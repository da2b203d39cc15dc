//! Remembered settings: the window's size, which panel sections are open, the presets
//! and model files used lately and the graph's window, kept between runs in `settings.toml` in the
//! platform's config folder (`MESHTRACER_CONFIG_DIR` overrides it). `--no-persist` and
//! scripted runs neither read nor write it, so a script sees the same tool every time.
//!
//! The file is a convenience: a file that cannot be read gives one warning line and the
//! defaults, and one that cannot be written one warning line; neither stops the tool.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The environment variable naming the folder of `settings.toml` (tests point it at a
/// temporary folder so they never touch the user's).
pub(crate) const DIR_VAR: &str = "MESHTRACER_CONFIG_DIR";

/// The file's format version; a file with a newer one is left alone.
pub(crate) const FORMAT: u32 = 1;

/// What is remembered.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub(crate) struct Settings {
    /// The file's format version ([`FORMAT`]).
    pub(crate) version: u32,
    /// The window's inner size in logical pixels when it was last closed.
    pub(crate) window: Option<[u32; 2]>,
    /// Panel sections by title: open (true) or closed.
    pub(crate) sections: BTreeMap<String, bool>,
    /// Presets saved or loaded, the latest first.
    pub(crate) recent_presets: Vec<PathBuf>,
    /// Model files loaded, the latest first.
    pub(crate) recent_models: Vec<PathBuf>,
    /// Seconds of history the frame-time graph shows.
    pub(crate) graph_seconds: Option<f64>,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            version: FORMAT,
            window: None,
            sections: BTreeMap::new(),
            recent_presets: Vec::new(),
            recent_models: Vec::new(),
            graph_seconds: None,
        }
    }
}

/// Parse the text of a settings file; the error is one sentence.
pub(crate) fn parse(text: &str) -> Result<Settings, String> {
    let settings: Settings = toml::from_str(text)
        .map_err(|e| e.message().trim().trim_end_matches('.').replace('\n', " "))?;
    if settings.version > FORMAT {
        return Err(format!(
            "format version {} is newer than this meshtracer's {FORMAT}",
            settings.version
        ));
    }
    Ok(settings)
}

/// Read `path`: the settings, and a warning when the file exists but is not usable (then
/// the defaults). A missing file is no warning: it is the first run.
pub(crate) fn read(path: &Path) -> (Settings, Option<String>) {
    let text = match crate::files::read_text(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return (Settings::default(), None),
        Err(e) => {
            return (
                Settings::default(),
                Some(format!(
                    "cannot read the remembered settings {} ({e}); using the defaults",
                    crate::files::shown_path(path)
                )),
            )
        }
    };
    match parse(&text) {
        Ok(settings) => (settings, None),
        Err(e) => (
            Settings::default(),
            Some(format!(
                "ignoring the remembered settings {} ({e}); using the defaults",
                crate::files::shown_path(path)
            )),
        ),
    }
}

/// Write `settings` to `path` through a temporary file renamed over it, so a crash never
/// leaves half a file; creates the folder.
pub(crate) fn write(path: &Path, settings: &Settings) -> Result<(), String> {
    let fail = |e: &dyn std::fmt::Display| {
        format!("cannot remember the settings in {} ({e})", crate::files::shown_path(path))
    };
    let text = toml::to_string(settings).map_err(|e| fail(&e))?;
    if let Some(dir) = path.parent() {
        crate::files::create_folder(dir).map_err(|e| fail(&e))?;
    }
    crate::files::write_bytes_atomic(path, text.as_bytes()).map_err(|e| fail(&e.root_cause()))
}

/// Where the settings live, or nowhere (`--no-persist`, scripted runs, no home folder).
#[derive(Clone, Debug, Default)]
pub(crate) struct Store {
    /// The settings file; None: nothing is read or written.
    pub(crate) path: Option<PathBuf>,
}

impl Store {
    /// The store of a run: the config folder's `settings.toml` when `persist`.
    pub(crate) fn new(persist: bool) -> Self {
        if !persist {
            return Self { path: None };
        }
        let dir =
            std::env::var_os(DIR_VAR).filter(|v| !v.is_empty()).map(PathBuf::from).or_else(|| {
                directories::ProjectDirs::from("", "", "meshtracer")
                    .map(|d| d.config_dir().to_path_buf())
            });
        Self { path: dir.map(|d| d.join("settings.toml")) }
    }

    /// The remembered settings (defaults when none); a bad file is one warning line.
    pub(crate) fn load(&self) -> Settings {
        let Some(path) = &self.path else { return Settings::default() };
        let (settings, warning) = read(path);
        if let Some(w) = warning {
            eprintln!("warning: {w}");
        }
        settings
    }

    /// Remember `settings`; a failure is one warning line.
    pub(crate) fn save(&self, settings: &Settings) {
        if let Some(path) = &self.path {
            if let Err(e) = write(path, settings) {
                eprintln!("warning: {e}");
            }
        }
    }

    /// Forget everything remembered: the file is removed.
    pub(crate) fn reset(&self) -> Result<(), String> {
        match &self.path {
            Some(path) => match crate::files::remove_file(path) {
                Ok(()) => Ok(()),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
                Err(e) => Err(format!("cannot remove {} ({e})", crate::files::shown_path(path))),
            },
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("meshtracer-settings-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn settings_round_trip_through_the_file() {
        let dir = temp("round-trip");
        let path = dir.join("nested").join("settings.toml");
        let mut s = Settings {
            window: Some([900, 600]),
            recent_presets: vec![PathBuf::from("/tmp/look.toml")],
            recent_models: vec![PathBuf::from("/tmp/bunny.obj")],
            graph_seconds: Some(30.0),
            ..Default::default()
        };
        s.sections.insert("Performance".into(), true);
        s.sections.insert("Light".into(), false);
        write(&path, &s).unwrap();
        assert_eq!(read(&path), (s, None));
        assert!(!path.with_extension("toml.tmp").exists(), "the temporary file is renamed");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_missing_file_is_the_defaults_without_a_warning() {
        assert_eq!(read(&temp("missing").join("settings.toml")), (Settings::default(), None));
    }

    #[test]
    fn a_corrupt_file_is_one_warning_and_the_defaults() {
        let dir = temp("corrupt");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("settings.toml");
        for text in ["window = [900, \"wide\"]", "this is not toml", "\u{0}\u{1}", "version = 99"] {
            std::fs::write(&path, text).unwrap();
            let (s, warning) = read(&path);
            assert_eq!(s, Settings::default(), "{text}");
            let warning = warning.unwrap_or_else(|| panic!("no warning for {text:?}"));
            assert!(
                warning.contains(&path.display().to_string())
                    && warning.ends_with("using the defaults"),
                "{warning}"
            );
            assert!(!warning.contains('\n'), "{warning}");
        }
        // Unknown keys (a newer release's) are no reason to forget the rest.
        std::fs::write(&path, "window = [800, 600]\nsomething_new = 1\n").unwrap();
        assert_eq!(read(&path).0.window, Some([800, 600]));
        std::fs::remove_dir_all(dir).unwrap();
    }

    /// Issue #43, point 17: the messages beyond the reads' (the `-o` format check, a preset's
    /// read and save, the remembered settings) escape a path too.
    #[test]
    fn paths_in_other_messages_are_escaped() {
        let dir = temp("escaped");
        std::fs::create_dir_all(&dir).unwrap();
        let evil = |name: &str| dir.join(format!("\u{1b}]0;PWNED\u{7}{name}"));
        let check = |err: String| {
            assert!(!err.chars().any(char::is_control), "{err:?}");
            assert!(err.contains("\\u{1b}]0;PWNED\\u{7}"), "{err:?}");
        };
        check(crate::files::image_files::OutputFormat::from_path(&evil("x.bmp")).unwrap_err());
        // A PNG that is not this program's: the preset's own message names it.
        let png = evil("x.png");
        std::fs::write(&png, b"\x89PNG\r\n\x1a\nnot really").unwrap();
        check(crate::scene::preset::read(&png).unwrap_err());
        let spec = crate::scene::spec::SceneSpec::default();
        check(crate::scene::preset::save(&spec, &png, false).unwrap_err().to_string());
        let (_, warning) = read(&png);
        check(warning.expect("a PNG is no settings file"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn no_persist_reads_and_writes_nothing() {
        let store = Store::new(false);
        assert!(store.path.is_none());
        assert_eq!(store.load(), Settings::default());
        store.save(&Settings { window: Some([1, 1]), ..Default::default() });
        assert!(store.reset().is_ok());
    }
}
