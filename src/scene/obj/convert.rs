//! From tobj's models to one `Mesh`: triangulation (quads as the paper splits them,
//! fans beyond), merging all models with their materials, normals from the file or
//! smoothed by position, and locating the line of a non-finite value or of a vertex
//! colour mismatch once tobj's output shows there is one.

use glam::{Vec2, Vec3};

use super::{LoadOptions, ObjError};
use crate::scene::{Material, Mesh};

/// Number of triangles a tobj mesh makes once triangulated.
fn triangles_in(m: &tobj::Mesh) -> usize {
    if m.face_arities.is_empty() {
        m.indices.len() / 3
    } else {
        m.face_arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum()
    }
}

/// An OBJ vertex colour (`v x y z r g b`, 0..1 floats) as RGBA8: scaled, rounded, clamped.
pub(super) fn colour(rgb: [f32; 3]) -> [u8; 4] {
    let [r, g, b] = rgb.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
    [r, g, b, 255]
}

/// Append the triangles of one mesh, offset by `base`. Quads split as the paper
/// says, (1,2,4) and (2,3,4); larger polygons become fans around their first corner.
pub(super) fn triangulate(indices: &[u32], arities: &[u32], base: u32, out: &mut Vec<[u32; 3]>) {
    if arities.is_empty() {
        // tobj drops the arities when every face is a triangle.
        out.extend(indices.chunks_exact(3).map(|c| [c[0] + base, c[1] + base, c[2] + base]));
        return;
    }
    let mut start = 0;
    for &n in arities {
        let n = n as usize;
        let Some(c) = indices.get(start..start + n) else { break };
        start += n;
        let at = |i: usize| c[i] + base;
        match n {
            0..=2 => {} // points and lines: not surfaces
            3 => out.push([at(0), at(1), at(2)]),
            4 => out.extend([[at(0), at(1), at(3)], [at(1), at(2), at(3)]]),
            _ => out.extend((1..n - 1).map(|i| [at(0), at(i), at(i + 1)])),
        }
    }
}

/// What the line feeder learned about the faces that tobj does not keep.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct FaceNotes<'a> {
    /// Where the smoothing group changes: (first face, group); empty without `s` lines.
    pub(super) smoothing: &'a [(usize, u32)],
    /// Faces (file order, ascending) handed to tobj without their texture coordinates.
    pub(super) dropped_texcoords: &'a [usize],
    /// Faces handed to tobj without their normals.
    pub(super) dropped_normals: &'a [usize],
}

