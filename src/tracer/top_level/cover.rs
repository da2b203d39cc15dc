//! What an instance's world box is made from: its mesh's support function (how far the mesh
//! reaches along a direction) sampled on a grid over the faces of a cube of directions.
//!
//! The world box of a mesh under `x -> A x + t` reaches along world axis k as far as the
//! mesh reaches along row k of `A` (`h(A_k) + t_k`, and `-h(-A_k) + t_k` the other way).
//! A support function is sublinear (`h(a u + b v) <= a h(u) + b h(v)` for `a, b >= 0`), so
//! for a direction inside a triangle of the grid the sampled corners' values, weighted as
//! the direction's barycentric coordinates there, bound it from above: the box is never
//! cut, and it is exact along the grid's directions (so an unturned instance gets its
//! mesh's box). Turned, a knot's box holds at most 3% more area than the box of its turned
//! vertices, where the turned boxes of its tree's top eight nodes held 65% more
//! (docs/BENCHMARKS.md, thirty-first and thirty-second sessions). The turned mesh box
//! (Arvo's method) still bounds it, exactly so for a mesh that is a box.

use glam::{Affine3A, Vec3, Vec3A};
use rayon::prelude::*;

use crate::bvh::{BvhChild, BvhNode};
use crate::geometry::Aabb;
use crate::scene::Mesh;

/// Cells along a side of a face of the cube of directions.
const CELLS: usize = 8;

/// Samples along a side of a face.
const SIDE: usize = CELLS + 1;

/// Grid points in the table: the three faces of the cube towards +x, +y and +z, `SIDE` x
/// `SIDE` each. Each holds the reach along its direction `g` and along `-g`, which is the
/// opposite face's grid point mirrored through the centre: one table entry serves both
/// faces of an axis.
const SAMPLES: usize = 3 * SIDE * SIDE;

/// Trees of more nodes sample their directions on every core.
const PARALLEL_NODES: usize = 16 * 1024;

/// A mesh's box and its support function sampled over the cube of directions (see the
/// module doc).
#[derive(Clone, Copy, Debug)]
pub(crate) struct MeshCover {
    /// The mesh's box (empty for no mesh).
    bounds: Aabb,
    /// `[h(g), h(-g)]` for the grid point `g` of each positive face (`direction`), or none
    /// for a mesh known only by its box.
    support: Option<[[f32; 2]; SAMPLES]>,
    /// A bound on `|x| + |y| + |z|` over the mesh: the scale of the table's rounding.
    reach: f32,
    /// The sphere around the mesh's box centre that holds every corner (centre, radius),
    /// where it is clearly tighter than the box (`SPHERE_MOST_OUTLINE`); radius 0 where it
    /// is not, or is unknown.
    sphere: [f32; 4],
}

impl MeshCover {
    /// The cover of a mesh known only by its box (a tree built on the device; an empty box:
    /// no mesh).
    pub(crate) fn of_box(bounds: Aabb) -> Self {
        Self { bounds, support: None, reach: 0.0, sphere: [0.0; 4] }
    }

    /// The cover of a mesh whose tree (`nodes`, root first) holds, in leaf slot `s`, a
    /// triangle with the corners `corners(s)`; `bounds` its box. Each sample is the exact
    /// reach of the corners, found by branch and bound down the tree.
    pub(crate) fn of_tree(
        nodes: &[BvhNode],
        corners: impl Fn(u32) -> [Vec3; 3] + Sync,
        bounds: Aabb,
    ) -> Self {
        if nodes.is_empty() || bounds.is_empty() {
            return Self::of_box(bounds);
        }
        let mut support = [[0.0; 2]; SAMPLES];
        let sample = |(i, s): (usize, &mut [f32; 2])| {
            let g = direction(i);
            *s = [reach(nodes, &corners, g), reach(nodes, &corners, -g)];
        };
        // About 0.1 ms a direction for a 1M knot (its table 14 ms on this 2-core machine,
        // 3 ms on the H200's host), well under a microsecond for the paper's models.
        if nodes.len() > PARALLEL_NODES {
            support.par_iter_mut().enumerate().for_each(sample);
        } else {
            support.iter_mut().enumerate().for_each(sample);
        }
        let extent = bounds.min.abs().max(bounds.max.abs());
        let sphere = bounding_sphere(nodes, &corners, bounds);
        Self { bounds, support: Some(support), reach: extent.x + extent.y + extent.z, sphere }
    }

