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
const NODE_COST: f64 = 1.0;
/// SAH cost of testing one triangle (the paper's).
const TRIANGLE_COST: f64 = 0.3;

/// What one slot of a wide node holds, as the plan cuts the binary tree.
#[derive(Clone, Copy, Debug)]
pub(super) enum Planned {
    /// A wide node made from binary node `index`.
    Node { index: u32, bounds: Aabb },
    /// Triangles `first .. first + count` (a binary leaf).
    Leaf { first: u32, count: u32, bounds: Aabb },
    /// Every triangle under binary node `index` (at most three) as one leaf.
    Merged { index: u32, count: u32, bounds: Aabb },
}

/// One binary node's entries of each of [`Plan`]'s arrays.
type Row = ([f64; WIDTH + 1], [u8; WIDTH + 1], [u8; WIDTH + 1], u32);

/// Per binary node, for 1..=8 slots: the least cost and how it is reached.
pub(super) struct Plan {
    /// `cost[n][i]`: the least cost of node n's subtree in at most `i` slots.
    cost: Vec<[f64; WIDTH + 1]>,
    /// `split[n][i]`: slots given to the left child when node n's subtree is spread over
    /// exactly its children (`i` >= 2, and 8 for a wide node made from n).
    split: Vec<[u8; WIDTH + 1]>,
    /// `how[n][1]`: 0 = one merged leaf, 1 = one wide node; `how[n][i >= 2]`: 0 = as with
    /// `i - 1` slots, 1 = spread over the children (`split`).
    how: Vec<[u8; WIDTH + 1]>,
    /// Triangles under each binary node.
    triangles: Vec<u32>,
}

/// Half the surface area, in f64 so that huge boxes do not overflow.
pub(super) fn half_area(b: &Aabb) -> f64 {
    let e = b.extent().as_dvec3();
    e.x * e.y + e.y * e.z + e.z * e.x
}

impl Plan {
    /// The plan for `bvh` (children after parents in `bvh.nodes` is not assumed).
    pub(super) fn new(bvh: &Bvh) -> Self {
        let n = bvh.nodes.len();
        let mut plan = Plan { cost: vec![[f64::INFINITY; WIDTH + 1]; n], split: vec![[0; WIDTH + 1]; n], how: vec![[0; WIDTH + 1]; n], triangles: vec![0; n] };
        // Parents before their inner children (read backwards: children first).
        let mut order = Vec::with_capacity(n);
        let mut stack = vec![0u32];
        while let Some(index) = stack.pop() {
            order.push(index);
            stack.extend(bvh.nodes[index as usize].children().iter().filter(|c| c.is_inner()).map(|c| c.index));
        }
        let root_box = bvh.nodes.first().map_or(Aabb::EMPTY, |r| r.children().iter().filter(|c| !c.is_empty()).fold(Aabb::EMPTY, |b, c| b.union(c.bounds)));
        let mut area = vec![0.0; n];
        area[0] = half_area(&root_box);
        for &index in &order {
            for c in bvh.nodes[index as usize].children().iter().filter(|c| c.is_inner()) {
                area[c.index as usize] = half_area(&c.bounds);
            }
        }
        // Bottom up, a level of equal height at a time, each level's rows on every core: a
        // node's height is one more than its inner children's.
        let mut height = vec![0u32; n];
        for &index in order.iter().rev() {
            height[index as usize] = bvh.nodes[index as usize].children().iter().filter(|c| c.is_inner()).map(|c| height[c.index as usize] + 1).max().unwrap_or(0);
        }
        let mut levels: Vec<Vec<u32>> = vec![Vec::new(); height.iter().max().map_or(0, |&h| h as usize + 1)];
        for &index in &order {
            levels[height[index as usize] as usize].push(index);
        }
        for level in &levels {
            let rows: Vec<Row> = level.par_iter().map(|&index| plan.row(bvh, index as usize, area[index as usize])).collect();
            for (&index, row) in level.iter().zip(rows) {
                let i = index as usize;
                (plan.cost[i], plan.split[i], plan.how[i], plan.triangles[i]) = row;
            }
        }
        plan
    }

