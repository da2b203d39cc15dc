//! The build's unit of work: one primitive's box and index ([`Prim`]), boxes in SIMD
//! registers for the hot loops ([`Bounds`]), and the most SAH bins per axis.

use glam::{Vec3, Vec3A};

use crate::bvh::BvhChild;
use crate::geometry::Aabb;

/// Most SAH bins per axis (`BuildOptions::bins` is clamped to it).
pub(super) const MAX_BINS: usize = 32;

/// One primitive's box and original index: the unit that the build sorts in place
/// (32 bytes, so a partition swap moves half a cache line).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct Prim {
    pub(super) min: Vec3,
    pub(super) index: u32,
    pub(super) max: Vec3,
    _pad: u32,
}

impl Prim {
    pub(super) fn new(min: Vec3, max: Vec3, index: u32) -> Self {
        Self { min, index, max, _pad: 0 }
    }

    /// A box to build over, an empty one as a point at the origin, whose leaf is named
    /// `name` in a named-leaf build ([`crate::bvh::Bvh::build_named_leaves_into`]).
    pub(crate) fn named(bounds: Aabb, name: u32) -> Self {
        if bounds.is_empty() {
            Self::new(Vec3::ZERO, Vec3::ZERO, name)
        } else {
            Self::new(bounds.min, bounds.max, name)
        }
    }

    /// The box built over.
    pub(crate) fn aabb(&self) -> Aabb {
        Aabb { min: self.min, max: self.max }
    }

    /// The box of triangle `index`, whose corners are `t`.
    #[inline(always)]
    pub(super) fn of_triangle(t: [Vec3; 3], index: u32) -> Self {
        Self::new(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]), index)
    }

    #[inline(always)]
    pub(super) fn bounds_min(&self) -> Vec3A {
        self.min.into()
    }

    #[inline(always)]
    pub(super) fn bounds_max(&self) -> Vec3A {
        self.max.into()
    }

    /// A total order between primitives that tie on a centroid: by triangle, then (for
    /// pieces of one cut triangle) by box, so that builds do not depend on the order a
    /// partition left them in. Equal only for identical primitives, which may go either way.
    pub(super) fn tie_break(&self, other: &Prim) -> std::cmp::Ordering {
        let corners = |p: &Prim| [p.min.x, p.min.y, p.min.z, p.max.x, p.max.y, p.max.z];
        let (a, b) = (corners(self), corners(other));
        self.index.cmp(&other.index).then_with(|| {
            a.iter()
                .zip(&b)
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    }

    /// The box in SIMD form.
    #[inline(always)]
    pub(super) fn bounds(&self) -> Bounds {
        Bounds { min: self.bounds_min(), max: self.bounds_max() }
    }

    /// Box centre; halves first so that huge coordinates cannot overflow.
    #[inline(always)]
    pub(super) fn centroid(&self) -> Vec3A {
        self.bounds_min() * 0.5 + self.bounds_max() * 0.5
    }
}

/// A box in SIMD registers, for the hot loops (`Aabb` is the public, 12-byte-vector one).
#[derive(Clone, Copy, Debug)]
pub(super) struct Bounds {
    pub(super) min: Vec3A,
    pub(super) max: Vec3A,
}

impl Bounds {
    pub(super) const EMPTY: Bounds =
        Bounds { min: Vec3A::splat(f32::INFINITY), max: Vec3A::splat(f32::NEG_INFINITY) };

    #[inline(always)]
    pub(super) fn grow(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    #[inline(always)]
    pub(super) fn union(self, o: Bounds) -> Bounds {
        Bounds { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// Half the surface area of the box scaled by `scale`, plus a tiny floor on each edge
    /// so that boxes flat in two axes (collinear primitives) still weigh by length.
    #[inline(always)]
    pub(super) fn half_area(&self, scale: f32) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO) * scale + Vec3A::splat(1e-6);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    pub(super) fn to_aabb(self) -> Aabb {
        Aabb { min: self.min.into(), max: self.max.into() }
    }
}

/// A child as its parent will record it (`BvhChild` with the box still in SIMD form).
#[derive(Clone, Copy)]
pub(super) struct ChildRef {
    pub(super) bounds: Bounds,
    pub(super) index: u32,
    pub(super) count: u32,
}

impl ChildRef {
    pub(super) fn to_child(self) -> BvhChild {
        BvhChild { bounds: self.bounds.to_aabb(), index: self.index, count: self.count }
    }
}
