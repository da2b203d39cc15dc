//! The binary BVH built on the device (`--bvh-build device`, `gpu::bvh_build`: Morton codes,
//! a radix sort, Karras's hierarchy, a bottom-up refit, all in place after the upload),
//! read back and held to what the CPU build is held to: the structural checker, closest
//! hits equal to brute force on random rays, the same triangle and hit records as the CPU
//! packing (only their order differs), and frames equal to the CPU reference's. Ordinary,
//! flat and degenerate meshes, and leaf counts around the leaf size. All under validation.

use glam::Vec3;
use meshtracer::bvh::{BuildOptions, BvhNode, TraversalStats};
use meshtracer::gpu::ComputeTracer;
use meshtracer::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
use meshtracer::scene::{Material, Mesh, Scene};
use meshtracer::tracer::packed::{DeviceFit, Layouts};
use meshtracer::tracer::{cpu, FrameParams, PackedScene, DEVICE_LEAF_SIZES};

mod common;

use common::bvh_oracle::{brute_force, hittable, random_rays, Aim};
use common::random::{soup, Rng};

/// Every mesh but the mirror box's 12 triangles left to the device, with leaves of one.
const ON_DEVICE: DeviceFit = DeviceFit { storage_range: None, builds_from: Some(0) };

/// Nodes of a device tree over `n` triangles with leaves of `leaf`.
fn nodes_for(n: usize, leaf: u32) -> usize {
    n.div_ceil(leaf as usize) - 1
}

/// [`ON_DEVICE`] with room for exactly the nodes of the model (`n` triangles, the scene's
/// first mesh) with leaves of `leaf`: the device's leaves hold as few as fit.
fn leaves_of(n: usize, leaf: u32) -> DeviceFit {
    DeviceFit { storage_range: Some(nodes_for(n, leaf) as u64 * 64), ..ON_DEVICE }
}

