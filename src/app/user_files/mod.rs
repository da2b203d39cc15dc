//! What the tool reads and writes besides the frame: models, presets, screenshots,
//! remembered settings and shaders.
//!
//! - `model_loader`: loading .obj files (or generating models) on a worker thread;
//! - `open_dialog`: the Open dialog (Ctrl+O) that picks a model or a preset;
//! - `screenshot`: screenshot names and files;
//! - `settings`: what is remembered between runs (`settings.toml`);
//! - `shader_watch`: `--watch-shaders`, reloading the trace shader on an edit.

pub(crate) mod model_loader;
pub(crate) mod open_dialog;
pub(crate) mod screenshot;
pub(crate) mod settings;
pub(crate) mod shader_watch;
