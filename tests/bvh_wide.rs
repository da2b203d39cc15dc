//! The compressed wide BVH against the binary tree it is collapsed from and against brute
//! force: the same closest hits (up to ties) on ordinary and degenerate meshes, boxes that
//! contain what they bound, and its size beside the binary tree.

use glam::Vec3;
use meshtracer::bvh::wide::{self, WideBvh, WideSlot, WideStats, WIDTH};
use meshtracer::bvh::{ordered_edges, BuildOptions, Bvh, TraversalStats};
use meshtracer::geometry::{Aabb, Ray};
use meshtracer::scene::primitives::PaperModel;

use common::bvh_oracle::{bounds, brute_force, hittable, random_rays, Aim};
use common::random::{room, soup, Rng};

/// Every wide node's decoded child boxes contain the exact boxes of what they hold (where
/// the build cut triangles, overlap them and together cover them), and every triangle slot
/// sits in exactly one leaf.
fn check_boxes(wide: &WideBvh, bvh: &Bvh, tris: &[[Vec3; 3]], cut: bool) {
    let mut seen = vec![0u32; bvh.prim_indices.len()];
    let mut covered = vec![Aabb::EMPTY; tris.len()];
    let mut stack = vec![(0u32, None::<Aabb>)];
    while let Some((index, parent_slot)) = stack.pop().filter(|_| !wide.nodes.is_empty()) {
        let node = &wide.nodes[index as usize];
        let mut node_box = Aabb::EMPTY;
        for s in 0..WIDTH {
            let decoded = node.child_box(s);
            match node.slot(s) {
                WideSlot::Empty => continue,
                WideSlot::Inner(child) => stack.push((child, Some(decoded))),
                WideSlot::Leaf { first, count } => {
                    assert!((1..=3).contains(&count));
                    for k in first..first + count {
                        seen[k as usize] += 1;
                        let p = bvh.prim_indices[k as usize] as usize;
                        let exact = Aabb::from_points(&tris[p]);
                        covered[p] = covered[p].union(decoded);
                        let ok =
                            if cut { overlap(&exact, &decoded) } else { inside(&exact, &decoded) };
                        assert!(ok, "triangle {k} {exact:?} outside its slot {decoded:?}");
                    }
                }
            }
            node_box = node_box.union(decoded);
        }
        if let Some(slot) = parent_slot {
            // The children's frame lies within the slot that points here, up to one step.
            let step = node.scale().max_element() * 2.0 + slot.extent().max_element() * 1e-6;
            assert!(
                node_box.min.cmpge(slot.min - step).all()
                    && node_box.max.cmple(slot.max + step).all(),
                "node {index} leaves its slot"
            );
        }
    }
    assert!(seen.iter().all(|&n| n == 1), "every triangle slot in exactly one leaf");
    for (p, t) in tris.iter().enumerate() {
        assert!(
            tris.len() <= 1 || inside(&Aabb::from_points(t), &covered[p]),
            "triangle {p}'s slots do not cover it"
        );
    }
}

fn overlap(a: &Aabb, b: &Aabb) -> bool {
    a.min.cmple(b.max).all() && b.min.cmple(a.max).all()
}

fn inside(inner: &Aabb, outer: &Aabb) -> bool {
    inner.min.cmpge(outer.min).all() && inner.max.cmple(outer.max).all()
}

