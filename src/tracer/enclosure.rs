//! The scene's enclosure: a mesh of a few triangles whose box holds every other instance
//! (the paper's mirror box around its models). Nearly every ray starts inside it and ends
//! on it or nearer, so the top level keeps it out of its tree: the walk visits it first
//! (`walk` in `top_level.rs`, `trace_instances` in `shaders/intersect.glsl`). Where it is a
//! closed box (six axis-aligned faces of two triangles each, in its own space), a ray from
//! inside leaves by the face the slab test names, where the slab gives its distance and the
//! face's plane its triangle and barycentrics: no triangle is tested
//! ([`ClosedBox::exit`]).
//!
//! The top level's root has the enclosure as its left child (count [`TOP_ENCLOSURE`]),
//! pointing at an [`EnclosureRecord`] stored after the tree's nodes, and the tree over the
//! other instances as its right child.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::bvh::{BuildOptions, Bvh, BvhChild, BvhNode, LeafBox};
use crate::contract::{EMPTY, TOP_ENCLOSURE};
use crate::geometry::{safe_inverse, Aabb};
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
    /// Where each of those triangles' corners (v0, v1, v2) sit on their face: 2 bits a
    /// corner ([`corner_code`]), v0 in the lowest.
    pub(crate) corners: [[u8; 2]; 6],
}

/// Where a ray from inside a [`ClosedBox`] leaves it: the distance, the triangle slot and
/// its barycentrics (the weights of corners 1 and 2), as Möller–Trumbore would report them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Exit {
    pub(crate) t: f32,
    pub(crate) slot: u8,
    pub(crate) u: f32,
    pub(crate) v: f32,
}

