//! Small nodes split by the exact SAH: every plane between neighbouring centroids on each
//! axis, instead of bins. Most of a tree's nodes are this small (at leaves of 2, about 80%
//! of the inner nodes hold at most 8 triangles), and for them binning pays for clearing and
//! sweeping bins that hold a primitive or none; sorting a handful of centroids is cheaper
//! and finds the best plane rather than the best bin boundary.

use super::prim::{Bounds, Prim};
use super::{NodeInfo, Split};

/// Nodes of at most this many primitives take the exact split.
pub(super) const SMALL_NODE: usize = 8;

/// The exact-SAH split of `prims` (2 ..= `SMALL_NODE` of them), which it reorders so that
/// the left side comes first. Centroids tie by original index, so the split does not depend
/// on the order the primitives arrive in; NaN centroids sort last.
pub(super) fn exact_split(prims: &mut [Prim], node_bounds: &Bounds) -> Split {
    let n = prims.len();
    debug_assert!((2..=SMALL_NODE).contains(&n));
    if n == 2 {
        return pair_split(prims);
    }
    swept_split(prims, node_bounds)
}

/// The exact split of two primitives: one a side whichever axis orders them, so every axis
/// costs the same and the sweep would keep x. Half the nodes of a top level (leaves of one
/// instance) are pairs; this skips their three sorts and sweeps.
fn pair_split(prims: &mut [Prim]) -> Split {
    let mut order = [0u8; 2];
    sort_by_centroid(prims, 0, &mut order);
    if order[0] == 1 {
        prims.swap(0, 1);
    }
    Split { mid: 1, left: NodeInfo::of(&prims[..1]), right: NodeInfo::of(&prims[1..]) }
}

/// The exact split by sweeping every centroid plane of every axis.
fn swept_split(prims: &mut [Prim], node_bounds: &Bounds) -> Split {
    let n = prims.len();
    // Areas scaled as in the binned sweep, so that huge coordinates stay finite.
    let extent = (node_bounds.max - node_bounds.min).max_element();
    let scale = if extent > 0.0 && (1.0 / extent).is_finite() { 1.0 / extent } else { 1.0 };

    let mut best = (f32::INFINITY, 0usize, 1usize); // (cost, axis, left count)
    let mut orders = [[0u8; SMALL_NODE]; 3];
    for (axis, order) in orders.iter_mut().enumerate() {
        sort_by_centroid(prims, axis, &mut order[..n]);
        let order = &order[..n];
        // Right to left: the box of everything from each position on.
        let mut right_area = [0.0f32; SMALL_NODE];
        let mut acc = Bounds::EMPTY;
        for i in (1..n).rev() {
            let p = &prims[order[i] as usize];
            acc.grow(p.bounds_min(), p.bounds_max());
            right_area[i] = acc.half_area(scale) * (n - i) as f32;
        }
        let mut acc = Bounds::EMPTY;
        for (i, &right) in right_area.iter().enumerate().take(n).skip(1) {
            let p = &prims[order[i - 1] as usize];
            acc.grow(p.bounds_min(), p.bounds_max());
            let cost = acc.half_area(scale) * i as f32 + right;
            // `<` keeps the first axis and plane among equals; a NaN cost never wins, and
            // the initial plane (axis 0, one on the left) stands if every cost is NaN.
            if cost < best.0 {
                best = (cost, axis, i);
            }
        }
    }

    let (_, axis, mid) = best;
    let mut sorted = [prims[0]; SMALL_NODE];
    for (slot, &i) in sorted.iter_mut().zip(&orders[axis][..n]) {
        *slot = prims[i as usize];
    }
    prims.copy_from_slice(&sorted[..n]);
    Split { mid, left: NodeInfo::of(&prims[..mid]), right: NodeInfo::of(&prims[mid..]) }
}

/// Writes into `order` the positions of `prims` sorted by centroid on `axis`, ties by
/// original index (then box). The keys (centroid bits, then index) differ unless two
/// pieces of one cut triangle share a centroid: then each primitive's place is its rank,
/// the number of primitives before it in the full order (a total order, so the ranks are
/// a permutation even with NaNs).
fn sort_by_centroid(prims: &[Prim], axis: usize, order: &mut [u8]) {
    let n = prims.len();
    let mut keys = [0u64; SMALL_NODE];
    for (key, p) in keys.iter_mut().zip(prims) {
        let c = p.min[axis] * 0.5 + p.max[axis] * 0.5;
        *key = (u64::from(sortable_bits(c)) << 32) | u64::from(p.index);
    }
    // Insertion sort of (key, position) pairs: a handful of compares for 8 or fewer
    // (the rank loop below costs n² of them and took 40% of a top level's build).
    let mut sorted = [(0u64, 0u8); SMALL_NODE];
    for (i, &key) in keys[..n].iter().enumerate() {
        let item = (key, i as u8);
        let mut j = i;
        while j > 0 && sorted[j - 1].0 > item.0 {
            sorted[j] = sorted[j - 1];
            j -= 1;
        }
        sorted[j] = item;
    }
    if sorted[..n].windows(2).all(|w| w[0].0 < w[1].0) {
        for (slot, &(_, i)) in order.iter_mut().zip(&sorted[..n]) {
            *slot = i;
        }
        return;
    }
    let keys = &keys[..n];
    for (i, &key) in keys.iter().enumerate() {
        // Equal keys are pieces of one cut triangle (same index) with the same centroid
        // here: their boxes order them, and identical pieces their positions.
        let before = |j: usize| {
            let other = keys[j];
            other < key || (other == key && prims[j].tie_break(&prims[i]).then(j.cmp(&i)).is_lt())
        };
        let rank = (0..keys.len()).filter(|&j| before(j)).count();
        order[rank] = i as u8;
    }
}