/// Build, collapse, check the boxes and the reordered binary tree, then trace `rays` random
/// rays through both trees and brute force; returns the two trees' traversal counts.
fn check_mesh(
    name: &str,
    tris: &[[Vec3; 3]],
    rays: usize,
    options: &BuildOptions,
) -> (TraversalStats, TraversalStats) {
    let mut bvh = Bvh::build(tris, options);
    let wide = wide::collapse(&mut bvh);
    bvh.validate_with(tris, options)
        .unwrap_or_else(|e| panic!("{name}: reordered binary tree: {e}"));
    check_boxes(&wide, &bvh, tris, options.split_budget > 0.0);
    assert!(
        wide.stack_need() <= wide::STACK_SIZE,
        "{name}: the traversal may need {} stack entries",
        wide.stack_need()
    );
    assert!(wide.stack_need() >= wide.depth(), "{name}: a path's every node is pending at its end");
    let targets = hittable(tris);
    let ordered = ordered_edges(&bvh, &targets);
    let (mut binary_stats, mut wide_stats) = (TraversalStats::default(), TraversalStats::default());
    let mut rng = Rng(0x9e37_79b9 ^ tris.len() as u64);
    for (r, ray) in random_rays(&mut rng, tris, tris, Aim::Inside, rays).iter().enumerate() {
        let binary = bvh.closest_hit(&ordered, ray, 0.0, f32::INFINITY, &mut binary_stats);
        let got =
            wide::closest_hit(&wide.nodes, &ordered, ray, 0.0, f32::INFINITY, &mut wide_stats);
        let want = brute_force(&targets, ray);
        for (what, other) in
            [("binary", binary), ("brute force", want.map(|(i, h)| (u32::MAX - i, h)))]
        {
            match (got, other) {
                (None, None) => {}
                (Some((k, g)), Some((_, w))) => {
                    let close = (g.t - w.t).abs() <= 1e-5 * w.t.abs().max(1e-30);
                    assert!(
                        close,
                        "{name} ray {r}: wide t = {} (k {k}) vs {what} t = {}: {ray:?}",
                        g.t, w.t
                    );
                }
                (g, w) => panic!("{name} ray {r}: wide {g:?} vs {what} {w:?}: {ray:?}"),
            }
        }
        // The occlusion query: a hit just beyond the closest one, none just before it.
        let any = |t_max: f32| {
            wide::any_hit(&wide.nodes, &ordered, ray, 0.0, t_max, &mut TraversalStats::default())
        };
        match want {
            Some((_, w)) => assert!(
                any(w.t * 1.01) && !any(w.t * 0.99),
                "{name} ray {r}: any-hit around t = {}",
                w.t
            ),
            None => assert!(!any(f32::INFINITY), "{name} ray {r}: any-hit without a hit"),
        }
        if let (Some((k, g)), Some((j, b))) = (got, binary) {
            if k == j {
                assert_eq!(g, b, "{name} ray {r}: same triangle, different hit");
            }
        }
    }
    (binary_stats, wide_stats)
}

fn tracing() -> BuildOptions {
    BuildOptions { max_leaf_size: 2, ..BuildOptions::default() }
}

#[test]
fn random_soup_matches_binary_and_brute_force() {
    let mut rng = Rng(1);
    check_mesh("soup", &soup(&mut rng, 3000, 10.0, 0.5), 4000, &tracing());
    // Bigger binary leaves split into several slots or their own nodes.
    for leaf in [1, 3, 4, 8, 30, 255] {
        let options = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
        check_mesh(
            &format!("soup, leaves of {leaf}"),
            &soup(&mut rng, 700, 5.0, 0.8),
            1500,
            &options,
        );
    }
}

#[test]
fn cut_triangles_match_binary_and_brute_force() {
    // A room of huge triangles around small ones: the build cuts the huge ones into pieces
    // that several leaves hold, and both trees still find what brute force finds.
    let tris = room(&mut Rng(5), 2000);
    let cut = BuildOptions { split_budget: 0.3, ..tracing() };
    assert!(
        Bvh::build(&tris, &cut).prim_indices.len() > tris.len() + 20,
        "the room's big triangles are cut"
    );
    let (binary, wide) = check_mesh("room, cut", &tris, 6000, &cut);
    let (whole_binary, whole_wide) = check_mesh("room", &tris, 6000, &tracing());
    // The same rays take fewer steps through the trees of pieces.
    let steps = |s: TraversalStats| s.nodes + s.triangles;
    assert!(steps(binary) < steps(whole_binary), "binary: {binary:?} cut, {whole_binary:?} whole");
    assert!(steps(wide) < steps(whole_wide), "wide: {wide:?} cut, {whole_wide:?} whole");
}