    /// The mesh's bounding sphere (`[centre, radius]` in the mesh's space; radius 0: none,
    /// the box is as tight).
    #[cfg(test)]
    pub(crate) fn sphere(&self) -> [f32; 4] {
        self.sphere
    }

    /// The sphere an instance's top-level leaf holds in place of its world box `world` (see
    /// [`crate::contract::TOP_SPHERE`]): the mesh's sphere under `transform`, where the mesh
    /// has one and it stays clearly tighter than `world` (a scale that squashes the mesh
    /// can make the box the tighter). A ray that enters an instance's box can still pass by
    /// the mesh: on the paper's 27 geospheres in the mirror box 72% of the instances a ray
    /// entered gave no closer hit, and the sphere turns away two thirds of those.
    pub(crate) fn world_sphere(&self, transform: &Affine3A, world: &Aabb) -> Option<[f32; 4]> {
        let [x, y, z, r] = self.sphere;
        if r <= 0.0 {
            return None;
        }
        let centre = transform.transform_point3(Vec3::new(x, y, z));
        let radius =
            r * largest_stretch(transform) * (1.0 + 1e-6) + 1e-6 * centre.abs().max_element();
        tight_enough(radius, world).then_some([centre.x, centre.y, centre.z, radius])
    }

    /// Bounds from above on how far the mesh reaches along `u` and along `-u` (`max u . x`
    /// and `max -u . x`): both lie on the same axis of the cube, on opposite faces.
    ///
    /// Without branches on the direction: the turns of a field of copies send each row
    /// to any face, and the branches of a plain version (which axis is longest, and glam's
    /// indexing by a run-time axis) went either way; dropping them took 7% off the world
    /// boxes of 10,000 turned copies on this 2-core machine (867 -> 806 µs on one thread).
    fn reaches(&self, support: &[[f32; 2]; SAMPLES], u: Vec3) -> (f32, f32) {
        let u = u.to_array();
        let size = u.map(f32::abs);
        // The longest axis, the first of equals (a NaN row lands on z: its box stays the
        // turned mesh box, which `world_box` caps it by).
        let x_longest = size[0] >= size[1] && size[0] >= size[2];
        let k = usize::from(!x_longest) * (2 - usize::from(size[1] >= size[2]));
        let major = size[k];
        if major == 0.0 {
            return (0.0, 0.0);
        }
        // Where whichever of `u` and `-u` points to the positive side of axis k passes
        // through that face of the cube, in its grid (0 to CELLS along each side); the
        // table there holds the reach along it and against it.
        const NEXT: [usize; 3] = [1, 2, 0];
        let half = CELLS as f32 / 2.0;
        let scale = half.copysign(u[k]) / major;
        let x = (u[NEXT[k]] * scale + half).clamp(0.0, CELLS as f32);
        let y = (u[NEXT[NEXT[k]]] * scale + half).clamp(0.0, CELLS as f32);
        let [positive, negative] = interpolate(support, k, x, y);
        let (along, against) = if u[k] < 0.0 { (negative, positive) } else { (positive, negative) };
        // The samples and the weights are rounded: a few units in the last place of the
        // mesh's reach, widened here by far more.
        let pad = 1e-5 * self.reach * (size[0] + size[1] + size[2]);
        (major * along + pad, major * against + pad)
    }

    /// The world box of the covered mesh under `transform`, or an empty box for no mesh:
    /// the turned mesh box, cut down to the sampled reach where the mesh has a table.
    pub(crate) fn world_box(&self, transform: &Affine3A) -> Aabb {
        if self.bounds.is_empty() {
            return Aabb::EMPTY;
        }
        let turned = turned_box(&self.bounds, transform);
        let Some(support) = &self.support else { return turned };
        let rows = transform.matrix3.transpose();
        let t = Vec3::from(transform.translation);
        let (mut min, mut max) = (turned.min, turned.max);
        for k in 0..3 {
            let (along, against) = self.reaches(support, Vec3::from(rows.col(k)));
            let pad = 1e-6 * t[k].abs();
            max[k] = max[k].min(t[k] + along + pad);
            min[k] = min[k].max(t[k] - against - pad);
        }
        Aabb { min, max }
    }
}

