//! The CPU's walk over the top level: the instances a ray meets, in the order the
//! shader's `trace_instances` (`shaders/intersect.glsl`) visits them, so that the CPU
//! reference finds the same hits and counts the same nodes.

use glam::Vec3;

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
/// every instance whose box (or sphere, [`crate::contract::TOP_SPHERE`]) the ray meets
/// before the closest hit so far, as the shader's `trace_instances` does: of a node's two
/// children the nearer next, the farther pushed with its entry distance and dropped when
/// popped if a hit found since ends before it.
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
        if let Some(entry) = entry(&rest, ray, inv_dir, t_max) {
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
                    let entry = entry(&c, ray, inv_dir, t_max).unwrap_or(f32::INFINITY);
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

/// Where `ray` enters the child (its box, or a sphere leaf's sphere) in (0, `t_max`), as
/// the shader's `child_entry`; None for a miss or an absent child.
fn entry(child: &BvhChild, ray: &Ray, inv_dir: Vec3, t_max: f32) -> Option<f32> {
    if child.is_empty() {
        None
    } else if let Some(sphere) = super::leaf_sphere(child) {
        sphere_entry(ray, sphere, t_max)
    } else {
        child.bounds.intersect(ray, inv_dir, t_max)
    }
}

/// Where `ray` enters the sphere `[centre, radius]` (0 from inside), if it meets it for some
/// t in [0, t_max]; loosely (the shader's `sphere_entry`, step for step): a ray that passes
/// by within rounding may be let in, one that meets the sphere never turned away, and the
/// entry is never later than the true one. From the ray's closest approach to the centre,
/// which keeps its precision far from the sphere (Haines et al., Ray Tracing Gems,
/// chapter 7).
fn sphere_entry(ray: &Ray, sphere: [f32; 4], t_max: f32) -> Option<f32> {
    let [x, y, z, radius] = sphere;
    let oc = ray.origin - Vec3::new(x, y, z);
    let inv_a = 1.0 / ray.dir.dot(ray.dir);
    let tm = -oc.dot(ray.dir) * inv_a;
    let l = oc + tm * ray.dir;
    let r = radius + 1e-5 * (radius + oc.length());
    let h2 = r * r - l.dot(l);
    let dt = (h2.max(0.0) * inv_a).sqrt();
    (h2 >= 0.0 && tm + dt >= 0.0 && tm - dt <= t_max * 1.0001).then(|| (tm - dt).max(0.0))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The ray against the sphere in double precision: the distance by which it misses
    /// (negative: how deep it passes inside), its entry and exit, and the slack a clear
    /// miss must exceed (a hundredth of the radius, and the test's own padding for rays
    /// from far away), as a distance and along the ray.
    fn exact(ray: &Ray, sphere: [f32; 4]) -> (f64, f64, f64, f64, f64) {
        let d = ray.dir.as_dvec3();
        let oc = ray.origin.as_dvec3() - Vec3::new(sphere[0], sphere[1], sphere[2]).as_dvec3();
        let tm = -oc.dot(d) / d.dot(d);
        let closest = (oc + tm * d).length();
        let r = f64::from(sphere[3]);
        let half = (r * r - closest * closest).max(0.0).sqrt() / d.length();
        let slack = 0.01 * r + 1e-4 * oc.length();
        (closest - r, tm - half, tm + half, slack, slack / d.length())
    }

    #[test]
    fn a_sphere_leaf_never_turns_away_a_ray_that_meets_the_sphere_nor_enters_it_late() {
        // Rays from near and far (up to 10^4 radii), with directions of any length (an
        // instance's scale), grazing, missing by a little and passing through.
        let mut seed = 7u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        let (mut met, mut turned_away) = (0, 0);
        for _ in 0..20_000 {
            let radius = 10f32.powf(next() * 6.0 - 3.0);
            let centre = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * radius * 20.0;
            let sphere = [centre.x, centre.y, centre.z, radius];
            let away = radius * 10f32.powf(next() * 4.0);
            let origin = centre + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0 * away;
            // Aim at a point near the sphere's surface: inside, on it, or just outside.
            let aim = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::X);
            let target = centre + aim * radius * (0.9 + 0.2 * next());
            let dir = (target - origin) * 10f32.powf(next() * 4.0 - 2.0);
            if dir.length_squared() == 0.0 || !dir.is_finite() {
                continue;
            }
            let ray = Ray::new(origin, dir);
            let t_max = if next() < 0.5 { f32::INFINITY } else { next() * 2.0 };
            let (miss, enter, exit, slack, slack_t) = exact(&ray, sphere);
            let meets = miss <= 0.0 && exit >= 0.0 && enter <= f64::from(t_max);
            let found = sphere_entry(&ray, sphere, t_max);
            let said = found.is_some();
            assert!(said || !meets, "{ray:?} meets {sphere:?} before {t_max}");
            // The entry found is never later than the true one (0 from inside).
            if let (Some(t), true) = (found, meets) {
                assert!(
                    f64::from(t) <= enter.max(0.0),
                    "{ray:?} enters {sphere:?} at {enter}, not {t}"
                );
            }
            met += usize::from(meets);
            // Clear misses (beside, behind or beyond t_max by more than the slack) are
            // turned away: the test is no constant yes.
            let clear =
                miss > slack || exit < -slack_t || enter > 1.01 * f64::from(t_max) + slack_t;
            turned_away += usize::from(clear && !said);
            assert!(said == meets || !clear, "{ray:?} clearly misses {sphere:?} before {t_max}");
        }
        assert!(met > 3_000 && turned_away > 3_000, "{met} met, {turned_away} turned away");
    }
}
