//! One frame headless, to a file (`meshtracer render`): the output's format checked first,
//! the scene loaded and packed, traced on a GPU or the CPU reference (accumulated as the
//! window accumulates), and written as PNG (carrying its preset), JPEG or EXR.

use std::io::IsTerminal;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use anyhow::bail;

use super::khr_rt::VendorKernel;
use super::{ClockProbe, ComputeTracer, ContextOptions, GpuContext};
use crate::files::image_files::{save_jpeg, save_png, OutputFormat};
use crate::progress::Progress;
use crate::render_settings::{Accel, Aov};
use crate::scene::spec::SceneSpec;
use crate::scene::Scene;
use crate::tracer::heat_map::heat_map;
use crate::tracer::packed::{BvhBuilder, DeviceFit, Layouts};
use crate::tracer::{cpu, FrameParams, Image, LoadedScene, PackedScene};

/// Where a headless frame is traced.
#[derive(Clone, Copy, Debug, Default)]
pub struct TraceOn {
    /// The CPU reference tracer instead of a GPU.
    pub cpu: bool,
    /// Vulkan device index (None: the fastest kind present).
    pub device: Option<usize>,
    /// Turn on the Vulkan validation layer.
    pub validation: bool,
    /// How vendor frames trace the driver's structures (None: the device's preferred).
    pub vendor_kernel: Option<VendorKernel>,
    /// Where the BVHs are built (the CPU tracer's always on the CPU).
    pub bvh_builder: BvhBuilder,
}

/// The output file's format, by its extension, once its folder is known to take it:
/// checked before the work, so a long render is not lost to a typo in the path.
pub(crate) fn output_format(path: &Path) -> anyhow::Result<OutputFormat> {
    let format = OutputFormat::from_path(path).map_err(anyhow::Error::msg)?;
    crate::files::check_writable(path)?;
    Ok(format)
}

/// Trace `spec` on `on` and write it to `output` in `format`, printing what was written.
/// `RUST_LOG=debug` logs when each step ended, in seconds from the start.
pub(crate) fn render_to_file(
    spec: &SceneSpec,
    output: &Path,
    format: OutputFormat,
    on: &TraceOn,
) -> anyhow::Result<()> {
    let heat_map_image = heat_map_wanted(format, spec.settings.aov)?;
    spec.validate().map_err(anyhow::Error::msg)?;
    let clock = Instant::now();
    let (scene, image, how, lacks_wide) = if on.cpu {
        let (scene, packed) = load(spec, DeviceFit::NONE, clock)?;
        let params = FrameParams::new(&scene, spec.settings);
        let (image, how) = trace_on_cpu(&packed, &params, spec.accumulate);
        (scene, image, how, packed.some_mesh_lacks_wide())
    } else {
        let (ctx, mut tracer, loaded) = load_beside_device(spec, on, clock)?;
        let params = FrameParams::new(loaded.scene(), spec.settings);
        // The triangles are written straight into the upload's staging memory, as the
        // window's loads do: no host copy (at 100M triangles 5.6 GB and half a second).
        tracer.set_loaded_scene(&loaded)?;
        log::debug!("{:.3} s: uploaded", clock.elapsed().as_secs_f64());
        let lacks_wide = loaded.tables().some_mesh_lacks_wide();
        let (scene, _) = loaded.uploaded();
        let (image, how) = trace_on_gpu(&ctx, &mut tracer, &params, spec.accumulate)?;
        (scene, image, how, lacks_wide)
    };
    log::debug!("{:.3} s: traced", clock.elapsed().as_secs_f64());
    // A file's camera is written into the image's preset as the numbers it traced with.
    let resolved;
    let spec = if spec.file_camera.is_some() {
        resolved = spec.with_camera(scene.camera);
        &resolved
    } else {
        spec
    };
    let preset_text = spec.to_preset_text();
    write_image(&image, spec, heat_map_image, (output, format), &preset_text)?;
    println!("{}", summary(spec, &scene, output, &how, lacks_wide));
    log::debug!("{:.3} s: written", clock.elapsed().as_secs_f64());
    Ok(())
}

