//! `meshtracer render`: one frame, headless, to a PNG or EXR.

use std::io::IsTerminal;

use anyhow::{bail, Context};

use super::args::RenderArgs;
use crate::gpu::{ContextOptions, GpuContext, ComputeTracer};
use crate::tracer::heat_map::heat_map;
use crate::tracer::{cpu, Aov, FrameParams, PackedScene};

/// Run the command; the returned error is printed as one line by `main`.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let is_exr = args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    // Colour is PNG; every AOV is float EXR; cost and samples may also be a heat-map PNG.
    let heat_png = !is_exr && matches!(args.aov, Aov::Cost | Aov::Samples);
    if !is_exr && !heat_png && args.aov != Aov::Color {
        bail!("the {} AOV is written as 32-bit float OpenEXR: give an output path ending in .exr", args.aov);
    }
    let spec = args.scene.spec(args.aov);
    spec.validate().map_err(anyhow::Error::msg)?;
    let settings = spec.settings;
    let source = &spec.model;
    // Progress on a terminal's stderr: big meshes take seconds to load and to build their
    // BVH. Scripts reading stderr get only warnings and the one-line error.
    let progress = std::io::stderr().is_terminal();
    let started = std::time::Instant::now();
    if progress {
        eprintln!("loading {} ...", source.label());
    }
    let (scene, warnings) = spec.load()?;
    if progress {
        eprintln!("loaded {} triangles in {:.2} s; building the BVH ...", scene.triangle_count(), started.elapsed().as_secs_f64());
    }
    let packed = PackedScene::new(&scene);
    if progress {
        eprintln!("BVH built in {:.2} s", packed.bvh_build_seconds);
    }
    for w in warnings.iter().chain(&packed.warnings) {
        eprintln!("warning: {w}");
    }
    let params = FrameParams::new(&scene, settings);

    let (image, how) = if args.cpu {
        let start = std::time::Instant::now();
        let image = cpu::render(&packed, &params);
        (image, format!("CPU reference, {:.1} ms", start.elapsed().as_secs_f64() * 1e3))
    } else {
        let options = ContextOptions { validation: args.validation, device_index: args.scene.device, ..Default::default() };
        let ctx = GpuContext::new(&options)?;
        let mut tracer = ComputeTracer::with_scene(&ctx, &packed)?;
        let (image, timing) = tracer.render(&params)?;
        let messages = ctx.validation_messages();
        if !messages.is_empty() {
            bail!("the Vulkan validation layer reported {} problem(s), the first: {}", messages.len(), messages[0]);
        }
        let gpu = timing.gpu_ms.map_or("no timestamps".into(), |ms| format!("trace {ms:.2} ms"));
        (image, format!("{}, {gpu}", ctx.info.name))
    };
    if heat_png {
        // Cost: nodes visited with the BVH, triangles tested with brute force.
        let channel = usize::from(args.aov == Aov::Cost && settings.accel == crate::tracer::Accel::Brute);
        let values: Vec<f32> = image.pixels.iter().map(|p| p[channel]).collect();
        let map = heat_map(&values);
        image::RgbaImage::from_raw(image.width, image.height, map.rgba)
            .expect("size matches")
            .save(&args.output)
            .with_context(|| format!("cannot write {}", args.output.display()))?;
        println!("heat map scale: 0 (black) to {:.0} (pale yellow, the 99th percentile); max {:.0}, mean {:.1}", map.scale_max, map.max, map.mean);
    } else {
        image.save(&args.output)?;
    }
    println!(
        "wrote {} ({}x{}, {} x{}, {} triangles, {} bounces, {}; {how})",
        args.output.display(),
        settings.width,
        settings.height,
        source.label(),
        spec.models,
        scene.triangle_count(),
        settings.bounces,
        settings.accel,
    );
    Ok(())
}