/// A closed UV sphere of radius 1.
fn sphere(rings: usize, segments: usize) -> Vec<[Vec3; 3]> {
    let p = |i: usize, j: usize| {
        let (theta, phi) = (
            std::f32::consts::PI * i as f32 / rings as f32,
            std::f32::consts::TAU * j as f32 / segments as f32,
        );
        Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
    };
    let mut tris = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

/// The meshes: ordinary, flat, all centroids at one point (every Morton code equal, the
/// tree made from the tie-break alone), and counts around a multiple of the leaf size.
fn meshes() -> Vec<(&'static str, Vec<[Vec3; 3]>)> {
    let flat: Vec<[Vec3; 3]> = (0..900)
        .map(|i| {
            let (x, y) = ((i % 30) as f32, (i / 30) as f32);
            if i % 2 == 0 {
                [Vec3::new(x, y, 0.0), Vec3::new(x + 1.0, y, 0.0), Vec3::new(x, y + 1.0, 0.0)]
            } else {
                [
                    Vec3::new(x + 1.0, y, 0.0),
                    Vec3::new(x + 1.0, y + 1.0, 0.0),
                    Vec3::new(x, y + 1.0, 0.0),
                ]
            }
        })
        .collect();
    // Triangles turned about the origin, their centroids all there.
    let one_point: Vec<[Vec3; 3]> = (0..400)
        .map(|i| {
            let a = i as f32 * 0.0157;
            let (s, c) = a.sin_cos();
            let p = |x: f32, y: f32| {
                Vec3::new(c * x - s * y, s * x + c * y, 0.1 * (i % 7) as f32 - 0.3)
            };
            let (u, v, w) = (p(1.0, 0.0), p(-0.5, 0.866), p(-0.5, -0.866));
            let shift = -(u + v + w) / 3.0;
            [u + shift, v + shift, w + shift]
        })
        .collect();
    let leaf = 4;
    let mut out = vec![
        ("soup", soup(&mut Rng(5), 3_000, 10.0, 0.6)),
        ("sphere", sphere(30, 50)),
        ("flat grid", flat),
        ("one point", one_point),
    ];
    for (name, n) in [("16 leaves", 16 * leaf), ("16 leaves and one triangle", 16 * leaf + 1)] {
        out.push((name, soup(&mut Rng(n as u64), n, 3.0, 0.8)));
    }
    out.push(("17 leaves, the last short", soup(&mut Rng(9), 17 * leaf - 1, 3.0, 0.8)));
    out
}

/// A mesh of `tris`, one material, with computed normals, scaled as every model is.
fn mesh_of(name: &str, tris: &[[Vec3; 3]]) -> Mesh {
    let mut mesh = Mesh {
        name: name.into(),
        positions: tris.iter().flatten().copied().collect(),
        triangles: (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
        triangle_materials: vec![0; tris.len()],
        materials: vec![Material::default()],
        ..Default::default()
    };
    mesh.compute_vertex_normals();
    prepare_mesh(&mut mesh);
    mesh
}

/// `scene` packed for `fit`, its model's tree left to the device, uploaded (built there) and
/// read back; and the tracer holding it.
fn built_on_device(scene: &Scene, fit: DeviceFit) -> (PackedScene, ComputeTracer) {
    let ctx = common::ctx();
    let mut packed = PackedScene::with_layouts_within(scene, Layouts::Binary, fit);
    let reserved = packed.meshes[0].bvh(&packed);
    assert!(
        reserved.nodes.iter().all(|n| *n == BvhNode::default()),
        "the model's nodes are the device's to write"
    );
    let tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    tracer.read_back_device_builds(&mut packed).unwrap();
    common::assert_validation_clean(&ctx);
    (packed, tracer)
}

#[test]
fn device_trees_pass_the_checker_and_find_the_brute_force_hits() {
    for ((name, tris), leaf) in meshes().into_iter().zip(DEVICE_LEAF_SIZES.into_iter().cycle()) {
        check_device_tree(name, &tris, leaf);
    }
    // Every leaf size on one mesh.
    let tris = soup(&mut Rng(6), 500, 4.0, 0.7);
    for leaf in DEVICE_LEAF_SIZES {
        check_device_tree("soup of 500", &tris, leaf);
    }
}

/// The device's tree over `tris` with leaves of `leaf`, checked as the test above says.
fn check_device_tree(name: &str, tris: &[[Vec3; 3]], leaf: u32) {
    let name = &format!("{name}, leaves of {leaf}");
    let scene = paper_scene(mesh_of(name, tris), 1, LightOrbit::default());
    let mesh = &scene.meshes[0];
    let (packed, _tracer) = built_on_device(&scene, leaves_of(tris.len(), leaf));
    let bvh = packed.meshes[0].bvh(&packed);
    assert_eq!(bvh.nodes.len(), nodes_for(tris.len(), leaf), "{name}: a node a leaf but one");
    let corners: Vec<[Vec3; 3]> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();

    // The records are the CPU packing's, moved whole: slot k holds triangle prim's.
    let cpu_packed = PackedScene::new(&scene);
    let m = &cpu_packed.meshes[0];
    let mut by_prim = vec![None; mesh.triangle_count()];
    for k in m.triangle_base..m.triangle_base + m.triangle_count {
        let t = cpu_packed.triangles[k as usize];
        by_prim[t.prim as usize] = Some((t, cpu_packed.shading[k as usize]));
    }
    // The device builds over the records: the corners they give (a zero-area
    // triangle's edges are zeroed by the packing, so it is the point v0 here).
    let record_corners: Vec<[Vec3; 3]> = by_prim
        .iter()
        .map(|r| {
            let t = r.expect("every triangle packed").0;
            let v0 = Vec3::from(t.v0);
            [v0, v0 + Vec3::from(t.e1), v0 + Vec3::from(t.e2)]
        })
        .collect();
    let options = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
    bvh.validate_with(&record_corners, &options).unwrap_or_else(|e| panic!("{name}: {e}"));
    let d = &packed.meshes[0];
    for k in d.triangle_base..d.triangle_base + d.triangle_count {
        let t = packed.triangles[k as usize];
        let want = by_prim[t.prim as usize].unwrap_or_else(|| panic!("{name}: prim {}", t.prim));
        assert_eq!((t, packed.shading[k as usize]), want, "{name}: slot {k}");
    }

    // Closest hits through the device's tree equal brute force over the mesh.
    let range = d.triangle_base as usize..(d.triangle_base + d.triangle_count) as usize;
    let ordered: Vec<[Vec3; 3]> = packed.triangles[range]
        .iter()
        .map(|t| [Vec3::from(t.v0), Vec3::from(t.e1), Vec3::from(t.e2)])
        .collect();
    let hittable_corners = hittable(&corners);
    let mut rng = Rng(17);
    let rays = random_rays(&mut rng, &corners, &hittable_corners, Aim::Inside, 1_500);
    let mut hits = 0;
    for (r, ray) in rays.iter().enumerate() {
        let got =
            bvh.closest_hit(&ordered, ray, 0.0, f32::INFINITY, &mut TraversalStats::default());
        let want = brute_force(&hittable_corners, ray);
        match (got, want) {
            (None, None) => {}
            (Some((_, g)), Some((_, w))) => {
                hits += 1;
                assert!(
                    (g.t - w.t).abs() <= 1e-4 * w.t.abs().max(1e-6),
                    "{name} ray {r}: device tree t = {} vs brute force {}",
                    g.t,
                    w.t
                );
            }
            (g, w) => panic!("{name} ray {r}: device tree {g:?} vs brute force {w:?}"),
        }
    }
    assert!(hits > rays.len() / 4, "{name}: only {hits} of {} rays hit", rays.len());
}

#[test]
fn frames_of_a_device_tree_equal_the_cpu_reference_and_the_cpu_tree() {
    let scene = paper_scene(mesh_of("sphere", &sphere(40, 60)), 3, LightOrbit::default());
    let (packed, mut tracer) = built_on_device(&scene, ON_DEVICE);
    let params = FrameParams::new(&scene, common::settings(64, 2));
    let (gpu, _) = tracer.render(&params).unwrap();
    let on_read_back = cpu::render(&packed, &params);
    let cpu_tree = cpu::render(&PackedScene::new(&scene), &params);
    common::assert_close(&gpu, &on_read_back, "GPU frame vs the CPU tracer on the device's tree");
    common::assert_close(&gpu, &cpu_tree, "the device's tree vs the CPU-built tree");
    common::assert_validation_clean(&common::ctx());
}

#[test]
fn only_meshes_of_the_threshold_and_more_are_left_to_the_device() {
    let scene = paper_scene(mesh_of("sphere", &sphere(10, 10)), 1, LightOrbit::default());
    let n = scene.meshes[0].triangle_count();
    let fit = |from| DeviceFit { storage_range: None, builds_from: Some(from) };
    let zeroed = |packed: &PackedScene| {
        packed.meshes[0].bvh(packed).nodes.iter().all(|n| *n == BvhNode::default())
    };
    assert!(zeroed(&PackedScene::with_layouts_within(&scene, Layouts::Binary, fit(n))));
    assert!(!zeroed(&PackedScene::with_layouts_within(&scene, Layouts::Binary, fit(n + 1))));
    // The mirror box (12 triangles) stays the CPU's even when every mesh is asked for: its
    // closed-box test reads its triangles in the CPU tree's order.
    let packed = PackedScene::with_layouts_within(&scene, Layouts::Wide, ON_DEVICE);
    let mirror = packed.meshes.last().unwrap();
    assert_eq!(mirror.triangle_count, 12);
    assert!(mirror.has_wide_tree(), "the mirror box keeps its CPU trees, the wide one too");
    assert!(!packed.meshes[0].has_wide_tree(), "a device tree is binary: wide frames trace it");
}