/// The bits of `x` as an unsigned number that orders like the float (`f32::total_cmp`).
fn sortable_bits(x: f32) -> u32 {
    let bits = x.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 1 << 31
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn prim(x: f32, index: u32) -> Prim {
        Prim::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0), index)
    }

    #[test]
    fn a_pair_splits_as_the_sweep_splits_it() {
        // Pairs apart, overlapping, with equal centroids on some axes, NaN and infinite.
        let corners = [0.0, 1.0, -3.0, 0.5, f32::INFINITY, f32::NAN, 1e30, -0.0];
        let mut pairs = 0;
        for (i, &a) in corners.iter().enumerate() {
            for &b in &corners[i..] {
                for (ia, ib) in [(0u32, 1u32), (1, 0), (7, 7)] {
                    let p = Prim::new(Vec3::new(a, b, 0.0), Vec3::new(a + 1.0, b + 2.0, 1.0), ia);
                    let q = Prim::new(Vec3::new(b, a, 0.0), Vec3::new(b + 1.0, a, 3.0), ib);
                    let mut fast = vec![p, q];
                    let mut swept = fast.clone();
                    let bounds = NodeInfo::of(&fast).bounds;
                    let f = pair_split(&mut fast);
                    let s = swept_split(&mut swept, &bounds);
                    assert_eq!(f.mid, s.mid);
                    let key = |v: &[Prim]| {
                        v.iter()
                            .map(|p| (p.index, p.min[0].to_bits(), p.min[1].to_bits()))
                            .collect::<Vec<_>>()
                    };
                    assert_eq!(key(&fast), key(&swept), "{a} {b} {ia} {ib}");
                    pairs += 1;
                }
            }
        }
        assert_eq!(pairs, 108);
    }

    #[test]
    fn sortable_bits_order_like_total_cmp() {
        let xs = [f32::NEG_INFINITY, -1e30, -1.0, -0.0, 0.0, 1e-40, 1.0, f32::INFINITY, f32::NAN];
        for a in xs {
            for b in xs {
                assert_eq!(sortable_bits(a).cmp(&sortable_bits(b)), a.total_cmp(&b), "{a} {b}");
            }
        }
    }

    #[test]
    fn splits_two_clusters_between_them_whatever_the_input_order() {
        // Three boxes near x = 0 and three near x = 100: the only sensible plane is between.
        let xs = [100.0, 0.5, 101.0, 0.0, 100.5, 1.0];
        let mut prims: Vec<Prim> = xs.iter().enumerate().map(|(i, &x)| prim(x, i as u32)).collect();
        let bounds = NodeInfo::of(&prims).bounds;
        let split = exact_split(&mut prims, &bounds);
        assert_eq!(split.mid, 3);
        let mut left: Vec<u32> = prims[..3].iter().map(|p| p.index).collect();
        left.sort_unstable();
        assert_eq!(left, [1, 3, 5]);
        assert_eq!(split.left.bounds.max.x, 2.0);
        assert_eq!(split.right.bounds.min.x, 100.0);
    }

    #[test]
    fn pieces_of_one_triangle_with_one_centroid_are_each_kept() {
        // A cut wall: pieces of triangle 7, flat at x = 3 (one centroid on x), and two
        // identical pieces; the order must stay a permutation (equal sort keys once lost
        // pieces and doubled others).
        let piece = |y: f32| Prim::new(Vec3::new(3.0, y, 0.0), Vec3::new(3.0, y + 1.0, 1.0), 7);
        let mut prims: Vec<Prim> = [2.0, 0.0, 4.0, 1.0, 3.0, 1.0].into_iter().map(piece).collect();
        let bounds = NodeInfo::of(&prims).bounds;
        exact_split(&mut prims, &bounds);
        let mut ys: Vec<f32> = prims.iter().map(|p| p.min.y).collect();
        ys.sort_by(f32::total_cmp);
        assert_eq!(ys, [0.0, 1.0, 1.0, 2.0, 3.0, 4.0]);
    }

    #[test]
    fn coincident_and_nan_centroids_still_split_into_two_non_empty_sides() {
        let mut same: Vec<Prim> = (0..SMALL_NODE as u32).map(|i| prim(5.0, i)).collect();
        let bounds = NodeInfo::of(&same).bounds;
        let split = exact_split(&mut same, &bounds);
        assert!(split.mid > 0 && split.mid < SMALL_NODE);
        let mut indices: Vec<u32> = same.iter().map(|p| p.index).collect();
        indices.sort_unstable();
        assert_eq!(indices, (0..SMALL_NODE as u32).collect::<Vec<_>>(), "a permutation");

        let mut with_nan = vec![prim(f32::NAN, 0), prim(1.0, 1), prim(2.0, 2)];
        let bounds = NodeInfo::of(&with_nan).bounds;
        let split = exact_split(&mut with_nan, &bounds);
        assert!(split.mid > 0 && split.mid < 3);
        let mut indices: Vec<u32> = with_nan.iter().map(|p| p.index).collect();
        indices.sort_unstable();
        assert_eq!(indices, [0, 1, 2]);
    }
}
