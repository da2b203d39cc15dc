//! The CPU's walk over the top level: the instances a ray meets, in the order the
//! shader's `trace_instances` (`shaders/intersect.glsl`) visits them, so that the CPU
//! reference finds the same hits and counts the same nodes.

use crate::bvh::{BvhChild, BvhNode, TraversalStats};
use crate::geometry::{safe_inverse, Ray};
use crate::tracer::enclosure::EnclosureRecord;

/// What visiting one instance found.
pub(crate) enum Visit {
    /// Nothing closer (or nothing blocking).
    Nothing,
    /// A closer hit at this distance: the farther boxes are cut to it.
    Closer(f32),
    /// The ray is blocked: the walk ends (occlusion queries).
    Blocked,
}

/// The next stop of a walk: a node to open or an instance to visit.
#[derive(Clone, Copy)]
enum Stop {
    Node(u32),
    Instance(u32),
}

/// What a walk asks its caller to visit.
pub(crate) enum Target<'a> {
    /// An instance, through its mesh.
    Instance(u32),
    /// The enclosure, as a closed box: `None` from the caller (no closed box) has it
    /// visited as an instance instead.
    ClosedBox(&'a EnclosureRecord),
}

/// Walk the tree for `ray` in (0, `t_max`), calling `visit(Target::Instance(i), t_max)` for
/// every instance whose box the ray meets before the closest hit so far, as the shader's
/// `trace_instances` does: of a node's two children the nearer next, the farther pushed
/// with its entry distance and dropped when popped if a hit found since ends before it.
/// An enclosure (the root's left child, `TOP_ENCLOSURE`) comes first, offered as a
/// [`Target::ClosedBox`], then the tree over the others (the root's right child); but a
/// single instance inside a closed box comes before the box, as the `ONE_INSTANCE`
/// kernel takes them. Returns
/// true when a visit said [`Visit::Blocked`]. Counts a node per node opened.
pub(crate) fn walk(
    nodes: &[BvhNode],
    ray: &Ray,
    mut t_max: f32,
    stats: &mut TraversalStats,
    mut visit: impl FnMut(Target, f32) -> Option<Visit>,
) -> bool {
    let inv_dir = safe_inverse(ray.dir);
    let mut stack = [(Stop::Node(0), 0.0f32); crate::bvh::STACK_SIZE];
    let mut sp = 0;
    let mut next = Some(Stop::Node(0));
    if let Some(record) = EnclosureRecord::of(nodes) {
        stats.nodes += 1;
        let rest = nodes[0].children()[1];
        if rest.is_leaf() && record.closed_box().is_some() {
            return one_in_a_closed_box(rest, record, ray, inv_dir, t_max, visit);
        }
        next = match visit(Target::ClosedBox(record), t_max) {
            Some(Visit::Blocked) => return true,
            Some(Visit::Closer(t)) => {
                t_max = t;
                None
            }
            Some(Visit::Nothing) => None,
            None => Some(Stop::Instance(record.instance())),
        };
        let entry = rest.bounds.intersect(ray, inv_dir, t_max).filter(|_| !rest.is_empty());
        if let Some(entry) = entry {
            let stop =
                if rest.is_leaf() { Stop::Instance(rest.index) } else { Stop::Node(rest.index) };
            stack[0] = (stop, entry);
            sp = 1;
        }
    }
    loop {
        let stop = match next.take() {
            Some(stop) => stop,
            None => {
                if sp == 0 {
                    return false;
                }
                sp -= 1;
                let (stop, entry) = stack[sp];
                if entry > t_max {
                    continue; // begins beyond the closest hit found since
                }
                stop
            }
        };
        match stop {
            Stop::Instance(i) => match visit(Target::Instance(i), t_max) {
                None | Some(Visit::Nothing) => {}
                Some(Visit::Closer(t)) => t_max = t,
                Some(Visit::Blocked) => return true,
            },
            Stop::Node(node) => {
                stats.nodes += 1;
                let children = nodes[node as usize].children().map(|c| {
                    let entry = if c.is_empty() {
                        f32::INFINITY
                    } else {
                        c.bounds.intersect(ray, inv_dir, t_max).unwrap_or(f32::INFINITY)
                    };
                    let stop =
                        if c.is_leaf() { Stop::Instance(c.index) } else { Stop::Node(c.index) };
                    (stop, entry)
                });
                let [l, r] = children;
                let (near, far) = if r.1 < l.1 { (r, l) } else { (l, r) };
                if far.1 < f32::INFINITY {
                    stack[sp] = far;
                    sp += 1;
                }
                if near.1 < f32::INFINITY {
                    next = Some(near.0);
                }
            }
        }
    }
}

/// The walk over one instance (`leaf`) inside a closed-box enclosure, as the shader's
/// `ONE_INSTANCE` kernel takes it: the instance first, where the ray meets its box, then the
/// enclosure as a closed box, whose wall is not tested where it lies beyond the instance's
/// hit. (The box first cost the framed rows 7-8% on the H200: a ray that meets the model
/// tested the wall behind it too.)
fn one_in_a_closed_box(
    leaf: BvhChild,
    record: &EnclosureRecord,
    ray: &Ray,
    inv_dir: glam::Vec3,
    mut t_max: f32,
    mut visit: impl FnMut(Target, f32) -> Option<Visit>,
) -> bool {
    if leaf.bounds.intersect(ray, inv_dir, t_max).is_some() {
        match visit(Target::Instance(leaf.index), t_max) {
            None | Some(Visit::Nothing) => {}
            Some(Visit::Closer(t)) => t_max = t,
            Some(Visit::Blocked) => return true,
        }
    }
    matches!(visit(Target::ClosedBox(record), t_max), Some(Visit::Blocked))
}
