//! The interactive tool: a window with the traced image and the egui tuning panel.

use crate::cli::args::ViewArgs;

/// Open the window and run until it is closed (or `--frames` have been shown).
pub fn run(_args: &ViewArgs) -> anyhow::Result<()> {
    anyhow::bail!("the interactive tool is not built yet: use `meshtracer render -o out.png`")
}
