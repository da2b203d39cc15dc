//! Unit tests of `top_level.rs`: world boxes and spheres of turned copies, the tree's
//! leaves, the enclosure, rebuilds, records and refused transforms.

use glam::{Affine3A, Quat, Vec3};

use super::*;
use crate::bvh::TraversalStats;
use crate::contract::TOP_ENCLOSURE;
use crate::geometry::Ray;
use crate::tracer::enclosure::ENCLOSURE_TRIANGLES;

fn place(bounds: Aabb) -> MeshPlace {
    MeshPlace {
        node_base: 0,
        triangle_base: 0,
        triangle_count: 1,
        prim_base: 0,
        wide_words: EMPTY,
        cover: MeshCover::of_box(bounds),
        closed_box: None,
        convex: 0,
    }
}

/// Turns with non-uniform and mirrored scales, some by 45 degrees about two axes.
fn turns() -> Vec<Affine3A> {
    (0..24)
        .map(|i| {
            let f = i as f32;
            let scale = Vec3::new(1.0 + f % 3.0, if i % 2 == 0 { 0.5 } else { -0.5 }, 2.0);
            let turn = if i % 4 == 0 {
                Quat::from_euler(glam::EulerRot::XYZ, 0.785, 0.785, 0.0)
            } else {
                Quat::from_euler(glam::EulerRot::XYZ, f * 0.7, f * 1.3, -f)
            };
            Affine3A::from_scale_rotation_translation(scale, turn, Vec3::new(f, -3.0 * f, 1e3))
        })
        .collect()
}

/// A knot's cover, built from its tree, and the knot.
fn knot_cover() -> (MeshCover, crate::scene::Mesh) {
    let mesh = crate::scene::primitives::torus_knot(2, 3, 96, 8);
    (cover(&mesh), mesh)
}

#[test]
fn a_turned_cover_holds_every_turned_vertex_within_four_percent_of_their_box() {
    let (cover, mesh) = knot_cover();
    let area = |b: &Aabb| {
        let e = b.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    };
    for t in turns() {
        let world: Vec<Vec3> = mesh.positions.iter().map(|&p| t.transform_point3(p)).collect();
        let exact = Aabb::from_points(&world);
        let tight = cover.world_box(&t);
        for w in &world {
            assert!(w.cmpge(tight.min).all() && w.cmple(tight.max).all(), "{w} outside {tight:?}");
        }
        let loose = Instance::new(0, t).unwrap().world_bounds(mesh.bounds());
        assert!(area(&tight) < 1.04 * area(&exact), "{tight:?} against {exact:?}");
        assert!(loose.contains(&tight), "{tight:?} sticks out of {loose:?}");
        assert!(area(&tight) < area(&loose), "{tight:?} against the turned box {loose:?}");
    }
}

#[test]
fn an_unturned_cover_is_the_mesh_box_and_no_mesh_has_none() {
    let (cover, mesh) = knot_cover();
    let b = mesh.bounds();
    for t in [
        Affine3A::IDENTITY,
        Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, -0.5, 3.0),
            Quat::IDENTITY,
            Vec3::new(10.0, 0.0, -4.0),
        ),
    ] {
        let exact = Aabb::from_points(&[t.transform_point3(b.min), t.transform_point3(b.max)]);
        let got = cover.world_box(&t);
        assert!(got.contains(&exact), "{got:?} holds {exact:?}");
        let slack = (got.max - exact.max).max(exact.min - got.min).max_element();
        assert!(slack < 1e-4 * exact.extent().max_element(), "{got:?} against {exact:?}");
    }
    let unit = Aabb { min: Vec3::splat(-1.0), max: Vec3::ONE };
    let box_only = MeshCover::of_box(unit).world_box(&Affine3A::IDENTITY);
    assert!(
        box_only.contains(&unit)
            && unit.extent().max_element() * 1.0001 > box_only.extent().max_element()
    );
    assert_eq!(MeshCover::of_box(Aabb::EMPTY).world_box(&Affine3A::IDENTITY), Aabb::EMPTY);
    let empty = Bvh::build(&[], &BuildOptions::default());
    let none = MeshCover::of_tree(&empty.nodes, |_| [Vec3::ZERO; 3], Aabb::EMPTY);
    assert_eq!(none.world_box(&Affine3A::IDENTITY), Aabb::EMPTY);
}