#[test]
fn empty_and_single_triangle() {
    let mut bvh = Bvh::build(&[], &tracing());
    let wide = wide::collapse(&mut bvh);
    assert!(wide.nodes.is_empty());
    assert_eq!((wide.depth(), wide.stack_need()), (0, 0));
    let ray = Ray::new(Vec3::ZERO, Vec3::Z);
    assert!(wide::closest_hit(
        &wide.nodes,
        &[],
        &ray,
        0.0,
        f32::INFINITY,
        &mut TraversalStats::default()
    )
    .is_none());
    let one = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
    check_mesh("one triangle", &one, 500, &tracing());
    let mut bvh = Bvh::build(&one, &tracing());
    let wide = wide::collapse(&mut bvh);
    let mut stats = TraversalStats::default();
    let hit = wide::closest_hit(
        &wide.nodes,
        &ordered_edges(&bvh, &one),
        &Ray::new(Vec3::new(0.2, 0.2, 3.0), -Vec3::Z),
        0.0,
        f32::INFINITY,
        &mut stats,
    );
    assert_eq!(hit.map(|(k, h)| (k, h.t)), Some((0, 3.0)));
    assert_eq!(stats, TraversalStats { nodes: 1, triangles: 1 });
    assert_eq!((wide.depth(), wide.stack_need()), (1, 1));
}

#[test]
fn coplanar_and_one_point() {
    let mut rng = Rng(13);
    let flat: Vec<[Vec3; 3]> = soup(&mut rng, 2000, 10.0, 0.7)
        .into_iter()
        .map(|t| t.map(|p| Vec3::new(p.x, p.y, 1.5)))
        .collect();
    check_mesh("coplanar", &flat, 4000, &tracing());
    let p = Vec3::new(1.0, -2.0, 3.0);
    check_mesh("one point", &vec![[p, p, p]; 500], 500, &tracing());
}

#[test]
fn huge_and_tiny_coordinates() {
    let mut rng = Rng(17);
    // Möller–Trumbore overflows f32 beyond ~1e12, so hits are traced at 1e10; the boxes
    // are checked up to 1e30.
    check_mesh("1e10 scale", &soup(&mut rng, 1500, 1e10, 3e9), 3000, &tracing());
    check_mesh("1e-20 scale", &soup(&mut rng, 1500, 1e-20, 3e-21), 3000, &tracing());
    // Far from the origin, where a node's frame origin is large beside its steps (at 1e7
    // these corners would snap to whole units and rays graze box faces: both trees miss).
    let far: Vec<[Vec3; 3]> = soup(&mut rng, 500, 1.0, 0.1)
        .into_iter()
        .map(|t| t.map(|p| p + Vec3::splat(1e4)))
        .collect();
    check_mesh("unit triangles at 1e4", &far, 2000, &tracing());
    for extent in [1e20f32, 1e30] {
        let big = soup(&mut rng, 800, extent, extent * 0.3);
        let mut bvh = Bvh::build(&big, &tracing());
        let wide = wide::collapse(&mut bvh);
        check_boxes(&wide, &bvh, &big, false);
    }
}

#[test]
fn a_mesh_collapsed_in_pieces_on_every_core_matches() {
    // Above 16k triangles the collapse spreads subtrees over threads and splices them in:
    // every triangle still lies in one slot's box, and the hits are the binary tree's.
    let mesh = meshtracer::scene::primitives::large_torus_knot(60_000);
    let tris: Vec<[Vec3; 3]> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();
    let (binary, wide_counts) = check_mesh("60k knot", &tris, 400, &tracing());
    assert!(wide_counts.nodes < binary.nodes, "{wide_counts:?} vs {binary:?}");
}

