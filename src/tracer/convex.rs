//! Convex meshes. A convex mesh lies behind the plane of each of its triangles, so a ray
//! that leaves one of its triangles from outside (lifted off it along the normal that
//! faces where the ray came from, and heading away from its plane: a mirror bounce or an
//! AO ray) cannot meet the mesh again. Both tracers then skip that instance for the next
//! ray: a bounce off one of the paper's geospheres used to enter its own instance, walk
//! its tree and test a few triangles, all for nothing (docs/BENCHMARKS.md, "Thirty-seventh
//! session").
//!
//! Which side is outside is read off the winding: [`winding`] finds whether every vertex
//! lies behind every triangle's plane as `cross(e1, e2)` faces ([`CONVEX_OUTWARD`]) or in
//! front of it ([`CONVEX_INWARD`]); a mesh wound both ways, or not convex, gets 0 and is
//! never skipped.

use glam::DVec3;

use crate::contract::{CONVEX_INWARD, CONVEX_OUTWARD};
use crate::scene::Mesh;

/// Meshes of more triangles are not tested (the test is every vertex against every
/// triangle's plane: 4,096 triangles take about 10 ms on one core): they keep 0.
pub(crate) const MAX_TRIANGLES: usize = 4096;

/// How far in front of a triangle's plane a vertex may lie and still count as behind it,
/// as a share of the mesh's diagonal: a flat face's corners (a cylinder's side, a cube's
/// two triangles a face) round off their common plane by up to a few 1e-6 once turned or
/// moved from the origin in single floats. A tenth of the rays' least lift off a surface
/// (1e-4 of the scene's extent, `FrameParams::ray_epsilon`), so a skipped instance hides
/// no hit beyond that lift.
const TOLERANCE: f64 = 1e-5;

