//! From the binary SAH tree to the wide one: each wide node takes the cheapest cut of its
//! binary subtree into at most eight slots, as the paper's cost-based collapse plans it
//! (`plan.rs`). Triangles are then laid out in the wide tree's leaf order and the binary
//! tree is rewritten to read them there. The top of the tree is collapsed on one thread,
//! the binary subtrees of at most 16k triangles below it on every core, each on its own,
//! and spliced in.

use glam::{DVec3, Vec3};

use super::plan::{Children, Plan, Planned};
use super::{WideBvh, WideNode, INNER_META_BASE, MAX_LEAF_TRIANGLES, WIDTH};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

use crate::bvh::Bvh;
use crate::geometry::Aabb;

/// Collapse `bvh` into a compressed wide BVH and reorder `bvh`'s triangles (its
/// `prim_indices` and leaf indices) into the wide tree's leaf order, which both trees then
/// share. The binary tree keeps its shape and answers as before.
pub fn collapse(bvh: &mut Bvh) -> WideBvh {
    collapse_within(bvh, usize::MAX).unwrap_or_default()
}

/// [`collapse`] where the wide tree has at most `max_nodes` nodes; otherwise nothing is
/// written or reordered and the error is how many nodes the plan would make. The count
/// comes from the plan, before any node is made (the plan and the count are a third to a
/// half of the collapse).
pub fn collapse_within(bvh: &mut Bvh, max_nodes: usize) -> Result<WideBvh, usize> {
    if bvh.nodes.is_empty() {
        return Ok(WideBvh::default());
    }
    let root = bvh.nodes[0]
        .children()
        .iter()
        .filter(|c| !c.is_empty())
        .fold(Aabb::EMPTY, |b, c| b.union(c.bounds));
    let plan = Plan::new(bvh);
    if max_nodes < usize::MAX {
        let nodes = planned_nodes(bvh, &plan, Planned::Node { index: 0, bounds: root });
        if nodes > max_nodes {
            return Err(nodes);
        }
    }
    // The top of the tree here, the subtrees below it on every core, then spliced in.
    let mut top = Collapser {
        bvh,
        plan: &plan,
        nodes: vec![WideNode::default()],
        order: Vec::new(),
        deferred: Some(Vec::new()),
    };
    top.build(0, Planned::Node { index: 0, bounds: root });
    let deferred = top.deferred.take().unwrap_or_default();
    let subtrees: Vec<(usize, Collapser)> = deferred
        .into_par_iter()
        .map(|(index, item)| {
            let mut sub = Collapser {
                bvh,
                plan: &plan,
                nodes: vec![WideNode::default()],
                order: Vec::new(),
                deferred: None,
            };
            sub.build(0, item);
            (index, sub)
        })
        .collect();
    let Collapser { nodes, order, .. } = top;
    let (nodes, order) = splice(nodes, order, subtrees);
    reorder_binary(bvh, &order);
    Ok(WideBvh { nodes })
}

/// The wide nodes the collapse makes for `item` and below it: the node itself and, for each
/// slot that is no leaf of at most three triangles, that child's (the children of big
/// subtrees on every core). Nothing is allocated: at 100M triangles it visits 8.7M nodes.
fn planned_nodes(bvh: &Bvh, plan: &Plan, item: Planned) -> usize {
    let children = children_of(bvh, plan, item);
    let inner = |c: &&Planned| match **c {
        Planned::Leaf { count, .. } => count > MAX_LEAF_TRIANGLES,
        Planned::Merged { .. } => false,
        Planned::Node { .. } => true,
    };
    let below = |c: &Planned| planned_nodes(bvh, plan, *c);
    let big = matches!(item, Planned::Node { index, .. }
        if plan.triangles_under(index) > PARALLEL_MAX_TRIANGLES);
    let slots = children.as_slice();
    1 + if big {
        slots.par_iter().filter(inner).map(below).sum::<usize>()
    } else {
        slots.iter().filter(inner).map(below).sum::<usize>()
    }
}

/// Binary subtrees with at most this many triangles are collapsed on their own (in
/// parallel) and spliced in: small enough for the work to spread, big enough that the
/// sequential top stays short.
const PARALLEL_MAX_TRIANGLES: u32 = 16 * 1024;