#[test]
fn every_instance_is_one_leaf_holding_its_world_box() {
    let unit = Aabb { min: Vec3::splat(-1.0), max: Vec3::ONE };
    for count in [0usize, 1, 2, 3, 17, 1000] {
        let instances: Vec<Instance> = (0..count)
            .map(|i| {
                let t = Affine3A::from_scale_rotation_translation(
                    Vec3::new(1.0 + i as f32 % 3.0, 0.5, -2.0),
                    Quat::from_rotation_y(i as f32),
                    Vec3::new(i as f32 * 3.0, (i % 7) as f32, 0.0),
                );
                Instance::new(0, t).unwrap()
            })
            .collect();
        let top = TopLevel::build(&[place(unit)], &instances);
        assert!(!top.nodes.is_empty());
        let leaves: Vec<u32> = top
            .nodes
            .iter()
            .flat_map(|n| n.children())
            .filter(|c| c.is_leaf())
            .map(|c| c.index)
            .collect();
        let mut sorted = leaves.clone();
        sorted.sort();
        assert_eq!(sorted, (0..count as u32).collect::<Vec<_>>(), "each instance once");
        for (i, inst) in instances.iter().enumerate() {
            // The turned box, widened by rounding's slack and no more.
            let leaf = leaf_box(&top.nodes, i as u32).unwrap();
            let exact = inst.world_bounds(unit);
            assert!(leaf.contains(&exact), "{leaf:?} holds {exact:?}");
            let slack = 1e-5 * exact.min.abs().max(exact.max.abs()).max_element().max(1.0);
            assert!((leaf.min - exact.min).abs().max_element() < slack);
            assert!((leaf.max - exact.max).abs().max_element() < slack);
        }
    }
}

/// A mesh's cover, built from its tree.
fn cover(mesh: &crate::scene::Mesh) -> MeshCover {
    let tris: Vec<_> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();
    let bvh = Bvh::build(&tris, &BuildOptions::default());
    let corners = |slot: u32| tris[bvh.prim_indices[slot as usize] as usize];
    MeshCover::of_tree(&bvh.nodes, corners, mesh.bounds())
}

#[test]
fn a_round_instance_has_a_world_sphere_holding_every_vertex_unless_squashed() {
    let mut round = crate::scene::primitives::geosphere(2);
    for p in &mut round.positions {
        *p = *p * 3.0 + Vec3::new(10.0, -4.0, 2.0);
    }
    let cover = cover(&round);
    let [_, _, _, r] = cover.sphere();
    let uniform = (0..12).map(|i| {
        let f = i as f32;
        let turn = Quat::from_euler(glam::EulerRot::XYZ, f * 0.7, f * 1.3, -f);
        let scale = Vec3::splat(0.25 + f).copysign(Vec3::new(1.0, 1.0 - f % 2.0 * 2.0, 1.0));
        Affine3A::from_scale_rotation_translation(scale, turn, Vec3::new(f, -3.0 * f, 1e3))
    });
    // A shear (a scale along a turned axis), whose stretch is bounded loosely: its
    // sphere still holds every vertex.
    let shear = |k: f32| {
        let m = glam::Mat3::from_cols(Vec3::X, Vec3::new(k, 1.0, 0.0), Vec3::new(0.0, k, 1.0));
        (Affine3A::from_mat3_translation(m, Vec3::new(-5.0, 2.0, 0.0)), true)
    };
    let straight = uniform.chain(turns()).map(|t| (t, false));
    let (mut kept, mut squashed) = (0, 0);
    for (t, sheared) in straight.chain([shear(0.2), shear(-0.4)]) {
        let world = cover.world_box(&t);
        let Some([x, y, z, radius]) = cover.world_sphere(&t, &world) else {
            squashed += 1;
            continue;
        };
        kept += 1;
        let centre = Vec3::new(x, y, z);
        let far = round.positions.iter().map(|&p| (t.transform_point3(p) - centre).length());
        let far = far.fold(0.0, f32::max);
        assert!(far <= radius, "a vertex {far} from the centre, radius {radius}");
        // The largest stretch: as far as the farthest of many directions goes, and for
        // a turn and a uniform scale, the scale itself.
        let stretch = (0..2000)
            .map(|k| {
                let (a, b) = (k as f32 * 2.399, (k as f32 / 1000.0 - 1.0).acos());
                let u = Vec3::new(b.sin() * a.cos(), b.sin() * a.sin(), b.cos());
                t.transform_vector3(u).length()
            })
            .fold(0.0, f32::max);
        assert!(
            sheared || radius <= r * stretch * 1.01 + 1e-3,
            "{radius} for {r} stretched {stretch}"
        );
    }
    // Every turn with a uniform scale keeps its sphere; of the non-uniform scales (up to
    // 6:1), the flattest give it up for their box.
    assert!(kept >= 13 && squashed > 0, "{kept} kept, {squashed} squashed");
}

