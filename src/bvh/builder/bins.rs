//! The SAH bins of the builder: a node's primitives binned by centroid into slabs per
//! axis (`BinGrid` maps a centroid to its slab, `BinSet` holds the slabs' boxes and
//! counts), and the sweep over the slab planes that finds the cheapest split.

use glam::{UVec3, Vec3A};

use super::prim::{Bounds, Prim, MAX_BINS};

#[derive(Clone, Copy)]
pub(super) struct Bin {
    pub(super) bounds: Bounds,
    count: u32,
}

impl Bin {
    const EMPTY: Bin = Bin { bounds: Bounds::EMPTY, count: 0 };
}

/// The bins of one node, per axis. Lives on the heap (see `boxed`) and is reused down a
/// subtree; only the first `n` bins of each axis are in use.
pub(super) struct BinSet {
    pub(super) bins: [[Bin; MAX_BINS]; 3],
    /// A second set for the odd primitives of big ranges (see `add`).
    spare: [[Bin; MAX_BINS]; 3],
}

impl BinSet {
    fn new() -> Self {
        Self { bins: [[Bin::EMPTY; MAX_BINS]; 3], spare: [[Bin::EMPTY; MAX_BINS]; 3] }
    }

    /// On the heap: a BinSet is about 7 KB, and fork-join frames that each hold some nest
    /// deeply when rayon's workers steal work while they wait (a 10M-triangle build needed
    /// more than 256 KB per worker with two threads before the sets moved here, 64 KB after).
    pub(super) fn boxed() -> Box<Self> {
        Box::new(Self::new())
    }

    pub(super) fn copy_from(&mut self, o: &BinSet) {
        self.bins = o.bins;
        self.spare = o.spare;
    }

    pub(super) fn clear(&mut self, n: usize) {
        for axis in &mut self.bins {
            axis[..n].fill(Bin::EMPTY);
        }
    }

    /// Bins `prims` (on top of what the bins hold). Neighbouring triangles of a mesh tend to
    /// land in the same bins, chaining each update on the previous one; big ranges therefore
    /// alternate between two sets of bins, merged at the end.
    pub(super) fn add(&mut self, prims: &[Prim], grid: &BinGrid) {
        let BinSet { bins, spare } = self;
        if prims.len() < 256 {
            prims.iter().for_each(|p| add_to(bins, p, grid));
            return;
        }
        for axis in spare.iter_mut() {
            axis[..grid.count].fill(Bin::EMPTY);
        }
        let pairs = prims.chunks_exact(2);
        pairs.remainder().iter().for_each(|p| add_to(bins, p, grid));
        for pair in pairs {
            add_to(bins, &pair[0], grid);
            add_to(spare, &pair[1], grid);
        }
        merge_bins(bins, spare, grid.count);
    }

    /// The cheapest SAH split plane over all axes as (axis, plane): plane `i` has bins `..i`
    /// on its left. `None` when no plane has primitives on both sides.
    pub(super) fn best_plane(
        &self,
        grid: &BinGrid,
        node_bounds: &Bounds,
    ) -> Option<(usize, usize)> {
        // Areas are scaled by the node's size so that they stay finite for huge coordinates.
        let extent = (node_bounds.max - node_bounds.min).max_element();
        let scale = if extent > 0.0 && (1.0 / extent).is_finite() { 1.0 / extent } else { 1.0 };
        let n = grid.count;
        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, plane)
        for axis in 0..3 {
            if grid.scale[axis] == 0.0 {
                continue; // the centroids do not spread along this axis
            }
            let bins = &self.bins[axis][..n];
            // Left to right: area * count of everything left of each plane.
            let mut left_cost = [0.0f32; MAX_BINS];
            let mut left_count = [0u32; MAX_BINS];
            let (mut acc, mut count) = (Bounds::EMPTY, 0);
            for i in 1..n {
                acc = acc.union(bins[i - 1].bounds);
                count += bins[i - 1].count;
                left_count[i] = count;
                left_cost[i] = acc.half_area(scale) * count as f32;
            }
            // Right to left, completing each plane's cost.
            let (mut acc, mut count) = (Bounds::EMPTY, 0);
            for i in (1..n).rev() {
                acc = acc.union(bins[i].bounds);
                count += bins[i].count;
                if left_count[i] == 0 || count == 0 {
                    continue;
                }
                let cost = left_cost[i] + acc.half_area(scale) * count as f32;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, i));
                }
            }
        }
        best.map(|(_, axis, plane)| (axis, plane))
    }

    pub(super) fn merge(&mut self, o: &BinSet, n: usize) {
        merge_bins(&mut self.bins, &o.bins, n);
    }
}