/// The two axes that span the faces perpendicular to `axis`, in the order the corner codes
/// and the shader's `closed_box_hit` use.
fn in_plane(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// A face corner `p` as 2 bits: whether it sits at the box's max along each in-plane axis
/// of `axis` (the first in bit 0).
fn corner_code(p: Vec3, bounds: &Aabb, axis: usize) -> u8 {
    let (a1, a2) = in_plane(axis);
    u8::from(p[a1] == bounds.max[a1]) | u8::from(p[a2] == bounds.max[a2]) << 1
}

/// The barycentrics (u, v) of `q`, a face point in the face's unit square, in the triangle
/// whose corners `code` names (three 2-bit [`corner_code`]s). Half the unit square, so the
/// edges' determinant is 1 or -1 and is its own inverse. The shader's `face_barycentrics`.
fn face_barycentrics(q: Vec2, code: u8) -> Vec2 {
    let corner =
        |c: u8| Vec2::new(f32::from(code >> (2 * c) & 1), f32::from(code >> (2 * c + 1) & 1));
    let c0 = corner(0);
    let (e1, e2, w) = (corner(1) - c0, corner(2) - c0, q - c0);
    let det = e1.x * e2.y - e1.y * e2.x;
    Vec2::new(w.x * e2.y - w.y * e2.x, e1.x * w.y - e1.y * w.x) * det
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
        let mut corners = [[0u8; 2]; 6];
        for f in 0..6 {
            let (axis, plane) = (f / 2, if f % 2 == 0 { bounds.min } else { bounds.max });
            let on: Vec<usize> =
                (0..12).filter(|&k| slots[k].iter().all(|p| p[axis] == plane[axis])).collect();
            let [a, b] = on[..] else { return None };
            if !covers_face(&slots[a], &slots[b], &bounds, axis) {
                return None;
            }
            faces[f] = [a as u8, b as u8];
            corners[f] = [a, b].map(|k| {
                let [c0, c1, c2] = slots[k].map(|p| corner_code(p, &bounds, axis));
                c0 | c1 << 2 | c2 << 4
            });
        }
        Some(Self { bounds, faces, corners })
    }

    /// Where the ray `origin + t dir` (in the box's space, `origin` inside or on it) leaves
    /// the box, if for some t > 0. The face is the slab test's nearest exit plane, t its
    /// distance there, and the point's place on the face picks the triangle and gives its
    /// barycentrics, so a ray cannot slip between a face's two triangles. None for a ray
    /// that starts on the plane it leaves by (t = 0), which meets no wall: the other faces
    /// lie behind it or beside it. Mirrored step for step by the shader's `closed_box_hit`.
    pub(crate) fn exit(&self, origin: Vec3, dir: Vec3) -> Option<Exit> {
        let (min, max) = (self.bounds.min, self.bounds.max);
        let up = dir.cmpge(Vec3::ZERO);
        let t3 = (Vec3::select(up, max, min) - origin) * safe_inverse(dir);
        let axis = if t3.x <= t3.y && t3.x <= t3.z {
            0
        } else if t3.y <= t3.z {
            1
        } else {
            2
        };
        let t = t3[axis];
        if t.is_nan() || t <= 0.0 {
            return None;
        }
        let face = 2 * axis + usize::from(up.test(axis));
        let rel = (origin + dir * t - min) * self.inv_extent();
        let (a1, a2) = in_plane(axis);
        let q = Vec2::new(rel[a1], rel[a2]).clamp(Vec2::ZERO, Vec2::ONE);
        let [a, b] = self.corners[face];
        let mut uv = face_barycentrics(q, a);
        let mut slot = self.faces[face][0];
        if uv.x < 0.0 || uv.y < 0.0 || uv.x + uv.y > 1.0 {
            uv = face_barycentrics(q, b);
            slot = self.faces[face][1];
        }
        Some(Exit { t, slot, u: uv.x, v: uv.y })
    }

    /// 1 / the box's extent on each axis, as the record stores it for the shader.
    fn inv_extent(&self) -> Vec3 {
        Vec3::ONE / (self.bounds.max - self.bounds.min)
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
    /// The slots' corner codes, 16 bits a face (slot a's 6 bits, then slot b's), two
    /// faces a word.
    corners: [u32; 3],
    /// 1 / the box's extent on each axis (the face point's place on its face).
    inv_extent: [f32; 3],
    unused: u32,
}

impl EnclosureRecord {
    /// The record of instance `instance`, a closed box or not.
    pub(crate) fn new(instance: u32, closed: Option<ClosedBox>) -> Self {
        let byte = |[a, b]: [u8; 2]| u32::from(a) | u32::from(b) << 4;
        let codes = |[a, b]: [u8; 2]| u32::from(a) | u32::from(b) << 6;
        let (box_min, box_max, faces_low, faces_high, corners, inv_extent) = match closed {
            Some(c) => (
                c.bounds.min.to_array(),
                c.bounds.max.to_array(),
                (0..4).fold(0, |w, f| w | byte(c.faces[f]) << (8 * f)),
                byte(c.faces[4]) | byte(c.faces[5]) << 8,
                [0, 1, 2].map(|w| codes(c.corners[2 * w]) | codes(c.corners[2 * w + 1]) << 16),
                c.inv_extent().to_array(),
            ),
            None => ([0.0; 3], [0.0; 3], EMPTY, EMPTY, [0; 3], [0.0; 3]),
        };
        Self { box_min, instance, box_max, faces_low, faces_high, corners, inv_extent, unused: 0 }
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
        let mut corners = [[0u8; 2]; 6];
        for f in 0..6 {
            faces[f] = if f < 4 { slot(self.faces_low, f) } else { slot(self.faces_high, f - 4) };
            let code = self.corners[f / 2] >> (16 * (f % 2));
            corners[f] = [(code & 63) as u8, (code >> 6 & 63) as u8];
        }
        let bounds = Aabb { min: self.box_min.into(), max: self.box_max.into() };
        Some(ClosedBox { bounds, faces, corners })
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
    use crate::geometry::{intersect_triangle, Ray};

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

    /// A closed box's 12 triangles with every choice a mesh may make: each face split on
    /// either diagonal, each triangle's corners rotated and wound either way, the slots
    /// shuffled, all drawn from `seed`.
    fn any_box(min: Vec3, max: Vec3, seed: &mut u32) -> Vec<[Vec3; 3]> {
        let mut next = || {
            *seed = seed.wrapping_mul(747796405).wrapping_add(2891336453);
            *seed >> 8
        };
        let mut slots = Vec::new();
        for axis in 0..3 {
            for side in [min[axis], max[axis]] {
                let (a1, a2) = in_plane(axis);
                let corner = |i: u32, j: u32| {
                    let mut p = Vec3::ZERO;
                    p[axis] = side;
                    p[a1] = if i == 0 { min[a1] } else { max[a1] };
                    p[a2] = if j == 0 { min[a2] } else { max[a2] };
                    p
                };
                let [c00, c10, c11, c01] = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                let pair = if next() % 2 == 0 {
                    [[c00, c10, c11], [c00, c11, c01]]
                } else {
                    [[c10, c11, c01], [c10, c01, c00]]
                };
                for [p0, p1, p2] in pair {
                    let turned = match next() % 3 {
                        0 => [p0, p1, p2],
                        1 => [p1, p2, p0],
                        _ => [p2, p0, p1],
                    };
                    let [q0, q1, q2] = turned;
                    slots.push(if next() % 2 == 0 { turned } else { [q0, q2, q1] });
                }
            }
        }
        for k in (1..slots.len()).rev() {
            slots.swap(k, next() as usize % (k + 1));
        }
        slots
    }

    #[test]
    fn a_ray_leaves_a_closed_box_where_moller_trumbore_finds_it() {
        let mut seed = 7u32;
        let unit = |seed: &mut u32| {
            *seed = seed.wrapping_mul(747796405).wrapping_add(2891336453);
            (*seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut rays = 0;
        for (min, max) in [
            (Vec3::splat(-2.0), Vec3::splat(2.0)),
            (Vec3::new(-3.0, 0.5, -1.0), Vec3::new(5.0, 0.75, 9.0)),
        ] {
            for _ in 0..16 {
                let slots = any_box(min, max, &mut seed);
                let closed = ClosedBox::of(&slots).expect("a closed box");
                for r in 0..400 {
                    let origin = min
                        + (max - min)
                            * Vec3::new(unit(&mut seed), unit(&mut seed), unit(&mut seed));
                    let mut dir =
                        Vec3::new(unit(&mut seed), unit(&mut seed), unit(&mut seed)) * 2.0 - 1.0;
                    // Some along an axis or in a plane: zero components.
                    if r % 7 == 0 {
                        dir[r % 3] = 0.0;
                    }
                    if r % 11 == 0 {
                        dir[(r + 1) % 3] = 0.0;
                    }
                    let exit = closed.exit(origin, dir).expect("a ray from inside leaves");
                    let ray = Ray::new(origin, dir);
                    let found = slots.iter().enumerate().filter_map(|(k, [v0, v1, v2])| {
                        intersect_triangle(&ray, *v0, *v1 - *v0, *v2 - *v0, 0.0, f32::INFINITY)
                            .map(|h| (k, h))
                    });
                    let (k, best) = found
                        .min_by(|a, b| a.1.t.total_cmp(&b.1.t))
                        .expect("Möller–Trumbore finds the wall");
                    let scale = (max - min).max_element();
                    assert!(
                        (exit.t - best.t).abs() <= 1e-5 * scale.max(best.t),
                        "t {} against {}",
                        exit.t,
                        best.t
                    );
                    let [v0, v1, v2] = slots[usize::from(exit.slot)];
                    let at = v0 + (v1 - v0) * exit.u + (v2 - v0) * exit.v;
                    assert!(
                        (at - ray.at(best.t)).length() <= 1e-4 * scale,
                        "{at} against {}",
                        ray.at(best.t)
                    );
                    // The same triangle, or a point on the diagonal they share.
                    let on_diagonal = |u: f32, v: f32| u.min(v).min(1.0 - u - v) <= 1e-5;
                    assert!(
                        usize::from(exit.slot) == k
                            || (on_diagonal(exit.u, exit.v) && on_diagonal(best.u, best.v))
                    );
                    assert!(exit.u >= -1e-6 && exit.v >= -1e-6 && exit.u + exit.v <= 1.0 + 1e-6);
                    rays += 1;
                }
                // From the plane a ray leaves by, no exit: the caller tests the triangles.
                let on_wall = Vec3::new(max.x, (min.y + max.y) / 2.0, (min.z + max.z) / 2.0);
                assert_eq!(closed.exit(on_wall, Vec3::X), None);
                // The record keeps the corners.
                assert_eq!(EnclosureRecord::new(0, Some(closed)).closed_box(), Some(closed));
            }
        }
        assert_eq!(rays, 2 * 16 * 400);
    }
}
