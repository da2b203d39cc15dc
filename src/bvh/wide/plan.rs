//! The paper's cost-based collapse (Ylitie et al. 2017, section 4.1): dynamic programming
//! over the binary tree for the cheapest way (by the SAH: node visits and triangle tests
//! weighted by surface area) to cut each binary subtree into at most `i` slots of a wide
//! node, `i` = 1..=8. A slot is a wide node of its own, a binary leaf, or a whole subtree
//! of at most three triangles made one leaf.

use rayon::prelude::*;

use super::{MAX_LEAF_TRIANGLES, WIDTH};
use crate::bvh::{Bvh, BvhChild};
use crate::geometry::Aabb;

/// SAH cost of visiting one wide node (the paper's).
const NODE_COST: f32 = 1.0;
/// SAH cost of testing one triangle (the paper's).
const TRIANGLE_COST: f32 = 0.3;

/// What one slot of a wide node holds, as the plan cuts the binary tree.
#[derive(Clone, Copy, Debug)]
pub(super) enum Planned {
    /// A wide node made from binary node `index`.
    Node { index: u32, bounds: Aabb },
    /// Triangles `first .. first + count` (a binary leaf, or a piece of one too big for a slot).
    Leaf { first: u32, count: u32, bounds: Aabb },
    /// Every triangle under binary node `index` (at most three) as one leaf.
    Merged { index: u32, count: u32, bounds: Aabb },
}

impl Planned {
    /// The slot's box.
    pub(super) fn bounds(&self) -> Aabb {
        match *self {
            Planned::Node { bounds, .. }
            | Planned::Leaf { bounds, .. }
            | Planned::Merged { bounds, .. } => bounds,
        }
    }
}

/// The (at most eight) children of one wide node, kept inline: the collapse makes one of
/// these per wide node, and a heap allocation each was a fifth of its time.
#[derive(Clone, Copy, Debug)]
pub(super) struct Children {
    items: [Planned; WIDTH],
    len: usize,
}

impl Default for Children {
    fn default() -> Self {
        Self { items: [Planned::Leaf { first: 0, count: 0, bounds: Aabb::EMPTY }; WIDTH], len: 0 }
    }
}

impl Children {
    /// Append a child (at most eight in all).
    pub(super) fn push(&mut self, child: Planned) {
        self.items[self.len] = child;
        self.len += 1;
    }

    /// The children in order.
    pub(super) fn as_slice(&self) -> &[Planned] {
        &self.items[..self.len]
    }
}

/// What the plan knows of one binary node's subtree: 52 bytes, one per binary node (at 16M
/// triangles, 8M of them).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Row {
    /// `cost[i]`: the least cost of the subtree in at most `i` slots, its areas a share of
    /// the root's (so that f32 holds any scene's).
    cost: [f32; WIDTH + 1],
    /// `split[i]`: slots given to the left child when the subtree is spread over exactly its
    /// children (`i` >= 2, and 8 for a wide node made from the node).
    split: [u8; WIDTH + 1],
    /// Bit 1: clear = one merged leaf, set = one wide node; bit `i >= 2`: clear = as with
    /// `i - 1` slots, set = spread over the children (`split`).
    how: u16,
    /// Triangles under the node.
    triangles: u32,
}

const _: () = assert!(std::mem::size_of::<Row>() == 52);

impl Default for Row {
    fn default() -> Self {
        Self { cost: [f32::INFINITY; WIDTH + 1], split: [0; WIDTH + 1], how: 0, triangles: 0 }
    }
}

impl Row {
    /// Bit `i` of `how`.
    fn how(&self, i: usize) -> bool {
        self.how & (1 << i) != 0
    }

    /// The least cost with at most `i` slots, and whether it spreads over the children (or,
    /// for one slot, makes a wide node).
    fn set(&mut self, i: usize, cost: f32, spread: bool) {
        self.cost[i] = cost;
        self.how |= (spread as u16) << i;
    }
}

/// Per binary node, for 1..=8 slots: the least cost and how it is reached.
pub(super) struct Plan {
    rows: Vec<Row>,
}

/// Half the surface area, in f64 so that huge boxes do not overflow.
pub(super) fn half_area(b: &Aabb) -> f64 {
    let e = b.extent().as_dvec3();
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Half areas as a share of the root's (1 where the root's is zero or not finite).
#[derive(Clone, Copy)]
struct AreaScale(f64);

impl AreaScale {
    fn of_root(root: &Aabb) -> Self {
        let area = half_area(root);
        Self(if area > 0.0 && area.is_finite() { 1.0 / area } else { 1.0 })
    }

    /// `b`'s half area as a share of the root's.
    fn area(self, b: &Aabb) -> f32 {
        (half_area(b) * self.0) as f32
    }
}

/// Subtrees of at least this many binary nodes solve their two halves on two threads.
const PARALLEL_MIN_NODES: usize = 8 * 1024;