#[test]
fn torus_knot_matches_and_is_smaller() {
    let mesh = PaperModel::TorusKnot.mesh();
    let tris: Vec<[Vec3; 3]> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();
    let (binary, wide_counts) = check_mesh("torus knot", &tris, 20_000, &tracing());
    let mut bvh = Bvh::build(&tris, &tracing());
    let wide = wide::collapse(&mut bvh);
    let stats = WideStats::new(&bvh, &wide);
    // The expectations written down before the GPU is measured (see the report).
    println!("knot: {} triangles, binary {} nodes ({:.1} B/tri), wide {} nodes ({:.1} B/tri), {:.2} children per node, depth {}", stats.triangles, stats.binary_nodes, stats.binary_bytes_per_triangle(), stats.wide_nodes, stats.wide_bytes_per_triangle(), stats.mean_children, stats.wide_depth);
    let rays = 20_000.0;
    let per_ray = |s: TraversalStats, node_bytes: f64| {
        (
            s.nodes as f64 / rays,
            s.triangles as f64 / rays,
            (s.nodes as f64 * node_bytes + s.triangles as f64 * 40.0) / rays,
        )
    };
    println!(
        "binary per ray: {:.1} nodes, {:.1} triangles, {:.0} B",
        per_ray(binary, 64.0).0,
        per_ray(binary, 64.0).1,
        per_ray(binary, 64.0).2
    );
    println!(
        "wide per ray: {:.1} nodes, {:.1} triangles, {:.0} B",
        per_ray(wide_counts, 80.0).0,
        per_ray(wide_counts, 80.0).1,
        per_ray(wide_counts, 80.0).2
    );
    assert!(stats.wide_nodes * 3 < stats.binary_nodes, "{stats:?}");
    assert!(stats.wide_bytes_per_triangle() < stats.binary_bytes_per_triangle());
    assert!(wide_counts.nodes < binary.nodes, "fewer node visits: {wide_counts:?} vs {binary:?}");
}

// --- the GPU's traversal against the CPU reference (lavapipe, validation layer) -----------

mod common;

use common::{assert_close, assert_same_cost, paper, render_both};
use meshtracer::render_settings::{Accel, Aov, BvhLayout, RenderSettings};

fn wide_settings(size: u32, bounces: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        bounces,
        accel: Accel::Bvh,
        bvh: BvhLayout::Wide,
        aov: Aov::Color,
        ..RenderSettings::default()
    }
}

#[test]
fn gpu_wide_traversal_matches_the_cpu_reference_and_the_binary_tree() {
    for model in PaperModel::ALL {
        let scene = paper(model, 2);
        let (gpu, cpu) = render_both(&scene, wide_settings(48, 2));
        assert_close(&gpu, &cpu, &format!("{}: wide GPU vs CPU", model.name()));
        let (binary, _) =
            render_both(&scene, RenderSettings { bvh: BvhLayout::Binary, ..wide_settings(48, 2) });
        assert_close(&gpu, &binary, &format!("{}: wide vs binary", model.name()));
    }
    common::assert_validation_clean(&common::ctx());
}

#[test]
fn gpu_traces_cut_triangles_as_the_cpu_reference_in_every_layout() {
    let scene = common::room_scene();
    let (slots, triangles) = common::slots_and_triangles(&scene);
    assert!(
        slots > triangles,
        "the room's big triangles are cut ({slots} slots for {triangles} triangles)"
    );
    for bvh in [BvhLayout::Binary, BvhLayout::Wide, BvhLayout::WideRuns] {
        let (gpu, cpu) = render_both(&scene, RenderSettings { bvh, ..wide_settings(64, 2) });
        assert_close(&gpu, &cpu, &format!("room of cut triangles, {bvh:?}"));
    }
}

#[test]
fn gpu_wide_cost_view_counts_like_the_cpu_reference() {
    let scene = paper(PaperModel::TorusKnot, 3);
    let (gpu, cpu) = render_both(&scene, RenderSettings { aov: Aov::Cost, ..wide_settings(32, 2) });
    assert_same_cost(&gpu, &cpu, "wide");
    assert!(cpu.pixels.iter().any(|p| p[0] > 1.0), "the wide BVH is traversed");
    // Fewer nodes than the binary tree visits for the same rays.
    let (binary, _) = render_both(
        &scene,
        RenderSettings { aov: Aov::Cost, bvh: BvhLayout::Binary, ..wide_settings(32, 2) },
    );
    let nodes =
        |img: &meshtracer::tracer::Image| img.pixels.iter().map(|p| p[0] as f64).sum::<f64>();
    assert!(
        nodes(&gpu) < nodes(&binary),
        "wide {} vs binary {} nodes",
        nodes(&gpu),
        nodes(&binary)
    );
    common::assert_validation_clean(&common::ctx());
}