/// The world box of `b` under `transform`, turned by its centre and half extent (Arvo's
/// method) and widened by a few units in the last place, so that rounding never cuts it.
fn turned_box(b: &Aabb, transform: &Affine3A) -> Aabb {
    let m = transform.matrix3;
    let abs = glam::Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
    let center = transform.transform_point3a(Vec3A::from(b.min + b.max) * 0.5);
    let half = abs * (Vec3A::from(b.max - b.min) * 0.5);
    let half = half + (center.abs() + half) * 1e-6;
    Aabb { min: (center - half).into(), max: (center + half).into() }
}

/// The sampled reaches at `(x, y)` of the grid on the positive face of `axis`, along its
/// direction there and against it: the samples at the corners of the cell's triangle
/// holding the point, weighted by its barycentric coordinates there. (Against, the corners
/// are the opposite face's, mirrored through the centre with the triangle holding the
/// mirrored point, whose weights are these.)
fn interpolate(support: &[[f32; 2]; SAMPLES], axis: usize, x: f32, y: f32) -> [f32; 2] {
    let (i, j) = ((x as usize).min(CELLS - 1), (y as usize).min(CELLS - 1));
    let (fx, fy) = (x - i as f32, y - j as f32);
    let first = (axis * SIDE + i) * SIDE + j;
    // The triangle is (i, j), (i + 1, j) or (i, j + 1), (i + 1, j + 1); chosen without a
    // branch, which the turns of a field of copies would mispredict half the time.
    let (low, high) = (fx.min(fy), fx.max(fy));
    let middle = first + if fx >= fy { SIDE } else { 1 };
    let (a, b, c) = (support[first], support[middle], support[first + SIDE + 1]);
    let weigh = |n: usize| (1.0 - high) * a[n] + (high - low) * b[n] + low * c[n];
    [weigh(0), weigh(1)]
}

/// Grid point `i` of the table: on the positive face of axis `k = i / SIDE²`, the point
/// whose other two coordinates (the next axes in turn) are the grid's.
fn direction(i: usize) -> Vec3 {
    let (k, cell) = (i / (SIDE * SIDE), i % (SIDE * SIDE));
    let coordinate = |n: usize| -1.0 + 2.0 * n as f32 / CELLS as f32;
    let mut g = Vec3::ZERO;
    g[k] = 1.0;
    g[(k + 1) % 3] = coordinate(cell / SIDE);
    g[(k + 2) % 3] = coordinate(cell % SIDE);
    g
}

/// How far the corners reach along `g` (`max g . x`).
fn reach(nodes: &[BvhNode], corners: &(impl Fn(u32) -> [Vec3; 3] + Sync), g: Vec3) -> f32 {
    let box_reach = |b: &Aabb| {
        let (center, half) = ((b.min + b.max) * 0.5, (b.max - b.min) * 0.5);
        center.dot(g) + half.dot(g.abs())
    };
    farthest(nodes, corners, box_reach, |c| c.dot(g))
}

/// A sphere is kept where its outline is at most this share of its box's (on average over
/// directions). A geosphere's is 0.52 and paid for itself on the H200 (the model series
/// 8-15% faster); the 1M knot's is 0.85 and did not (its fields 0.5-1.2% slower).
const SPHERE_MOST_OUTLINE: f32 = 0.75;

/// The sphere around the centre of `bounds` through the corner farthest from it, padded
/// for rounding, where its outline is at most [`SPHERE_MOST_OUTLINE`] of the box's (on
/// average over directions: `pi r^2` against a quarter of the box's surface area); radius
/// 0 where it is not.
fn bounding_sphere(
    nodes: &[BvhNode],
    corners: &(impl Fn(u32) -> [Vec3; 3] + Sync),
    bounds: Aabb,
) -> [f32; 4] {
    let center = (bounds.min + bounds.max) * 0.5;
    let box_far = |b: &Aabb| (b.min - center).abs().max((b.max - center).abs()).length_squared();
    let radius = farthest(nodes, corners, box_far, |c| (c - center).length_squared()).sqrt();
    let radius = padded(radius, center);
    if tight_enough(radius, &bounds) {
        [center.x, center.y, center.z, radius]
    } else {
        [0.0; 4]
    }
}