/// The device opened, the tracer made (its kernels compiled) and the scene loaded and
/// packed, the two sides at once: the driver's start-up and compiler run beside the parse
/// and the BVH build. The device is still known before the build, so that a model too big
/// for it is refused first (issue #43: `torusknot:4M` on lavapipe failed only after a 10 s
/// build and 1 GB); a device that cannot be opened is the error reported.
fn load_beside_device(
    spec: &SceneSpec,
    on: &TraceOn,
    clock: Instant,
) -> anyhow::Result<(Arc<GpuContext>, ComputeTracer, LoadedScene)> {
    std::thread::scope(|s| {
        let (ctx_tx, ctx_rx) = std::sync::mpsc::channel();
        let device = s.spawn(move || -> anyhow::Result<ComputeTracer> {
            let ctx = open_context(on.device, on.validation)?;
            log::debug!("{:.3} s: device opened", clock.elapsed().as_secs_f64());
            let _ = ctx_tx.send(ctx.clone());
            let mut tracer = ComputeTracer::new(&ctx, 0)?;
            if let Some(kernel) = on.vendor_kernel {
                tracer.set_vendor_kernel(kernel)?;
            }
            let one_instance = spec.is_one_instance_before_loading();
            let twin = crate::tracer::top_level::wide_twin_before_loading(spec);
            tracer.make_kernel_for(&spec.settings, one_instance, twin);
            log::debug!("{:.3} s: kernels made", clock.elapsed().as_secs_f64());
            Ok(tracer)
        });
        let loaded = load_scene(spec, clock);
        let join = |device: std::thread::ScopedJoinHandle<'_, anyhow::Result<ComputeTracer>>| {
            device.join().map_err(|_| anyhow::anyhow!("the device thread panicked"))?
        };
        let Ok(ctx) = ctx_rx.recv() else {
            // No device was sent: opening it failed, and the thread's error says why.
            return join(device).and(Err(anyhow::anyhow!("the device thread ended early")));
        };
        let (scene, warnings) = loaded?;
        let fit = ctx.info.fit(on.bvh_builder);
        check_fits_before_build(spec, &scene, fit)?;
        show_build_start(&scene, clock);
        let layouts = Layouts::only(spec.settings.bvh);
        let loaded = LoadedScene::pack(scene, layouts, &Progress::default(), fit)?;
        let seconds = loaded.tables().bvh_build_seconds;
        show_build_end(seconds, warnings.iter().chain(&loaded.warnings), clock);
        Ok((ctx, join(device)?, loaded))
    })
}

/// Whether the AOV goes out as a heat map; an error where `format` cannot hold it. Colour
/// and AO (grey in [0, 1]) are PNG, JPEG or EXR; every other AOV is float EXR; cost and
/// samples may also be a heat map (PNG or JPEG).
fn heat_map_wanted(format: OutputFormat, aov: Aov) -> anyhow::Result<bool> {
    let heat_map_image = format != OutputFormat::Exr && matches!(aov, Aov::Cost | Aov::Samples);
    if format != OutputFormat::Exr && !heat_map_image && !matches!(aov, Aov::Color | Aov::Ao) {
        bail!(
            "the {aov} AOV is written as 32-bit float OpenEXR: give an output path ending in .exr"
        );
    }
    Ok(heat_map_image)
}

/// Load the spec's scene and pack it for its layout ([`load_scene`], [`pack`]).
fn load(
    spec: &SceneSpec,
    device: DeviceFit,
    clock: Instant,
) -> anyhow::Result<(Scene, PackedScene)> {
    let (scene, warnings) = load_scene(spec, clock)?;
    let packed = pack(spec, &scene, &warnings, device, clock)?;
    Ok((scene, packed))
}

/// Whether progress goes to stderr: on a terminal, where big meshes take seconds to load
/// and to build their BVH; scripts reading stderr get only warnings and the one-line error.
fn shows_progress() -> bool {
    std::io::stderr().is_terminal()
}