#[test]
fn gpu_leaf_runs_test_what_the_wide_traversal_tests() {
    // The leaf-runs kernel regroups the same tests into fewer rounds: the same image as the
    // CPU reference, and the same nodes and triangles at every pixel as the plain kernel.
    for (model, bounces) in [(PaperModel::TorusKnot, 2), (PaperModel::Geosphere, 1)] {
        let scene = paper(model, 2);
        let runs = RenderSettings { bvh: BvhLayout::WideRuns, ..wide_settings(32, bounces) };
        let (gpu, cpu) = render_both(&scene, runs);
        assert_close(&gpu, &cpu, &format!("{}: wide-runs GPU vs CPU", model.name()));
        let (runs_cost, _) = render_both(&scene, RenderSettings { aov: Aov::Cost, ..runs });
        let (wide_cost, _) =
            render_both(&scene, RenderSettings { aov: Aov::Cost, ..wide_settings(32, bounces) });
        let differ = runs_cost
            .pixels
            .iter()
            .zip(&wide_cost.pixels)
            .filter(|(r, w)| r[..2] != w[..2])
            .count();
        assert_eq!(differ, 0, "{}: leaf runs changed the counts of {differ} pixels", model.name());
        assert!(runs_cost.pixels.iter().any(|p| p[1] > 2.0), "{}: leaves are tested", model.name());
    }
    common::assert_validation_clean(&common::ctx());
}

#[test]
fn a_mesh_without_a_wide_tree_traces_its_binary_one_in_wide_frames() {
    // A mesh whose wide tree could overflow the traversal's stack keeps the binary layout
    // alone, beside meshes traced wide (here the mirror box): same image, the binary tree's
    // node counts for the knot, GPU as CPU.
    use meshtracer::gpu::ComputeTracer;
    use meshtracer::tracer::packed::Layouts;
    use meshtracer::tracer::{cpu, FrameParams, PackedScene};
    let scene = paper(PaperModel::TorusKnot, 1);
    let mut packed = PackedScene::with_layouts(&scene, Layouts::Both);
    let cost = FrameParams::new(&scene, RenderSettings { aov: Aov::Cost, ..wide_settings(32, 1) });
    let all_wide = cpu::render(&packed, &cost);
    packed.drop_wide_tree(0, &scene.instances);
    assert!(packed.has_wide(), "the box keeps its wide tree");
    let ctx = common::ctx();
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    let (gpu, _) = tracer.render(&cost).unwrap();
    let cpu_cost = cpu::render(&packed, &cost);
    assert_same_cost(&gpu, &cpu_cost, "one mesh without its wide tree");
    let nodes =
        |img: &meshtracer::tracer::Image| img.pixels.iter().map(|p| p[0] as f64).sum::<f64>();
    assert!(
        nodes(&cpu_cost) > 1.5 * nodes(&all_wide),
        "the knot's binary tree: {} vs wide {} nodes",
        nodes(&cpu_cost),
        nodes(&all_wide)
    );
    let colour = FrameParams::new(&scene, wide_settings(32, 1));
    let (gpu_colour, _) = tracer.render(&colour).unwrap();
    assert_close(
        &gpu_colour,
        &cpu::render(&packed, &colour),
        "the knot's binary tree in a wide frame, GPU vs CPU",
    );
    drop(tracer);
    common::assert_validation_clean(&ctx);
}

#[test]
fn a_scene_packed_without_the_wide_layout_traces_its_binary_tree() {
    // The wide tree is packed only when a frame asks for it (its collapse costs as much as
    // the build): a wide frame of a binary-only scene is the binary frame, on both tracers.
    use meshtracer::gpu::ComputeTracer;
    use meshtracer::tracer::packed::Layouts;
    use meshtracer::tracer::{cpu, FrameParams, PackedScene};
    let scene = paper(PaperModel::TorusKnot, 1);
    let binary_only = PackedScene::new(&scene);
    assert!(!binary_only.has_wide());
    assert!(PackedScene::with_layouts(&scene, Layouts::only(BvhLayout::Wide)).has_wide());
    let ctx = common::ctx();
    let mut tracer = ComputeTracer::with_scene(&ctx, &binary_only).unwrap();
    let wide = FrameParams::new(&scene, wide_settings(32, 1));
    let binary =
        FrameParams::new(&scene, RenderSettings { bvh: BvhLayout::Binary, ..wide_settings(32, 1) });
    let (gpu_wide, _) = tracer.render(&wide).unwrap();
    let (gpu_binary, _) = tracer.render(&binary).unwrap();
    assert_eq!(gpu_wide.pixels, gpu_binary.pixels);
    assert_eq!(cpu::render(&binary_only, &wide).pixels, cpu::render(&binary_only, &binary).pixels);
    drop(tracer);
    common::assert_validation_clean(&ctx);
}

