//! Scenes of instances (the two-level structure): several meshes, each placed many times by
//! rotations, non-uniform and mirrored scales. The GPU against the CPU reference in both
//! BVH layouts, colour and AO views; the vendor's structures against ours; and an
//! instanced scene against its flattened twin (every instance's triangles written out in
//! world space, normals by the inverse transpose), which must look the same. Every GPU
//! test runs under the validation layer.
//!
//! Tolerances: `common::tolerance::SAME_MATHS` (`SAME_MATHS_FIELD` for a field of hundreds of
//! copies) and `AO` for GPU against CPU, `VENDOR` and
//! `AO_VENDOR` against the vendor's, and `VENDOR` for the twin (its triangles are rounded
//! in world space, so a ray grazing an edge may pick the neighbour; why, there).

mod common;

use common::tolerance::{AO, AO_VENDOR, SAME_MATHS, SAME_MATHS_FIELD, VENDOR, VENDOR_IDS};
use common::*;
use glam::{Affine3A, EulerRot, Quat, Vec3};
use meshtracer::gpu::khr_rt::VendorKernel;
use meshtracer::gpu::ComputeTracer;
use meshtracer::render_settings::{Accel, Aov, BvhLayout, RenderSettings};
use meshtracer::scene::paper::prepare_mesh;
use meshtracer::scene::primitives::PaperModel;
use meshtracer::scene::{Camera, Instance, Mesh, PointLight, Scene};
use meshtracer::tracer::packed::Layouts;
use meshtracer::tracer::{cpu, FrameParams, Image, PackedScene};

/// `translation`, then `rotation` (Euler XYZ, radians), then `scale` (any sign).
fn placed(mesh: usize, scale: [f32; 3], rotation: [f32; 3], translation: [f32; 3]) -> Instance {
    let [a, b, c] = rotation;
    let transform = Affine3A::from_scale_rotation_translation(
        Vec3::from(scale),
        Quat::from_euler(EulerRot::XYZ, a, b, c),
        Vec3::from(translation),
    );
    Instance::new(mesh, transform).expect("an invertible transform")
}