pub(super) fn build_mesh(
    text: &str,
    name: &str,
    models: &[tobj::Model],
    mut materials: Vec<Material>,
    notes: FaceNotes,
    options: &LoadOptions,
) -> Result<Mesh, ObjError> {
    let vertex_total: usize = models.iter().map(|m| m.mesh.positions.len() / 3).sum();
    let triangle_total: usize = models.iter().map(|m| triangles_in(&m.mesh)).sum();
    if triangle_total == 0 {
        return Err(ObjError::NoFaces { name: name.to_owned() });
    }
    if u32::try_from(vertex_total).is_err() {
        let reason = format!("{vertex_total} vertices are more than 32-bit indices can address");
        return Err(ObjError::Invalid { name: name.to_owned(), reason });
    }
    // tobj gives a vertex a normal (texcoord) only when its face corner names one, so a
    // model has them for every vertex when the counts agree, for none when there are none,
    // and otherwise the corners in the text say which vertices have them.
    let attributes = vertex_attributes(text, models, notes);
    let with_normals = attributes.iter().any(|a| a.normals != Coverage::None);
    let all_normals = attributes
        .iter()
        .zip(models)
        .all(|(a, m)| a.normals == Coverage::All || m.mesh.positions.is_empty());
    let with_texcoords = attributes.iter().any(|a| a.texcoords != Coverage::None);
    let with_colours = models.iter().any(|m| !m.mesh.vertex_color.is_empty());

    let mut mesh = Mesh {
        name: name.to_owned(),
        positions: Vec::with_capacity(vertex_total),
        normals: Vec::with_capacity(if with_normals { vertex_total } else { 0 }),
        texcoords: Vec::with_capacity(if with_texcoords { vertex_total } else { 0 }),
        triangles: Vec::with_capacity(triangle_total),
        triangle_materials: Vec::with_capacity(triangle_total),
        ..Default::default()
    };
    let mut default_material = None;
    for (model, attrs) in models.iter().zip(&attributes) {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32; // fits: checked against u32 above
        mesh.positions.extend(m.positions.chunks_exact(3).map(Vec3::from_slice));
        if with_normals {
            // Vertices without a file normal get zero: computed below.
            attrs.normals.spread(
                m.normals.chunks_exact(3).map(Vec3::from_slice),
                Vec3::ZERO,
                &mut mesh.normals,
                mesh.positions.len(),
            );
        }
        if with_texcoords {
            attrs.texcoords.spread(
                m.texcoords.chunks_exact(2).map(Vec2::from_slice),
                Vec2::ZERO,
                &mut mesh.texcoords,
                mesh.positions.len(),
            );
        }
        if with_colours {
            // tobj gives every vertex of a file with colours its colour (or fails).
            mesh.colors.extend(m.vertex_color.chunks_exact(3).map(|c| colour([c[0], c[1], c[2]])));
            mesh.colors.resize(mesh.positions.len(), [255; 4]);
        }
        let material = match m.material_id {
            Some(i) if i < materials.len() => i as u32,
            _ => *default_material.get_or_insert_with(|| {
                materials.push(Material::default());
                (materials.len() - 1) as u32
            }),
        };
        triangulate(&m.indices, &m.face_arities, base, &mut mesh.triangles);
        mesh.triangle_materials.resize(mesh.triangles.len(), material);
    }
    mesh.materials = materials;

    let bad = [
        !mesh.positions.iter().all(|p| p.is_finite()),
        !mesh.normals.iter().all(|n| n.is_finite()),
        !mesh.texcoords.iter().all(|t| t.is_finite()),
    ];
    if bad.contains(&true) {
        return Err(locate_non_finite(text, name, bad));
    }

    let groups = (!notes.smoothing.is_empty()).then(|| triangle_groups(models, notes.smoothing));
    let models_with_faces = models.iter().filter(|m| !m.mesh.indices.is_empty()).count();
    let sources = NormalSources { with_normals, all_normals, with_texcoords, models_with_faces };
    finish_normals(&mut mesh, groups.as_deref(), sources, options);
    Ok(mesh)
}

/// What the file gave the mesh's vertices, which decides how its normals are made.
#[derive(Clone, Copy, Debug)]
pub(super) struct NormalSources {
    /// Some vertex has a normal from the file.
    pub(super) with_normals: bool,
    /// Every vertex has one.
    pub(super) all_normals: bool,
    /// Some vertex has a texture coordinate.
    pub(super) with_texcoords: bool,
    /// How many models (runs of faces with one material, object or group) have faces.
    pub(super) models_with_faces: usize,
}

/// The mesh's final normals: the file's (normalised) where every vertex has a usable one,
/// otherwise computed by smoothing group, crease angle or position (see the module docs).
/// `groups` is the smoothing group of every triangle, None without `s` lines.
pub(super) fn finish_normals(
    mesh: &mut Mesh,
    groups: Option<&[u32]>,
    sources: NormalSources,
    options: &LoadOptions,
) {
    let NormalSources { with_normals, all_normals, with_texcoords, models_with_faces } = sources;
    if all_normals && mesh.normals.iter().all(|n| n.try_normalize().is_some()) {
        // File normals need not be unit length.
        mesh.normals.iter_mut().for_each(|n| *n = n.normalize());
        mesh.has_file_normals = true;
    } else if !with_normals && groups.is_none() && options.crease_angle.is_none() {
        if models_with_faces > 1 || with_texcoords {
            // tobj splits vertices at every `usemtl`/`o`/`g` and at texture seams: averaging
            // per vertex would leave shading seams there, so average per position instead.
            smooth_normals_by_position(mesh);
        } else {
            mesh.compute_vertex_normals();
        }
    } else {
        // Some vertices (or all) need computed normals, in smoothing groups or within a
        // crease angle: a vertex used with different normals is split.
        let file_normals = std::mem::take(&mut mesh.normals);
        let crease = if groups.is_some() { None } else { options.crease_angle };
        let corners = corner_normals(mesh, groups, crease);
        let usable = |v: usize| file_normals.get(v).and_then(|n| n.try_normalize());
        apply_corner_normals(mesh, |v, corner| usable(v).unwrap_or(corners[corner]));
        mesh.has_file_normals = all_normals;
    }
}