#[test]
fn a_scene_packed_for_wide_frames_alone_drops_the_binary_nodes_and_traces_the_same() {
    // `render` and `bench` pack only the layout they trace: the wide trees, and binary nodes
    // only for a mesh without a wide tree. Wide frames match those of a scene holding both
    // trees, binary frames are traced wide, on both tracers, and the GPU scene is smaller
    // by the binary nodes.
    use meshtracer::gpu::ComputeTracer;
    use meshtracer::tracer::packed::Layouts;
    use meshtracer::tracer::{cpu, FrameParams, PackedScene};
    let scene = paper(PaperModel::TorusKnot, 2);
    let (wide_only, both) = (
        PackedScene::with_layouts(&scene, Layouts::only(BvhLayout::Wide)),
        PackedScene::with_layouts(&scene, Layouts::Both),
    );
    assert!(wide_only.has_wide() && !wide_only.has_binary());
    assert!(both.has_wide() && both.has_binary());
    assert!(PackedScene::with_layouts(&scene, Layouts::only(BvhLayout::Binary)).has_binary());
    assert_eq!(wide_only.traced_layout(BvhLayout::Binary), BvhLayout::Wide);
    let wide = FrameParams::new(&scene, wide_settings(48, 2));
    let binary =
        FrameParams::new(&scene, RenderSettings { bvh: BvhLayout::Binary, ..wide_settings(48, 2) });
    let ctx = common::ctx();
    let mut both_tracer = ComputeTracer::with_scene(&ctx, &both).unwrap();
    let (reference, _) = both_tracer.render(&wide).unwrap();
    let mut tracer = ComputeTracer::with_scene(&ctx, &wide_only).unwrap();
    let binary_nodes = (both.nodes_bytes() - wide_only.nodes_bytes()) as u64;
    assert!(binary_nodes > 0);
    assert_eq!(
        tracer.scene_bytes() + binary_nodes,
        both_tracer.scene_bytes(),
        "the scene is smaller by the binary nodes"
    );
    let (gpu_wide, _) = tracer.render(&wide).unwrap();
    let (gpu_binary, _) = tracer.render(&binary).unwrap();
    assert_eq!(gpu_wide.pixels, reference.pixels, "wide frames as with both trees");
    assert_eq!(gpu_binary.pixels, gpu_wide.pixels, "a binary frame is traced wide");
    assert_close(&gpu_wide, &cpu::render(&wide_only, &wide), "wide-only scene, GPU vs CPU");
    assert_eq!(cpu::render(&wide_only, &binary).pixels, cpu::render(&wide_only, &wide).pixels);
    assert_eq!(cpu::render(&wide_only, &wide).pixels, cpu::render(&both, &wide).pixels);
    drop((tracer, both_tracer));
    common::assert_validation_clean(&ctx);
}

