//! Pre-splitting of large triangles (Karras and Aila, "Fast Parallel Construction of
//! High-Quality Bounding Volume Hierarchies", HPG 2013, section 4).
//!
//! A long diagonal triangle (an architectural wall, a floor strip) has a box mostly of empty
//! space, and every ray through that space visits its leaf. Before the build, such a
//! triangle's box is cut into several smaller boxes, each bounding the part of the triangle
//! inside it; the build then sorts the pieces like any other primitives, and a triangle
//! whose pieces land in several leaves is referenced from each of them (`prim_indices`
//! names it more than once). The traversal is unchanged: a ray tests the same triangle in
//! whichever of its leaves it reaches first.
//!
//! Only triangles whose boxes are far bigger than the mesh's typical one are cut
//! (`CANDIDATE_FACTOR` times the median box): in a scan of even triangles (the dragon) no
//! piece would be smaller than the leaves around it, and the extra references only cost
//! (on the H100 a 30% budget spread over the dragon traced it 7% slower). Among those, the
//! budget of extra references (a share of the triangle count, and at most
//! `CUTS_PER_CANDIDATE` a candidate) goes in proportion to how much a triangle's box
//! surface exceeds the surface of the boxes that would bound it if cut into infinitely many
//! pieces (its area projected on the three axes). Cuts fall on the planes of a power-of-two
//! grid over the scene, the coarsest one crossing the piece's longest axis, so pieces of
//! neighbouring triangles share planes that the SAH can find.

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use super::prim::{Bounds, Prim};

/// Most cuts given to one triangle (a cap on what a single huge triangle can take of the budget).
const MAX_CUTS: u32 = 64;

/// A triangle is cut only if its box's half surface is more than this many times the
/// median over the mesh's triangles (Crytek Sponza: 9% of its triangles; the dragon: one).
const CANDIDATE_FACTOR: f32 = 8.0;

/// The budget is at most this many cuts per candidate: Lucy (100K triangles, 192 candidates)
/// had taken 64 pieces each, 12% more slots for no time saved on the H100; Crytek Sponza
/// (22,320 candidates, 71K cuts) is within it.
const CUTS_PER_CANDIDATE: u64 = 4;

/// Finest level of the grid whose planes the cuts follow; below it a piece is halved.
const MAX_GRID_LEVEL: i32 = 24;

/// A big mesh (one the builder would otherwise plan on a sample, for speed) is cut only if
/// at least this share of its triangles are candidates: architecture (Crytek Sponza 9.4%),
/// not scans (the dragon: one triangle in 200K; Lucy 0.19%) or generated meshes (the knots:
/// none), whose builds keep the fast path.
const BIG_MESH_MIN_CANDIDATES: f64 = 0.01;

/// Every this many triangles, one estimates a big mesh's share of candidates.
const ESTIMATE_STRIDE: usize = 32;

/// Whether cutting pays in a big mesh of `count` triangles: estimated on every
/// `ESTIMATE_STRIDE`-th triangle (the median box and the candidates among them), so that a
/// mesh with nothing to cut spends a few milliseconds on the question.
pub(super) fn worth_cutting(count: usize, corners: &(impl Fn(usize) -> [Vec3; 3] + Sync)) -> bool {
    let sample: Vec<(f32, f32)> = (0..count)
        .into_par_iter()
        .step_by(ESTIMATE_STRIDE)
        .map(|i| {
            let t = corners(i);
            (half_area(&Prim::of_triangle(t, 0).bounds()), weight(t))
        })
        .collect();
    let areas: Vec<f32> = sample.iter().map(|&(a, _)| a).collect();
    let threshold = CANDIDATE_FACTOR * median(&areas);
    let candidates = sample.iter().filter(|&&(a, w)| a > threshold && w > 0.0).count();
    !sample.is_empty() && candidates as f64 >= BIG_MESH_MIN_CANDIDATES * sample.len() as f64
}

