//! The structural checker: every primitive referenced once (at least once, each piece
//! overlapping it and the pieces covering its box, where the build cut triangles), boxes
//! nested, leaves within the size limit, every node reached once and the depth within
//! `MAX_DEPTH`. The tests,
//! the fuzzer and the BVH build benchmark check their trees with it.

use glam::Vec3;

use super::{BuildOptions, Bvh, BvhChild, MAX_DEPTH};
use crate::geometry::Aabb;

impl Bvh {
    /// Check the structural invariants (leaf sizes against the default options); Err names the first broken one.
    /// See [`Bvh::validate_with`].
    pub fn validate(&self, triangles: &[[Vec3; 3]]) -> Result<(), String> {
        self.validate_with(triangles, &BuildOptions::default())
    }

    /// Check the structural invariants; Err names the first broken one: every primitive referenced exactly
    /// once, child boxes inside the box recorded for their node in its parent, primitives inside their leaf's
    /// box, leaves within `max_leaf_size`, node indices in range, every node reached once (no cycles, no
    /// orphans), depth within `MAX_DEPTH`. Where `options.split_budget` let the build cut triangles, a
    /// primitive may be referenced more than once: each of its leaf boxes must overlap its box, and
    /// together they must cover it.
    pub fn validate_with(
        &self,
        triangles: &[[Vec3; 3]],
        options: &BuildOptions,
    ) -> Result<(), String> {
        self.check(triangles.len(), |i| Aabb::from_points(&triangles[i]), options)
    }

    /// [`Bvh::validate_with`] for a BVH built over boxes.
    pub fn validate_boxes(&self, boxes: &[Aabb], options: &BuildOptions) -> Result<(), String> {
        self.check(boxes.len(), |i| boxes[i], options)
    }

    fn check(
        &self,
        prim_count: usize,
        prim_box: impl Fn(usize) -> Aabb,
        options: &BuildOptions,
    ) -> Result<(), String> {
        let split = options.split_budget > 0.0;
        self.check_prim_indices(prim_count, split)?;
        if prim_count == 0 {
            return match self.nodes.is_empty() {
                true => Ok(()),
                false => Err("nodes present but no primitives".into()),
            };
        }
        if self.nodes.is_empty() {
            return Err("no nodes for a non-empty primitive set".into());
        }
        let mut walk = TreeWalk {
            bvh: self,
            prim_box: &prim_box,
            split,
            max_leaf: options.max_leaf_size.max(1),
            node_seen: vec![false; self.nodes.len()],
            slot_seen: vec![false; self.prim_indices.len()],
            // Where pieces are allowed: the union of each primitive's leaf boxes.
            covered: vec![Aabb::EMPTY; if split { prim_count } else { 0 }],
        };
        walk.walk()?;
        walk.check_all_reached()
    }

    /// Every primitive in `prim_indices`, in range, and once unless the build cut triangles.
    fn check_prim_indices(&self, prim_count: usize, split: bool) -> Result<(), String> {
        let slots = self.prim_indices.len();
        if slots != prim_count && !(split && slots > prim_count) {
            return Err(format!("prim_indices has {slots} entries for {prim_count} primitives"));
        }
        let mut seen = vec![false; prim_count];
        for (k, &p) in self.prim_indices.iter().enumerate() {
            let Some(s) = seen.get_mut(p as usize) else {
                return Err(format!("prim_indices[{k}] = {p} is out of range"));
            };
            if std::mem::replace(s, true) && !split {
                return Err(format!("primitive {p} appears twice in prim_indices (again at {k})"));
            }
        }
        if let Some(p) = seen.iter().position(|s| !s) {
            return Err(format!("primitive {p} is not in prim_indices"));
        }
        Ok(())
    }
}

/// The walk from the root: which nodes and slots it reached, and (where the build cut
/// triangles) the union of each primitive's leaf boxes.
struct TreeWalk<'a, F: Fn(usize) -> Aabb> {
    bvh: &'a Bvh,
    prim_box: &'a F,
    split: bool,
    max_leaf: u32,
    node_seen: Vec<bool>,
    slot_seen: Vec<bool>,
    covered: Vec<Aabb>,
}