impl Plan {
    /// The plan for `bvh`. Our builders lay the tree out depth first (a node, its left
    /// subtree, its right subtree), so every subtree's rows are one slice, solved bottom up
    /// with the halves of big subtrees on two threads; any other layout is solved on one.
    pub(super) fn new(bvh: &Bvh) -> Self {
        // Filled on every core: at 16M triangles the rows are some 800 MB of fresh pages.
        let mut rows: Vec<Row> =
            (0..bvh.nodes.len()).into_par_iter().map(|_| Row::default()).collect();
        let Some(root) = bvh.nodes.first() else { return Plan { rows } };
        let root = root
            .children()
            .iter()
            .filter(|c| !c.is_empty())
            .fold(Aabb::EMPTY, |b, c| b.union(c.bounds));
        let scale = AreaScale::of_root(&root);
        if is_depth_first(bvh) {
            solve_slice(bvh, 0, &mut rows, scale, scale.area(&root));
        } else {
            solve_anywhere(bvh, 0, &mut rows, scale, scale.area(&root));
        }
        Plan { rows }
    }

    /// Triangles under binary node `index`.
    pub(super) fn triangles_under(&self, index: u32) -> u32 {
        self.rows[index as usize].triangles
    }

    /// The slots of the wide node made from binary node `index`: its subtree cut into at
    /// most eight pieces the cheapest way.
    pub(super) fn slots(&self, bvh: &Bvh, index: u32) -> Children {
        let mut out = Children::default();
        let [left, right] = bvh.nodes[index as usize].children();
        let k = self.rows[index as usize].split[WIDTH] as usize;
        self.gather(bvh, &left, k, &mut out);
        self.gather(bvh, &right, WIDTH - k, &mut out);
        out
    }

    /// `child`'s subtree cut into at most `slots` pieces, as planned.
    fn gather(&self, bvh: &Bvh, child: &BvhChild, slots: usize, out: &mut Children) {
        if child.is_empty() {
            return;
        }
        if child.is_leaf() {
            out.push(Planned::Leaf {
                first: child.index,
                count: child.count,
                bounds: child.bounds,
            });
            return;
        }
        let n = child.index as usize;
        let mut i = slots;
        while i >= 2 && !self.rows[n].how(i) {
            i -= 1;
        }
        if i >= 2 {
            let [left, right] = bvh.nodes[n].children();
            let k = self.rows[n].split[i] as usize;
            self.gather(bvh, &left, k, out);
            self.gather(bvh, &right, i - k, out);
        } else if !self.rows[n].how(1) {
            out.push(Planned::Merged {
                index: child.index,
                count: self.rows[n].triangles,
                bounds: child.bounds,
            });
        } else {
            out.push(Planned::Node { index: child.index, bounds: child.bounds });
        }
    }
}

/// Whether every node's left child, where inner, is the next node and its right child, where
/// inner, follows the left subtree: each subtree then owns the slice of rows from its root.
fn is_depth_first(bvh: &Bvh) -> bool {
    // Subtree sizes from the last node back, children before parents (checked on the way).
    let n = bvh.nodes.len();
    let mut size = vec![0usize; n];
    for index in (0..n).rev() {
        let [left, right] = bvh.nodes[index].children();
        let mut next = index + 1;
        for child in [left, right] {
            if child.is_inner() {
                if child.index as usize != next || next >= n {
                    return false;
                }
                next += size[next];
            }
        }
        size[index] = next - index;
    }
    size.first() == Some(&n)
}

/// Solve binary node `index`'s subtree, laid out depth first in `rows` (its own row first),
/// `area` the node box's half area.
fn solve_slice(bvh: &Bvh, index: usize, rows: &mut [Row], scale: AreaScale, area: f32) {
    let [left, right] = bvh.nodes[index].children();
    let total = rows.len();
    let (head, rest) = rows.split_first_mut().expect("a node's own row");
    let (left_rows, right_rows): (&mut [Row], &mut [Row]) =
        match (left.is_inner(), right.is_inner()) {
            (true, true) => rest.split_at_mut(right.index as usize - index - 1),
            (true, false) => (rest, &mut []),
            (false, true) => (&mut [], rest),
            (false, false) => (&mut [], &mut []),
        };
    let solve_left = |r: &mut [Row]| {
        if left.is_inner() {
            solve_slice(bvh, left.index as usize, r, scale, scale.area(&left.bounds))
        }
    };
    let solve_right = |r: &mut [Row]| {
        if right.is_inner() {
            solve_slice(bvh, right.index as usize, r, scale, scale.area(&right.bounds))
        }
    };
    if total >= PARALLEL_MIN_NODES {
        rayon::join(|| solve_left(&mut *left_rows), || solve_right(&mut *right_rows));
    } else {
        solve_left(&mut *left_rows);
        solve_right(&mut *right_rows);
    }
    *head = row(&left, left_rows.first(), &right, right_rows.first(), scale, area);
}