/// Which of a model's vertices have an attribute (normal or texture coordinate).
#[derive(Clone, Debug, PartialEq)]
enum Coverage {
    All,
    None,
    /// Per vertex, from the face corners that made it.
    Some(Vec<bool>),
}

impl Coverage {
    /// Append one value per vertex to `out` (up to `total` entries): the model's values
    /// to the vertices that have one, in order, `absent` to the others.
    fn spread<T: Copy>(
        &self,
        values: impl Iterator<Item = T>,
        absent: T,
        out: &mut Vec<T>,
        total: usize,
    ) {
        match self {
            Coverage::All => out.extend(values),
            Coverage::None => {}
            Coverage::Some(has) => {
                let mut values = values;
                out.extend(has.iter().map(|&h| {
                    if h {
                        values.next().unwrap_or(absent)
                    } else {
                        absent
                    }
                }));
            }
        }
        out.resize(total, absent);
    }
}

/// Per model: which vertices have a normal and which a texture coordinate.
#[derive(Clone, Debug)]
struct ModelAttributes {
    normals: Coverage,
    texcoords: Coverage,
}

/// The coverage of normals and texture coordinates of every model. Only when a model has
/// some and not all does the text get read again, corner by corner, in step with tobj:
/// models hold the faces in file order, and a vertex is made by the first corner that
/// names its indices.
fn vertex_attributes(text: &str, models: &[tobj::Model], notes: FaceNotes) -> Vec<ModelAttributes> {
    let coverage = |values: usize, width: usize, m: &tobj::Mesh| match values / width {
        0 => Coverage::None,
        n if n == m.positions.len() / 3 => Coverage::All,
        _ => Coverage::Some(Vec::new()),
    };
    let mut out: Vec<ModelAttributes> = models
        .iter()
        .map(|m| ModelAttributes {
            normals: coverage(m.mesh.normals.len(), 3, &m.mesh),
            texcoords: coverage(m.mesh.texcoords.len(), 2, &m.mesh),
        })
        .collect();
    let partial = |a: &ModelAttributes| {
        matches!(a.normals, Coverage::Some(_)) || matches!(a.texcoords, Coverage::Some(_))
    };
    if !out.iter().any(partial) {
        return out;
    }
    let mut faces = face_corners(text, notes);
    for (model, attrs) in models.iter().zip(&mut out) {
        let m = &model.mesh;
        let arities: Vec<u32> = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities.clone()
        };
        if !partial(attrs) {
            faces.by_ref().take(arities.len()).for_each(drop);
            continue;
        }
        let vertices = m.positions.len() / 3;
        let (mut has_vt, mut has_vn) = (Vec::with_capacity(vertices), Vec::with_capacity(vertices));
        let mut indices = m.indices.iter();
        for &n in &arities {
            let corners = faces.next().unwrap_or_default();
            for k in 0..n as usize {
                let Some(&index) = indices.next() else { break };
                if index as usize == has_vt.len() {
                    let (vt, vn) = corners.get(k).copied().unwrap_or((false, false));
                    has_vt.push(vt);
                    has_vn.push(vn);
                }
            }
        }
        // Should the text and tobj disagree, the attribute is left out (normals computed).
        let settle = |coverage: &mut Coverage, has: Vec<bool>, values: usize| {
            if let Coverage::Some(_) = coverage {
                let agrees = has.len() == vertices && has.iter().filter(|&&h| h).count() == values;
                *coverage = if agrees { Coverage::Some(has) } else { Coverage::None };
            }
        };
        settle(&mut attrs.texcoords, has_vt, m.texcoords.len() / 2);
        settle(&mut attrs.normals, has_vn, m.normals.len() / 3);
    }
    out
}

