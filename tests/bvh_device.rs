//! The binary BVH built on the device (`--bvh-build device`, `gpu::bvh_build`: Morton codes,
//! a radix sort, Karras's hierarchy, a bottom-up refit, all in place after the upload),
//! read back and held to what the CPU build is held to: the structural checker, closest
//! hits equal to brute force on random rays, the same triangle and hit records as the CPU
//! packing (only their order differs), and frames equal to the CPU reference's. Ordinary,
//! flat and degenerate meshes, and leaf counts around the leaf size. All under validation.

use glam::Vec3;
use meshtracer::bvh::{wide, BuildOptions, BvhNode, TraversalStats};
use meshtracer::gpu::ComputeTracer;
use meshtracer::render_settings::{BvhLayout, RenderSettings};
use meshtracer::scene::paper::{paper_scene, LightOrbit};
use meshtracer::scene::Scene;
use meshtracer::tracer::packed::{DeviceFit, Layouts};
use meshtracer::tracer::{cpu, FrameParams, PackedScene, DEVICE_LEAF_SIZES};

mod common;

use common::bvh_oracle::{brute_force, hittable, random_rays, Aim};
use common::random::{soup, Rng};
use common::{mesh_of, sphere};

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
        ("sphere", sphere(30, 50, 1.0)),
        ("flat grid", flat),
        ("one point", one_point),
    ];
    for (name, n) in [("16 leaves", 16 * leaf), ("16 leaves and one triangle", 16 * leaf + 1)] {
        out.push((name, soup(&mut Rng(n as u64), n, 3.0, 0.8)));
    }
    out.push(("17 leaves, the last short", soup(&mut Rng(9), 17 * leaf - 1, 3.0, 0.8)));
    out
}

/// `scene` packed for `fit` in `layouts`, its model's trees left to the device, uploaded
/// (built there) and read back; and the tracer holding it.
fn built_on_device(
    scene: &Scene,
    layouts: Layouts,
    fit: DeviceFit,
) -> (PackedScene, ComputeTracer) {
    let ctx = common::ctx();
    let mut packed = PackedScene::with_layouts_within(scene, layouts, fit);
    let model = &packed.meshes[0];
    let (binary, wide) = (model.bvh(&packed).nodes, model.wide_tree(&packed).nodes);
    let bytes: [&[u8]; 2] = [bytemuck::cast_slice(&binary), bytemuck::cast_slice(&wide)];
    assert!(
        bytes.iter().all(|b| b.iter().all(|&b| b == 0)),
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
        check_device_trees(name, &tris, Layouts::Binary, leaves_of(tris.len(), leaf));
    }
    // Every leaf size on one mesh.
    let tris = soup(&mut Rng(6), 500, 4.0, 0.7);
    for leaf in DEVICE_LEAF_SIZES {
        check_device_trees("soup of 500", &tris, Layouts::Binary, leaves_of(tris.len(), leaf));
    }
}

#[test]
fn device_wide_trees_find_the_brute_force_hits_beside_or_without_the_binary_ones() {
    // Both trees (the binary one pointed at the wide tree's triangle order), or the wide
    // one alone; leaves of one triangle, or two where the binary tree of one would not fit.
    for (name, tris) in meshes() {
        check_device_trees(name, &tris, Layouts::Both, ON_DEVICE);
        check_device_trees(name, &tris, Layouts::Wide, ON_DEVICE);
    }
    let tris = soup(&mut Rng(8), 1_001, 4.0, 0.7);
    check_device_trees("soup, leaves of two", &tris, Layouts::Wide, leaves_of(tris.len(), 2));
    // Both trees asked for where only one fits: the wide one alone (a warning says so), its
    // binary tree kept in the build's scratch memory.
    let leaves = tris.len();
    let both = nodes_for(leaves, 1) * 64 + wide_reserve(leaves) * 80;
    let fit = DeviceFit { storage_range: Some(both as u64 - 1), ..ON_DEVICE };
    check_device_trees("soup, room for one tree", &tris, Layouts::Both, fit);
}

/// The wide nodes reserved for the device's collapse of `leaves` leaves (the bound in
/// `tracer::prepare`: 7W <= 4 leaves - 1, and one spare).
fn wide_reserve(leaves: usize) -> usize {
    (4 * leaves).div_ceil(7) + 1
}

