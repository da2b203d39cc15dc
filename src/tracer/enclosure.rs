//! The scene's enclosure: a mesh of a few triangles whose box holds every other instance
//! (the paper's mirror box around its models). Nearly every ray starts inside it and ends
//! on it or nearer, so the top level keeps it out of its tree: the walk visits it first
//! (`walk` in `top_level.rs`, `trace_instances` in `shaders/intersect.glsl`). Where it is a
//! closed box (six axis-aligned faces of two triangles each, in its own space), a ray from
//! inside is tested against the two triangles of the face it leaves by, which the slab
//! test names, instead of visiting the mesh's tree.
//!
//! The top level's root has the enclosure as its left child (count [`TOP_ENCLOSURE`]),
//! pointing at an [`EnclosureRecord`] stored after the tree's nodes, and the tree over the
//! other instances as its right child.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::bvh::{BuildOptions, Bvh, BvhChild, BvhNode, LeafBox};
use crate::contract::{EMPTY, TOP_ENCLOSURE};
use crate::geometry::Aabb;
use crate::scene::Instance;

/// Most triangles an enclosure may have (the paper's mirror box has 12).
pub(crate) const ENCLOSURE_TRIANGLES: u32 = 16;

/// The first instance of a mesh of at most [`ENCLOSURE_TRIANGLES`] (`triangles(mesh)`)
/// whose world box (`world_box(i)`) holds every other instance's, in a scene of two or more.
pub(crate) fn find(
    instances: &[Instance],
    world_box: impl Fn(usize) -> Aabb,
    triangles: impl Fn(usize) -> u32,
) -> Option<usize> {
    if instances.len() < 2 {
        return None;
    }
    let small = |inst: &Instance| (1..=ENCLOSURE_TRIANGLES).contains(&triangles(inst.mesh));
    // Fields of copies have no small mesh: no need to read every box then.
    instances.iter().position(small)?;
    // On one thread: tens of microseconds for 10,000 boxes, less than waking the pool.
    let all = (0..instances.len()).fold(Aabb::EMPTY, |acc, i| acc.union(world_box(i)));
    (0..instances.len()).find(|&i| small(&instances[i]) && world_box(i).contains(&all))
}

/// A mesh that is a closed box in its own space: six axis-aligned faces, each two
/// triangles sharing a diagonal and using the face's four corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ClosedBox {
    pub(crate) bounds: Aabb,
    /// The triangle slots (in BVH order, from the mesh's first) of each face: -x, +x, -y,
    /// +y, -z, +z.
    pub(crate) faces: [[u8; 2]; 6],
}

impl ClosedBox {
    /// The closed box of `slots` (each slot's corners, in BVH order), if they make one.
    pub(crate) fn of(slots: &[[Vec3; 3]]) -> Option<Self> {
        if slots.len() != 12 {
            return None;
        }
        let corners: Vec<Vec3> = slots.iter().flatten().copied().collect();
        let bounds = Aabb::from_points(&corners);
        if bounds.extent().min_element() <= 0.0 {
            return None;
        }
        let mut faces = [[0u8; 2]; 6];
        for (f, face) in faces.iter_mut().enumerate() {
            let (axis, plane) = (f / 2, if f % 2 == 0 { bounds.min } else { bounds.max });
            let on: Vec<usize> =
                (0..12).filter(|&k| slots[k].iter().all(|p| p[axis] == plane[axis])).collect();
            let [a, b] = on[..] else { return None };
            if !covers_face(&slots[a], &slots[b], &bounds, axis) {
                return None;
            }
            *face = [a as u8, b as u8];
        }
        Some(Self { bounds, faces })
    }
}

/// Whether triangles `a` and `b` (on a face perpendicular to `axis`) tile its rectangle:
/// every corner of each is a corner of the face, together they use all four, and they
/// share exactly two (a diagonal).
fn covers_face(a: &[Vec3; 3], b: &[Vec3; 3], bounds: &Aabb, axis: usize) -> bool {
    let is_corner = |p: &Vec3| {
        (0..3).filter(|&i| i != axis).all(|i| p[i] == bounds.min[i] || p[i] == bounds.max[i])
    };
    let mut used: Vec<Vec3> = a.iter().chain(b).copied().collect();
    let shared = a.iter().filter(|p| b.contains(p)).count();
    // total_cmp: a NaN corner must not panic the sort (it is no corner, so no closed box).
    used.sort_by(|p, q| (p.x.total_cmp(&q.x)).then(p.y.total_cmp(&q.y)).then(p.z.total_cmp(&q.z)));
    used.dedup();
    a.iter().chain(b).all(is_corner) && used.len() == 4 && shared == 2
}

/// What the walk needs of the enclosure, stored as one more node of the top level's
/// (64 bytes; `shaders/intersect.glsl` reads it as a `BvhNode`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct EnclosureRecord {
    /// The closed box's bounds in object space (zero for no closed box).
    box_min: [f32; 3],
    /// The enclosure's instance.
    instance: u32,
    box_max: [f32; 3],
    /// Faces 0-3's two slots (a nibble each, a byte a face), or `EMPTY` for no closed box.
    faces_low: u32,
    /// Faces 4 and 5's slots.
    faces_high: u32,
    unused: [u32; 7],
}