/// The radius through the farthest corner from `center`, padded for rounding.
fn padded(radius: f32, center: Vec3) -> f32 {
    radius * (1.0 + 1e-5) + 1e-6 * center.abs().max_element()
}

/// Whether `mesh` gets a bounding sphere ([`bounding_sphere`], from its corners without a
/// tree): known before its tree is built, for the kernel a scene of its copies will run.
pub(crate) fn is_round(mesh: &Mesh) -> bool {
    let bounds = mesh.bounds();
    if mesh.triangles.is_empty() || bounds.is_empty() {
        return false;
    }
    let center = (bounds.min + bounds.max) * 0.5;
    let far = (0..mesh.triangle_count())
        .flat_map(|i| mesh.corners(i))
        .fold(0.0f32, |far, c| far.max((c - center).length_squared()));
    tight_enough(padded(far.sqrt(), center), &bounds)
}

/// Whether a sphere of `radius` has an outline at most [`SPHERE_MOST_OUTLINE`] of the box
/// `b`'s, on average over directions (`pi r^2` against a quarter of the box's area).
fn tight_enough(radius: f32, b: &Aabb) -> bool {
    let e = b.extent();
    let box_outline = 0.5 * (e.x * e.y + e.y * e.z + e.z * e.x);
    std::f32::consts::PI * radius * radius <= SPHERE_MOST_OUTLINE * box_outline
}

/// A bound from above on the most `transform` stretches a length (its linear part's
/// largest singular value, the square root of the largest eigenvalue of `AᵀA`): by
/// Gershgorin's circles, each row of `AᵀA` (the columns' dot products) bounds it by its
/// diagonal plus the rest of the row. Exact for a turn after any scale along the axes
/// (`A = R S`, where `AᵀA = S²`), what scenes and fields of copies make; looser only for a
/// shear, whose sphere may then give way to the box. A few products a copy, where the
/// closed form's cosines in double precision made rebuilds of 10,000 copies 13% slower on
/// this 2-core machine.
fn largest_stretch(transform: &Affine3A) -> f32 {
    let m = transform.matrix3;
    let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
    let (xy, yz, zx) = (x.dot(y).abs(), y.dot(z).abs(), z.dot(x).abs());
    let largest = (x.dot(x) + xy + zx).max(y.dot(y) + xy + yz).max(z.dot(z) + yz + zx);
    // Rounded up by far more than the products' rounding.
    largest.sqrt() * (1.0 + 1e-5)
}

/// The largest `value` of a corner (`max value(x)`), by branch and bound down the tree: the
/// boxes visited best bound first (`bound(b)`: at least the value of any point of box `b`),
/// and those that cannot beat the best corner found skipped.
fn farthest(
    nodes: &[BvhNode],
    corners: &(impl Fn(u32) -> [Vec3; 3] + Sync),
    bound: impl Fn(&Aabb) -> f32,
    value: impl Fn(Vec3) -> f32,
) -> f32 {
    let mut best = f32::NEG_INFINITY;
    let mut stack: Vec<BvhChild> =
        nodes[0].children().into_iter().filter(|c| !c.is_empty()).collect();
    while let Some(child) = stack.pop() {
        if bound(&child.bounds) <= best {
            continue;
        }
        if child.is_leaf() {
            for slot in child.index..child.index + child.count {
                for c in corners(slot) {
                    best = best.max(value(c));
                }
            }
            continue;
        }
        let [a, b] = nodes[child.index as usize].children();
        let (near, far) = if bound(&a.bounds) >= bound(&b.bounds) { (a, b) } else { (b, a) };
        // The farther reaching one is popped first.
        stack.extend([far, near].into_iter().filter(|c| !c.is_empty()));
    }
    best
}
