//! `meshtracer render`: one frame, headless, to a PNG (carrying its preset in a text chunk),
//! JPEG or EXR.

use std::io::IsTerminal;

use anyhow::bail;

use super::args::RenderArgs;
use crate::files::image_files::{save_jpeg, save_png, OutputFormat};
use crate::gpu::{ClockProbe, ComputeTracer, ContextOptions, GpuContext};
use crate::render_settings::{Accel, Aov};
use crate::tracer::heat_map::heat_map;
use crate::tracer::packed::Layouts;
use crate::tracer::{cpu, FrameParams, PackedScene};

/// Run the command; the returned error is printed as one line by `main`.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let format = OutputFormat::from_path(&args.output).map_err(anyhow::Error::msg)?;
    // Before the work, not after it: a long render must not be lost to a typo in the path.
    crate::files::check_writable(&args.output)?;
    let (spec, preset_warnings) = args.spec()?;
    for w in &preset_warnings {
        log::warn!("{w}");
    }
    let aov = spec.settings.aov;
    // Colour and AO (grey in [0, 1]) are PNG, JPEG or EXR; every other AOV is float EXR;
    // cost and samples may also be a heat map (PNG or JPEG).
    let heat_map_image = format != OutputFormat::Exr && matches!(aov, Aov::Cost | Aov::Samples);
    if format != OutputFormat::Exr && !heat_map_image && !matches!(aov, Aov::Color | Aov::Ao) {
        bail!(
            "the {aov} AOV is written as 32-bit float OpenEXR: give an output path ending in .exr"
        );
    }
    spec.validate().map_err(anyhow::Error::msg)?;
    let settings = spec.settings;
    let preset_text = spec.to_preset_text();
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
        eprintln!(
            "loaded {} triangles in {:.2} s; building the BVH ...",
            scene.triangle_count(),
            started.elapsed().as_secs_f64()
        );
    }
    let packed = PackedScene::with_layouts(&scene, Layouts::only(settings.bvh));
    if progress {
        eprintln!("BVH built in {:.2} s", packed.bvh_build_seconds);
    }
    for w in warnings.iter().chain(&packed.warnings) {
        log::warn!("{w}");
    }
    let params = FrameParams::new(&scene, settings);

    let (image, how) = if args.cpu {
        let start = std::time::Instant::now();
        let mut image = cpu::render(&packed, &params);
        for frame_index in 1..spec.accumulate {
            cpu::accumulate(&packed, &FrameParams { frame_index, ..params }, &mut image);
        }
        (image, format!("CPU reference, {:.1} ms", start.elapsed().as_secs_f64() * 1e3))
    } else {
        let options = ContextOptions {
            validation: args.validation,
            device_index: args.scene.device,
            ..Default::default()
        };
        let ctx = GpuContext::new(&options)?;
        let mut tracer = ComputeTracer::with_scene(&ctx, &packed)?;
        if let Some(kernel) = args.vendor_kernel {
            tracer.set_vendor_kernel(kernel)?;
        }
        if tracer.kernel().orders_tiles() && settings.accel != crate::render_settings::Accel::Vendor
        {
            // A first frame records what each tile costs, so that the frame kept (and timed)
            // takes its tiles costliest first, as every later frame of `view` and `bench` does.
            tracer.trace(&params)?;
        }
        // Accumulation: every frame but the last folds into the output, the last is read
        // back (and timed).
        for frame_index in 0..spec.accumulate - 1 {
            tracer.trace(&FrameParams { frame_index, ..params })?;
        }
        let (image, timing) =
            tracer.render(&FrameParams { frame_index: spec.accumulate - 1, ..params })?;
        // One frame straight after the upload, so the GPU's clock may still be down (see
        // bench::clock_guard): say which clock the time was taken at.
        // A CPU device (lavapipe) has no shader clock worth naming: its "clock" is the
        // host's cycle counter.
        let probe = if ctx.info.is_cpu() { None } else { ClockProbe::new(&ctx)? };
        let clock = match probe {
            Some(mut probe) => {
                probe.measure()?; // the first dispatch pays for the pipeline's first use
                format!(" at a {:.0} MHz shader clock", probe.measure()?.mhz())
            }
            None => String::new(),
        };
        let messages = ctx.validation_messages();
        if !messages.is_empty() {
            bail!(
                "the Vulkan validation layer reported {} problem(s), the first: {}",
                messages.len(),
                messages[0]
            );
        }
        let mut gpu =
            timing.gpu_ms.map_or("no timestamps".into(), |ms| format!("trace {ms:.2} ms{clock}"));
        if let (crate::render_settings::Accel::Vendor, Ok(kernel), Some(stats)) =
            (settings.accel, tracer.vendor_kernel(), tracer.vendor_stats())
        {
            gpu = format!(
                "vendor {kernel}, structures built in {:.1} ms, {gpu}",
                stats.bottom_ms + stats.top_ms
            );
        }
        (image, format!("{}, {gpu}", ctx.info.name))
    };
    if heat_map_image {
        // Cost: nodes visited with the BVH, triangles tested with brute force.
        let channel =
            usize::from(aov == Aov::Cost && settings.accel == crate::render_settings::Accel::Brute);
        let values: Vec<f32> = image.pixels.iter().map(|p| p[channel]).collect();
        let map = heat_map(&values);
        let rgba =
            image::RgbaImage::from_raw(image.width, image.height, map.rgba).expect("size matches");
        if format == OutputFormat::Jpeg {
            save_jpeg(&rgba, &args.output)?;
        } else {
            save_png(&rgba, Some(&preset_text), &args.output)?;
        }
        println!("heat map scale: 0 (black) to {:.0} (pale yellow, the 99th percentile); max {:.0}, mean {:.1}", map.scale_max, map.max, map.mean);
    } else {
        image.save(&args.output, aov, Some(&preset_text))?;
    }
    // The AO view traces no bounces: say what it traced instead.
    let rays = match aov {
        Aov::Ao => format!("{} AO rays within {}", settings.ao_samples, settings.ao_radius),
        _ => format!("{} bounce{}", settings.bounces, if settings.bounces == 1 { "" } else { "s" }),
    };
    println!(
        "wrote {} ({}x{}, {} x{}, {} triangles, {rays}, {}; {how})",
        args.output.display(),
        settings.width,
        settings.height,
        source.label(),
        spec.models,
        scene.triangle_count(),
        if settings.accel == Accel::Bvh && settings.bvh.is_wide() {
            format!("bvh ({})", settings.bvh)
        } else {
            settings.accel.to_string()
        },
    );
    Ok(())
}