impl EnclosureRecord {
    /// The record of instance `instance`, a closed box or not.
    pub(crate) fn new(instance: u32, closed: Option<ClosedBox>) -> Self {
        let byte = |[a, b]: [u8; 2]| u32::from(a) | u32::from(b) << 4;
        let (box_min, box_max, faces_low, faces_high) = match closed {
            Some(c) => (
                c.bounds.min.to_array(),
                c.bounds.max.to_array(),
                (0..4).fold(0, |w, f| w | byte(c.faces[f]) << (8 * f)),
                byte(c.faces[4]) | byte(c.faces[5]) << 8,
            ),
            None => ([0.0; 3], [0.0; 3], EMPTY, EMPTY),
        };
        Self { box_min, instance, box_max, faces_low, faces_high, unused: [0; 7] }
    }

    /// The enclosure's instance.
    pub(crate) fn instance(&self) -> u32 {
        self.instance
    }

    /// The closed box it is, if it is one.
    pub(crate) fn closed_box(&self) -> Option<ClosedBox> {
        if self.faces_low == EMPTY {
            return None;
        }
        let slot =
            |word: u32, f: usize| [(word >> (8 * f) & 15) as u8, (word >> (8 * f + 4) & 15) as u8];
        let mut faces = [[0u8; 2]; 6];
        for (f, face) in faces.iter_mut().enumerate() {
            *face = if f < 4 { slot(self.faces_low, f) } else { slot(self.faces_high, f - 4) };
        }
        let bounds = Aabb { min: self.box_min.into(), max: self.box_max.into() };
        Some(ClosedBox { bounds, faces })
    }

    /// The record of a top level's `nodes` whose root holds an enclosure.
    pub(crate) fn of(nodes: &[BvhNode]) -> Option<&Self> {
        let left = nodes.first()?.children()[0];
        (left.count == TOP_ENCLOSURE).then(|| bytemuck::cast_ref(&nodes[left.index as usize]))
    }
}

/// The top level's nodes over `leaves` (named by instance) with instance `enclosure`
/// taken out, into `nodes`: a root whose left child is the enclosure (its world box, count
/// [`TOP_ENCLOSURE`], and the index of its `record`, the last node) and whose right is the
/// tree over the others (their one leaf, for one).
pub(crate) fn tree_around(
    leaves: &mut Vec<LeafBox>,
    enclosure: usize,
    record: EnclosureRecord,
    nodes: &mut Vec<BvhNode>,
) {
    let bounds = leaves[enclosure].aabb();
    // The order of the leaves does not change the tree.
    leaves.swap_remove(enclosure);
    // The root, the tree's nodes (one fewer than its leaves), the record.
    nodes.clear();
    nodes.reserve(leaves.len() + 1);
    nodes.push(BvhNode::default()); // the root, made once its right child is built
    let right = Bvh::build_named_leaves_into(leaves, &BuildOptions::default(), nodes);
    let left = BvhChild { bounds, index: nodes.len() as u32, count: TOP_ENCLOSURE };
    nodes[0] = BvhNode::new(left, right);
    nodes.push(bytemuck::cast(record));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mirror_box_slots() -> Vec<[Vec3; 3]> {
        let mesh = crate::scene::paper::mirror_box_mesh(2.0);
        (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect()
    }

    #[test]
    fn the_mirror_box_is_a_closed_box_in_any_slot_order() {
        let slots = mirror_box_slots();
        let closed = ClosedBox::of(&slots).expect("the mirror box is closed");
        assert_eq!(closed.bounds, Aabb { min: Vec3::splat(-2.0), max: Vec3::splat(2.0) });
        assert_eq!(closed.faces, [[0, 1], [2, 3], [4, 5], [6, 7], [8, 9], [10, 11]]);
        // Reversed, each face's slots are found where they went.
        let reversed: Vec<_> = slots.iter().rev().copied().collect();
        let closed = ClosedBox::of(&reversed).unwrap();
        assert_eq!(closed.faces, [[10, 11], [8, 9], [6, 7], [4, 5], [2, 3], [0, 1]]);
        // The record keeps it.
        let record = EnclosureRecord::new(7, Some(closed));
        assert_eq!((record.instance(), record.closed_box()), (7, Some(closed)));
        assert_eq!(EnclosureRecord::new(3, None).closed_box(), None);
    }

    #[test]
    fn other_meshes_of_twelve_triangles_are_not_closed_boxes() {
        let slots = mirror_box_slots();
        // One face's triangles twice (the face opposite left open).
        let mut doubled = slots.clone();
        doubled[2] = slots[0];
        doubled[3] = slots[1];
        // A corner moved off its plane.
        let mut bent = slots.clone();
        bent[0][0].x += 0.25;
        // Both triangles of a face the same.
        let mut same = slots.clone();
        same[1] = slots[0];
        // A flat box.
        let flat: Vec<[Vec3; 3]> =
            slots.iter().map(|t| t.map(|p| Vec3::new(p.x, 0.0, p.z))).collect();
        for (name, case) in [("doubled", doubled), ("bent", bent), ("same", same), ("flat", flat)] {
            assert_eq!(ClosedBox::of(&case), None, "{name}");
        }
        assert_eq!(ClosedBox::of(&slots[..10]), None, "ten triangles");
    }
}
