//! The top level of the two-level structure: the instance records the GPU reads (each a
//! mesh's place in the packed arrays and its world-to-object transform) and a two-child
//! tree over the instances' world boxes, built here and walked here the way
//! `trace_instances` in `shaders/intersect.glsl` walks it, for the CPU reference.
//!
//! The tree is the bottom levels' node layout ([`BvhNode`]) with leaves of one instance,
//! whose index is the instance's own: the instance list keeps the scene's order. It is
//! built as a linear BVH (Morton order), quick enough to rebuild whenever instances move.

use glam::{DAffine3, Vec3};
use rayon::prelude::*;

use super::records::{GpuInstance, GpuMesh};
use crate::contract::EMPTY;
use crate::bvh::{BvhChild, BvhNode, TraversalStats};
use crate::geometry::{safe_inverse, Aabb, Ray};
use crate::scene::Instance;

/// Where a mesh sits in the packed arrays, as an instance record needs it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MeshPlace {
    pub(crate) node_base: u32,
    pub(crate) triangle_base: u32,
    pub(crate) triangle_count: u32,
    pub(crate) prim_base: u32,
    /// The mesh's first wide node in 16-byte words of the node buffer, or `EMPTY`.
    pub(crate) wide_words: u32,
    /// The mesh's object-space box.
    pub(crate) bounds: Aabb,
}

/// The instance records, the tree over them and the mesh table they index.
#[derive(Clone, Debug, Default)]
pub struct TopLevel {
    pub instances: Vec<GpuInstance>,
    /// One record per mesh, as `instances[i].mesh` names it.
    pub meshes: Vec<GpuMesh>,
    /// Root first; at least one node (a root with two absent children for no instances).
    pub nodes: Vec<BvhNode>,
}

impl TopLevel {
    /// Records for `instances` (mesh `m` placed as `meshes[m]` says) and the tree over their
    /// world boxes. Built in a few milliseconds for 10,000 instances, so moving instances
    /// stays live.
    pub(crate) fn build(meshes: &[MeshPlace], instances: &[Instance]) -> Self {
        // Records and boxes in one pass, on every core for large fields (each record is a
        // double-precision inverse, each box eight transformed corners).
        let (records, boxes): (Vec<GpuInstance>, Vec<Aabb>) = instances
            .par_iter()
            .with_min_len(1024)
            .map(|inst| {
                let mesh = &meshes[inst.mesh];
                let b = inst.world_bounds(mesh.bounds);
                // An empty mesh has no box; a point keeps it in the tree (its visit finds
                // no triangles).
                let b = if b.is_empty() {
                    Aabb::from_points(&[inst.transform.translation.into()])
                } else {
                    b
                };
                (record(mesh, inst.mesh as u32, inst), b)
            })
            .unzip();
        let meshes = meshes
            .iter()
            .map(|m| GpuMesh { triangle_count: m.triangle_count, prim_base: m.prim_base })
            .collect();
        Self { instances: records, meshes, nodes: tree_over(&boxes) }
    }

    /// Triangle slots over all instances (each instance's mesh counted again).
    pub fn triangle_slots(&self) -> u64 {
        self.instances.iter().map(|i| self.meshes[i.mesh as usize].triangle_count as u64).sum()
    }

    /// The tree's surface-area cost: every node's and every instance box's area over the
    /// root's, a node opened and an instance visited costing 1 each (tinybvh's measure with
    /// C_trav = C_int = 1). Lower is a tree that sends a ray to fewer boxes.
    pub fn sah_cost(&self) -> f64 {
        sah_cost(&self.nodes)
    }

    /// Bytes of the records and the tree (what the scene costs beyond its meshes).
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.instances.as_slice())
            + std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.meshes.as_slice())
    }
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