/// The primitives of `count` triangles, `corners(i)` giving triangle i, with about
/// `budget * count` extra pieces cut from the triangles whose boxes are the emptiest.
/// Without a budget, one primitive per triangle in index order.
pub(super) fn split_prims(
    count: usize,
    corners: &(impl Fn(usize) -> [Vec3; 3] + Sync),
    budget: f32,
) -> Vec<Prim> {
    let whole: Vec<Prim> =
        (0..count).into_par_iter().map(|i| Prim::of_triangle(corners(i), i as u32)).collect();
    let extra = (budget.max(0.0) * count as f32) as u64;
    if extra == 0 {
        return whole;
    }
    let areas: Vec<f32> = whole.par_iter().map(|p| half_area(&p.bounds())).collect();
    let threshold = CANDIDATE_FACTOR * median(&areas);
    let weights: Vec<f32> = (0..count)
        .into_par_iter()
        .map(|i| if areas[i] > threshold { weight(corners(i)) } else { 0.0 })
        .collect();
    drop(areas);
    // A few big triangles among many small ones need a few pieces each, not the whole budget.
    let candidates = weights.par_iter().filter(|&&w| w > 0.0).count() as u64;
    let extra = extra.min(CUTS_PER_CANDIDATE * candidates);
    let scale = cut_scale(&weights, extra);
    // The grid spans the triangles to cut (all finite).
    let scene = whole
        .par_iter()
        .zip(&weights)
        .filter(|(_, &w)| w > 0.0)
        .map(|(p, _)| p.bounds())
        .reduce(|| Bounds::EMPTY, Bounds::union);
    let grid = Grid { origin: scene.min, extent: scene.max - scene.min };
    whole
        .par_iter()
        .zip(&weights)
        .flat_map_iter(|(&p, &w)| {
            let cuts = cuts_for(w, scale);
            let mut out = Vec::with_capacity(cuts as usize + 1);
            if cuts == 0 {
                out.push(p);
            } else {
                let tri = corners(p.index as usize).map(Vec3A::from);
                cut(&tri, p.bounds(), cuts, &grid, p.index, &mut out);
            }
            out
        })
        .collect()
}