#[inline(always)]
fn add_to(bins: &mut [[Bin; MAX_BINS]; 3], p: &Prim, grid: &BinGrid) {
    let b = grid.bin_of(p.centroid());
    let (min, max) = (p.bounds_min(), p.bounds_max());
    for axis in 0..3 {
        let bin = &mut bins[axis][b[axis] as usize];
        bin.count += 1;
        bin.bounds.grow(min, max);
    }
}

fn merge_bins(into: &mut [[Bin; MAX_BINS]; 3], from: &[[Bin; MAX_BINS]; 3], n: usize) {
    for axis in 0..3 {
        for i in 0..n {
            let (a, b) = (&mut into[axis][i], &from[axis][i]);
            a.count += b.count;
            a.bounds = a.bounds.union(b.bounds);
        }
    }
}

/// Maps a centroid to its bin on each axis: `bin = (c - origin) * scale`, clamped.
/// Axes along which the centroids do not spread get `scale = 0` (everything in bin 0).
pub(super) struct BinGrid {
    origin: Vec3A,
    scale: Vec3A,
    count: usize,
}

impl BinGrid {
    /// `None` when the centroids coincide (or their spread is not representable).
    pub(super) fn new(centroids: &Bounds, count: usize) -> Option<BinGrid> {
        let extent = centroids.max - centroids.min;
        let mut scale = Vec3A::ZERO;
        for axis in 0..3 {
            let s = count as f32 / extent[axis];
            if extent[axis] > 0.0 && s.is_finite() {
                scale[axis] = s;
            }
        }
        (scale != Vec3A::ZERO).then_some(BinGrid { origin: centroids.min, scale, count })
    }

    /// The bins of centroid `c` on all three axes (for binning).
    ///
    /// Clamped in floats first (a NaN offset goes to bin 0, as `as` would send it), so that
    /// the conversion needs no saturation: one vector instruction on x86-64 instead of three
    /// scalar conversions with their range checks, a quarter of the binning's instructions.
    #[inline(always)]
    fn bin_of(&self, c: Vec3A) -> UVec3 {
        // `max` returns its argument for a NaN lane, so NaN becomes 0.
        let offset = ((c - self.origin) * self.scale)
            .max(Vec3A::ZERO)
            .min(Vec3A::splat((self.count - 1) as f32));
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{__m128, _mm_cvttps_epi32};
            // SAFETY: SSE2 is part of x86-64; every lane is in 0..count, so truncation is exact.
            let lanes: [i32; 4] =
                unsafe { std::mem::transmute(_mm_cvttps_epi32(__m128::from(offset))) };
            UVec3::new(lanes[0] as u32, lanes[1] as u32, lanes[2] as u32)
        }
        #[cfg(not(target_arch = "x86_64"))]
        offset.as_uvec3()
    }

    /// The partition's test "centroid bin on `axis` below `plane`" for `0 < plane < count`.
    pub(super) fn left_of(&self, axis: usize, plane: usize) -> LeftOf {
        LeftOf { axis, origin: self.origin[axis], scale: self.scale[axis], plane: plane as f32 }
    }
}

/// Whether a primitive's centroid bin on one axis is below a plane ([`BinGrid::left_of`]).
/// It takes the same float operations as one lane of `bin_of(p.centroid())`, so both always
/// agree, but compares before converting to a bin number (the slow part): a bin is below a
/// whole number exactly when the scaled offset is; a NaN offset is bin 0 there, left here.
#[derive(Clone, Copy)]
pub(super) struct LeftOf {
    axis: usize,
    origin: f32,
    scale: f32,
    plane: f32,
}

impl LeftOf {
    /// Moves the primitives that pass `left_of` to the front and returns how many there are.
    ///
    /// Branch-free (Lomuto with an unconditional swap): a primitive's side is a coin flip to the
    /// branch predictor, and a mispredict costs more than the swap.
    pub(super) fn partition(&self, prims: &mut [Prim]) -> usize {
        let mut i = 0; // prims[..i] go left, prims[i..k] go right
        for k in 0..prims.len() {
            let goes_left = self.test(&prims[k]);
            prims.swap(i, k);
            i += goes_left as usize;
        }
        i
    }

    #[inline(always)]
    pub(super) fn test(&self, p: &Prim) -> bool {
        let c = p.min[self.axis] * 0.5 + p.max[self.axis] * 0.5;
        // Negated on purpose: a NaN centroid compares false and so goes left, in the sequential
        // and the parallel partition alike.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let left = !((c - self.origin) * self.scale >= self.plane);
        left
    }
}