/// The device's trees over `tris` packed in `layouts` for `fit`: the binary one (where
/// kept) against the checker, both against brute force on random rays, the triangle and hit
/// records the CPU packing's, moved whole.
fn check_device_trees(name: &str, tris: &[[Vec3; 3]], layouts: Layouts, fit: DeviceFit) {
    let name = &format!("{name}, {layouts:?}, {fit:?}");
    let scene = paper_scene(mesh_of(name, tris), 1, LightOrbit::default());
    let mesh = &scene.meshes[0];
    let (packed, _tracer) = built_on_device(&scene, layouts, fit);
    let d = &packed.meshes[0];
    let bvh = d.bvh(&packed);
    let wide = d.wide_tree(&packed);
    assert_eq!(d.has_wide_tree(), layouts != Layouts::Binary, "{name}");
    assert_eq!(bvh.nodes.is_empty(), !packed.has_binary(), "{name}");
    let corners: Vec<[Vec3; 3]> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();

    // The records are the CPU packing's, moved whole: slot k holds triangle prim's.
    let cpu_packed = PackedScene::new(&scene);
    let m = &cpu_packed.meshes[0];
    let mut by_prim = vec![None; mesh.triangle_count()];
    for k in m.triangle_base..m.triangle_base + m.triangle_count {
        let t = cpu_packed.triangles[k as usize];
        by_prim[t.prim as usize] = Some((t, cpu_packed.shading[k as usize]));
    }
    for k in d.triangle_base..d.triangle_base + d.triangle_count {
        let t = packed.triangles[k as usize];
        let want = by_prim[t.prim as usize].unwrap_or_else(|| panic!("{name}: prim {}", t.prim));
        assert_eq!((t, packed.shading[k as usize]), want, "{name}: slot {k}");
    }
    if !bvh.nodes.is_empty() {
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
        let leaf = DEVICE_LEAF_SIZES
            .into_iter()
            .find(|&l| nodes_for(tris.len(), l) == bvh.nodes.len())
            .unwrap_or_else(|| panic!("{name}: {} nodes is no leaf size's", bvh.nodes.len()));
        let options = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
        bvh.validate_with(&record_corners, &options).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    if d.has_wide_tree() {
        let need = wide.stack_need();
        assert!(need <= wide::STACK_SIZE, "{name}: the wide tree needs {need} stack entries");
    }

    // Closest hits through the device's trees equal brute force over the mesh.
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
        let want = brute_force(&hittable_corners, ray);
        let mut got = Vec::new();
        if !bvh.nodes.is_empty() {
            let stats = &mut TraversalStats::default();
            got.push(("binary", bvh.closest_hit(&ordered, ray, 0.0, f32::INFINITY, stats)));
        }
        if d.has_wide_tree() {
            let stats = &mut TraversalStats::default();
            let hit = wide::closest_hit(&wide.nodes, &ordered, ray, 0.0, f32::INFINITY, stats);
            got.push(("wide", hit));
        }
        for (tree, got) in got {
            match (got, want) {
                (None, None) => {}
                (Some((_, g)), Some((_, w))) => {
                    hits += 1;
                    assert!(
                        (g.t - w.t).abs() <= 1e-4 * w.t.abs().max(1e-6),
                        "{name} ray {r}: the device's {tree} tree t = {} vs brute force {}",
                        g.t,
                        w.t
                    );
                }
                (g, w) => panic!("{name} ray {r}: the device's {tree} tree {g:?} vs {w:?}"),
            }
        }
    }
    assert!(hits > rays.len() / 4, "{name}: only {hits} of {} rays hit", rays.len());
}

#[test]
fn frames_of_device_trees_equal_the_cpu_reference_and_the_cpu_trees() {
    let scene = paper_scene(mesh_of("sphere", &sphere(40, 60, 1.0)), 3, LightOrbit::default());
    for (layouts, layout) in [
        (Layouts::Binary, BvhLayout::Binary),
        (Layouts::Both, BvhLayout::Binary),
        (Layouts::Both, BvhLayout::Wide),
        (Layouts::Wide, BvhLayout::Wide),
    ] {
        let what = format!("{layouts:?} packing, {layout} frames");
        let (packed, mut tracer) = built_on_device(&scene, layouts, ON_DEVICE);
        let settings = RenderSettings { bvh: layout, ..common::settings(64, 2) };
        let params = FrameParams::new(&scene, settings);
        let (gpu, _) = tracer.render(&params).unwrap();
        let on_read_back = cpu::render(&packed, &params);
        let cpu_trees = cpu::render(&PackedScene::with_layouts(&scene, layouts), &params);
        common::assert_close(&gpu, &on_read_back, &format!("{what}: GPU vs CPU, device trees"));
        common::assert_close(&gpu, &cpu_trees, &format!("{what}: device trees vs CPU trees"));
    }
    common::assert_validation_clean(&common::ctx());
}

#[test]
fn only_meshes_of_the_threshold_and_more_are_left_to_the_device() {
    let scene = paper_scene(mesh_of("sphere", &sphere(10, 10, 1.0)), 1, LightOrbit::default());
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
    assert!(packed.meshes[0].has_wide_tree(), "the device collapses its tree where asked to");
    // A packing of binary trees alone holds none.
    let packed = PackedScene::with_layouts_within(&scene, Layouts::Binary, ON_DEVICE);
    assert!(!packed.meshes[0].has_wide_tree());
}
