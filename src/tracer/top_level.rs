//! The top level of the two-level structure: the instance records the GPU reads (each a
//! mesh's place in the packed arrays and its world-to-object transform) and a two-child
//! tree over the instances' world boxes, built here and walked (`walk`) the way
//! `trace_instances` in `shaders/intersect.glsl` walks it, for the CPU reference.
//!
//! The tree is the bottom levels' node layout ([`BvhNode`]) with leaves of one instance,
//! whose index is the instance's own: the instance list keeps the scene's order. A leaf
//! whose mesh is round holds its instance's world bounding sphere instead of its box
//! ([`TOP_SPHERE`]), so that the walk turns away the rays that pass by the mesh before
//! it visits the instance.

use glam::DAffine3;
use rayon::prelude::*;

use super::enclosure::{self, ClosedBox, EnclosureRecord};
use super::records::{GpuInstance, GpuMesh};
use crate::bvh::{BuildOptions, Bvh, BvhChild, BvhNode, LeafBox};
use crate::contract::{EMPTY, TOP_SPHERE};
use crate::geometry::Aabb;
use crate::scene::Instance;

mod cover;
mod walk;
pub(crate) use cover::MeshCover;
pub(crate) use walk::{walk, Target, Visit};

/// Where a mesh sits in the packed arrays, as an instance record needs it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MeshPlace {
    pub(crate) node_base: u32,
    pub(crate) triangle_base: u32,
    pub(crate) triangle_count: u32,
    pub(crate) prim_base: u32,
    /// The mesh's first wide node in 16-byte words of the node buffer, or `EMPTY`.
    pub(crate) wide_words: u32,
    /// How far the mesh reaches in each direction, for its instances' world boxes.
    pub(crate) cover: MeshCover,
    /// The mesh as a closed box, if it is one (an enclosure's fast test).
    pub(crate) closed_box: Option<ClosedBox>,
}

/// The instance records, the tree over them and the mesh table they index.
#[derive(Clone, Debug, Default)]
pub struct TopLevel {
    pub instances: Vec<GpuInstance>,
    /// One record per mesh, as `instances[i].mesh` names it.
    pub meshes: Vec<GpuMesh>,
    /// Root first; at least one node (a root with two absent children for no instances).
    pub nodes: Vec<BvhNode>,
    /// Whether some leaf of the tree is a sphere ([`TOP_SPHERE`]).
    pub(crate) has_spheres: bool,
    /// The last build's leaves and their world spheres (by instance, radius 0 for none):
    /// their memory, kept for the next rebuild's.
    leaves: Vec<LeafBox>,
    spheres: Vec<[f32; 4]>,
}

impl TopLevel {
    /// Records for `instances` (mesh `m` placed as `meshes[m]` says) and the tree over their
    /// world boxes.
    #[cfg(test)]
    pub(crate) fn build(meshes: &[MeshPlace], instances: &[Instance]) -> Self {
        let mut top = Self::default();
        top.rebuild(meshes, instances);
        top
    }

    /// [`TopLevel::build`] into this top level's arrays. Built in about a millisecond for
    /// 10,000 instances on the H200's host (16 threads; docs/BENCHMARKS.md), so moving
    /// instances stays live. The arrays keep their memory from the last build: fresh ones
    /// (about 1.3 MB for 10,000 instances) were page-faulted in on every rebuild, and the
    /// old ones handed back to the system, which interrupts every core to forget them.
    pub(crate) fn rebuild(&mut self, meshes: &[MeshPlace], instances: &[Instance]) {
        let Self {
            instances: records_out,
            meshes: mesh_records,
            nodes,
            has_spheres,
            leaves,
            spheres,
        } = self;
        let mut tree = || {
            fill_leaves(meshes, instances, leaves, spheres);
            let triangles = |mesh: usize| meshes[mesh].triangle_count;
            let enclosure = enclosure::find(instances, |i| leaves[i].aabb(), triangles);
            let closed = enclosure.and_then(|e| meshes[instances[e].mesh].closed_box);
            match enclosure {
                None => tree_over(leaves, nodes),
                Some(e) => {
                    let record = EnclosureRecord::new(e as u32, closed);
                    enclosure::tree_around(leaves, e, record, nodes)
                }
            }
            // A scene of one instance (or one in a closed box) runs the ONE_INSTANCE
            // kernels, which open the root without a walk and take its leaf as a box.
            let one = instances.len() == 1 || (instances.len() == 2 && closed.is_some());
            // The enclosure's record, the last node, is no node of the tree.
            let tree_nodes = nodes.len() - usize::from(enclosure.is_some());
            *has_spheres = !one && fit_spheres(&mut nodes[..tree_nodes], spheres);
        };
        // Big fields make their records (each a double-precision inverse) beside the tree,
        // on the threads its build leaves idle: 0.1 ms off 10,000 copies' rebuild on the
        // H200's host, where the tree keeps about half of the 16 threads busy.
        if instances.len() < INSTANCES_A_TASK {
            fill_records(meshes, instances, records_out);
            tree();
        } else {
            rayon::join(|| fill_records(meshes, instances, records_out), tree);
        }
        mesh_records.clear();
        mesh_records.extend(meshes.iter().map(|m| GpuMesh {
            triangle_count: m.triangle_count,
            prim_base: m.prim_base,
            _pad: [0; 2],
        }));
    }