/// The two-child tree over `boxes` with leaves of one box each, a leaf's index the box's:
/// a linear BVH (Karras 2012), the boxes sorted by their centres' Morton codes and every
/// range split where its codes' highest differing bit changes. Far quicker to build than
/// the bottom levels' binned SAH (a sort and one pass: ~0.3 ms for 10,000 boxes against
/// 4-8 ms), which keeps moving instances live; on fields of copies, a grid, the Morton
/// order is close to what the SAH picks.
fn tree_over(boxes: &[Aabb]) -> Vec<BvhNode> {
    let none = BvhChild::EMPTY;
    if boxes.is_empty() {
        return vec![BvhNode::new(none, none)];
    }
    let centres = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.grow_point(b.center()));
    let extent = centres.max - centres.min;
    // 10 bits an axis; an axis without extent maps every centre to 0.
    let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), 1023.0 / extent, Vec3::ZERO);
    // The code in the high half, the box's index in the low: one sort key, ties in order.
    let mut keys: Vec<u64> = boxes
        .par_iter()
        .with_min_len(4096)
        .enumerate()
        .map(|(i, b)| {
            let q = ((b.center() - centres.min) * scale).round();
            let q = q.clamp(Vec3::ZERO, Vec3::splat(1023.0)).as_uvec3();
            let code = spread_bits(q.x) << 2 | spread_bits(q.y) << 1 | spread_bits(q.z);
            u64::from(code) << 32 | i as u64
        })
        .collect();
    keys.par_sort_unstable();
    if boxes.len() == 1 {
        // One box: a root holding it as its only child.
        return vec![BvhNode::new(leaf(keys[0], boxes), none)];
    }
    // n boxes make n - 1 nodes, and a range's nodes follow its own parent first, so every
    // subtree knows where its nodes go and the halves are made in parallel.
    let mut nodes = vec![BvhNode::new(none, none); boxes.len() - 1];
    emit(&keys, boxes, &mut nodes, 0);
    nodes
}

/// The leaf record of the box `key` names.
fn leaf(key: u64, boxes: &[Aabb]) -> BvhChild {
    let index = (key & 0xffff_ffff) as u32;
    BvhChild { bounds: boxes[index as usize], index, count: 1 }
}

/// The subtree over `keys` (sorted, at least two), its `keys.len() - 1` nodes written to
/// `nodes` parent first, the parent being node `at` of the whole tree; returns the box.
fn emit(keys: &[u64], boxes: &[Aabb], nodes: &mut [BvhNode], at: u32) -> Aabb {
    let (first, last) = (keys[0] >> 32, keys[keys.len() - 1] >> 32);
    let split = if first == last {
        keys.len() / 2 // equal codes: halves
    } else {
        // The first key with the highest differing bit set.
        let bit = 63 - (first ^ last).leading_zeros();
        keys.partition_point(|k| (k >> 32) >> bit & 1 == 0)
    };
    let (lk, rk) = keys.split_at(split);
    let (node, rest) = nodes.split_first_mut().expect("a range of two or more keys has a node");
    let (ln, rn) = rest.split_at_mut(split - 1);
    let (l_at, r_at) = (at + 1, at + split as u32);
    let side = |keys: &[u64], nodes: &mut [BvhNode], at: u32| {
        if keys.len() == 1 {
            leaf(keys[0], boxes)
        } else {
            BvhChild { bounds: emit(keys, boxes, nodes, at), index: at, count: 0 }
        }
    };
    let (left, right) = if keys.len() > 4096 {
        rayon::join(|| side(lk, ln, l_at), || side(rk, rn, r_at))
    } else {
        (side(lk, ln, l_at), side(rk, rn, r_at))
    };
    *node = BvhNode::new(left, right);
    left.bounds.union(right.bounds)
}

