//! Unit tests of `compute_tracer.rs`: which trace kernel a frame runs, and when it is made.

use super::*;
use crate::gpu::dispatch::GROUP_LANES;
use crate::gpu::trace_kernels::Variant;
use crate::gpu::ContextOptions;
use crate::render_settings::{Accel, Aov, RenderSettings};
use crate::scene::paper::ModelSource;
use crate::scene::primitives::PaperModel;
use crate::scene::spec::SceneSpec;
use crate::scene::Scene;
use crate::tracer::packed::Layouts;

impl ComputeTracer {
    /// The headless slot's tile costs (from its last frame) and order (for its next one).
    pub(crate) fn headless_tiles(&self) -> (Vec<u32>, Vec<u32>) {
        let out = self.output.as_ref().expect("a frame was traced");
        let mut tiles = lock(&out.tiles);
        (tiles.costs(self.recorded_slots), tiles.slot_order(self.recorded_slots))
    }
}

/// A validated context and two of the paper's torus knots in its mirror box: the top
/// level's walk visits two instances, so frames run the kernels with the walk.
fn knots_in_the_box() -> (Arc<GpuContext>, Scene) {
    knots(2, true)
}

/// A validated context and `models` of the paper's torus knots, in the mirror box or not.
fn knots(models: u32, mirror_box: bool) -> (Arc<GpuContext>, Scene) {
    let ctx =
        GpuContext::new(&ContextOptions::validated()).expect("Vulkan with the validation layer");
    let model = ModelSource::Paper(PaperModel::TorusKnot);
    let spec = SceneSpec { model, models, mirror_box, ..Default::default() };
    let (scene, _) = spec.load().unwrap();
    (ctx, scene)
}

/// A 32x32 frame of `scene`, one bounce, traced with `bvh`.
fn small_frame(scene: &Scene, bvh: BvhLayout) -> FrameParams {
    FrameParams::new(
        scene,
        RenderSettings { width: 32, height: 32, bounces: 1, bvh, ..Default::default() },
    )
}

#[test]
fn wide_runs_frames_run_the_leaf_runs_kernel_made_on_first_use() {
    let (ctx, scene) = knots_in_the_box();
    let mut tracer =
        ComputeTracer::with_scene(&ctx, &PackedScene::with_layouts(&scene, Layouts::Both)).unwrap();
    for bvh in [BvhLayout::Binary, BvhLayout::Wide] {
        tracer.render(&small_frame(&scene, bvh)).unwrap();
    }
    assert!(!tracer.pass.made(Variant::Runs), "no leaf-runs kernel before a frame asks for it");
    let (runs, _) = tracer.render(&small_frame(&scene, BvhLayout::WideRuns)).unwrap();
    assert!(tracer.pass.made(Variant::Runs), "a wide-runs frame made and ran the leaf-runs kernel");
    let (wide, _) = tracer.render(&small_frame(&scene, BvhLayout::Wide)).unwrap();
    assert!(runs.compare(&wide, 1e-4).fraction_over <= 0.002);
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}

#[test]
fn wide_frames_run_the_wide_kernel_where_every_mesh_has_a_wide_tree() {
    let (ctx, scene) = knots_in_the_box();
    let mut packed = PackedScene::with_layouts(&scene, Layouts::Both);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    let (binary, _) = tracer.render(&small_frame(&scene, BvhLayout::Binary)).unwrap();
    assert!(!tracer.pass.made(Variant::Wide), "no wide kernel before a wide frame");
    let (wide, _) = tracer.render(&small_frame(&scene, BvhLayout::Wide)).unwrap();
    assert!(tracer.pass.made(Variant::Wide), "a wide frame made and ran the wide kernel");
    assert!(wide.compare(&binary, 1e-4).fraction_over <= 0.002, "the same hits as the binary tree");
    assert!(
        wide.compare(
            &crate::tracer::cpu::render(&packed, &small_frame(&scene, BvhLayout::Wide)),
            1e-4
        )
        .fraction_over
            <= 0.002,
        "GPU as CPU"
    );
    drop(tracer);
    // A mesh without a wide tree needs the binary traversal, which the wide kernel lacks.
    packed.drop_wide_tree(0, &scene.instances);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    let (fallback, _) = tracer.render(&small_frame(&scene, BvhLayout::Wide)).unwrap();
    assert!(!tracer.pass.made(Variant::Wide), "the full kernel traced it");
    assert!(fallback.compare(&binary, 1e-4).fraction_over <= 0.002);
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}

