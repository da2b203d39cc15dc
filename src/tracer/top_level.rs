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
use crate::scene::paper::ModelSource;
use crate::scene::spec::SceneSpec;
use crate::scene::Instance;

mod cover;
mod walk;

/// Whether the frames of `spec`'s scene will run the wide kernel's twin (its top level with
/// sphere leaves, [`TOP_SPHERE`], or convex copies, [`TopLevel::has_convex`]), as far as is
/// known before its model is loaded: several copies of a model made in code that is round
/// or convex (the paper's geosphere, sphere and cylinder). `render` makes the twin for them
/// beside the load. A file's meshes are known only once read (false).
pub(crate) fn wide_twin_before_loading(spec: &SceneSpec) -> bool {
    match spec.model {
        ModelSource::Paper(model) => {
            let mesh = model.mesh();
            spec.models > 1 && (cover::is_round(&mesh) || super::convex::winding(&mesh) != 0)
        }
        ModelSource::File(_) | ModelSource::Generated(_) => false,
    }
}
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
    /// Its convexity code (`GpuMesh::convex`).
    pub(crate) convex: u32,
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
    /// Whether some instance the walk visits (every one but an enclosure tested as a closed
    /// box) has a convex mesh, which a ray that leaves it skips (`tracer/convex.rs`): such
    /// frames run the wide kernel's twin (`contract::FLAG_CONVEX`). False for one instance,
    /// whose kernels skip it without the walk.
    pub(crate) has_convex: bool,
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
            has_convex,
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
            // The ONE_INSTANCE kernels open the root without a walk and take its leaf as a
            // box. The enclosure's record, the last node, is no node of the tree.
            let one = one_instance(instances.len(), closed.is_some());
            let tree_nodes = nodes.len() - usize::from(enclosure.is_some());
            *has_spheres = !one && fit_spheres(&mut nodes[..tree_nodes], spheres);
            let boxed = enclosure.filter(|_| closed.is_some());
            *has_convex = !one
                && (instances.iter().enumerate())
                    .any(|(i, inst)| meshes[inst.mesh].convex != 0 && Some(i) != boxed);
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
            convex: m.convex,
            _unused: 0,
        }));
    }

    /// The flags a frame over this top level sets (`contract::FLAG_SPHERES` with sphere
    /// leaves, `FLAG_CONVEX` with convex copies: both send wide frames to the wide
    /// kernel's twin; `FLAG_WARP_BLOCKS` where the walk visits [`WARP_BLOCKS_FROM`]
    /// instances or more).
    pub(crate) fn frame_flags(&self) -> u32 {
        use crate::contract::{FLAG_CONVEX, FLAG_SPHERES, FLAG_WARP_BLOCKS};
        let walked = self.instances.len() - usize::from(EnclosureRecord::of(&self.nodes).is_some());
        let mut flags = 0;
        if self.has_spheres {
            flags |= FLAG_SPHERES;
        }
        if self.has_convex {
            flags |= FLAG_CONVEX;
        }
        if walked >= WARP_BLOCKS_FROM {
            flags |= FLAG_WARP_BLOCKS;
        }
        flags
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
        one_instance(self.instances.len(), closed.is_some())
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

/// Instances the walk visits (an enclosure not counted) from which a frame's subgroups
/// trace 8x4 blocks instead of 32-pixel rows (`contract::FLAG_WARP_BLOCKS`). On the H200
/// (1024², docs/BENCHMARKS.md, thirty-eighth session) blocks made 4 to 10,000 geospheres
/// in the box 5-13% faster and the fields of 10,000 knots 7-10%, left 4 1M knots in the box
/// where they were and made 2 of them 11% slower: two big instances are a big mesh's
/// case, where rows are faster. At three, 3 geospheres and 3 dragons gained 3-5% and 3
/// knots lost 5%.
pub(crate) const WARP_BLOCKS_FROM: usize = 3;

/// Whether a scene of `count` instances, with an enclosure that is a closed box or not, is
/// one instance to the kernels ([`TopLevel::is_one_instance`]).
fn one_instance(count: usize, closed_enclosure: bool) -> bool {
    count == 1 || (count == 2 && closed_enclosure)
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

/// The sphere (`[centre, radius]`) a sphere leaf holds, as [`fit_spheres`] wrote it (the
/// centre in the min corner, the radius in the max's x); None for any other child.
pub(crate) fn leaf_sphere(child: &BvhChild) -> Option<[f32; 4]> {
    let [x, y, z] = child.bounds.min.to_array();
    (child.count == TOP_SPHERE).then_some([x, y, z, child.bounds.max.x])
}

/// The box of a top-level child: its own, or a sphere leaf's cube around the sphere.
fn outer_box(child: &BvhChild) -> Aabb {
    let Some([x, y, z, radius]) = leaf_sphere(child) else { return child.bounds };
    let centre = glam::Vec3::new(x, y, z);
    Aabb { min: centre - radius, max: centre + radius }
}

/// The world box of `inst`'s record's tree leaf, for tests: the union of the leaves
/// naming instance `i`.
#[cfg(test)]
fn leaf_box(nodes: &[BvhNode], i: u32) -> Option<Aabb> {
    nodes.iter().flat_map(|n| n.children()).find(|c| c.is_leaf() && c.index == i).map(|c| c.bounds)
}

#[cfg(test)]
mod tests;