#[test]
fn round_leaves_are_spheres_past_one_instance_and_the_walk_meets_them() {
    let geosphere = crate::scene::primitives::geosphere(2);
    let bounds = geosphere.bounds();
    let ball = MeshPlace { cover: cover(&geosphere), ..place(bounds) };
    let room = crate::scene::paper::mirror_box_mesh(1.0);
    let walls: Vec<[Vec3; 3]> = (0..12).map(|i| room.corners(i)).collect();
    let closed_box = enclosure::ClosedBox::of(&walls);
    assert!(closed_box.is_some());
    let mirror = MeshPlace { triangle_count: 12, closed_box, ..place(room.bounds()) };
    // Inside every copy's box, beside its sphere (radius 1): the box's corner region.
    let (y, z) = (0.9 * bounds.max.y, 0.9 * bounds.max.z);
    assert!(y * y + z * z > 1.01, "the corner ray passes inside the sphere");
    for (copies, boxed) in [(1u32, false), (1, true), (2, false), (27, true), (300, false)] {
        let mut instances: Vec<Instance> = (0..copies)
            .map(|i| Instance::placed(0, Vec3::new(3.0 * i as f32, 0.0, 0.0), 1.0))
            .collect();
        if boxed {
            instances.push(Instance::placed(1, Vec3::ZERO, 8.0 * copies as f32));
        }
        let top = TopLevel::build(&[ball, mirror], &instances);
        let tree = &top.nodes[..top.nodes.len() - usize::from(boxed)];
        let children = tree.iter().flat_map(|n| n.children());
        let spheres = children.filter(|c| c.count == TOP_SPHERE).count();
        // A lone copy (alone or in a closed box) runs the one-instance kernels, which
        // take its leaf as a box.
        let want = if copies == 1 { 0 } else { copies as usize };
        assert_eq!((spheres, top.has_spheres), (want, want > 0), "{copies}, box {boxed}");
        let met = |ray: Ray| {
            let (order, _) = visits(&top, &ray);
            order.iter().filter(|&&i| i < copies).count()
        };
        // A ray down the row meets every copy; one through the boxes' corners, only the
        // boxes: the spheres turn it away.
        assert_eq!(met(Ray::new(Vec3::new(-5.0, 0.0, 0.0), Vec3::X)), copies as usize);
        let corner = met(Ray::new(Vec3::new(-5.0, y, z), Vec3::X));
        assert_eq!(corner, if want > 0 { 0 } else { copies as usize }, "{copies}, box {boxed}");
        // A ray that grazes a corner of the first copy (at the origin), just inside it and
        // along its surface, enters that copy: the sphere holds the mesh to its corners.
        for &p in &geosphere.positions {
            let along = p.any_orthonormal_vector();
            let graze = Ray::new(p * 0.999 - along * 4.0, along);
            assert!(visits(&top, &graze).0.contains(&0), "{copies}, box {boxed}: past {p}");
        }
    }
}