    /// The instance the walk visits before the tree (the root's left child,
    /// `TOP_ENCLOSURE`), if the scene has one.
    #[cfg(test)]
    pub(crate) fn enclosure(&self) -> Option<u32> {
        EnclosureRecord::of(&self.nodes).map(EnclosureRecord::instance)
    }

    /// Whether the scene is one instance, or one inside an enclosure that is a closed box:
    /// BVH frames of either run the `ONE_INSTANCE` kernels, which visit one instance
    /// outside any walk.
    pub(crate) fn is_one_instance(&self) -> bool {
        let closed = EnclosureRecord::of(&self.nodes).and_then(EnclosureRecord::closed_box);
        self.instances.len() == 1 || (self.instances.len() == 2 && closed.is_some())
    }

    /// Triangle slots over all instances (each instance's mesh counted again).
    pub fn triangle_slots(&self) -> u64 {
        self.instances.iter().map(|i| self.meshes[i.mesh as usize].triangle_count as u64).sum()
    }

    /// The tree's surface-area cost: every node's and every instance box's area over the
    /// root's, a node opened and an instance visited costing 1 each (tinybvh's measure with
    /// C_trav = C_int = 1). Lower is a tree that sends a ray to fewer boxes.
    pub fn sah_cost(&self) -> f64 {
        // The enclosure's record, the last node, is no node of the tree.
        let record = usize::from(EnclosureRecord::of(&self.nodes).is_some());
        sah_cost(&self.nodes[..self.nodes.len() - record])
    }

    /// Bytes of the records and the tree (what the scene costs beyond its meshes).
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.instances.as_slice())
            + std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.meshes.as_slice())
    }
}

/// Instances a task where records or leaves are made on every core.
const INSTANCES_A_TASK: usize = 256;

/// Every instance's record, into `out`.
fn fill_records(meshes: &[MeshPlace], instances: &[Instance], out: &mut Vec<GpuInstance>) {
    instances
        .par_iter()
        .with_min_len(INSTANCES_A_TASK)
        .map(|inst| record(&meshes[inst.mesh], inst.mesh as u32, inst))
        .collect_into_vec(out);
}

/// Every instance's leaf in the tree, into `out`: its world box (its mesh's cover turned by
/// its transform), named by the instance; and into `spheres` its world sphere, where its
/// mesh has one that stays tighter than the box (radius 0 where not).
fn fill_leaves(
    meshes: &[MeshPlace],
    instances: &[Instance],
    out: &mut Vec<LeafBox>,
    spheres: &mut Vec<[f32; 4]>,
) {
    instances
        .par_iter()
        .enumerate()
        .with_min_len(INSTANCES_A_TASK)
        .map(|(i, inst)| {
            let cover = &meshes[inst.mesh].cover;
            let b = cover.world_box(&inst.transform);
            // An empty mesh has no box; a point keeps it in the tree (its visit finds no
            // triangles).
            let b = if b.is_empty() {
                Aabb::from_points(&[inst.transform.translation.into()])
            } else {
                b
            };
            let sphere = cover.world_sphere(&inst.transform, &b).unwrap_or([0.0; 4]);
            (LeafBox::named(b, i as u32), sphere)
        })
        .unzip_into_vecs(out, spheres);
}

/// Nodes a task where leaves are made spheres on every core.
const NODES_A_TASK: usize = 1024;

