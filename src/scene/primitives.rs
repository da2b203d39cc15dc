//! Procedural meshes: the four models of the paper's Table 1 (built like 3ds Max's
//! primitives, with the same face counts), a finely tessellated torus knot for scaling
//! benchmarks, and an OBJ writer to export any of them.
//!
//! Every generator returns a closed, consistently wound mesh (counter-clockwise seen from
//! outside), with no seams: each vertex appears once, so every edge is shared by exactly
//! two triangles. All models are unit-sized: every vertex lies within distance 1 of the
//! origin, and the farthest is at (or very near) 1. The y axis is up.

use std::f32::consts::{PI, TAU};
use std::io::{self, Write};
use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use super::{Material, Mesh};

/// The four models of the paper's Table 1 (3ds Max-style primitives).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PaperModel {
    /// An icosahedron subdivided once: 42 vertices, 80 faces.
    Geosphere,
    /// A (2,3) torus knot (trefoil), 32 segments along the knot and 8 around the tube:
    /// 256 vertices, 512 faces.
    TorusKnot,
    /// A UV sphere of 32 segments by 16 rings: 2 poles + 15 rings of 32 = 482 vertices, 960 faces.
    Sphere,
    /// A closed cylinder of 24 sides and 24 height segments: 1200 faces as in the paper.
    /// The paper lists 600 vertices, but a closed seamless mesh with 1200 triangles has
    /// 602 by Euler's formula (V - E + F = 2, E = 3F/2): 25 rings of 24 + 2 cap centres.
    Cylinder,
}

impl PaperModel {
    /// All four, in the order of Table 1.
    pub const ALL: [PaperModel; 4] =
        [PaperModel::Geosphere, PaperModel::TorusKnot, PaperModel::Sphere, PaperModel::Cylinder];

    /// Short lowercase name, used on the command line and as the mesh and material name.
    pub fn name(self) -> &'static str {
        match self {
            PaperModel::Geosphere => "geosphere",
            PaperModel::TorusKnot => "torusknot",
            PaperModel::Sphere => "sphere",
            PaperModel::Cylinder => "cylinder",
        }
    }

    /// The model called `s`, ignoring case; "torus-knot", "torus_knot" and "torus knot" also work.
    pub(crate) fn from_name(s: &str) -> Option<Self> {
        let key: String = s.trim().chars().filter(|c| !matches!(c, '-' | '_' | ' ')).collect();
        Self::ALL.into_iter().find(|m| m.name().eq_ignore_ascii_case(&key))
    }

    /// The (vertices, faces) that Table 1 of the paper lists.
    pub fn paper_counts(self) -> (usize, usize) {
        match self {
            PaperModel::Geosphere => (42, 80),
            PaperModel::TorusKnot => (256, 512),
            PaperModel::Sphere => (482, 960),
            PaperModel::Cylinder => (600, 1200),
        }
    }

    /// The generated model, unit-sized (every vertex within radius 1 of the origin).
    pub fn mesh(self) -> Mesh {
        let mut mesh = match self {
            PaperModel::Geosphere => geosphere(1),
            PaperModel::TorusKnot => torus_knot(2, 3, 32, 8),
            PaperModel::Sphere => uv_sphere(32, 16),
            PaperModel::Cylinder => cylinder(24, 24),
        };
        name_mesh(&mut mesh, self.name());
        mesh
    }
}

/// Name a mesh and give it its single default material, named the same.
fn name_mesh(mesh: &mut Mesh, name: &str) {
    mesh.name = name.to_owned();
    mesh.materials = vec![Material { name: name.to_owned(), ..Material::default() }];
    mesh.triangle_materials = vec![0; mesh.triangles.len()];
}

/// A mesh from generated data: one default material, normals as given.
fn finish(name: &str, positions: Vec<Vec3>, normals: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    let mut mesh = Mesh { positions, normals, triangles, ..Default::default() };
    name_mesh(&mut mesh, name);
    mesh
}

