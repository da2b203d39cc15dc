//! `meshtracer render`: one frame, headless, to a PNG (carrying its preset in a text chunk),
//! JPEG or EXR.

use super::args::RenderArgs;
use crate::gpu::headless::{output_format, render_to_file, TraceOn};

/// Run the command; the returned error is printed as one line by `main`.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let format = output_format(&args.output)?;
    let (spec, preset_warnings) = args.spec()?;
    for w in &preset_warnings {
        log::warn!("{w}");
    }
    let on = TraceOn {
        cpu: args.cpu,
        device: args.scene.device,
        validation: args.validation,
        vendor_kernel: args.vendor_kernel,
        bvh_builder: args.scene.bvh_build,
    };
    render_to_file(&spec, &args.output, format, &on)
}