#[test]
fn wide_frames_of_several_samples_run_the_full_kernel_as_the_cpu_traces_them() {
    // The wide kernel traces one sample a pixel (its sample loop left out for registers).
    let (ctx, scene) = knots_in_the_box();
    let packed = PackedScene::with_layouts(&scene, Layouts::Both);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    let settings = RenderSettings { spp: 4, ..small_frame(&scene, BvhLayout::Wide).settings };
    let frame = FrameParams::new(&scene, settings);
    let (gpu, _) = tracer.render(&frame).unwrap();
    assert!(!tracer.pass.made(Variant::Wide), "four samples a pixel: the full kernel");
    let over = gpu.compare(&crate::tracer::cpu::render(&packed, &frame), 1e-4).fraction_over;
    assert!(over <= 0.002, "GPU as CPU at 4 spp ({over})");
    let one = FrameParams::new(&scene, RenderSettings { spp: 1, ..settings });
    let (single, _) = tracer.render(&one).unwrap();
    assert!(tracer.pass.made(Variant::Wide), "one sample a pixel: the wide kernel");
    assert!(gpu.compare(&single, 1e-4).fraction_over > 0.0, "the samples were averaged");
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}

#[test]
fn a_scene_of_one_instance_runs_the_one_instance_kernels_as_the_cpu_traces_it() {
    let cases = [
        (BvhLayout::Wide, Aov::Color, Variant::Wide),
        (BvhLayout::Binary, Aov::Color, Variant::Core),
        (BvhLayout::Wide, Aov::Cost, Variant::Wide),
        (BvhLayout::Binary, Aov::Ao, Variant::Full),
    ];
    // A knot alone, a knot in the mirror box (a closed-box enclosure around one instance),
    // from inside and from outside the box, then two knots in the box (the walk's kernels).
    for (models, mirror_box, outside, one) in [
        (1, false, false, true),
        (1, true, false, true),
        (1, true, true, true),
        (2, true, false, false),
    ] {
        let (ctx, mut scene) = knots(models, mirror_box);
        if outside {
            scene.camera.position = glam::Vec3::new(6.0, 4.0, 10.0);
        }
        let packed = PackedScene::with_layouts(&scene, Layouts::Both);
        assert_eq!(packed.top_level.is_one_instance(), one);
        let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
        for (bvh, aov, variant) in cases {
            let settings = RenderSettings { aov, ..small_frame(&scene, bvh).settings };
            let frame = FrameParams::new(&scene, settings);
            let (gpu, _) = tracer.render(&frame).unwrap();
            let twin = tracer.pass.made_one_instance(variant);
            let name = format!("{} instances at {}", scene.instances.len(), scene.camera.position);
            assert_eq!(twin, one, "{name}: {variant:?}'s one-instance twin for {aov:?}");
            let cpu = crate::tracer::cpu::render(&packed, &frame);
            let over = gpu.compare(&cpu, 1e-4).fraction_over;
            assert!(over <= 0.002, "{name}, {bvh:?} {aov:?}: GPU as CPU ({over})");
        }
        assert_eq!(tracer.pass.made(Variant::Wide), !one, "the wide kernel with the walk");
        // Brute force visits every instance: not the twin's frames.
        let brute = RenderSettings {
            accel: Accel::Brute,
            ..small_frame(&scene, BvhLayout::Binary).settings
        };
        let frame = FrameParams::new(&scene, brute);
        let (gpu, _) = tracer.render(&frame).unwrap();
        let cpu = crate::tracer::cpu::render(&packed, &frame);
        assert!(gpu.compare(&cpu, 1e-4).fraction_over <= 0.002, "brute force, GPU as CPU");
        drop(tracer);
        assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
    }
}