/// The mesh's convexity code for `GpuMesh::convex`: [`CONVEX_OUTWARD`], [`CONVEX_INWARD`],
/// or 0 for a mesh that is not convex, is wound both ways, has a triangle too thin for the
/// tracers to hit (`records::triangle_record` zeroes its edges), has no triangles or more
/// than [`MAX_TRIANGLES`].
pub(crate) fn winding(mesh: &Mesh) -> u32 {
    if mesh.triangle_count() == 0 || mesh.triangle_count() > MAX_TRIANGLES {
        return 0;
    }
    let bounds = mesh.bounds();
    let tolerance = TOLERANCE * f64::from(bounds.max.distance(bounds.min));
    let vertices: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    // Whether every vertex can still lie behind (outward) or in front of (inward) every
    // plane seen so far.
    let (mut outward, mut inward) = (true, true);
    for corners in &mesh.triangles {
        let [a, b, c] = corners.map(|k| vertices[k as usize]);
        let (e1, e2) = (b - a, c - a);
        let n = e1.cross(e2);
        // The tracers' own test for a triangle they skip (records::triangle_record).
        if n.length() <= 1e-7 * e1.length() * e2.length() {
            return 0;
        }
        let n = n.normalize();
        // The triangle's own corners too: they lie on its plane, well within the tolerance.
        for v in &vertices {
            let height = n.dot(*v - a);
            outward &= height <= tolerance;
            inward &= height >= -tolerance;
        }
        if !outward && !inward {
            return 0;
        }
    }
    // A flat mesh passes both ways: either side of it is outside.
    if outward {
        CONVEX_OUTWARD
    } else {
        CONVEX_INWARD
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};

    use super::*;
    use crate::scene::paper::mirror_box_mesh;
    use crate::scene::primitives::PaperModel;

    /// `mesh` with every triangle's winding turned.
    fn turned(mut mesh: Mesh) -> Mesh {
        for t in &mut mesh.triangles {
            t.swap(1, 2);
        }
        mesh
    }

    #[test]
    fn the_papers_round_models_are_convex_and_the_knot_is_not() {
        for model in [PaperModel::Geosphere, PaperModel::Sphere, PaperModel::Cylinder] {
            let mesh = model.mesh();
            assert_eq!(winding(&mesh), CONVEX_OUTWARD, "{}", model.name());
            assert_eq!(winding(&turned(mesh)), CONVEX_INWARD, "{} turned", model.name());
        }
        assert_eq!(winding(&PaperModel::TorusKnot.mesh()), 0);
    }

    #[test]
    fn the_mirror_box_faces_in() {
        assert_eq!(winding(&mirror_box_mesh(4.0)), CONVEX_INWARD);
    }

    #[test]
    fn a_mesh_wound_both_ways_a_dent_or_a_sliver_is_not_convex() {
        let mut mixed = PaperModel::Geosphere.mesh();
        mixed.triangles[7].swap(1, 2);
        assert_eq!(winding(&mixed), 0, "one triangle wound the other way");

        // One vertex pushed in below its neighbours (a third of the radius): the faces
        // around it now dent.
        let mut dented = PaperModel::Geosphere.mesh();
        dented.positions[5] *= 0.7;
        assert_eq!(winding(&dented), 0, "dented");
        // ... and pushed out past the planes of the faces beyond its neighbours.
        let mut bulged = PaperModel::Geosphere.mesh();
        bulged.positions[5] *= 1.5;
        assert_eq!(winding(&bulged), 0, "bulged");

        let mut sliver = PaperModel::Geosphere.mesh();
        let [a, b, _] = sliver.triangles[3];
        sliver.triangles[3][2] = if sliver.triangles[3][0] == a { b } else { a };
        assert_eq!(winding(&sliver), 0, "a triangle with two equal corners");
    }

    #[test]
    fn empty_and_oversized_meshes_are_not_tested() {
        let mut empty = PaperModel::Geosphere.mesh();
        empty.triangles.clear();
        assert_eq!(winding(&empty), 0);
        // Convex, but past the limit.
        let fine = crate::scene::primitives::geosphere(4);
        assert!(fine.triangle_count() > MAX_TRIANGLES);
        assert_eq!(winding(&fine), 0);
        assert_eq!(winding(&crate::scene::primitives::geosphere(3)), CONVEX_OUTWARD);
    }

    #[test]
    fn convexity_survives_any_placement_of_the_vertices() {
        // A turn, a mirror and a stretch of the vertices keep a convex mesh convex; a
        // mirror flips which way its triangles face.
        let mesh = PaperModel::Cylinder.mesh();
        let place = |m: Affine3A| {
            let mut placed = mesh.clone();
            placed.positions.iter_mut().for_each(|p| *p = m.transform_point3(*p));
            winding(&placed)
        };
        let turn = Affine3A::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let stretch = Affine3A::from_scale(Vec3::new(3.0, 0.2, 1.0));
        let mirror = Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        assert_eq!(place(turn * stretch), CONVEX_OUTWARD);
        assert_eq!(place(Affine3A::from_translation(Vec3::splat(5.0)) * turn), CONVEX_OUTWARD);
        // Far from its origin for its size, the flat faces' corners round off their planes
        // by more than the tolerance: not claimed convex (no instance skipped).
        assert_eq!(place(Affine3A::from_translation(Vec3::splat(1e3)) * turn), 0);
        assert_eq!(place(mirror * turn), CONVEX_INWARD);
    }

    #[test]
    fn skipping_the_instance_left_behind_changes_no_pixel_and_saves_work() {
        // Seven geospheres in the mirror box and one alone in it (two bounces: rays leave
        // the spheres and walls alike), and three turned and scaled ones under the AO
        // view, traced by the CPU reference with the meshes' convexity and again with it
        // cleared.
        use crate::render_settings::{Accel, Aov, BvhLayout, RenderSettings};
        use crate::scene::paper::{prepare_mesh, scattered_scene, LightOrbit};
        use crate::tracer::{cpu, FrameParams, PackedScene};
        let mut model = PaperModel::Geosphere.mesh();
        prepare_mesh(&mut model);
        for (copies, seed, aov) in [(7, 0, Aov::Color), (1, 0, Aov::Color), (3, 5, Aov::Ao)] {
            let scene = scattered_scene(model.clone(), copies, seed, LightOrbit::default());
            let mut packed = PackedScene::new(&scene);
            assert_eq!(packed.top_level.meshes[0].convex, CONVEX_OUTWARD);
            assert_eq!(packed.top_level.meshes[1].convex, CONVEX_INWARD, "the mirror box");
            for bvh in [BvhLayout::Binary, BvhLayout::Wide] {
                let settings = |aov| RenderSettings {
                    width: 40,
                    height: 40,
                    bounces: 2,
                    accel: Accel::Bvh,
                    bvh,
                    aov,
                    ..RenderSettings::default()
                };
                let frame = FrameParams::new(&scene, settings(aov));
                let cost = FrameParams::new(&scene, settings(Aov::Cost));
                let skipping = (cpu::render(&packed, &frame), cpu::render(&packed, &cost));
                let convex: Vec<u32> = packed.top_level.meshes.iter().map(|m| m.convex).collect();
                packed.top_level.meshes.iter_mut().for_each(|m| m.convex = 0);
                let visiting = (cpu::render(&packed, &frame), cpu::render(&packed, &cost));
                packed.top_level.meshes.iter_mut().zip(convex).for_each(|(m, c)| m.convex = c);
                let what = format!("{copies} copies, {aov:?}, {bvh:?}");
                let differ = skipping.0.pixels.iter().zip(&visiting.0.pixels);
                assert_eq!(differ.filter(|(a, b)| a != b).count(), 0, "{what}");
                let work = |image: &crate::tracer::Image| -> f32 {
                    image.pixels.iter().map(|p| p[0] + p[1]).sum()
                };
                // The cost view counts the bounces' rays (the AO view's own rays are not
                // in it); every copy seen sends rays off its outside.
                assert!(work(&skipping.1) < 0.95 * work(&visiting.1), "{what}");
            }
        }
    }
}