impl<F: Fn(usize) -> Aabb> TreeWalk<'_, F> {
    /// Visit every node once from the root, checking each child.
    fn walk(&mut self) -> Result<(), String> {
        // (node, the box its parent records for it, level)
        let mut stack: Vec<(u32, Option<Aabb>, usize)> = vec![(0, None, 1)];
        while let Some((index, parent_box, level)) = stack.pop() {
            if std::mem::replace(&mut self.node_seen[index as usize], true) {
                return Err(format!("node {index} is reached twice (cycle or shared child)"));
            }
            if level > MAX_DEPTH {
                return Err(format!("node {index} is at depth {level} > MAX_DEPTH = {MAX_DEPTH}"));
            }
            let node = &self.bvh.nodes[index as usize];
            for (side, child) in ["left", "right"].into_iter().zip(node.children()) {
                let here = format!("node {index} {side} child");
                if child.is_empty() {
                    let lone_leaf = index == 0 && side == "right" && node.child(0).is_leaf();
                    if !lone_leaf {
                        return Err(format!(
                            "{here} is EMPTY (only a root over a single leaf may have one)"
                        ));
                    }
                    continue;
                }
                check_child_box(&here, &child, parent_box)?;
                if child.is_inner() {
                    let nodes = self.bvh.nodes.len();
                    if child.index as usize >= nodes {
                        return Err(format!("{here} points to node {} of {nodes}", child.index));
                    }
                    stack.push((child.index, Some(child.bounds), level + 1));
                    continue;
                }
                self.check_leaf(&here, &child)?;
            }
        }
        Ok(())
    }

    /// A leaf within the size limit and the slots, its slots in no other leaf, its
    /// primitives inside its box (or, cut, overlapping it).
    fn check_leaf(&mut self, here: &str, child: &BvhChild) -> Result<(), String> {
        if child.count > self.max_leaf {
            let max_leaf = self.max_leaf;
            return Err(format!(
                "{here} is a leaf of {} > max_leaf_size = {max_leaf}",
                child.count
            ));
        }
        let slots = self.slot_seen.len();
        let range = child.index as usize..child.index as usize + child.count as usize;
        if range.end > slots {
            return Err(format!("{here} leaf range {range:?} exceeds {slots} slots"));
        }
        for k in range {
            if std::mem::replace(&mut self.slot_seen[k], true) {
                return Err(format!("{here} references slot {k}, already in another leaf"));
            }
            let p = self.bvh.prim_indices[k] as usize;
            if self.split {
                if !child.bounds.overlaps(&(self.prim_box)(p)) {
                    return Err(format!("{here}: primitive {p} does not overlap the leaf box"));
                }
                self.covered[p] = self.covered[p].union(child.bounds);
            } else if !child.bounds.contains(&(self.prim_box)(p)) {
                return Err(format!("{here}: primitive {p} is not inside the leaf box"));
            }
        }
        Ok(())
    }

    /// After the walk: every slot in a leaf, every node reached, every cut primitive
    /// covered by its leaf boxes.
    fn check_all_reached(&self) -> Result<(), String> {
        if let Some(k) = self.slot_seen.iter().position(|s| !s) {
            return Err(format!("slot {k} (primitive {}) is in no leaf", self.bvh.prim_indices[k]));
        }
        if let Some(i) = self.node_seen.iter().position(|s| !s) {
            return Err(format!("node {i} is unreachable from the root"));
        }
        let covered = &self.covered;
        let prim_box = self.prim_box;
        if let Some(p) = (0..covered.len()).find(|&p| !covered[p].contains(&prim_box(p))) {
            return Err(format!(
                "the leaf boxes of primitive {p} ({:?}) do not cover it ({:?})",
                covered[p],
                prim_box(p)
            ));
        }
        Ok(())
    }
}

/// A child's box is not empty and lies inside the box its node's parent records.
fn check_child_box(here: &str, child: &BvhChild, parent_box: Option<Aabb>) -> Result<(), String> {
    if child.bounds.is_empty() {
        return Err(format!("{here} has an empty box"));
    }
    if let Some(pb) = parent_box {
        if !pb.contains(&child.bounds) {
            return Err(format!(
                "{here} box {:?} is not inside its node's box {pb:?}",
                child.bounds
            ));
        }
    }
    Ok(())
}