/// A knot and a geosphere, each placed four times: turned, stretched along one axis,
/// mirrored, and overlapping their neighbours, in front of a turned quad floor.
fn instanced_scene() -> Scene {
    let prepared = |m: PaperModel| {
        let mut mesh = m.mesh();
        prepare_mesh(&mut mesh);
        mesh
    };
    let floor = quad_mesh(meshtracer::scene::Material::default());
    Scene {
        meshes: vec![prepared(PaperModel::TorusKnot), prepared(PaperModel::Geosphere), floor],
        instances: vec![
            placed(0, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
            placed(0, [0.6, 1.4, 0.8], [0.4, 1.0, -0.3], [2.2, 0.3, -0.5]),
            placed(0, [-0.7, 0.7, 0.7], [0.0, 0.5, 0.0], [-2.0, 0.0, 0.4]),
            placed(1, [1.5, 0.5, 1.0], [0.0, 0.0, 0.7], [0.5, 1.6, 0.2]),
            placed(1, [0.4, -0.9, 0.6], [1.0, 0.2, 0.0], [-0.6, -1.5, 0.9]),
            placed(1, [0.8, 0.8, 0.8], [0.0, 0.0, 0.0], [1.4, -1.2, 1.0]),
            placed(2, [6.0, 4.0, 1.0], [-1.2, 0.1, 0.0], [0.0, -2.2, -1.0]),
        ],
        camera: Camera {
            position: Vec3::new(1.0, 1.5, 7.0),
            target: Vec3::new(0.0, -0.2, 0.0),
            up: Vec3::Y,
            vfov_deg: 55.0,
        },
        light: PointLight { position: Vec3::new(2.0, 4.0, 5.0), color: Vec3::ONE },
        background: Vec3::new(0.1, 0.1, 0.15),
        ambient: 0.1,
        environment: None,
        assembly: Default::default(),
    }
}

/// Every instance's triangles written out in world space, one mesh per instance: what the
/// two-level structure must trace like. Vertex normals go out by the inverse transpose and
/// are not normalised: the tracers interpolate them before normalising, so the twin's
/// interpolated normal is then exactly the transformed one of the instance.
fn flattened(scene: &Scene) -> Scene {
    let meshes: Vec<Mesh> = scene
        .instances
        .iter()
        .map(|inst| {
            let mut mesh = scene.meshes[inst.mesh].clone();
            let normal_matrix = inst.transform.matrix3.inverse().transpose();
            for p in &mut mesh.positions {
                *p = inst.transform.transform_point3(*p);
            }
            for n in &mut mesh.normals {
                *n = normal_matrix * *n;
            }
            mesh
        })
        .collect();
    let instances = (0..meshes.len()).map(|m| Instance::placed(m, Vec3::ZERO, 1.0)).collect();
    Scene { meshes, instances, ..scene.clone() }
}

fn colour(size: u32, bvh: BvhLayout, smooth: bool) -> RenderSettings {
    RenderSettings { bvh, smooth, ..settings(size, 2) }
}

fn ao(size: u32, bvh: BvhLayout) -> RenderSettings {
    RenderSettings { aov: Aov::Ao, ao_samples: 8, ao_radius: 1.5, ..colour(size, bvh, true) }
}

/// The image of `scene` on the GPU with `settings`.
fn gpu(scene: &Scene, settings: RenderSettings) -> Image {
    let ctx = ctx();
    let packed = PackedScene::with_layouts(scene, Layouts::only(settings.bvh));
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    let (image, _) = tracer.render(&FrameParams::new(scene, settings)).expect("trace");
    drop(tracer);
    assert_validation_clean(&ctx);
    image
}

#[test]
fn turned_stretched_and_mirrored_instances_match_the_cpu_in_both_layouts() {
    let scene = instanced_scene();
    for bvh in [BvhLayout::Binary, BvhLayout::Wide] {
        for smooth in [false, true] {
            let (gpu, cpu) = render_both(&scene, colour(96, bvh, smooth));
            assert_within(&gpu, &cpu, SAME_MATHS, &format!("{bvh:?} smooth {smooth}"));
            // Something of every kind of instance shows: the image is not one colour.
            assert!(large_neighbour_steps(&gpu, 0.05) > 50, "{bvh:?}: a flat image");
        }
        let (gpu, cpu) = render_both(&scene, ao(64, bvh));
        assert_within(&gpu, &cpu, AO, &format!("{bvh:?} AO"));
    }
    // Brute force takes the same instances (no top level) and finds the same hits.
    let brute = RenderSettings { accel: Accel::Brute, ..colour(64, BvhLayout::Binary, true) };
    let (gpu_brute, cpu_brute) = render_both(&scene, brute);
    assert_within(&gpu_brute, &cpu_brute, SAME_MATHS, "brute force");
    let (bvh, _) = render_both(&scene, colour(64, BvhLayout::Binary, true));
    assert_within(&gpu_brute, &bvh, SAME_MATHS, "brute force against the BVH");
}

#[test]
fn turned_stretched_and_mirrored_convex_copies_are_skipped_alike_by_the_gpu_and_the_cpu() {
    // Cylinders, stretched, turned and mirrored, are convex without being round: a bounce
    // off their outside skips their instance on both tracers (tracer/convex.rs), so both
    // count the same work. Without sphere leaves, it is the convex copies alone that send
    // wide frames to the wide kernel's twin (FLAG_CONVEX), whose plain sibling skips
    // nothing and would count more.
    let mut cylinder = PaperModel::Cylinder.mesh();
    prepare_mesh(&mut cylinder);
    let scene = Scene {
        meshes: vec![cylinder],
        instances: vec![
            placed(0, [2.0, 0.5, 0.7], [0.3, 0.2, 0.0], [0.0, 0.0, 0.0]),
            placed(0, [-0.6, 1.8, 0.6], [0.0, 0.9, 0.4], [1.7, 0.4, -0.6]),
            placed(0, [0.5, 0.6, 2.2], [1.1, 0.0, 0.3], [-1.6, -0.3, 0.5]),
        ],
        ..instanced_scene()
    };
    let packed = PackedScene::new(&scene);
    let sphere_leaf = |n: &meshtracer::bvh::BvhNode| {
        n.children().iter().any(|c| c.count == meshtracer::contract::TOP_SPHERE)
    };
    assert!(!packed.top_level.nodes.iter().any(sphere_leaf), "no copy is round");
    let mut skipped = 0.0;
    for bvh in [BvhLayout::Binary, BvhLayout::Wide] {
        let cost = RenderSettings { aov: Aov::Cost, ..colour(64, bvh, false) };
        let (gpu, cpu) = render_both(&scene, cost);
        assert_same_cost(&gpu, &cpu, &format!("{bvh:?}"));
        skipped += gpu.pixels.iter().map(|p| p[0] + p[1]).sum::<f32>();
    }
    assert!(skipped > 0.0, "the BVHs are traversed");
}

#[test]
fn an_instanced_scene_traces_like_its_flattened_twin() {
    let scene = instanced_scene();
    let twin = flattened(&scene);
    assert_eq!(twin.triangle_count(), scene.triangle_count());
    // Flat shading: the geometric normal of a transformed triangle is the inverse
    // transpose of its object-space one. Smooth normals: the twin's were carried out the
    // same way. Depth: ray parameters stay world distances.
    for (what, settings) in [
        ("flat colour", colour(96, BvhLayout::Wide, false)),
        (
            "smooth normals",
            RenderSettings { aov: Aov::Normal, ..colour(96, BvhLayout::Wide, true) },
        ),
        ("depth", RenderSettings { aov: Aov::Depth, ..colour(96, BvhLayout::Binary, false) }),
    ] {
        let tolerance = if what == "flat colour" { VENDOR } else { VENDOR_IDS };
        assert_within(&gpu(&scene, settings), &gpu(&twin, settings), tolerance, what);
    }
}

#[test]
fn the_vendors_structures_place_instances_as_ours_do() {
    let ctx = ctx();
    let support = &ctx.info.vendor;
    assert!(
        support.available(),
        "CI's lavapipe (Mesa 25) has the vendor's ray tracing: {:?}",
        support.missing
    );
    let scene = instanced_scene();
    let packed = PackedScene::new(&scene);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    for (settings, tolerance) in
        [(colour(64, BvhLayout::Binary, true), VENDOR), (ao(48, BvhLayout::Binary), AO_VENDOR)]
    {
        let (ours, _) = tracer.render(&FrameParams::new(&scene, settings)).expect("trace");
        for kernel in VendorKernel::ALL.into_iter().filter(|k| k.supported(support)) {
            tracer.set_vendor_kernel(kernel).expect("a kind the device has");
            let vendor_settings = RenderSettings { accel: Accel::Vendor, ..settings };
            let (vendor, _) =
                tracer.render(&FrameParams::new(&scene, vendor_settings)).expect("trace");
            assert_within(&vendor, &ours, tolerance, &format!("{kernel} {:?}", settings.aov));
        }
    }
    drop(tracer);
    assert_validation_clean(&ctx);
}

#[test]
fn a_field_of_copies_matches_the_cpu_and_moving_it_rebuilds_only_the_top_level() {
    // 300 scattered copies: past the paper's lattice, in a grown mirror box.
    let mut mesh = PaperModel::Geosphere.mesh();
    prepare_mesh(&mut mesh);
    let spec = meshtracer::scene::spec::SceneSpec { models: 300, scatter: 5, ..Default::default() };
    let scene = spec.scene_with(mesh);
    assert_eq!(scene.instances.len(), 301);
    // Primary rays: a mirror bounce among 300 turned copies amplifies the tracers' last-bit
    // differences (FMA in the transforms) into other hits, in 0.4% of pixels at 2 bounces.
    let primary = RenderSettings { bounces: 0, ..colour(96, BvhLayout::Wide, true) };
    let (gpu_image, cpu_image) = render_both(&scene, primary);
    assert_within(&gpu_image, &cpu_image, SAME_MATHS_FIELD, "300 copies");

    // A new field on the same tracer: only the top level is uploaded again.
    let ctx = ctx();
    let mut packed = PackedScene::new(&scene);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    let bytes = tracer.scene_bytes();
    let bigger = meshtracer::scene::spec::SceneSpec { models: 2000, ..spec };
    let moved = bigger.scene_with(scene.meshes[0].clone());
    packed.set_instances(&moved.instances);
    tracer.set_instances(&packed.top_level).expect("a new top level");
    let primary = RenderSettings { bounces: 0, ..colour(48, BvhLayout::Binary, false) };
    let params = FrameParams::new(&moved, primary);
    let (image, _) = tracer.render(&params).expect("trace");
    assert_within(&image, &cpu::render(&packed, &params), SAME_MATHS_FIELD, "2000 copies");
    assert_eq!(tracer.scene_bytes(), bytes, "written in place: the buffers hold 10,000 copies");
    drop(tracer);
    assert_validation_clean(&ctx);
}

#[test]
fn a_lone_turned_instance_is_traced_like_the_cpu() {
    // One instance: the cost view counts the top level's node and the mesh's, the same on
    // both (a ray grazing a box edge may go either way on a driver: 0.2% of the pixels), in
    // both layouts; the images agree.
    let mut scene = instanced_scene();
    scene.instances.truncate(2);
    scene.instances.remove(0); // the turned, stretched knot alone
    for bvh in [BvhLayout::Binary, BvhLayout::Wide] {
        let cost = RenderSettings { aov: Aov::Cost, ..colour(48, bvh, false) };
        let (gpu, cpu) = render_both(&scene, cost);
        let differ = gpu.pixels.iter().zip(&cpu.pixels).filter(|(g, c)| g[..2] != c[..2]).count();
        assert!(differ <= 4, "{bvh:?}: cost differs on {differ} pixels");
        assert!(cpu.pixels.iter().any(|p| p[1] > 0.0), "{bvh:?}: the knot is hit");
        let (gpu, cpu) = render_both(&scene, colour(48, bvh, true));
        assert_within(&gpu, &cpu, SAME_MATHS, &format!("lone instance, {bvh:?}"));
    }
    common::assert_validation_clean(&common::ctx());
}

/// Small knots inside a big one, seen along its axis through its hole: a ray that hits a
/// small knot enters the big knot's box first, and walks the big knot's far side too
/// unless it already knows its hit.
fn knots_in_a_knot() -> Scene {
    let mut knot = PaperModel::TorusKnot.mesh();
    prepare_mesh(&mut knot);
    let small = |x: f32, y: f32, z: f32| placed(0, [0.25; 3], [0.3 * x, 0.7, 0.2 * y], [x, y, z]);
    let mut scene = instanced_scene();
    scene.meshes = vec![knot];
    scene.instances = vec![
        placed(0, [3.0; 3], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        small(0.0, 0.0, 0.0),
        small(0.5, 0.3, -0.5),
        small(-0.4, -0.3, 0.4),
    ];
    scene.camera.position = Vec3::new(0.0, 0.0, 9.0);
    scene.camera.target = Vec3::ZERO;
    scene
}

#[test]
fn a_frame_started_from_the_last_frames_hits_is_the_same_frame_with_fewer_steps() {
    // A second frame of the same view starts each camera ray's walk at the copy the first
    // frame's ray hit (the walk hints), both layouts, 2 bounces: the same image bit for
    // bit; and a ray that sees a small knot walks the big one only up to that hit, so the
    // frame takes fewer steps. A new top level forgets the hints: its first frame counts
    // what a fresh tracer's does.
    let scene = knots_in_a_knot();
    let ctx = ctx();
    let steps = |cost: &Image| cost.pixels.iter().map(|p| (p[0] + p[1]) as f64).sum::<f64>();
    for bvh in [BvhLayout::Binary, BvhLayout::Wide] {
        let packed = PackedScene::with_layouts(&scene, Layouts::only(bvh));
        let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
        let settings = colour(64, bvh, true);
        let colour = FrameParams::new(&scene, settings);
        let (first, _) = tracer.render(&colour).expect("trace");
        let (second, _) = tracer.render(&colour).expect("trace");
        assert!(first.pixels == second.pixels, "{bvh:?}: the hinted frame differs");
        assert!(large_neighbour_steps(&first, 0.05) > 50, "{bvh:?}: a flat image");

        let cost = FrameParams::new(&scene, RenderSettings { aov: Aov::Cost, ..settings });
        tracer.set_instances(&packed.top_level).expect("the same top level again");
        let (fresh, _) = tracer.render(&cost).expect("trace");
        let (hinted, _) = tracer.render(&cost).expect("trace");
        let (before, after) = (steps(&fresh), steps(&hinted));
        assert!(after < before, "{bvh:?}: {after} steps with hints, {before} without");
        let mut new_tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
        let (first_cost, _) = new_tracer.render(&cost).expect("trace");
        assert!(fresh.pixels == first_cost.pixels, "{bvh:?}: hints survived a new top level");
    }
    assert_validation_clean(&ctx);
}