#[test]
fn a_round_mesh_has_a_sphere_holding_every_corner_and_a_box_has_none() {
    // A geosphere, moved off the origin: its sphere is centred on its box and holds
    // every corner, within a few parts in a million of the farthest.
    let mut round = crate::scene::primitives::geosphere(2);
    for p in &mut round.positions {
        *p = *p * 3.0 + Vec3::new(10.0, -4.0, 2.0);
    }
    let [x, y, z, r] = cover(&round).sphere();
    let centre = Vec3::new(x, y, z);
    assert!((centre - Vec3::new(10.0, -4.0, 2.0)).length() < 1e-4, "{centre}");
    let far = round.positions.iter().map(|p| (*p - centre).length()).fold(0.0, f32::max);
    assert!(far <= r && r < far * 1.0001, "radius {r} for a farthest corner at {far}");
    // A box's sphere would be looser than the box, a knot's hardly tighter (0.85 of its
    // outline): none. Nor has a mesh known by its box.
    let boxed = crate::scene::paper::mirror_box_mesh(2.0);
    assert_eq!(cover(&boxed).sphere(), [0.0; 4]);
    assert_eq!(knot_cover().0.sphere(), [0.0; 4]);
    assert_eq!(MeshCover::of_box(round.bounds()).sphere(), [0.0; 4]);
}

#[test]
fn a_rebuild_over_the_last_builds_memory_equals_a_fresh_build() {
    // A field, then scenes with and without the mirror box, bigger and smaller than the
    // last, each rebuilt into the same top level: nothing of an earlier build may stay.
    let model = place(Aabb { min: Vec3::splat(-1.0), max: Vec3::ONE });
    let mirror = MeshPlace { triangle_count: 12, ..model };
    let meshes = [model, mirror];
    let field = |n: u32, boxed: bool| -> Vec<Instance> {
        let copies = (0..n).map(|i| {
            let turn = Quat::from_rotation_z(i as f32);
            let at = Vec3::new((i % 10) as f32 * 3.0, (i / 10) as f32 * 3.0, 0.0);
            Instance::new(0, Affine3A::from_rotation_translation(turn, at)).unwrap()
        });
        let room = boxed.then(|| Instance::placed(1, Vec3::ZERO, 4.0 * n as f32 + 8.0));
        copies.chain(room).collect()
    };
    let mut top = TopLevel::default();
    for (n, boxed) in [(1000, false), (27, true), (300, true), (2, false), (0, false)] {
        let instances = field(n, boxed);
        top.rebuild(&meshes, &instances);
        let fresh = TopLevel::build(&meshes, &instances);
        // As bytes: the enclosure's record is no box, and its words may read as NaN.
        let bytes = |nodes: &[BvhNode]| bytemuck::cast_slice::<BvhNode, u8>(nodes).to_vec();
        assert_eq!(bytes(&top.nodes), bytes(&fresh.nodes), "{n} copies, box {boxed}");
        assert_eq!(top.instances, fresh.instances, "{n} copies, box {boxed}");
        assert_eq!(top.meshes.len(), fresh.meshes.len());
        assert_eq!(top.enclosure(), boxed.then_some(n), "{n} copies, box {boxed}");
    }
}

/// A walk's visits in order, and the nodes it opened.
fn visits(top: &TopLevel, ray: &Ray) -> (Vec<u32>, u32) {
    let mut stats = TraversalStats::default();
    let mut order = Vec::new();
    walk(&top.nodes, ray, f32::INFINITY, &mut stats, |target, _| match target {
        Target::Instance(i) => {
            order.push(i);
            Some(Visit::Nothing)
        }
        Target::ClosedBox(_) => None,
    });
    (order, stats.nodes)
}