/// Put each subtree (collapsed on its own, its root at its node 0) in place of the top's
/// node `index` it was deferred from: its other nodes go after the top's nodes, its
/// triangles after the top's, subtree after subtree. Copied on every core.
fn splice(
    mut nodes: Vec<WideNode>,
    mut order: Vec<u32>,
    subtrees: Vec<(usize, Collapser)>,
) -> (Vec<WideNode>, Vec<u32>) {
    // Where each subtree's nodes (but its root) and triangles start.
    let mut starts = Vec::with_capacity(subtrees.len());
    let (mut node_end, mut triangle_end) = (nodes.len(), order.len());
    for (_, sub) in &subtrees {
        starts.push((node_end, triangle_end));
        node_end += sub.nodes.len() - 1;
        triangle_end += sub.order.len();
    }
    let (top_nodes, top_triangles) = (nodes.len(), order.len());
    nodes.resize(node_end, WideNode::default());
    order.resize(triangle_end, 0);
    let (head, mut node_tail) = nodes.split_at_mut(top_nodes);
    let mut triangle_tail = &mut order[top_triangles..];
    let mut work = Vec::with_capacity(subtrees.len());
    for ((index, sub), &(node_start, triangle_start)) in subtrees.into_iter().zip(&starts) {
        let (node_out, rest) = std::mem::take(&mut node_tail).split_at_mut(sub.nodes.len() - 1);
        let (triangle_out, more) = std::mem::take(&mut triangle_tail).split_at_mut(sub.order.len());
        (node_tail, triangle_tail) = (rest, more);
        // Local node i > 0 becomes node_start - 1 + i; the root goes to `index`.
        let offsets = (node_start as u32 - 1, triangle_start as u32);
        head[index] = placed(sub.nodes[0], offsets);
        work.push((sub, node_out, triangle_out, offsets));
    }
    work.into_par_iter().for_each(|(sub, node_out, triangle_out, offsets)| {
        for (out, &node) in node_out.iter_mut().zip(&sub.nodes[1..]) {
            *out = placed(node, offsets);
        }
        triangle_out.copy_from_slice(&sub.order);
    });
    (nodes, order)
}

/// A subtree's node moved to its place in the whole tree: its children by the subtree's node
/// offset (when it has any), its triangles by the triangle offset.
fn placed(mut node: WideNode, (node_offset, triangle_offset): (u32, u32)) -> WideNode {
    if node.imask() != 0 {
        node.child_base += node_offset;
    }
    node.triangle_base += triangle_offset;
    node
}

struct Collapser<'a> {
    bvh: &'a Bvh,
    plan: &'a Plan,
    nodes: Vec<WideNode>,
    /// Wide leaf order -> binary tree position of each triangle placed so far.
    order: Vec<u32>,
    /// For the top of the tree: binary subtrees left to collapse on their own, with the
    /// wide node each becomes. None: collapse everything here.
    deferred: Option<Vec<(usize, Planned)>>,
}