/// Load the spec's scene, with its warnings.
fn load_scene(spec: &SceneSpec, clock: Instant) -> anyhow::Result<(Scene, Vec<String>)> {
    if shows_progress() {
        eprintln!("loading {} ...", spec.model.label());
    }
    let loaded = spec.load()?;
    log::debug!("{:.3} s: scene loaded", clock.elapsed().as_secs_f64());
    Ok(loaded)
}

/// Pack `scene` for the spec's layout and `device`, logging its load's `warnings` and the
/// packing's. A model whose triangles cannot fit the device's storage buffers is refused
/// before the build.
fn pack(
    spec: &SceneSpec,
    scene: &Scene,
    warnings: &[String],
    device: DeviceFit,
    clock: Instant,
) -> anyhow::Result<PackedScene> {
    check_fits_before_build(spec, scene, device)?;
    show_build_start(scene, clock);
    let packed = PackedScene::with_layouts_within(scene, Layouts::only(spec.settings.bvh), device);
    show_build_end(packed.bvh_build_seconds, warnings.iter().chain(&packed.warnings), clock);
    Ok(packed)
}

/// Refuse a model whose triangles cannot fit the `device`'s storage buffers, before its
/// BVH is built.
fn check_fits_before_build(
    spec: &SceneSpec,
    scene: &Scene,
    device: DeviceFit,
) -> anyhow::Result<()> {
    if let Some(limit) = device.storage_range {
        super::scene_buffers::check_before_build(scene, &spec.model.label(), limit)
            .map_err(anyhow::Error::msg)?;
    }
    Ok(())
}

/// On a terminal, say that the build starts.
fn show_build_start(scene: &Scene, clock: Instant) {
    if shows_progress() {
        eprintln!(
            "loaded {} triangles in {:.2} s; building the BVH ...",
            scene.triangle_count(),
            clock.elapsed().as_secs_f64()
        );
    }
}

/// On a terminal, say that the build ended (in `bvh_seconds`); log the load's and the
/// packing's `warnings`.
fn show_build_end<'a>(
    bvh_seconds: f64,
    warnings: impl Iterator<Item = &'a String>,
    clock: Instant,
) {
    if shows_progress() {
        eprintln!("BVH built in {bvh_seconds:.2} s");
    }
    log::debug!("{:.3} s: packed", clock.elapsed().as_secs_f64());
    for w in warnings {
        log::warn!("{w}");
    }
}

/// The frame on the CPU reference tracer, `accumulate` frames averaged; and how it went.
fn trace_on_cpu(packed: &PackedScene, params: &FrameParams, accumulate: u32) -> (Image, String) {
    let start = std::time::Instant::now();
    let mut image = cpu::render(packed, params);
    for frame_index in 1..accumulate {
        cpu::accumulate(packed, &FrameParams { frame_index, ..*params }, &mut image);
    }
    (image, format!("CPU reference, {:.1} ms", start.elapsed().as_secs_f64() * 1e3))
}

/// The frame on a GPU, `accumulate` frames averaged; and how it went (device, kernel,
/// trace time and the clock it was taken at).
fn trace_on_gpu(
    ctx: &Arc<GpuContext>,
    tracer: &mut ComputeTracer,
    params: &FrameParams,
    accumulate: u32,
) -> anyhow::Result<(Image, String)> {
    let accel = params.settings.accel;
    if tracer.kernel().orders_tiles() && accel != Accel::Vendor {
        // A first frame records what each tile costs, so that the frame kept (and timed)
        // takes its tiles costliest first, as every later frame of `view` and `bench` does.
        tracer.trace(params)?;
        log::debug!("tile costs recorded");
    }
    // Accumulation: every frame but the last folds into the output, the last is read
    // back (and timed).
    for frame_index in 0..accumulate - 1 {
        tracer.trace(&FrameParams { frame_index, ..*params })?;
    }
    let (image, timing) = tracer.render(&FrameParams { frame_index: accumulate - 1, ..*params })?;
    log::debug!("frame traced and read back");
    let clock = clock_note(ctx)?;
    log::debug!("clock measured");
    check_validation(ctx)?;
    let mut gpu =
        timing.gpu_ms.map_or("no timestamps".into(), |ms| format!("trace {ms:.2} ms{clock}"));
    if let (Accel::Vendor, Ok(kernel), Some(stats)) =
        (accel, tracer.vendor_kernel(), tracer.vendor_stats())
    {
        let built = stats.bottom_ms + stats.top_ms;
        gpu = format!("vendor {kernel}, structures built in {built:.1} ms, {gpu}");
    }
    Ok((image, format!("{}, {gpu}", ctx.info.name)))
}