/// The framed knot's primary rays (a camera on +z through a 256² grid over the knot's box,
/// as `bench --framed` frames it, roughly) hit the same in both trees; the trees' sizes and
/// per-ray work are printed. A 50k knot here; for the hand measurement of big ones:
/// `KNOT_SIZES=1000000,4000000 cargo test --release --test bvh_wide -- knot_statistics --nocapture`.
#[test]
fn framed_knot_statistics_with_both_trees_agreeing() {
    let sizes: Vec<usize> = std::env::var("KNOT_SIZES").map_or(vec![50_000], |list| {
        list.split(',').map(|n| n.trim().parse().expect("KNOT_SIZES: numbers")).collect()
    });
    for n in sizes {
        let mesh = meshtracer::scene::primitives::large_torus_knot(n);
        let tris: Vec<[Vec3; 3]> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();
        let start = std::time::Instant::now();
        let mut bvh = Bvh::build(&tris, &tracing());
        let built = start.elapsed();
        let wide_bvh = wide::collapse(&mut bvh);
        println!(
            "knot {n}: build {:.0} ms, collapse {:.0} ms",
            built.as_secs_f64() * 1e3,
            (start.elapsed() - built).as_secs_f64() * 1e3
        );
        let s = WideStats::new(&bvh, &wide_bvh);
        println!("knot {n}: {} triangles; binary {} nodes, {:.1} B/tri; wide {} nodes, {:.1} B/tri, {:.2} children per node, {} leaf slots, depth {} (binary {})", s.triangles, s.binary_nodes, s.binary_bytes_per_triangle(), s.wide_nodes, s.wide_bytes_per_triangle(), s.mean_children, s.wide_leaves, s.wide_depth, bvh.depth());
        let ordered = ordered_edges(&bvh, &tris);
        let b = bounds(&tris);
        let eye = Vec3::new(b.center().x, b.center().y, b.max.z + 1.2 * b.extent().max_element());
        let (mut binary, mut wide_counts, mut hits) =
            (TraversalStats::default(), TraversalStats::default(), 0);
        let side = 256;
        for j in 0..side {
            for i in 0..side {
                let target = Vec3::new(
                    b.min.x + b.extent().x * (i as f32 + 0.5) / side as f32,
                    b.min.y + b.extent().y * (j as f32 + 0.5) / side as f32,
                    b.center().z,
                );
                let ray = Ray::new(eye, (target - eye).normalize());
                let h = bvh.closest_hit(&ordered, &ray, 0.0, f32::INFINITY, &mut binary);
                let w = wide::closest_hit(
                    &wide_bvh.nodes,
                    &ordered,
                    &ray,
                    0.0,
                    f32::INFINITY,
                    &mut wide_counts,
                );
                assert_eq!(h.map(|x| x.1.t), w.map(|x| x.1.t));
                hits += h.is_some() as u32;
            }
        }
        let rays = (side * side) as f64;
        for (name, c, node_bytes) in [("binary", binary, 64.0), ("wide", wide_counts, 80.0)] {
            let (nodes, tested) = (c.nodes as f64 / rays, c.triangles as f64 / rays);
            println!("  {name}: {nodes:.1} nodes, {tested:.1} triangles per ray, {:.0} B per ray ({:.0}% of rays hit)", nodes * node_bytes + tested * 40.0, 100.0 * hits as f64 / rays);
        }
    }
}

#[test]
fn a_collapse_within_a_node_count_knows_the_count_before_making_any_node() {
    // Leaves of 2 (the tracers'), of 8 and 30 (split into pieces, some their own nodes),
    // and a 60k knot (its subtrees counted on every core).
    let knot = meshtracer::scene::primitives::large_torus_knot(60_000);
    let knot: Vec<[Vec3; 3]> = (0..knot.triangle_count()).map(|i| knot.corners(i)).collect();
    let soup = soup(&mut Rng(9), 2000, 5.0, 0.8);
    for (name, tris, leaf) in
        [("knot", &knot, 2), ("soup", &soup, 2), ("soup", &soup, 8), ("soup", &soup, 30)]
    {
        let options = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
        let built = Bvh::build(tris, &options);
        let made = wide::collapse(&mut built.clone()).nodes.len();
        // One node short: refused with the count, the binary tree untouched.
        let mut bvh = built.clone();
        assert_eq!(
            wide::collapse_within(&mut bvh, made - 1).map(|w| w.nodes.len()),
            Err(made),
            "{name}, leaves of {leaf}"
        );
        assert_eq!(bvh.prim_indices, built.prim_indices);
        assert_eq!(bvh.nodes.len(), built.nodes.len());
        // Room for exactly that many: the same tree as without a limit.
        let mut bvh = built.clone();
        let within = wide::collapse_within(&mut bvh, made).expect("fits");
        let mut plain = built.clone();
        let all = wide::collapse(&mut plain);
        assert_eq!(within.nodes.len(), made);
        assert!(within.nodes == all.nodes, "{name}, leaves of {leaf}");
        assert_eq!(bvh.prim_indices, plain.prim_indices);
    }
    // An empty tree fits any room, even none.
    assert_eq!(wide::collapse_within(&mut Bvh::default(), 0).map(|w| w.nodes.len()), Ok(0));
}
