//! The structural checker: every primitive referenced once (at least once, each piece
//! overlapping it and the pieces covering its box, where the build cut triangles), boxes
//! nested, leaves within the size limit, every node reached once and the depth within
//! `MAX_DEPTH`. The tests,
//! the fuzzer and the BVH build benchmark check their trees with it.

use glam::Vec3;

use super::{BuildOptions, Bvh, MAX_DEPTH};
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
        // Where pieces are allowed: the union of each primitive's leaf boxes.
        let mut covered = vec![Aabb::EMPTY; if split { prim_count } else { 0 }];
        if prim_count == 0 {
            return match self.nodes.is_empty() {
                true => Ok(()),
                false => Err("nodes present but no primitives".into()),
            };
        }
        if self.nodes.is_empty() {
            return Err("no nodes for a non-empty primitive set".into());
        }

        let max_leaf = options.max_leaf_size.max(1);
        let mut node_seen = vec![false; self.nodes.len()];
        let mut slot_seen = vec![false; slots];
        // (node, the box its parent records for it, level)
        let mut stack: Vec<(u32, Option<Aabb>, usize)> = vec![(0, None, 1)];
        while let Some((index, parent_box, level)) = stack.pop() {
            if std::mem::replace(&mut node_seen[index as usize], true) {
                return Err(format!("node {index} is reached twice (cycle or shared child)"));
            }
            if level > MAX_DEPTH {
                return Err(format!("node {index} is at depth {level} > MAX_DEPTH = {MAX_DEPTH}"));
            }
            let node = &self.nodes[index as usize];
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
                if child.is_inner() {
                    if child.index as usize >= self.nodes.len() {
                        return Err(format!(
                            "{here} points to node {} of {}",
                            child.index,
                            self.nodes.len()
                        ));
                    }
                    stack.push((child.index, Some(child.bounds), level + 1));
                    continue;
                }
                if child.count > max_leaf {
                    return Err(format!(
                        "{here} is a leaf of {} > max_leaf_size = {max_leaf}",
                        child.count
                    ));
                }
                let range = child.index as usize..child.index as usize + child.count as usize;
                if range.end > slots {
                    return Err(format!("{here} leaf range {range:?} exceeds {slots} slots"));
                }
                for k in range {
                    if std::mem::replace(&mut slot_seen[k], true) {
                        return Err(format!("{here} references slot {k}, already in another leaf"));
                    }
                    let p = self.prim_indices[k] as usize;
                    if split {
                        if !child.bounds.overlaps(&prim_box(p)) {
                            return Err(format!(
                                "{here}: primitive {p} does not overlap the leaf box"
                            ));
                        }
                        covered[p] = covered[p].union(child.bounds);
                    } else if !child.bounds.contains(&prim_box(p)) {
                        return Err(format!("{here}: primitive {p} is not inside the leaf box"));
                    }
                }
            }
        }
        if let Some(k) = slot_seen.iter().position(|s| !s) {
            return Err(format!("slot {k} (primitive {}) is in no leaf", self.prim_indices[k]));
        }
        if let Some(i) = node_seen.iter().position(|s| !s) {
            return Err(format!("node {i} is unreachable from the root"));
        }
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