/// " at a N MHz shader clock": one frame straight after the upload, so the GPU's clock may
/// still be down (see bench::clock_guard). Empty on a CPU device (lavapipe), whose "clock"
/// is the host's cycle counter.
fn clock_note(ctx: &Arc<GpuContext>) -> anyhow::Result<String> {
    let probe = if ctx.info.is_cpu() { None } else { ClockProbe::new(ctx)? };
    Ok(match probe {
        Some(mut probe) => {
            probe.measure()?; // the first dispatch pays for the pipeline's first use
            format!(" at a {:.0} MHz shader clock", probe.measure()?.mhz())
        }
        None => String::new(),
    })
}

/// Write the image: the AOV as the format takes it, or its heat map (whose scale is printed).
fn write_image(
    image: &Image,
    spec: &SceneSpec,
    heat_map_image: bool,
    (path, format): (&Path, OutputFormat),
    preset_text: &str,
) -> anyhow::Result<()> {
    let (aov, accel) = (spec.settings.aov, spec.settings.accel);
    if !heat_map_image {
        return image.save(path, aov, Some(preset_text));
    }
    // Cost: nodes visited with the BVH, triangles tested with brute force.
    let channel = usize::from(aov == Aov::Cost && accel == Accel::Brute);
    let values: Vec<f32> = image.pixels.iter().map(|p| p[channel]).collect();
    let map = heat_map(&values);
    let rgba =
        image::RgbaImage::from_raw(image.width, image.height, map.rgba).expect("size matches");
    if format == OutputFormat::Jpeg {
        save_jpeg(&rgba, path)?;
    } else {
        save_png(&rgba, Some(preset_text), path)?;
    }
    println!("heat map scale: 0 (black) to {:.0} (pale yellow, the 99th percentile); max {:.0}, mean {:.1}", map.scale_max, map.max, map.mean);
    Ok(())
}

/// The line saying what was written and how it was traced (`lacks_wide`: some mesh traced
/// its binary tree, its wide tree not fitting the device).
fn summary(spec: &SceneSpec, scene: &Scene, output: &Path, how: &str, lacks_wide: bool) -> String {
    let s = &spec.settings;
    // The AO view traces no bounces: say what it traced instead.
    let rays = match s.aov {
        Aov::Ao => format!("{} AO rays within {}", s.ao_samples, s.ao_radius),
        _ => format!("{} bounce{}", s.bounces, if s.bounces == 1 { "" } else { "s" }),
    };
    let accel = if s.accel == Accel::Bvh && s.bvh.is_wide() {
        let binary = if lacks_wide { ", binary where the wide tree did not fit" } else { "" };
        format!("bvh ({}{binary})", s.bvh)
    } else {
        s.accel.to_string()
    };
    format!(
        "wrote {} ({}x{}, {} x{}, {} triangles, {rays}, {accel}; {how})",
        crate::files::shown_path(output),
        s.width,
        s.height,
        spec.model.label(),
        spec.models,
        scene.triangle_count(),
    )
}

/// A context on `device` (None: the fastest kind present), with the validation layer
/// where asked.
pub(crate) fn open_context(
    device: Option<usize>,
    validation: bool,
) -> anyhow::Result<Arc<GpuContext>> {
    let options = ContextOptions { validation, device_index: device, ..Default::default() };
    Ok(GpuContext::new(&options)?)
}

/// An error naming the first problem the validation layer reported, if it reported any.
pub(crate) fn check_validation(ctx: &GpuContext) -> anyhow::Result<()> {
    let messages = ctx.validation_messages();
    if let Some(first) = messages.first() {
        bail!(
            "the Vulkan validation layer reported {} problem(s), the first: {first}",
            messages.len()
        );
    }
    Ok(())
}