impl Collapser<'_> {
    /// Fill `nodes[index]` from `item`, then its inner children (depth first, so that the
    /// triangles of any subtree, a split binary leaf's included, end up contiguous).
    fn build(&mut self, index: usize, item: Planned) {
        let children = self.children_of(item);
        let slots = assign_slots(children.as_slice(), item.bounds());
        let mut node = frame(item.bounds());
        let child_base = self.nodes.len() as u32;
        let triangle_base = self.order.len() as u32;
        let mut inner = Children::default();
        for (s, child) in slots.iter().enumerate() {
            let Some(child) = child else { continue };
            quantize(&mut node, s, &child.bounds());
            // A leaf small enough for one slot goes in; anything else becomes an inner node.
            let offset = self.order.len() as u32 - triangle_base;
            match *child {
                Planned::Leaf { first, count, .. } if count <= MAX_LEAF_TRIANGLES => {
                    node.meta[s] = (leaf_unary(count) << 5 | offset) as u8;
                    self.order.extend(first..first + count);
                }
                Planned::Merged { index, count, .. } => {
                    node.meta[s] = (leaf_unary(count) << 5 | offset) as u8;
                    self.push_subtree(index);
                }
                _ => {
                    node.exponents_imask[3] |= 1 << s;
                    node.meta[s] = ((1 << 5) | (INNER_META_BASE + s as u32)) as u8;
                    inner.push(*child);
                }
            }
        }
        node.child_base = child_base;
        node.triangle_base = triangle_base;
        self.nodes[index] = node;
        // Inner children sit side by side in slot order (the traversal counts `imask` bits).
        let inner = inner.as_slice();
        self.nodes.resize(self.nodes.len() + inner.len(), WideNode::default());
        for (k, &child) in inner.iter().enumerate() {
            let at = child_base as usize + k;
            // Whole binary subtrees only: the pieces of a split leaf stay with their parent,
            // so that the leaf's triangles stay contiguous.
            if let (Some(deferred), Planned::Node { index, .. }) = (self.deferred.as_mut(), child) {
                if self.plan.triangles_under(index) <= PARALLEL_MAX_TRIANGLES {
                    deferred.push((at, child));
                    continue;
                }
            }
            self.build(at, child);
        }
    }

    /// The (at most eight) children of the wide node made from `item`.
    fn children_of(&self, item: Planned) -> Children {
        children_of(self.bvh, self.plan, item)
    }

    /// Place every triangle under binary node `index`, leaf by leaf (a merged leaf's
    /// subtree: at most three triangles, so the recursion is shallow).
    fn push_subtree(&mut self, index: u32) {
        let children = self.bvh.nodes[index as usize].children();
        for child in children.iter().filter(|c| c.is_leaf()) {
            self.order.extend(child.index..child.index + child.count);
        }
        for child in children.iter().rev().filter(|c| c.is_inner()) {
            self.push_subtree(child.index);
        }
    }
}

/// The (at most eight) children of the wide node made from `item`, as `plan` cuts `bvh`.
fn children_of(bvh: &Bvh, plan: &Plan, item: Planned) -> Children {
    match item {
        Planned::Node { index, .. } => plan.slots(bvh, index),
        // At most three triangles always fit one slot: never a node of its own.
        Planned::Merged { .. } => unreachable!("a merged leaf is placed in its parent's slot"),
        // A leaf too big for a slot: split into pieces, each with the leaf's box.
        Planned::Leaf { first, count, bounds } => {
            let per_piece = if count <= MAX_LEAF_TRIANGLES * WIDTH as u32 {
                MAX_LEAF_TRIANGLES
            } else {
                count.div_ceil(WIDTH as u32)
            };
            let mut pieces = Children::default();
            for start in (first..first + count).step_by(per_piece as usize) {
                pieces.push(Planned::Leaf {
                    first: start,
                    count: per_piece.min(first + count - start),
                    bounds,
                });
            }
            pieces
        }
    }
}

/// The unary count of a leaf slot's `meta` (1 to 3 triangles: 0b001, 0b011, 0b111).
fn leaf_unary(count: u32) -> u32 {
    (1u32 << count) - 1
}

/// Places each child in one of the eight slots: slot `s` wants the child lying furthest
/// towards corner `s` of the parent box (bit `i` set: the high side of axis `i`). Greedy
/// over (child, slot) pairs, best first, which is close to the paper's assignment.
fn assign_slots(children: &[Planned], parent: Aabb) -> [Option<Planned>; WIDTH] {
    let centre = parent.center().as_dvec3();
    let corner = |s: usize| DVec3::new(sign(s, 0), sign(s, 1), sign(s, 2));
    // Each pair as one integer key, so that sorting them is cheap: the score descending
    // (its bits in f64::total_cmp's order, inverted), then the child, then the slot.
    let mut pairs = [0u128; WIDTH * WIDTH];
    let mut count = 0;
    for (c, child) in children.iter().enumerate().take(WIDTH) {
        let offset = child.bounds().center().as_dvec3() - centre;
        for s in 0..WIDTH {
            let bits = offset.dot(corner(s)).to_bits() as i64;
            let ascending = (bits ^ (((bits >> 63) as u64) >> 1) as i64) as u64 ^ (1 << 63);
            pairs[count] = ((!ascending) as u128) << 64 | (c as u128) << 8 | s as u128;
            count += 1;
        }
    }
    pairs[..count].sort_unstable();
    let mut slots = [None; WIDTH];
    let mut placed = [false; WIDTH];
    for &key in &pairs[..count] {
        let (c, s) = ((key >> 8) as u8 as usize, key as u8 as usize);
        if !placed[c] && slots[s].is_none() {
            slots[s] = Some(children[c]);
            placed[c] = true;
        }
    }
    slots
}