/// Each face of the text, in order, as (names a texture coordinate, names a normal) per
/// corner, after the feeder's dropping of out-of-range ones.
fn face_corners<'t>(
    text: &'t str,
    notes: FaceNotes<'t>,
) -> impl Iterator<Item = Vec<(bool, bool)>> + 't {
    let faces = text.lines().filter_map(|line| {
        let mut words = line.split_whitespace();
        (words.next() == Some("f")).then_some(words)
    });
    let (mut dropped_vt, mut dropped_vn) =
        (notes.dropped_texcoords.iter().peekable(), notes.dropped_normals.iter().peekable());
    faces.enumerate().map(move |(face, corners)| {
        let keep_vt = dropped_vt.next_if_eq(&&face).is_none();
        let keep_vn = dropped_vn.next_if_eq(&&face).is_none();
        corners
            .map(|corner| {
                let mut parts = corner.split('/').skip(1);
                let vt = parts.next().is_some_and(|t| !t.is_empty());
                let vn = parts.next().is_some_and(|t| !t.is_empty());
                (vt && keep_vt, vn && keep_vn)
            })
            .collect()
    })
}

/// The smoothing group of every triangle, in the order [`triangulate`] makes them.
fn triangle_groups(models: &[tobj::Model], smoothing: &[(usize, u32)]) -> Vec<u32> {
    let mut groups = Vec::new();
    let mut runs = smoothing.iter().peekable();
    let (mut face, mut group) = (0usize, 0u32);
    for model in models {
        let m = &model.mesh;
        let triangles_of = |n: u32| (n as usize).saturating_sub(2);
        let faces: Box<dyn Iterator<Item = usize>> = if m.face_arities.is_empty() {
            Box::new(std::iter::repeat_n(1, m.indices.len() / 3))
        } else {
            Box::new(m.face_arities.iter().map(|&n| triangles_of(n)))
        };
        for triangles in faces {
            while let Some(&(_, g)) = runs.next_if(|(first, _)| *first <= face) {
                group = g;
            }
            groups.extend(std::iter::repeat_n(group, triangles));
            face += 1;
        }
    }
    groups
}