#[test]
fn kernels_made_in_the_background_serve_the_frames_that_need_them() {
    let (ctx, scene) = knots_in_the_box();
    let mut tracer =
        ComputeTracer::with_scene(&ctx, &PackedScene::with_layouts(&scene, Layouts::Both)).unwrap();
    tracer.prepare_kernels_in_background();
    // A wide frame takes the wide kernel, waiting for its thread if need be.
    let (wide, _) = tracer.render(&small_frame(&scene, BvhLayout::Wide)).unwrap();
    assert!(tracer.pass.made(Variant::Wide));
    let start = Instant::now();
    while !tracer.kernels_ready() {
        assert!(start.elapsed().as_secs() < 300, "the background kernels never came");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(tracer.pass.made(Variant::Runs), "made without a wide-runs frame asking");
    let (runs, _) = tracer.render(&small_frame(&scene, BvhLayout::WideRuns)).unwrap();
    assert!(runs.compare(&wide, 1e-4).fraction_over <= 0.002);
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}

/// Issue #43: a brute-force frame traced in the bands its work asks for (rays times
/// triangles, here under a small budget) is the frame traced in one submission.
#[test]
fn a_banded_brute_force_frame_equals_the_unbanded_one() {
    let ctx =
        GpuContext::new(&ContextOptions::validated()).expect("Vulkan with the validation layer");
    let (scene, _) = SceneSpec::default().load().unwrap();
    let mut tracer = ComputeTracer::with_scene(&ctx, &PackedScene::new(&scene)).unwrap();
    let settings =
        RenderSettings { width: 64, height: 40, accel: Accel::Brute, ..Default::default() };
    let frame = FrameTrace::whole(FrameParams::new(&scene, settings));
    tracer.set_resolution(64, 40).unwrap();
    tracer.trace_band(&frame, &Band::rows(0..40, 64)).unwrap();
    let whole = tracer.read_image().unwrap();
    let budget = budget::Budget { work: 2e6, brute_cost: budget::CPU_BRUTE_TEST_COST };
    let triangles = tracer.triangle_total;
    let rows = budget::rows_per_submission(&settings, triangles, GROUP.height, &budget);
    assert!(rows < 40, "the small budget bands the frame ({rows} rows)");
    let mut row = 0;
    while row < 40 {
        tracer.trace_band(&frame, &Band::rows(row..(row + rows).min(40), 64)).unwrap();
        row += rows;
    }
    let banded = tracer.read_image().unwrap();
    assert_eq!(banded.pixels, whole.pixels, "bands of {rows} rows");
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}

/// Bands of `run` pixels in the order the window traces a long frame's bands finer than a
/// work group: group by group in reading order, each group's lanes in order (lanes over
/// the frame's edge ride along). A run that crosses a group's end goes on in the next
/// group as a second band.
fn runs_of_lanes(width: u32, height: u32, run: u32) -> Vec<Band> {
    let mut lanes = Vec::new();
    for row in (0..height).step_by(GROUP.height as usize) {
        for column in (0..width).step_by(GROUP.width as usize) {
            lanes.extend((0..GROUP_LANES).map(|lane| (row, column, lane)));
        }
    }
    let mut bands = Vec::new();
    for mut chunk in lanes.chunks(run as usize) {
        while let Some(&(row, column, first)) = chunk.first() {
            let n = chunk.iter().take_while(|&&(r, c, _)| (r, c) == (row, column)).count();
            bands.push(Band {
                rows: row..(row + GROUP.height).min(height),
                columns: column..(column + GROUP.width).min(width),
                lanes: first..first + n as u32,
            });
            chunk = &chunk[n..];
        }
    }
    bands
}

/// Issue #43: a brute-force frame traced in bands finer than a work group (runs of 1, 7
/// and 50 pixels, which cross group and strip boundaries) is the frame traced whole, byte
/// for byte, in both outputs; and a band writes its own pixels only.
#[test]
fn bands_finer_than_a_group_equal_the_unbanded_frame_and_write_only_their_pixels() {
    let ctx =
        GpuContext::new(&ContextOptions::validated()).expect("Vulkan with the validation layer");
    let (scene, _) = SceneSpec::default().load().unwrap();
    let mut tracer = ComputeTracer::with_scene(&ctx, &PackedScene::new(&scene)).unwrap();
    // 40 wide: each strip's second group overhangs the frame by 24 columns.
    let (width, height) = (40, 8);
    let settings = RenderSettings { width, height, accel: Accel::Brute, ..Default::default() };
    let frame = FrameTrace::whole(FrameParams::new(&scene, settings));
    // Another picture in the outputs first, which bands must overwrite or leave alone.
    let depth = RenderSettings { aov: crate::render_settings::Aov::Depth, ..settings };
    let other = FrameTrace::whole(FrameParams::new(&scene, depth));
    tracer.set_resolution(width, height).unwrap();
    let whole_band = Band::rows(0..height, width);
    let outputs = |tracer: &ComputeTracer| {
        (tracer.read_rgba8().unwrap().into_raw(), tracer.read_image().unwrap().pixels)
    };
    tracer.trace_band(&other, &whole_band).unwrap();
    let (other_rgba, other_float) = outputs(&tracer);
    tracer.trace_band(&frame, &whole_band).unwrap();
    let (rgba, float) = outputs(&tracer);
    assert_ne!(float, other_float, "the two pictures differ");

    // One band of 5 lanes of the second strip's last group: those pixels and no others.
    tracer.trace_band(&other, &whole_band).unwrap();
    let band = Band { rows: 4..8, columns: 32..40, lanes: 37..42 };
    tracer.trace_band(&frame, &band).unwrap();
    let (band_rgba, band_float) = outputs(&tracer);
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let lane = (y % GROUP.height) * GROUP.width + x % GROUP.width;
            let inside =
                band.rows.contains(&y) && band.columns.contains(&x) && band.lanes.contains(&lane);
            let (want_rgba, want_float) =
                if inside { (&rgba, &float) } else { (&other_rgba, &other_float) };
            assert_eq!(band_rgba[i * 4..i * 4 + 4], want_rgba[i * 4..i * 4 + 4], "({x}, {y})");
            assert_eq!(band_float[i], want_float[i], "({x}, {y}) inside: {inside}");
        }
    }
    assert_eq!(band.pixels(), 3, "lanes 40 and 41 are over the frame's edge");

    for run in [1, 7, 50] {
        tracer.trace_band(&other, &whole_band).unwrap();
        let bands = runs_of_lanes(width, height, run);
        assert!(bands.iter().all(Band::is_finer_than_a_group));
        for band in &bands {
            tracer.trace_band(&frame, band).unwrap();
        }
        let (banded_rgba, banded_float) = outputs(&tracer);
        assert!(banded_rgba == rgba, "bands of {run} pixels: colour");
        assert!(banded_float == float, "bands of {run} pixels: float");
    }
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}

