//! The GPU tracer against the CPU reference on the paper's scenes, and both against
//! scenes with analytic answers. Every test runs under the Vulkan validation layer.
//! Tolerance: `common::tolerance::SAME_MATHS` (why, there).

mod common;

use common::*;
use glam::Vec3;
use meshtracer::render_settings::{Accel, Aov, RenderSettings};
use meshtracer::scene::paper::BOX_HALF_SIZE;
use meshtracer::scene::primitives::PaperModel;
use meshtracer::scene::Material;

#[test]
fn each_paper_model_matches_the_cpu_reference() {
    for model in PaperModel::ALL {
        let (gpu, cpu) = render_both(&paper(model, 1), settings(64, 2));
        assert_close(&gpu, &cpu, model.name());
        // The model is in view: the image is not just the box.
        let centre = gpu.get(32, 32);
        assert!(
            centre[0] > centre[2],
            "{}: centre pixel {centre:?} is not the warm model",
            model.name()
        );
    }
}

#[test]
fn model_copies_and_bounce_counts_match() {
    for count in 1..=4 {
        for bounces in 0..=3 {
            let (gpu, cpu) =
                render_both(&paper(PaperModel::Geosphere, count), settings(48, bounces));
            assert_close(&gpu, &cpu, &format!("{count} copies, {bounces} bounces"));
        }
    }
}

#[test]
fn brute_force_and_bvh_give_the_same_image() {
    // From inside the mirror box, where the BVH frames test it as a closed box (the face a
    // ray leaves by), and from outside, where they visit it through its tree; brute force
    // tests every triangle of every instance.
    let inside = paper(PaperModel::TorusKnot, 2);
    let mut outside = inside.clone();
    outside.camera.position = Vec3::new(1.5, 1.0, 2.5) * BOX_HALF_SIZE;
    for (name, scene) in [("inside", inside), ("outside", outside)] {
        let (bvh, bvh_cpu) = render_both(&scene, settings(48, 2));
        let (brute, brute_cpu) =
            render_both(&scene, RenderSettings { accel: Accel::Brute, ..settings(48, 2) });
        assert_close(&bvh, &bvh_cpu, &format!("{name}: bvh"));
        assert_close(&brute, &brute_cpu, &format!("{name}: brute force"));
        assert_close(&brute, &bvh, &format!("{name}: brute vs bvh"));
    }
}

#[test]
fn flat_quad_under_a_light_on_the_axis_has_the_analytic_colour() {
    // Camera and light on the quad's axis: N.L = N.H = 1 at the centre, so the colour is
    // Kd*ambient + Kd + Ks; off-centre N.L = d / sqrt(d^2 + r^2).
    let m = Material {
        diffuse: Vec3::new(0.5, 0.25, 0.125),
        specular: Vec3::ZERO,
        shininess: 8.0,
        mirror: 0.0,
        ..Material::default()
    };
    let d = 3.0;
    let scene = quad_scene(m.clone(), d, Vec3::new(0.0, 0.0, d));
    let size = 33; // odd: a pixel centre lies exactly on the axis
    let (gpu, cpu) = render_both(&scene, settings(size, 0));
    let expect_centre = m.diffuse * 1.1;
    for img in [&gpu, &cpu] {
        let c = img.get(16, 16);
        assert!(
            (Vec3::new(c[0], c[1], c[2]) - expect_centre).abs().max_element() < 1e-4,
            "centre {c:?} vs {expect_centre}"
        );
        // Pixel (24, 16): the ray hits the quad at x = d * tan(fov/2) * (2*24.5/33 - 1).
        let x = d * 30f32.to_radians().tan() * (2.0 * 24.5 / size as f32 - 1.0);
        let ndl = d / (d * d + x * x).sqrt();
        let expect = m.diffuse * (0.1 + ndl);
        let c = img.get(24, 16);
        assert!(
            (Vec3::new(c[0], c[1], c[2]) - expect).abs().max_element() < 1e-4,
            "off-centre {c:?} vs {expect}"
        );
        // Corners miss the quad: black background.
        assert_eq!(img.get(0, 0)[..3], [0.0, 0.0, 0.0]);
    }
}