/// A computed normal for every triangle corner (index `3 * triangle + k`): the sum of the
/// area-weighted normals of the faces at the corner's position that are smoothed with its
/// face, normalised. With `groups`, those are the faces of the same nonzero group (group
/// 0 is flat); with a crease angle, those whose normal is within it of the corner's face;
/// otherwise all of them.
fn corner_normals(mesh: &Mesh, groups: Option<&[u32]>, crease_angle_deg: Option<f32>) -> Vec<Vec3> {
    let faces: Vec<Vec3> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| mesh.positions[k as usize]);
            (b - a).cross(c - a) // length = twice the area: the weight
        })
        .collect();
    let slot_of = position_slots(&mesh.positions);
    let slot_count = slot_of.iter().map(|&s| s as usize + 1).max().unwrap_or(0);
    let corner_slot =
        |corner: usize| slot_of[mesh.triangles[corner / 3][corner % 3] as usize] as usize;
    let corners = 3 * mesh.triangles.len();
    let normal = |v: Vec3| v.normalize_or(Vec3::Y);

    if let Some(groups) = groups {
        let mut sums: std::collections::HashMap<(u32, u32), Vec3> =
            std::collections::HashMap::new();
        for corner in 0..corners {
            let group = groups[corner / 3];
            if group != 0 {
                *sums.entry((corner_slot(corner) as u32, group)).or_default() += faces[corner / 3];
            }
        }
        return (0..corners)
            .map(|corner| {
                let (t, group) = (corner / 3, groups[corner / 3]);
                if group == 0 {
                    normal(faces[t])
                } else {
                    normal(sums[&(corner_slot(corner) as u32, group)])
                }
            })
            .collect();
    }

    let Some(angle) = crease_angle_deg else {
        let mut sums = vec![Vec3::ZERO; slot_count];
        for corner in 0..corners {
            sums[corner_slot(corner)] += faces[corner / 3];
        }
        return (0..corners).map(|corner| normal(sums[corner_slot(corner)])).collect();
    };

    // The corners at each position, for comparing the faces that meet there.
    let mut start = vec![0usize; slot_count + 1];
    for corner in 0..corners {
        start[corner_slot(corner) + 1] += 1;
    }
    for s in 0..slot_count {
        start[s + 1] += start[s];
    }
    let mut fill = start.clone();
    let mut at_slot = vec![0u32; corners];
    for corner in 0..corners {
        let s = corner_slot(corner);
        at_slot[fill[s]] = corner as u32;
        fill[s] += 1;
    }
    let cos_limit = angle.to_radians().cos();
    let units: Vec<Vec3> = faces.iter().map(|f| f.normalize_or_zero()).collect();
    let mut out = vec![Vec3::ZERO; corners];
    for s in 0..slot_count {
        let here = &at_slot[start[s]..start[s + 1]];
        for &corner in here {
            let t = corner as usize / 3;
            let sum = here.iter().fold(Vec3::ZERO, |sum, &other| {
                let o = other as usize / 3;
                if o == t || units[t].dot(units[o]) > cos_limit {
                    sum + faces[o]
                } else {
                    sum
                }
            });
            out[corner as usize] = normal(sum);
        }
    }
    out
}

/// The same number for vertices at the same position (numbered in order of first use).
fn position_slots(positions: &[Vec3]) -> Vec<u32> {
    let mut slots = std::collections::HashMap::with_capacity(positions.len());
    // `+ 0.0` turns -0.0 into 0.0, so that the two zeros share a slot.
    positions
        .iter()
        .map(|p| {
            let next = slots.len() as u32;
            *slots.entry((*p + 0.0).to_array().map(f32::to_bits)).or_insert(next)
        })
        .collect()
}

/// Give every triangle corner the normal `normal_of(vertex, corner)`: a vertex keeps its
/// index for the first normal it gets, and is copied (position and texture coordinate)
/// for each other normal it gets, so that triangles on either side of a hard edge do not
/// share a vertex.
fn apply_corner_normals(mesh: &mut Mesh, normal_of: impl Fn(usize, usize) -> Vec3) {
    let mut normals: Vec<Option<Vec3>> = vec![None; mesh.positions.len()];
    let mut copies: std::collections::HashMap<(u32, [u32; 3]), u32> =
        std::collections::HashMap::new();
    for t in 0..mesh.triangles.len() {
        for k in 0..3 {
            let v = mesh.triangles[t][k];
            let n = normal_of(v as usize, 3 * t + k);
            match normals[v as usize] {
                None => normals[v as usize] = Some(n),
                Some(first)
                    if first.to_array().map(f32::to_bits) == n.to_array().map(f32::to_bits) => {}
                Some(_) => {
                    let copy =
                        *copies.entry((v, n.to_array().map(f32::to_bits))).or_insert_with(|| {
                            mesh.positions.push(mesh.positions[v as usize]);
                            if !mesh.texcoords.is_empty() {
                                mesh.texcoords.push(mesh.texcoords[v as usize]);
                            }
                            if !mesh.colors.is_empty() {
                                mesh.colors.push(mesh.colors[v as usize]);
                            }
                            normals.push(Some(n));
                            (mesh.positions.len() - 1) as u32
                        });
                    mesh.triangles[t][k] = copy;
                }
            }
        }
    }
    mesh.normals = normals.into_iter().map(|n| n.unwrap_or(Vec3::Y)).collect();
}