/// Issue #43: after a resize, the rows a long frame's bands have not reached yet are the
/// background (opaque black, float zeros), not what the memory held: here the previous
/// frame, whose buffers of the same size the allocator hands out again.
#[test]
fn rows_not_yet_traced_after_a_resize_are_cleared() {
    let ctx =
        GpuContext::new(&ContextOptions::validated()).expect("Vulkan with the validation layer");
    let (scene, _) = SceneSpec::default().load().unwrap();
    let mut tracer = ComputeTracer::with_scene(&ctx, &PackedScene::new(&scene)).unwrap();
    let frame = |width, height| {
        let settings = RenderSettings { width, height, ..Default::default() };
        FrameTrace::whole(FrameParams::new(&scene, settings))
    };
    tracer.trace_frame(&frame(64, 40)).unwrap();
    let (width, height) = (40, 64);
    tracer.set_resolution(width, height).unwrap();
    let traced = GROUP.height * 2;
    tracer.trace_band(&frame(width, height), &Band::rows(0..traced, width)).unwrap();
    let rgba = tracer.read_rgba8().unwrap();
    let float = tracer.read_image().unwrap();
    let start = (traced * width) as usize;
    let black = super::super::trace_pass::CLEAR_RGBA8.to_le_bytes();
    assert!(rgba.pixels().skip(start).all(|p| p.0 == black), "colour not yet traced is black");
    assert!(float.pixels[start..].iter().all(|p| *p == [0.0; 4]), "float not yet traced is 0");
    assert!(rgba.pixels().take(start).any(|p| p.0 != black), "the band was traced");
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}

#[test]
fn round_copies_run_the_wide_kernels_sphere_twin_and_every_kernel_as_the_cpu_traces_them() {
    let ctx =
        GpuContext::new(&ContextOptions::validated()).expect("Vulkan with the validation layer");
    let model = ModelSource::Paper(PaperModel::Geosphere);
    let spec = SceneSpec { model, models: 4, mirror_box: true, ..Default::default() };
    let (scene, _) = spec.load().unwrap();
    let packed = PackedScene::with_layouts(&scene, Layouts::Both);
    assert!(packed.top_level.has_spheres, "geospheres' leaves are spheres");
    assert!(crate::tracer::top_level::wide_twin_before_loading(&spec), "and foreseen");
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    // `render` makes the twin beside the load, and not the wide kernel it would not run.
    tracer.make_kernel_for(&small_frame(&scene, BvhLayout::Wide).settings, false, true);
    assert!(tracer.pass.made_wide_spheres() && !tracer.pass.made(Variant::Wide));
    // The wide kernel's sphere twin, the core kernel (binary) and the full one (AO), which
    // test sphere leaves always.
    for (bvh, aov) in [
        (BvhLayout::Wide, Aov::Color),
        (BvhLayout::Binary, Aov::Color),
        (BvhLayout::Binary, Aov::Ao),
    ] {
        let settings = RenderSettings { aov, ..small_frame(&scene, bvh).settings };
        let frame = FrameParams::new(&scene, settings);
        let (gpu, _) = tracer.render(&frame).unwrap();
        let cpu = crate::tracer::cpu::render(&packed, &frame);
        let over = gpu.compare(&cpu, 1e-4).fraction_over;
        assert!(over <= 0.002, "{bvh:?} {aov:?}: GPU as CPU ({over})");
    }
    assert!(tracer.pass.made_wide_spheres(), "the wide frame ran the sphere twin");
    assert!(!tracer.pass.made(Variant::Wide), "and not the wide kernel, which takes boxes");
    drop(tracer);
    assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
}