/// An icosahedron whose faces are split in four `subdivisions` times, the new vertices
/// pushed out onto the unit sphere (3ds Max's geosphere). 0 -> 12 v / 20 f,
/// 1 -> 42 v / 80 f; in general 10·4ⁿ + 2 vertices and 20·4ⁿ faces.
pub(crate) fn geosphere(subdivisions: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    #[rustfmt::skip]
    let corners = [
        (-1.0, t, 0.0), (1.0, t, 0.0), (-1.0, -t, 0.0), (1.0, -t, 0.0),
        (0.0, -1.0, t), (0.0, 1.0, t), (0.0, -1.0, -t), (0.0, 1.0, -t),
        (t, 0.0, -1.0), (t, 0.0, 1.0), (-t, 0.0, -1.0), (-t, 0.0, 1.0),
    ];
    let mut positions: Vec<Vec3> =
        corners.iter().map(|&(x, y, z)| Vec3::new(x, y, z).normalize()).collect();
    #[rustfmt::skip]
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
        [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
        [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        // Each edge is split once, whichever of its two triangles gets there first.
        let mut midpoints = std::collections::HashMap::with_capacity(triangles.len() * 3 / 2);
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut finer = Vec::with_capacity(triangles.len() * 4);
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            finer.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = finer;
    }
    // On the unit sphere the position is the normal.
    let normals = positions.clone();
    finish("geosphere", positions, normals, triangles)
}

/// A UV sphere of unit radius: a vertex at each pole and `rings - 1` rings of `segments`
/// vertices between them; fans close the poles. 32 x 16 -> 482 v / 960 f. In general
/// `segments·(rings-1) + 2` vertices and `2·segments·(rings-1)` faces (minimum 3 x 2).
pub fn uv_sphere(segments: u32, rings: u32) -> Mesh {
    let (segments, rings) = (segments.max(3), rings.max(2));
    let mut positions = Vec::with_capacity((segments * (rings - 1) + 2) as usize);
    positions.push(Vec3::Y);
    for k in 1..rings {
        let (sin_t, cos_t) = (PI * k as f32 / rings as f32).sin_cos();
        for s in 0..segments {
            let (sin_p, cos_p) = (TAU * s as f32 / segments as f32).sin_cos();
            positions.push(Vec3::new(sin_t * cos_p, cos_t, sin_t * sin_p));
        }
    }
    positions.push(Vec3::NEG_Y);
    let south = positions.len() as u32 - 1;

    let ring = |k: u32, s: u32| 1 + (k - 1) * segments + s % segments;
    let mut triangles = Vec::with_capacity((2 * segments * (rings - 1)) as usize);
    for s in 0..segments {
        triangles.push([0, ring(1, s + 1), ring(1, s)]);
    }
    for k in 1..rings - 1 {
        for s in 0..segments {
            quad(&mut triangles, ring(k, s), ring(k, s + 1), ring(k + 1, s), ring(k + 1, s + 1));
        }
    }
    for s in 0..segments {
        triangles.push([ring(rings - 1, s), ring(rings - 1, s + 1), south]);
    }
    let normals = positions.clone();
    finish("sphere", positions, normals, triangles)
}

/// Two outward-facing triangles for the quad whose upper edge runs `a -> b` (in the
/// direction of increasing azimuth) above the lower edge `c -> d`.
fn quad(out: &mut Vec<[u32; 3]>, a: u32, b: u32, c: u32, d: u32) {
    out.extend([[a, b, d], [a, d, c]]);
}

/// A closed cylinder around the y axis, radius and half-height both 1/√2 (so its rims
/// touch the unit sphere): `height_segments + 1` rings of `sides` vertices, and a centre
/// vertex on each cap. The caps share their rims with the side, so the mesh is closed and
/// seamless: `sides·(height_segments+1) + 2` vertices and `2·sides·(height_segments+1)`
/// faces. 24 x 24 -> 602 v / 1200 f (the paper's 600 vertices cannot close 1200 faces:
/// V - E + F = 2 with E = 3F/2 gives V = 602). Minimum 3 sides, 1 segment.
///
/// Normals are the area-weighted vertex normals: radial on the side, and at a rim
/// dominated by the cap's larger triangles, which keeps the caps looking flat.
pub(crate) fn cylinder(sides: u32, height_segments: u32) -> Mesh {
    let (sides, segments) = (sides.max(3), height_segments.max(1));
    let r = std::f32::consts::FRAC_1_SQRT_2;
    let mut positions = Vec::with_capacity((sides * (segments + 1) + 2) as usize);
    for k in 0..=segments {
        let y = r * (1.0 - 2.0 * k as f32 / segments as f32);
        for s in 0..sides {
            let (sin_p, cos_p) = (TAU * s as f32 / sides as f32).sin_cos();
            positions.push(Vec3::new(r * cos_p, y, r * sin_p));
        }
    }
    let top = positions.len() as u32;
    positions.extend([Vec3::new(0.0, r, 0.0), Vec3::new(0.0, -r, 0.0)]);
    let bottom = top + 1;

    let ring = |k: u32, s: u32| k * sides + s % sides;
    let mut triangles = Vec::with_capacity((2 * sides * (segments + 1)) as usize);
    for s in 0..sides {
        triangles.push([top, ring(0, s + 1), ring(0, s)]);
    }
    for k in 0..segments {
        for s in 0..sides {
            quad(&mut triangles, ring(k, s), ring(k, s + 1), ring(k + 1, s), ring(k + 1, s + 1));
        }
    }
    for s in 0..sides {
        triangles.push([ring(segments, s), ring(segments, s + 1), bottom]);
    }
    let mut mesh = finish("cylinder", positions, Vec::new(), triangles);
    mesh.compute_vertex_normals();
    mesh
}

/// A (p, q) torus knot swept by a round tube: the knot winds `p` times around the y axis
/// and `q` times through the torus hole ((2, 3) is the trefoil). `segments` rings along
/// the knot, `sides` vertices around the tube; the ends join, so there is no seam:
/// `segments·sides` vertices and twice as many faces. (2, 3, 32, 8) -> 256 v / 512 f.
/// Minimum 3 segments and 3 sides; p and q should be coprime for a knot (else the tube
/// runs over itself).
pub(crate) fn torus_knot(p: u32, q: u32, segments: u32, sides: u32) -> Mesh {
    tube_knot("torusknot", p.max(1), q.max(1), segments.max(3), sides.max(3))
}

/// A finely tessellated torus knot with at least `min_triangles` triangles (for scaling benchmarks, millions included).
///
/// The trefoil again, with rings spaced so that the quads are close to square (good
/// triangles for a BVH); 10 million triangles take a fraction of a second.
pub fn large_torus_knot(min_triangles: usize) -> Mesh {
    let (segments, sides) = large_knot_rings(min_triangles);
    let mut mesh = tube_knot("torusknot", 2, 3, segments, sides);
    let name = format!("torusknot-{}", mesh.triangle_count());
    name_mesh(&mut mesh, &name);
    mesh
}

/// Rings along the knot and quads around its tube for at least `min_triangles`.
fn large_knot_rings(min_triangles: usize) -> (u32, u32) {
    // The trefoil is about 8 times longer than its tube's circumference.
    const LENGTH_OVER_CIRCUMFERENCE: f64 = 8.0;
    let quads = min_triangles.div_ceil(2).max(1) as f64;
    let sides = (quads / LENGTH_OVER_CIRCUMFERENCE).sqrt().ceil().max(8.0);
    let segments = (quads / sides).ceil().max(32.0);
    (segments as u32, sides as u32)
}

/// How many triangles [`large_torus_knot`] makes for `min_triangles`, without making them.
pub fn large_torus_knot_triangles(min_triangles: usize) -> usize {
    let (segments, sides) = large_knot_rings(min_triangles);
    2 * segments as usize * sides as usize
}

/// Radius of the torus the knot lies on, radius of the knot's swing around that torus's
/// core, and the tube radius: the trefoil's strands stay more than a tube apart.
const KNOT_R: f32 = 1.0;
const KNOT_A: f32 = 0.5;
const KNOT_TUBE: f32 = 0.25;

/// Point on the knot and its (unnormalised) tangent at parameter `phi` in [0, 2π).
fn knot_curve(p: f32, q: f32, phi: f32) -> (Vec3, Vec3) {
    let (sin_q, cos_q) = (q * phi).sin_cos();
    let (sin_p, cos_p) = (p * phi).sin_cos();
    let rho = KNOT_R + KNOT_A * cos_q;
    let d_rho = -KNOT_A * q * sin_q;
    let point = Vec3::new(rho * cos_p, KNOT_A * sin_q, rho * sin_p);
    let tangent = Vec3::new(
        d_rho * cos_p - rho * p * sin_p,
        KNOT_A * q * cos_q,
        d_rho * sin_p + rho * p * cos_p,
    );
    (point, tangent)
}

/// The tube around a torus knot, scaled to unit radius. The frame around the curve is a
/// function of the curve parameter alone (tangent, and the position vector made normal
/// to it), so the last ring meets the first without a twist.
fn tube_knot(name: &str, p: u32, q: u32, segments: u32, sides: u32) -> Mesh {
    let (n_seg, n_side) = (segments as usize, sides as usize);
    let around: Vec<(f32, f32)> =
        (0..sides).map(|j| (TAU * j as f32 / sides as f32).sin_cos()).collect();

    let mut positions = vec![Vec3::ZERO; n_seg * n_side];
    let mut normals = vec![Vec3::ZERO; n_seg * n_side];
    positions.par_chunks_mut(n_side).zip(normals.par_chunks_mut(n_side)).enumerate().for_each(
        |(i, (pos, nrm))| {
            // f64 for the angle: at millions of segments f32 would space the rings unevenly.
            let phi = (std::f64::consts::TAU * i as f64 / n_seg as f64) as f32;
            let (center, tangent) = knot_curve(p as f32, q as f32, phi);
            let t = tangent.normalize();
            // The position vector is never parallel to the tangent: the tangent always has a
            // component around the y axis, the position never does.
            let b = t.cross(center).normalize();
            let n = b.cross(t);
            for ((point, normal), &(sin_a, cos_a)) in
                pos.iter_mut().zip(nrm.iter_mut()).zip(&around)
            {
                *normal = n * cos_a + b * sin_a;
                *point = center + *normal * KNOT_TUBE;
            }
        },
    );
    // The tube surface's normal is exactly the direction from the curve: keep it.
    let scale = positions.par_iter().map(|p| p.length()).reduce(|| 0.0, f32::max);
    positions.par_iter_mut().for_each(|p| *p /= scale);

    // (n, b, t) is right-handed, so the ring runs counter-clockwise seen from ahead:
    // going around first, then along, faces outward.
    let mut triangles = vec![[0u32; 3]; 2 * n_seg * n_side];
    triangles.par_chunks_mut(2 * n_side).enumerate().for_each(|(i, tris)| {
        let next = (i + 1) % n_seg;
        for j in 0..n_side {
            let k = (j + 1) % n_side;
            let at = |seg: usize, side: usize| (seg * n_side + side) as u32;
            let (a, b, c, d) = (at(i, j), at(i, k), at(next, j), at(next, k));
            tris[2 * j] = [a, b, d];
            tris[2 * j + 1] = [a, d, c];
        }
    });
    finish(name, positions, normals, triangles)
}

/// Write `mesh` as a Wavefront OBJ: `v`, `vn` (and `vt` when the mesh has texture
/// coordinates), one `f` per triangle referring to the same index for all attributes;
/// vertex colours, when the mesh has them, as `v x y z r g b`.
/// Floats are written in their shortest exact form, so reading the file back gives the
/// same numbers. Written through `files::write_atomic`: a failed write keeps the old file.
pub fn write_obj(mesh: &Mesh, path: &Path) -> io::Result<()> {
    crate::files::write_atomic(path, |out| Ok(write_obj_to(mesh, out)?))
        .map_err(|e| io::Error::other(format!("{e:#}")))
}

/// [`write_obj`]'s text.
fn write_obj_to(mesh: &Mesh, out: &mut impl Write) -> io::Result<()> {
    writeln!(
        out,
        "# {}: {} vertices, {} triangles (written by meshtracer)",
        mesh.name,
        mesh.vertex_count(),
        mesh.triangle_count()
    )?;
    if mesh.colors.len() == mesh.positions.len() && !mesh.colors.is_empty() {
        // `v x y z r g b`, colours 0..1 (alpha has no place in OBJ). Nine digits bring
        // every byte back when the reader scales by 255 and rounds.
        for (p, c) in mesh.positions.iter().zip(&mesh.colors) {
            let [r, g, b] = [c[0], c[1], c[2]].map(|v| v as f64 / 255.0);
            writeln!(out, "v {} {} {} {r:.9} {g:.9} {b:.9}", p.x, p.y, p.z)?;
        }
    } else {
        for p in &mesh.positions {
            writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
        }
    }
    for n in &mesh.normals {
        writeln!(out, "vn {} {} {}", n.x, n.y, n.z)?;
    }
    for t in &mesh.texcoords {
        writeln!(out, "vt {} {}", t.x, t.y)?;
    }
    let with_normals = mesh.normals.len() == mesh.positions.len();
    let with_texcoords = mesh.texcoords.len() == mesh.positions.len();
    for tri in &mesh.triangles {
        out.write_all(b"f")?;
        for i in tri.map(|i| i + 1) {
            match (with_texcoords, with_normals) {
                (false, false) => write!(out, " {i}")?,
                (false, true) => write!(out, " {i}//{i}")?,
                (true, false) => write!(out, " {i}/{i}")?,
                (true, true) => write!(out, " {i}/{i}/{i}")?,
            }
        }
        out.write_all(b"\n")?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;

    /// Closed, consistently wound, outward-facing, no degenerate triangles, unit-sized,
    /// normals unit length and on the outer side of their triangles.
    fn check_closed_outward(mesh: &Mesh) {
        let what = &mesh.name;
        // Each directed edge exactly once, and its reverse exactly once: every edge has
        // exactly two triangles, which traverse it in opposite directions.
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for &[a, b, c] in &mesh.triangles {
            for e in [(a, b), (b, c), (c, a)] {
                *edges.entry(e).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "{what}: directed edge {a}->{b} used {n} times");
            assert_eq!(
                edges.get(&(b, a)),
                Some(&1),
                "{what}: edge {a}-{b} is not shared by exactly two triangles"
            );
        }
        // Every vertex is used.
        let mut used = vec![false; mesh.vertex_count()];
        mesh.triangles.iter().flatten().for_each(|&i| used[i as usize] = true);
        assert!(used.iter().all(|&u| u), "{what}: unused vertices");

        let mut volume = 0.0f64;
        for (i, tri) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = mesh.corners(i);
            let cross = (b - a).cross(c - a);
            assert!(cross.length() > 1e-7, "{what}: triangle {i} {tri:?} is degenerate");
            volume += f64::from(a.dot(b.cross(c))) / 6.0;
            // Smooth normals lean the same way as the face they belong to.
            for &k in tri {
                assert!(
                    mesh.normals[k as usize].dot(cross) > 0.0,
                    "{what}: normal of vertex {k} points inward"
                );
            }
        }
        assert!(volume > 0.0, "{what}: signed volume {volume} (wound inward?)");
        assert_eq!(mesh.normals.len(), mesh.vertex_count());
        assert!(
            mesh.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4),
            "{what}: normals not unit length"
        );
        let radius = mesh.positions.iter().map(|p| p.length()).fold(0.0, f32::max);
        assert!(radius <= 1.0 + 1e-5 && radius > 0.95, "{what}: not unit-sized (radius {radius})");
        assert_eq!(mesh.triangle_materials.len(), mesh.triangle_count());
        assert_eq!(mesh.materials.len(), 1);
    }

    #[test]
    fn paper_models_match_table_1() {
        for model in PaperModel::ALL {
            let mesh = model.mesh();
            let (v, f) = model.paper_counts();
            assert_eq!(mesh.triangle_count(), f, "{}", model.name());
            let expected_v = if model == PaperModel::Cylinder { 602 } else { v };
            assert_eq!(mesh.vertex_count(), expected_v, "{}", model.name());
            assert_eq!(mesh.name, model.name());
            assert_eq!(mesh.materials[0].name, model.name());
            check_closed_outward(&mesh);
        }
    }

    #[test]
    fn generators_stay_closed_at_other_resolutions() {
        check_closed_outward(&geosphere(0));
        check_closed_outward(&geosphere(3));
        check_closed_outward(&uv_sphere(3, 2));
        check_closed_outward(&uv_sphere(17, 9));
        // (A 3-sided prism is closed too, but its smooth normals cannot all lean outward
        // of every face they touch: 120° between neighbouring sides is too much.)
        check_closed_outward(&cylinder(4, 1));
        check_closed_outward(&cylinder(40, 3));
        check_closed_outward(&torus_knot(3, 5, 120, 12));
        assert_eq!(geosphere(2).triangle_count(), 320);
        assert_eq!(geosphere(2).vertex_count(), 162);
    }

    #[test]
    fn names_round_trip() {
        for model in PaperModel::ALL {
            assert_eq!(PaperModel::from_name(model.name()), Some(model));
            assert_eq!(PaperModel::from_name(&model.name().to_uppercase()), Some(model));
        }
        for alias in ["torus-knot", "Torus_Knot", "torus knot"] {
            assert_eq!(PaperModel::from_name(alias), Some(PaperModel::TorusKnot), "{alias}");
        }
        assert_eq!(PaperModel::from_name("cube"), None);
        assert_eq!(PaperModel::from_name(""), None);
    }

    #[test]
    fn knot_tube_does_not_run_into_itself() {
        // Points of the curve further apart along it than the tube is wide must stay more
        // than a tube diameter apart, or the surface would self-intersect.
        let n = 720;
        let samples: Vec<Vec3> =
            (0..n).map(|i| knot_curve(2.0, 3.0, TAU * i as f32 / n as f32).0).collect();
        let step = samples[0].distance(samples[1]);
        let near = (4.0 * KNOT_TUBE / step).ceil() as usize;
        let mut closest = f32::INFINITY;
        for i in 0..n {
            for j in i + near..n.min(i + n - near) {
                closest = closest.min(samples[i].distance(samples[j]));
            }
        }
        assert!(
            closest > 2.0 * KNOT_TUBE,
            "strands {closest} apart, tube diameter {}",
            2.0 * KNOT_TUBE
        );
    }

    #[test]
    fn large_torus_knot_reaches_the_requested_size() {
        for min in [1, 1000, 250_000] {
            let mesh = large_torus_knot(min);
            assert!(mesh.triangle_count() >= min, "{min}: got {}", mesh.triangle_count());
            // Not wildly more than asked for (beyond the minimum resolution).
            assert!(
                mesh.triangle_count() <= (min * 11 / 10).max(2 * 8 * 32),
                "{min}: got {}",
                mesh.triangle_count()
            );
        }
        check_closed_outward(&large_torus_knot(50_000));
    }

    #[test]
    fn written_obj_lists_every_vertex_and_face() {
        let mesh = PaperModel::Geosphere.mesh();
        let path =
            std::env::temp_dir().join(format!("meshtracer-write-{}.obj", std::process::id()));
        write_obj(&mesh, &path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 42);
        assert_eq!(text.lines().filter(|l| l.starts_with("vn ")).count(), 42);
        assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 80);
        let [a, b, c] = mesh.triangles[0].map(|i| i + 1);
        assert!(text.contains(&format!("\nf {a}//{a} {b}//{b} {c}//{c}\n")));
    }
}