/// Area-weighted normals like [`Mesh::compute_vertex_normals`], but shared by all
/// vertices at the same position.
fn smooth_normals_by_position(mesh: &mut Mesh) {
    let slot_of = position_slots(&mesh.positions);
    let mut sums = vec![Vec3::ZERO; slot_of.iter().map(|&s| s as usize + 1).max().unwrap_or(0)];
    for tri in &mesh.triangles {
        let [a, b, c] = tri.map(|k| mesh.positions[k as usize]);
        let face = (b - a).cross(c - a); // length = twice the area: the weight
        for &k in tri {
            sums[slot_of[k as usize] as usize] += face;
        }
    }
    mesh.normals = slot_of.iter().map(|&s| sums[s as usize].normalize_or(Vec3::Y)).collect();
    mesh.has_file_normals = false;
}

/// The error for the first `v`, `vn` or `vt` line (of the kinds flagged in `bad`) that
/// holds a NaN or infinity. Only runs once the loaded data was found to contain one.
fn locate_non_finite(text: &str, name: &str, bad: [bool; 3]) -> ObjError {
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let (what, width) = match words.next() {
            Some("v") if bad[0] => ("a vertex position", 3),
            Some("vn") if bad[1] => ("a normal", 3),
            Some("vt") if bad[2] => ("a texture coordinate", 2),
            _ => continue,
        };
        let values: Vec<f32> = words.map_while(|w| w.parse().ok()).collect();
        let mut coords: Vec<f32> = values.iter().copied().take(width).collect();
        if width == 3 && values.len() == 4 && what == "a vertex position" {
            // `v x y z w`: tobj divides by w, which can overflow to infinity.
            coords.iter_mut().for_each(|c| *c /= values[3]);
        }
        if coords.iter().any(|c| !c.is_finite()) {
            return ObjError::NonFinite { name: name.to_owned(), line: i + 1, what };
        }
    }
    let reason = "it contains a coordinate that is not a finite number".to_owned();
    ObjError::Invalid { name: name.to_owned(), reason }
}

/// The error for `v` lines that mix colours: tobj only notices when a face uses a vertex
/// past the last colour, so find the first vertex that differs from the first one.
pub(super) fn locate_colour_mismatch(text: &str, name: &str) -> ObjError {
    let mut first = None;
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        // x y z [w] or x y z r g b
        let coloured = words.count() >= 6;
        match first {
            None => first = Some((i + 1, coloured)),
            Some((first_line, first_coloured)) if coloured != first_coloured => {
                let (has, lacks) =
                    if first_coloured { (first_line, i + 1) } else { (i + 1, first_line) };
                let reason =
                    format!("the vertex on line {lacks} has no colour while the one on line {has} has; give every vertex a colour or none");
                return ObjError::Parse { name: name.to_owned(), line: i + 1, reason };
            }
            Some(_) => {}
        }
    }
    let reason = "some `v` lines carry a vertex colour and others do not".to_owned();
    ObjError::Invalid { name: name.to_owned(), reason }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_follow_the_paper_and_polygons_fan() {
        let mut out = Vec::new();
        // A triangle, a quad and a pentagon, offset by 10.
        triangulate(&[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11], &[3, 4, 5], 10, &mut out);
        assert_eq!(
            out,
            [[10, 11, 12], [13, 14, 16], [14, 15, 16], [17, 18, 19], [17, 19, 20], [17, 20, 21]]
        );
    }

    #[test]
    fn non_finite_values_are_found_on_their_line() {
        let text = "v 0 0 0\nvn 0 0 1\nv 1 0 0 1e-45\nv nan 0 0\n";
        match locate_non_finite(text, "t.obj", [true, false, false]) {
            ObjError::NonFinite { line, what, .. } => {
                assert_eq!((line, what), (3, "a vertex position"))
            }
            other => panic!("{other}"),
        }
    }
}