/// Half the surface of a box, exactly (the build's `Bounds::half_area` keeps a floor on
/// each edge that would swamp the boxes of a small model's triangles).
fn half_area(b: &Bounds) -> f32 {
    let e = (b.max - b.min).max(Vec3A::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// The median of `values` (NaN sorts last; 0 for none).
fn median(values: &[f32]) -> f32 {
    let mut v = values.to_vec();
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}

/// How much a triangle wants cutting: its box's half surface beyond the half surface that
/// infinitely many pieces would have (area times the normal's L1 norm). Zero for degenerate
/// and non-finite triangles, which both tracers skip anyway.
fn weight(t: [Vec3; 3]) -> f32 {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let n = e1.cross(e2);
    if !n.is_finite() || n.length() <= 1e-7 * e1.length() * e2.length() {
        return 0.0;
    }
    let b = Bounds { min: t[0].min(t[1]).min(t[2]).into(), max: t[0].max(t[1]).max(t[2]).into() };
    let excess = half_area(&b) - 0.5 * (n.x.abs() + n.y.abs() + n.z.abs());
    if excess.is_finite() && excess > 0.0 {
        excess
    } else {
        0.0
    }
}

/// Cuts for a triangle of `weight` at `scale`.
fn cuts_for(weight: f32, scale: f32) -> u32 {
    ((weight * scale) as u32).min(MAX_CUTS)
}

/// The largest scale whose cuts stay within `extra` (bisection: the sum grows with it).
fn cut_scale(weights: &[f32], extra: u64) -> f32 {
    let total = |scale: f32| weights.par_iter().map(|&w| cuts_for(w, scale) as u64).sum::<u64>();
    let max = weights.par_iter().copied().reduce(|| 0.0, f32::max);
    if max <= 0.0 {
        return 0.0;
    }
    // At `hi` the heaviest triangle alone takes the whole budget (or its cap).
    let (mut lo, mut hi) = (0.0f32, (extra as f32 + 1.0) / max);
    if total(hi) <= extra {
        return hi;
    }
    for _ in 0..32 {
        let mid = 0.5 * (lo + hi);
        if total(mid) <= extra {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The power-of-two grid over the scene's box that the cuts follow.
struct Grid {
    origin: Vec3A,
    extent: Vec3A,
}

impl Grid {
    /// The plane on `axis` that cuts (lo, hi): the coarsest grid plane strictly inside, or
    /// the middle where none is (a piece finer than the grid, or a flat scene axis).
    fn plane(&self, axis: usize, lo: f32, hi: f32) -> f32 {
        let (origin, extent) = (self.origin[axis], self.extent[axis]);
        if extent > 0.0 {
            for level in 1..=MAX_GRID_LEVEL {
                let cell = extent * (-level as f32).exp2();
                let plane = origin + ((lo - origin) / cell).floor() * cell + cell;
                if plane > lo && plane < hi {
                    return plane;
                }
            }
        }
        0.5 * (lo + hi)
    }
}

/// Cut the part of triangle `tri` inside `bounds` into `cuts + 1` pieces, pushing each as
/// a primitive of triangle `index`.
fn cut(tri: &[Vec3A; 3], bounds: Bounds, cuts: u32, grid: &Grid, index: u32, out: &mut Vec<Prim>) {
    let extent = bounds.max - bounds.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let plane = grid.plane(axis, bounds.min[axis], bounds.max[axis]);
    let (below, above) =
        (clipped(tri, axis, plane, false, bounds), clipped(tri, axis, plane, true, bounds));
    let (Some(below), Some(above)) = (below, above) else {
        // The triangle's part here lies on one side (it touches the box only at the plane):
        // the piece stays whole.
        out.push(Prim::new(bounds.min.into(), bounds.max.into(), index));
        return;
    };
    // The remaining cuts go to each side in proportion to its longest edge.
    let (lb, la) = ((below.max - below.min).max_element(), (above.max - above.min).max_element());
    let rest = cuts - 1;
    let to_below =
        if lb + la > 0.0 { ((rest as f32) * lb / (lb + la)).round() as u32 } else { rest / 2 };
    let to_below = to_below.min(rest);
    for (side, n) in [(below, to_below), (above, rest - to_below)] {
        if n == 0 {
            out.push(Prim::new(side.min.into(), side.max.into(), index));
        } else {
            cut(tri, side, n, grid, index, out);
        }
    }
}

/// The box of the part of `tri` on one side of the plane `axis = plane` (`above`: the side
/// of greater coordinates), within `bounds`; None where no part of it is there.
///
/// The corners of the clipped polygon on the plane are interpolated along the triangle's
/// edges: their other coordinates carry a rounding error, so the box grows by a few ulps
/// (and never beyond `bounds`, the piece's box, which bounds the true part exactly).
fn clipped(
    tri: &[Vec3A; 3],
    axis: usize,
    plane: f32,
    above: bool,
    bounds: Bounds,
) -> Option<Bounds> {
    let inside = |v: Vec3A| if above { v[axis] >= plane } else { v[axis] <= plane };
    let mut b = Bounds::EMPTY;
    for i in 0..3 {
        let (a, c) = (tri[i], tri[(i + 1) % 3]);
        if inside(a) {
            b.grow(a, a);
        }
        let (da, dc) = (a[axis] - plane, c[axis] - plane);
        if (da < 0.0 && dc > 0.0) || (da > 0.0 && dc < 0.0) {
            let mut p = a + (c - a) * (da / (da - dc));
            p[axis] = plane;
            let slack = p.abs() * 4.0 * f32::EPSILON;
            b.grow(p - slack, p + slack);
        }
    }
    let mut b = Bounds { min: b.min.max(bounds.min), max: b.max.min(bounds.max) };
    // The slack must not carry a piece across its plane.
    if above {
        b.min[axis] = b.min[axis].max(plane);
    } else {
        b.max[axis] = b.max[axis].min(plane);
    }
    (b.min.cmple(b.max).all()).then_some(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds_of(prims: &[Prim]) -> Bounds {
        prims.iter().fold(Bounds::EMPTY, |b, p| b.union(p.bounds()))
    }

    /// Points spread over the triangle (barycentric grid).
    fn points_on(t: [Vec3; 3], n: u32) -> impl Iterator<Item = Vec3> {
        (0..=n).flat_map(move |i| {
            (0..=n - i).map(move |j| {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v
            })
        })
    }

    #[test]
    fn no_budget_is_one_primitive_per_triangle() {
        let tris = [[Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z, Vec3::ONE, Vec3::X * 3.0]];
        let prims = split_prims(2, &|i| tris[i], 0.0);
        assert_eq!(prims.iter().map(|p| p.index).collect::<Vec<_>>(), vec![0, 1]);
    }

    #[test]
    fn a_diagonal_triangle_is_cut_into_pieces_that_cover_it() {
        // One long diagonal sliver among small axis-aligned triangles: the budget goes to it.
        let sliver = [
            Vec3::ZERO,
            Vec3::new(10.0, 10.0, 0.3),
            Vec3::new(10.0, 10.0, 0.0) + Vec3::new(0.2, -0.2, 0.0),
        ];
        let tris = with_small(40, &[sliver]);
        let prims = split_prims(tris.len(), &|i| tris[i], 0.25);
        let pieces: Vec<Prim> = prims.iter().copied().filter(|p| p.index == 40).collect();
        assert!(pieces.len() > 4, "the sliver got {} pieces", pieces.len());
        assert_eq!(prims.len() - pieces.len(), 40, "the small triangles stay whole");
        assert!(prims.len() <= 41 + 10, "the budget holds: {}", prims.len());
        // Smaller in sum than the one box, and every point of the triangle in some piece.
        let whole = Bounds {
            min: sliver[0].min(sliver[1]).min(sliver[2]).into(),
            max: sliver[0].max(sliver[1]).max(sliver[2]).into(),
        };
        let sum: f32 = pieces.iter().map(|p| half_area(&p.bounds())).sum();
        assert!(
            sum < 0.5 * half_area(&whole),
            "pieces {sum} against the box {}",
            half_area(&whole)
        );
        for q in points_on(sliver, 60) {
            let q = Vec3A::from(q);
            assert!(
                pieces
                    .iter()
                    .any(|p| p.bounds_min().cmple(q).all() && q.cmple(p.bounds_max()).all()),
                "{q} is in no piece"
            );
        }
        let b = bounds_of(&pieces);
        assert!(
            whole.min.cmple(b.min).all() && b.max.cmple(whole.max).all(),
            "the pieces stay inside the triangle's box"
        );
    }

    /// `n` small triangles along x (the mesh's typical size), then `extra`.
    fn with_small(n: usize, extra: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
        let mut tris: Vec<[Vec3; 3]> = (0..n)
            .map(|k| {
                let o = Vec3::new(k as f32 * 0.25, 0.0, 0.0);
                [o, o + Vec3::X * 0.1, o + Vec3::Y * 0.1]
            })
            .collect();
        tris.extend_from_slice(extra);
        tris
    }

    #[test]
    fn a_big_mesh_is_worth_cutting_from_one_percent_of_candidates() {
        // Every 32nd triangle is looked at: slivers as 2% of the triangles (scattered by a
        // hash) count, as 0.5% or none at all do not.
        let sliver = [Vec3::ZERO, Vec3::new(10.0, 10.0, 0.3), Vec3::new(10.2, 9.8, 0.0)];
        let small = with_small(64_000, &[]);
        let mesh = |per_mille: u64| -> Vec<[Vec3; 3]> {
            let chosen =
                |i: usize| (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 54 < per_mille;
            small.iter().enumerate().map(|(i, &t)| if chosen(i) { sliver } else { t }).collect()
        };
        for (per_mille, worth) in [(20, true), (5, false), (0, false)] {
            let tris = mesh(per_mille);
            assert_eq!(
                worth_cutting(tris.len(), &|i| tris[i]),
                worth,
                "slivers {per_mille} in 1000"
            );
        }
        assert!(!worth_cutting(0, &|_| unreachable!()), "an empty mesh");
    }

    #[test]
    fn degenerate_and_infinite_triangles_are_never_cut() {
        let tris = with_small(
            40,
            &[
                [Vec3::ZERO, Vec3::new(5.0, 5.0, 5.0), Vec3::new(10.0, 10.0, 10.0)], // collinear
                [Vec3::ONE, Vec3::ONE, Vec3::ONE],
                [Vec3::ZERO, Vec3::new(f32::INFINITY, 1.0, 0.0), Vec3::Y],
                [Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0), Vec3::Y],
                [Vec3::ZERO, Vec3::new(4.0, 4.0, 4.0), Vec3::new(4.0, 0.0, 2.0)],
            ],
        );
        let prims = split_prims(tris.len(), &|i| tris[i], 0.5);
        for i in 40..44 {
            assert_eq!(prims.iter().filter(|p| p.index == i).count(), 1, "triangle {i}");
        }
        assert!(
            prims.iter().filter(|p| p.index == 44).count() > 1,
            "the one big real triangle takes the budget"
        );
    }

    #[test]
    fn even_triangles_are_left_whole() {
        // A scan-like mesh: every box within a few times the median, so nothing is cut
        // whatever the budget.
        let tris =
            with_small(200, &[[Vec3::ZERO, Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.2, 0.0, 0.05)]]);
        assert_eq!(split_prims(tris.len(), &|i| tris[i], 1.0).len(), tris.len());
    }

    #[test]
    fn cuts_follow_the_coarsest_grid_plane() {
        let grid = Grid { origin: Vec3A::ZERO, extent: Vec3A::splat(8.0) };
        assert_eq!(grid.plane(0, 1.0, 7.0), 4.0);
        assert_eq!(grid.plane(0, 4.5, 7.5), 6.0);
        assert_eq!(grid.plane(1, 4.0, 6.0), 5.0, "a plane on the piece's face does not cut it");
        let flat = Grid { origin: Vec3A::ZERO, extent: Vec3A::ZERO };
        assert_eq!(flat.plane(2, 1.0, 2.0), 1.5);
    }
}