fn sign(s: usize, axis: usize) -> f64 {
    if s & (1 << axis) != 0 {
        1.0
    } else {
        -1.0
    }
}

/// A node with its quantization frame over `bounds`: origin at the minimum, and per axis
/// the smallest power-of-two scale whose 255 steps reach the maximum.
fn frame(bounds: Aabb) -> WideNode {
    let mut node = WideNode { origin: bounds.min.into(), ..WideNode::default() };
    for axis in 0..3 {
        node.exponents_imask[axis] = exponent(bounds.min[axis], bounds.max[axis]);
    }
    // The meaningless planes of empty slots: lo above hi, never tested (meta 0).
    node.lo = [[u8::MAX; WIDTH]; 3];
    node
}

/// The biased exponent of the scale spanning `lo..hi` in 255 steps (checked in f32, as
/// the traversal decodes), from 1 (2^-126) to 254.
fn exponent(lo: f32, hi: f32) -> u8 {
    let extent = (hi as f64 - lo as f64) / 255.0;
    let mut biased = if extent > 0.0 && extent.is_finite() {
        (extent.log2().ceil() as i64 + 127).clamp(1, 254) as u32
    } else {
        1
    };
    while biased < 254 && lo + 255.0 * f32::from_bits(biased << 23) < hi {
        biased += 1;
    }
    biased as u8
}

/// Slot `s`'s quantized box, rounded outwards so that the decoded box (origin + q * scale,
/// in f32) contains `child`.
fn quantize(node: &mut WideNode, s: usize, child: &Aabb) {
    let origin = Vec3::from(node.origin);
    let scale = node.scale();
    for axis in 0..3 {
        let (p, step) = (origin[axis], scale[axis]);
        let decode = |q: f32| p + q * step;
        let mut lo = ((child.min[axis] - p) / step).floor().clamp(0.0, 255.0);
        while lo > 0.0 && decode(lo) > child.min[axis] {
            lo -= 1.0;
        }
        let mut hi = ((child.max[axis] - p) / step).ceil().clamp(0.0, 255.0);
        while hi < 255.0 && decode(hi) < child.max[axis] {
            hi += 1.0;
        }
        node.lo[axis][s] = lo as u8;
        node.hi[axis][s] = hi as u8;
    }
}

/// Put `bvh`'s triangles in wide leaf order (`order[new] = old` position) and point its
/// leaves at their new ranges; every binary leaf's triangles stay side by side.
fn reorder_binary(bvh: &mut Bvh, order: &[u32]) {
    debug_assert_eq!(order.len(), bvh.prim_indices.len(), "every triangle is placed once");
    // `order` is a permutation: each entry is written once, whichever thread writes it.
    let new_position: Vec<AtomicU32> =
        (0..order.len()).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    order
        .par_iter()
        .enumerate()
        .for_each(|(new, &old)| new_position[old as usize].store(new as u32, Relaxed));
    let first_new = |first: u32, count: u32| {
        (first..first + count)
            .map(|old| new_position[old as usize].load(Relaxed))
            .min()
            .unwrap_or(first)
    };
    bvh.nodes.par_iter_mut().for_each(|node| {
        if node.left_count > 0 {
            node.left_index = first_new(node.left_index, node.left_count);
        }
        if node.right_count > 0 {
            node.right_index = first_new(node.right_index, node.right_count);
        }
    });
    let prim_indices: Vec<u32> =
        order.par_iter().map(|&old| bvh.prim_indices[old as usize]).collect();
    bvh.prim_indices = prim_indices;
}