/// Each leaf of `nodes` (the tree, without an enclosure's record) whose instance has a
/// world sphere in `spheres` made a [`TOP_SPHERE`] leaf holding it; whether any was.
fn fit_spheres(nodes: &mut [BvhNode], spheres: &[[f32; 4]]) -> bool {
    let fit = |min: &mut [f32; 3], max: &mut [f32; 3], index: u32, count: &mut u32| {
        if *count != 1 {
            return false; // an inner node, an absent child or an enclosure
        }
        let [x, y, z, r] = spheres[index as usize];
        if r > 0.0 {
            (*min, *max, *count) = ([x, y, z], [r, 0.0, 0.0], TOP_SPHERE);
        }
        r > 0.0
    };
    nodes
        .par_iter_mut()
        .with_min_len(NODES_A_TASK)
        .map(|n| {
            let left = fit(&mut n.left_min, &mut n.left_max, n.left_index, &mut n.left_count);
            let right = fit(&mut n.right_min, &mut n.right_max, n.right_index, &mut n.right_count);
            left | right
        })
        .reduce(|| false, |a, b| a | b)
}

/// One instance's record: its mesh's place and the inverse of its transform, inverted in
/// double precision so that the round trip loses no more than the final rounding.
fn record(mesh: &MeshPlace, index: u32, inst: &Instance) -> GpuInstance {
    let to_object =
        DAffine3::from_cols_array(&inst.transform.to_cols_array().map(f64::from)).inverse();
    let m = to_object.matrix3;
    let t = to_object.translation;
    let row = |i: usize| [m.x_axis[i] as f32, m.y_axis[i] as f32, m.z_axis[i] as f32, t[i] as f32];
    GpuInstance {
        to_object: [row(0), row(1), row(2)],
        // A mesh without triangles has no nodes of its own: EMPTY says so to the visit.
        node_base: if mesh.triangle_count == 0 { EMPTY } else { mesh.node_base },
        triangle_base: mesh.triangle_base,
        wide_words: if mesh.triangle_count == 0 { EMPTY } else { mesh.wide_words },
        mesh: index,
    }
}

/// The two-child tree over `leaves` with one instance a leaf, into `nodes` (the bottom levels' binned SAH
/// build). (A linear BVH in Morton order built 10,000 boxes in 1.2 ms instead of 4-5 ms on
/// the H200's host, but its trees cost up to 16% more per frame on fields of copies:
/// docs/BENCHMARKS.md, twenty-third session.)
fn tree_over(leaves: &mut [LeafBox], nodes: &mut Vec<BvhNode>) {
    nodes.clear();
    let root = Bvh::build_named_leaves_into(leaves, &BuildOptions::default(), nodes);
    if !root.is_inner() {
        // No instance, or one: a root over its leaf (or nothing) and an absent child.
        nodes.push(BvhNode::new(root, BvhChild::EMPTY));
    }
}

/// [`TopLevel::sah_cost`] of `nodes` (root first).
fn sah_cost(nodes: &[BvhNode]) -> f64 {
    let area = |b: &Aabb| {
        let e = (b.max - b.min).as_dvec3();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    };
    let children: Vec<Aabb> = nodes
        .iter()
        .flat_map(|n| n.children())
        .filter(|c| !c.is_empty())
        .map(|c| outer_box(&c))
        .collect();
    let root = children.iter().fold(Aabb::EMPTY, |acc, c| acc.union(*c));
    let root_area = area(&root);
    if root_area <= 0.0 {
        return 0.0;
    }
    // The root is opened by every ray; every other box is entered in proportion to its area.
    1.0 + children.iter().map(|c| area(c) / root_area).sum::<f64>()
}

/// The box of a top-level child: its own, or a sphere leaf's cube around the sphere.
fn outer_box(child: &BvhChild) -> Aabb {
    if child.count != TOP_SPHERE {
        return child.bounds;
    }
    let (centre, radius) = (child.bounds.min, child.bounds.max.x);
    Aabb { min: centre - radius, max: centre + radius }
}

/// The world box of `inst`'s record's tree leaf, for tests: the union of the leaves
/// naming instance `i`.
#[cfg(test)]
fn leaf_box(nodes: &[BvhNode], i: u32) -> Option<Aabb> {
    nodes.iter().flat_map(|n| n.children()).find(|c| c.is_leaf() && c.index == i).map(|c| c.bounds)
}

#[cfg(test)]
mod tests {
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
        let tris: Vec<_> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();
        let bvh = Bvh::build(&tris, &BuildOptions::default());
        let corners = |slot: u32| tris[bvh.prim_indices[slot as usize] as usize];
        (MeshCover::of_tree(&bvh.nodes, corners, mesh.bounds()), mesh)
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
                assert!(
                    w.cmpge(tight.min).all() && w.cmple(tight.max).all(),
                    "{w} outside {tight:?}"
                );
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
            let others: Vec<u32> =
                (0..instances.len() as u32).filter(|&i| i != enclosure).collect();
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
}