/// The 10 low bits of `v` spread to every third bit (bit i to bit 3i), for Morton codes.
fn spread_bits(v: u32) -> u32 {
    let mut x = v & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

/// [`TopLevel::sah_cost`] of `nodes` (root first).
fn sah_cost(nodes: &[BvhNode]) -> f64 {
    let area = |b: &Aabb| {
        let e = (b.max - b.min).as_dvec3();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    };
    let children: Vec<_> =
        nodes.iter().flat_map(|n| n.children()).filter(|c| !c.is_empty()).collect();
    let root = children.iter().fold(Aabb::EMPTY, |acc, c| acc.union(c.bounds));
    let root_area = area(&root);
    if root_area <= 0.0 {
        return 0.0;
    }
    // The root is opened by every ray; every other box is entered in proportion to its area.
    1.0 + children.iter().map(|c| area(&c.bounds) / root_area).sum::<f64>()
}

/// What visiting one instance found.
pub(crate) enum Visit {
    /// Nothing closer (or nothing blocking).
    Nothing,
    /// A closer hit at this distance: the farther boxes are cut to it.
    Closer(f32),
    /// The ray is blocked: the walk ends (occlusion queries).
    Blocked,
}

/// The next stop of a walk: a node to open or an instance to visit.
#[derive(Clone, Copy)]
enum Stop {
    Node(u32),
    Instance(u32),
}

/// Walk the tree for `ray` in (0, `t_max`), calling `visit(i, t_max)` for every instance
/// whose box the ray meets before the closest hit so far, as the shader's
/// `trace_instances` does: of a node's two children the nearer next, the farther pushed
/// with its entry distance and dropped when popped if a hit found since ends before it.
/// Returns true when a visit said [`Visit::Blocked`]. Counts a node per node opened.
pub(crate) fn walk(
    nodes: &[BvhNode],
    ray: &Ray,
    mut t_max: f32,
    stats: &mut TraversalStats,
    mut visit: impl FnMut(u32, f32) -> Visit,
) -> bool {
    let inv_dir = safe_inverse(ray.dir);
    let mut stack = [(Stop::Node(0), 0.0f32); crate::bvh::STACK_SIZE];
    let mut sp = 0;
    let mut next = Some(Stop::Node(0));
    loop {
        let stop = match next.take() {
            Some(stop) => stop,
            None => {
                if sp == 0 {
                    return false;
                }
                sp -= 1;
                let (stop, entry) = stack[sp];
                if entry > t_max {
                    continue; // begins beyond the closest hit found since
                }
                stop
            }
        };
        match stop {
            Stop::Instance(i) => match visit(i, t_max) {
                Visit::Nothing => {}
                Visit::Closer(t) => t_max = t,
                Visit::Blocked => return true,
            },
            Stop::Node(node) => {
                stats.nodes += 1;
                let children = nodes[node as usize].children().map(|c| {
                    let entry = if c.is_empty() {
                        f32::INFINITY
                    } else {
                        c.bounds.intersect(ray, inv_dir, t_max).unwrap_or(f32::INFINITY)
                    };
                    let stop =
                        if c.is_leaf() { Stop::Instance(c.index) } else { Stop::Node(c.index) };
                    (stop, entry)
                });
                let [l, r] = children;
                let (near, far) = if r.1 < l.1 { (r, l) } else { (l, r) };
                if far.1 < f32::INFINITY {
                    stack[sp] = far;
                    sp += 1;
                }
                if near.1 < f32::INFINITY {
                    next = Some(near.0);
                }
            }
        }
    }
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

    fn place(bounds: Aabb) -> MeshPlace {
        MeshPlace {
            node_base: 0,
            triangle_base: 0,
            triangle_count: 1,
            prim_base: 0,
            wide_words: EMPTY,
            bounds,
        }
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
                assert_eq!(leaf_box(&top.nodes, i as u32), Some(inst.world_bounds(unit)));
            }
        }
    }

    #[test]
    fn morton_bits_interleave() {
        assert_eq!(spread_bits(0), 0);
        assert_eq!(spread_bits(1), 1);
        assert_eq!(spread_bits(0b11), 0b1001);
        assert_eq!(spread_bits(0x3ff), 0x0924_9249);
        assert_eq!(spread_bits(0x7ff), 0x0924_9249, "only 10 bits");
    }

    #[test]
    fn boxes_at_one_point_make_a_balanced_tree() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
        let nodes = tree_over(&vec![b; 64]);
        assert_eq!(nodes.len(), 63);
        // Halves down to single boxes: depth 6.
        fn depth(nodes: &[BvhNode], i: usize) -> usize {
            1 + nodes[i]
                .children()
                .iter()
                .filter(|c| c.is_inner())
                .map(|c| depth(nodes, c.index as usize))
                .max()
                .unwrap_or(0)
        }
        assert_eq!(depth(&nodes, 0), 6);
    }

    #[test]
    fn the_morton_tree_is_about_as_good_as_the_sah_one() {
        // The paper's field and a scattered one: boxes of the copies of a unit mesh.
        let unit = Aabb { min: Vec3::splat(-1.0), max: Vec3::ONE };
        for seed in [0, 7] {
            let instances = crate::scene::paper::instances(3000, seed);
            let boxes: Vec<Aabb> = instances.iter().map(|i| i.world_bounds(unit)).collect();
            let options = crate::bvh::BuildOptions { max_leaf_size: 1, ..Default::default() };
            let sah = crate::bvh::Bvh::build_from_boxes(&boxes, &options).nodes;
            let (morton, sah) = (sah_cost(&tree_over(&boxes)), sah_cost(&sah));
            assert!(morton < sah * 1.15, "seed {seed}: Morton {morton:.1}, SAH {sah:.1}");
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