#[test]
fn vertex_colours_multiply_the_diffuse_colour_on_both_tracers() {
    // One colour on every vertex: the centre is Kd * colour * (ambient + N.L) with N.L = 1,
    // as for a material of that diffuse colour.
    let m = Material {
        diffuse: Vec3::new(0.5, 1.0, 0.75),
        specular: Vec3::ZERO,
        shininess: 8.0,
        mirror: 0.0,
        ..Material::default()
    };
    let d = 3.0;
    let mut scene = quad_scene(m.clone(), d, Vec3::new(0.0, 0.0, d));
    scene.meshes[0].colors = vec![[255, 51, 0, 255]; 4];
    let (gpu, cpu) = render_both(&scene, settings(33, 0));
    let expect = m.diffuse * Vec3::new(1.0, 0.2, 0.0) * 1.1;
    for img in [&gpu, &cpu] {
        let c = img.get(16, 16);
        assert!(
            (Vec3::new(c[0], c[1], c[2]) - expect).abs().max_element() < 1e-4,
            "centre {c:?} vs {expect}"
        );
    }
    // The textures switch (`--no-textures`) turns them off with the textures: Kd alone.
    let (gpu, cpu) = render_both(&scene, RenderSettings { textures: false, ..settings(33, 0) });
    for img in [&gpu, &cpu] {
        let c = img.get(16, 16);
        assert!(
            (Vec3::new(c[0], c[1], c[2]) - m.diffuse * 1.1).abs().max_element() < 1e-4,
            "without colours: centre {c:?}"
        );
    }
    // Red on the left corners, blue on the right: interpolated across, the same on both.
    scene.meshes[0].colors =
        vec![[255, 0, 0, 255], [0, 0, 255, 255], [0, 0, 255, 255], [255, 0, 0, 255]];
    let (gpu, cpu) = render_both(&scene, settings(33, 0));
    assert_close(&gpu, &cpu, "interpolated vertex colours");
    let (left, right) = (gpu.get(10, 16), gpu.get(22, 16));
    assert!(
        left[0] > 2.0 * left[2] && right[2] > 2.0 * right[0],
        "left {left:?} is red, right {right:?} blue"
    );
    assert_eq!(left[1], 0.0, "no green anywhere: the colour multiplies, it does not add");
}

#[test]
fn a_coloured_model_in_the_mirror_box_matches_the_cpu_reference() {
    // The model has colours, the box has none (its vertices read white): smooth shading and
    // two bounces, so the colours are also seen in the mirrors.
    let mut scene = paper(PaperModel::Geosphere, 2);
    let mesh = &mut scene.meshes[0];
    mesh.colors = mesh
        .positions
        .iter()
        .map(|p| [(p.x.abs() * 255.0) as u8, (p.y.abs() * 255.0) as u8, 200, 255])
        .collect();
    let smooth = RenderSettings { smooth: true, ..settings(48, 2) };
    let (gpu, cpu) = render_both(&scene, smooth);
    assert_close(&gpu, &cpu, "coloured geosphere");
    scene.meshes[0].colors.clear();
    let (plain, _) = render_both(&scene, smooth);
    assert!(gpu.compare(&plain, 0.01).fraction_over > 0.05, "the colours change the image");
}

#[test]
fn aovs_report_depth_normal_and_triangle() {
    let d = 3.0;
    let scene = quad_scene(Material::default(), d, Vec3::new(0.0, 0.0, d));
    for (aov, check) in [
        (Aov::Depth, [d, -1.0]),
        (Aov::PrimId, [1.0, -1.0]), // pixel right of centre, above the diagonal: triangle 1
    ] {
        let (gpu, cpu) = render_both(&scene, RenderSettings { aov, ..settings(33, 2) });
        for img in [&gpu, &cpu] {
            let v = if aov == Aov::PrimId { img.get(20, 12)[0] } else { img.get(16, 16)[0] };
            assert!((v - check[0]).abs() < 1e-4, "{aov}: {v} vs {}", check[0]);
            assert_eq!(img.get(0, 0)[0], check[1], "{aov} on a miss");
        }
    }
    let (gpu, _) = render_both(&scene, RenderSettings { aov: Aov::Normal, ..settings(33, 2) });
    let n = gpu.get(16, 16);
    assert!((n[2] - 1.0).abs() < 1e-5, "normal faces the camera: {n:?}");
}

#[test]
fn cost_view_counts_brute_force_tests_exactly() {
    // Brute force tests every triangle of every instance for every ray.
    let scene = paper(PaperModel::Geosphere, 2);
    let tris = scene.triangle_count() as f32;
    let (gpu, cpu) = render_both(
        &scene,
        RenderSettings { aov: Aov::Cost, accel: Accel::Brute, ..settings(16, 0) },
    );
    for img in [&gpu, &cpu] {
        assert_eq!(img.get(8, 8)[1], tris);
    }
}

#[test]
fn cost_view_counts_bvh_traversal_like_the_shader() {
    // Both count the same nodes and triangles per pixel (`assert_same_cost`): one model in
    // the box (the one-instance kernel: the model, then the box's wall where it lies before
    // the model's hit) and two (the walk: the box first); the knot, and the geosphere, which
    // is convex: the bounces off it skip its instance on both (tracer/convex.rs).
    for model in [PaperModel::TorusKnot, PaperModel::Geosphere] {
        for copies in [1, 2] {
            let scene = paper(model, copies);
            let settings = RenderSettings { aov: Aov::Cost, ..settings(48, 2) };
            let (gpu, cpu) = render_both(&scene, settings);
            assert_same_cost(&gpu, &cpu, &format!("{} x{copies}", model.name()));
            assert!(cpu.pixels.iter().any(|p| p[0] > 1.0), "the BVH is traversed");
        }
    }
}