    /// Node `n`'s row from its children's: its least costs, splits and choices for 1..=8
    /// slots, and the triangles under it.
    fn row(&self, bvh: &Bvh, n: usize, area: f64) -> Row {
        let [left, right] = bvh.nodes[n].children();
        let triangles = self.triangles_of(&left) + self.triangles_of(&right);
        // Spread over the children: i slots, k of them to the left.
        // Each child's costs for 0..=8 slots, looked up 45 times below.
        let (l, r): ([f64; WIDTH + 1], [f64; WIDTH + 1]) = (std::array::from_fn(|k| self.child_cost(&left, k)), std::array::from_fn(|k| self.child_cost(&right, k)));
        let mut spread = [(f64::INFINITY, 0u8); WIDTH + 1];
        for (i, best) in spread.iter_mut().enumerate().skip(1) {
            for k in 0..=i {
                let c = l[k] + r[i - k];
                if c < best.0 {
                    *best = (c, k as u8);
                }
            }
        }
        let merged = if triangles <= MAX_LEAF_TRIANGLES { area * triangles as f64 * TRIANGLE_COST } else { f64::INFINITY };
        let node = area * NODE_COST + spread[WIDTH].0;
        let (mut cost, mut how, mut split) = ([f64::INFINITY; WIDTH + 1], [0u8; WIDTH + 1], [0u8; WIDTH + 1]);
        (cost[1], how[1]) = if merged <= node { (merged, 0) } else { (node, 1) };
        for i in 2..=WIDTH {
            split[i] = spread[i].1;
            (cost[i], how[i]) = if spread[i].0 < cost[i - 1] { (spread[i].0, 1) } else { (cost[i - 1], 0) };
        }
        (cost, split, how, triangles)
    }

    /// Triangles under binary node `index`.
    pub(super) fn triangles_under(&self, index: u32) -> u32 {
        self.triangles[index as usize]
    }

    fn triangles_of(&self, child: &BvhChild) -> u32 {
        if child.is_inner() { self.triangles[child.index as usize] } else { child.count }
    }

    /// The least cost of `child` in at most `slots` slots (an absent child costs nothing).
    fn child_cost(&self, child: &BvhChild, slots: usize) -> f64 {
        if child.is_empty() {
            0.0
        } else if slots == 0 {
            f64::INFINITY
        } else if child.is_leaf() {
            let area = half_area(&child.bounds);
            // A leaf too big for one slot becomes a node of its pieces.
            let node = if child.count > MAX_LEAF_TRIANGLES { NODE_COST } else { 0.0 };
            area * (node + child.count as f64 * TRIANGLE_COST)
        } else {
            self.cost[child.index as usize][slots]
        }
    }

    /// The slots of the wide node made from binary node `index`: its subtree cut into at
    /// most eight pieces the cheapest way.
    pub(super) fn slots(&self, bvh: &Bvh, index: u32) -> Vec<Planned> {
        let mut out = Vec::with_capacity(WIDTH);
        let [left, right] = bvh.nodes[index as usize].children();
        let k = self.split[index as usize][WIDTH] as usize;
        self.gather(bvh, &left, k, &mut out);
        self.gather(bvh, &right, WIDTH - k, &mut out);
        out
    }

    /// `child`'s subtree cut into at most `slots` pieces, as planned.
    fn gather(&self, bvh: &Bvh, child: &BvhChild, slots: usize, out: &mut Vec<Planned>) {
        if child.is_empty() {
            return;
        }
        if child.is_leaf() {
            out.push(Planned::Leaf { first: child.index, count: child.count, bounds: child.bounds });
            return;
        }
        let n = child.index as usize;
        let mut i = slots;
        while i >= 2 && self.how[n][i] == 0 {
            i -= 1;
        }
        if i >= 2 {
            let [left, right] = bvh.nodes[n].children();
            let k = self.split[n][i] as usize;
            self.gather(bvh, &left, k, out);
            self.gather(bvh, &right, i - k, out);
        } else if self.how[n][1] == 0 {
            out.push(Planned::Merged { index: child.index, count: self.triangles[n], bounds: child.bounds });
        } else {
            out.push(Planned::Node { index: child.index, bounds: child.bounds });
        }
    }
}