/// Solve binary node `index`'s subtree wherever its nodes lie, on this thread.
fn solve_anywhere(bvh: &Bvh, index: usize, rows: &mut [Row], scale: AreaScale, area: f32) {
    let [left, right] = bvh.nodes[index].children();
    for child in [left, right].iter().filter(|c| c.is_inner()) {
        solve_anywhere(bvh, child.index as usize, rows, scale, scale.area(&child.bounds));
    }
    let inner_row = |c: &BvhChild| c.is_inner().then(|| rows[c.index as usize]);
    rows[index] =
        row(&left, inner_row(&left).as_ref(), &right, inner_row(&right).as_ref(), scale, area);
}

/// A node's row from its children's (`*_row`: an inner child's row): its least costs,
/// splits and choices for 1..=8 slots, and the triangles under it.
fn row(
    left: &BvhChild,
    left_row: Option<&Row>,
    right: &BvhChild,
    right_row: Option<&Row>,
    scale: AreaScale,
    area: f32,
) -> Row {
    let triangles = triangles_of(left, left_row) + triangles_of(right, right_row);
    // Spread over the children: i slots, k of them to the left.
    // Each child's costs for 0..=8 slots, looked up 45 times below.
    let (l, r): ([f32; WIDTH + 1], [f32; WIDTH + 1]) =
        (child_costs(left, left_row, scale), child_costs(right, right_row, scale));
    let mut spread = [(f32::INFINITY, 0u8); WIDTH + 1];
    for (i, best) in spread.iter_mut().enumerate().skip(1) {
        for k in 0..=i {
            let c = l[k] + r[i - k];
            if c < best.0 {
                *best = (c, k as u8);
            }
        }
    }
    let merged = if triangles <= MAX_LEAF_TRIANGLES {
        area * triangles as f32 * TRIANGLE_COST
    } else {
        f32::INFINITY
    };
    let node = area * NODE_COST + spread[WIDTH].0;
    let mut out = Row { triangles, ..Row::default() };
    if merged <= node {
        out.set(1, merged, false)
    } else {
        out.set(1, node, true)
    }
    for (i, &(spread_cost, left_slots)) in spread.iter().enumerate().skip(2) {
        out.split[i] = left_slots;
        let fewer = out.cost[i - 1];
        if spread_cost < fewer {
            out.set(i, spread_cost, true)
        } else {
            out.set(i, fewer, false)
        }
    }
    out
}

fn triangles_of(child: &BvhChild, row: Option<&Row>) -> u32 {
    row.map_or(if child.is_leaf() { child.count } else { 0 }, |r| r.triangles)
}

/// The least cost of `child` in at most 0..=8 slots (an absent child costs nothing).
fn child_costs(child: &BvhChild, row: Option<&Row>, scale: AreaScale) -> [f32; WIDTH + 1] {
    if child.is_empty() {
        return [0.0; WIDTH + 1];
    }
    let mut costs = match row {
        Some(r) => r.cost,
        None => {
            // A leaf; one too big for one slot becomes a node of its pieces.
            let node = if child.count > MAX_LEAF_TRIANGLES { NODE_COST } else { 0.0 };
            [scale.area(&child.bounds) * (node + child.count as f32 * TRIANGLE_COST); WIDTH + 1]
        }
    };
    costs[0] = f32::INFINITY;
    costs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{BuildOptions, BvhNode};
    use glam::Vec3;

    #[test]
    fn any_node_layout_gets_the_plan_of_the_depth_first_one() {
        // A soup big enough for the two-thread split, its tree then relabelled so that
        // children come before their parents: solved on one thread, the same rows.
        let mut s = 0x2545f4914f6cdd1du64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        let tris: Vec<[Vec3; 3]> = (0..20_000)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 50.0;
                [c, c + Vec3::new(next(), next(), 0.0), c + Vec3::new(0.0, next(), next())]
            })
            .collect();
        let bvh = Bvh::build(&tris, &BuildOptions::for_tracing(tris.len()));
        assert!(is_depth_first(&bvh) && bvh.nodes.len() >= PARALLEL_MIN_NODES);
        let n = bvh.nodes.len();
        let moved = |i: u32| if i == 0 { 0 } else { n as u32 - i };
        let mut reversed = bvh.clone();
        for (i, node) in bvh.nodes.iter().enumerate() {
            let [l, r] = node.children().map(|c| {
                if c.is_inner() {
                    BvhChild { index: moved(c.index), ..c }
                } else {
                    c
                }
            });
            reversed.nodes[moved(i as u32) as usize] = BvhNode::new(l, r);
        }
        assert!(!is_depth_first(&reversed));
        let (plan, other) = (Plan::new(&bvh), Plan::new(&reversed));
        for i in 0..n {
            assert_eq!(plan.rows[i], other.rows[moved(i as u32) as usize], "node {i}");
        }
        assert_eq!(plan.rows[0].triangles, 20_000);
    }
}