#[test]
fn the_mirror_box_around_the_models_is_the_enclosure_visited_first() {
    let model =
        MeshPlace { triangle_count: 500, ..place(Aabb::from_points(&[-Vec3::ONE, Vec3::ONE])) };
    let mirror =
        MeshPlace { triangle_count: 12, ..place(Aabb::from_points(&[-Vec3::ONE, Vec3::ONE])) };
    let meshes = [model, mirror];
    for copies in [1u32, 2, 27, 100] {
        // The models in a row, then the box around them all, then one more model.
        let mut instances: Vec<Instance> = (0..copies)
            .map(|i| Instance::placed(0, Vec3::new(i as f32 * 3.0, 0.0, 0.0), 1.0))
            .collect();
        instances.push(Instance::placed(1, Vec3::ZERO, 4.0 * copies as f32));
        instances.push(Instance::placed(0, Vec3::new(0.0, 2.5, 0.0), 0.5));
        let enclosure = copies;
        let top = TopLevel::build(&meshes, &instances);
        assert_eq!(top.enclosure(), Some(enclosure), "{copies} copies");
        // The enclosure is the root's left child alone; every other instance is one
        // leaf of the tree under the root's right child.
        let tree = &top.nodes[..top.nodes.len() - 1]; // the last is the enclosure's record
        let leaves = |count| -> Vec<u32> {
            let children = tree.iter().flat_map(|n| n.children());
            let mut found: Vec<u32> =
                children.filter(|c| c.count == count).map(|c| c.index).collect();
            found.sort();
            found
        };
        assert_eq!(leaves(TOP_ENCLOSURE), vec![top.nodes.len() as u32 - 1]);
        let others: Vec<u32> = (0..instances.len() as u32).filter(|&i| i != enclosure).collect();
        assert_eq!(leaves(1), others, "{copies} copies: each other instance once");
        // A ray from inside the box visits it first, then the models it passes.
        let ray = Ray::new(Vec3::new(-2.0, 0.0, 0.0), Vec3::X);
        let (order, nodes) = visits(&top, &ray);
        assert_eq!(order[0], enclosure);
        assert!(order[1..].contains(&0) && !order[1..].contains(&enclosure));
        assert!(nodes >= 1, "the root is opened");
        // A ray that misses every model visits the box alone.
        let (order, _) = visits(&top, &Ray::new(Vec3::new(-2.0, -1.5, 0.0), -Vec3::Y));
        assert_eq!(order, vec![enclosure]);
    }
}

#[test]
fn no_enclosure_without_a_small_mesh_around_every_other_instance() {
    let unit = Aabb::from_points(&[-Vec3::ONE, Vec3::ONE]);
    let small = MeshPlace { triangle_count: ENCLOSURE_TRIANGLES, ..place(unit) };
    let big = MeshPlace { triangle_count: ENCLOSURE_TRIANGLES + 1, ..place(unit) };
    let empty = MeshPlace { triangle_count: 0, ..place(Aabb::EMPTY) };
    let model = Instance::placed(0, Vec3::new(3.0, 0.0, 0.0), 1.0);
    let around = |mesh| Instance::placed(mesh, Vec3::ZERO, 10.0);
    let cases: [(&[MeshPlace], Vec<Instance>, Option<u32>); 5] = [
        (&[small], vec![model, around(0)], Some(1)),
        (&[small, big], vec![model, around(1)], None), // too many triangles
        (&[small], vec![around(0)], None),             // nothing inside
        (&[small], vec![model, Instance::placed(0, Vec3::ZERO, 2.0)], None), // too small
        (&[small, empty], vec![model, around(1)], None), // no triangles
    ];
    for (k, (meshes, instances, want)) in cases.into_iter().enumerate() {
        let top = TopLevel::build(meshes, &instances);
        assert_eq!(top.enclosure(), want, "case {k}");
        let (order, _) = visits(&top, &Ray::new(Vec3::new(3.0, 0.0, -5.0), Vec3::Z));
        assert!(order.contains(&0), "case {k}: the model is visited ({order:?})");
    }
}

#[test]
fn records_carry_world_points_into_the_mesh() {
    let t = Affine3A::from_scale_rotation_translation(
        Vec3::new(2.0, -0.5, 3.0),
        Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0),
        Vec3::new(5.0, -1.0, 0.25),
    );
    let inst = Instance::new(0, t).unwrap();
    let top = TopLevel::build(&[place(Aabb::EMPTY)], &[inst]);
    let record = &top.instances[0];
    for p in [Vec3::ZERO, Vec3::new(1.0, -2.0, 0.5), Vec3::splat(10.0)] {
        let back = record.point_to_object(t.transform_point3(p));
        assert!((back - p).length() < 1e-5, "{p} came back as {back}");
        let v = record.vector_to_object(t.transform_vector3(p));
        assert!((v - p).length() < 1e-5);
    }
    // A normal stays perpendicular to the transformed surface.
    let (a, b) = (Vec3::X, Vec3::new(0.3, 1.0, -0.2));
    let n = record.normal_to_world(a.cross(b));
    assert!(n.dot(t.transform_vector3(a)).abs() < 1e-5);
    assert!(n.dot(t.transform_vector3(b)).abs() < 1e-5);
}

#[test]
fn singular_and_infinite_transforms_are_refused() {
    let flat = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    assert!(Instance::new(3, flat).unwrap_err().contains("singular"));
    let tiny = Affine3A::from_scale(Vec3::new(1.0, 1e-9, 1.0));
    assert!(Instance::new(3, tiny).unwrap_err().contains("singular"));
    let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
    assert!(Instance::new(3, nan).unwrap_err().contains("not finite"));
    let mirrored = Affine3A::from_scale(Vec3::new(-1.0, 2.0, 0.5));
    assert!(Instance::new(3, mirrored).is_ok());
}

#[test]
fn the_wide_twin_is_foreseen_before_loading_for_the_models_made_in_code() {
    use crate::scene::primitives::PaperModel;
    use crate::tracer::packed::{Layouts, PackedScene};
    let mut round = Vec::new();
    for model in PaperModel::ALL {
        for (models, mirror_box) in [(1, true), (2, false), (2, true), (27, true)] {
            let spec = SceneSpec {
                model: ModelSource::Paper(model),
                models,
                mirror_box,
                ..Default::default()
            };
            let (scene, _) = spec.load().unwrap();
            let packed = PackedScene::with_layouts(&scene, Layouts::Wide);
            let name = format!("{} x{models}, box {mirror_box}", model.name());
            let top = &packed.top_level;
            let twin = top.has_spheres || top.has_convex;
            assert_eq!(wide_twin_before_loading(&spec), twin, "{name}");
            if twin {
                round.push(model);
            }
        }
    }
    // The geosphere, sphere and cylinder (convex), not the knot: the prediction is neither
    // false nor true everywhere.
    assert_eq!(round.len(), 3 * 3, "{round:?}");
    assert!(!round.contains(&PaperModel::TorusKnot), "{round:?}");
    // A generated knot is neither (and a file is not known before it is read).
    let knot = SceneSpec { model: ModelSource::Generated(1000), models: 4, ..Default::default() };
    assert!(!wide_twin_before_loading(&knot));
}

#[test]
fn frames_walking_three_instances_or_more_trace_warp_blocks() {
    use crate::contract::FLAG_WARP_BLOCKS;
    let model = place(Aabb::from_points(&[-Vec3::ONE, Vec3::ONE]));
    let mirror = MeshPlace { triangle_count: 12, ..model };
    let blocks = |copies: u32, mirror_box: bool| {
        let mut instances: Vec<Instance> = (0..copies)
            .map(|i| Instance::placed(0, Vec3::new(i as f32 * 3.0, 0.0, 0.0), 1.0))
            .collect();
        if mirror_box {
            instances.push(Instance::placed(1, Vec3::ZERO, 4.0 * copies as f32));
        }
        let top = TopLevel::build(&[model, mirror], &instances);
        assert_eq!(top.enclosure().is_some(), mirror_box, "{copies} copies");
        top.frame_flags() & FLAG_WARP_BLOCKS != 0
    };
    // The mirror box is no instance of the walk's: two models in it stay rows.
    let expected = [(1, false), (2, false), (3, true), (27, true)];
    for (copies, many) in expected {
        assert_eq!(blocks(copies, false), many, "{copies} copies");
        assert_eq!(blocks(copies, true), many, "{copies} copies in the box");
    }
    assert_eq!(WARP_BLOCKS_FROM, 3);
}
