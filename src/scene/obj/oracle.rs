//! The loader as it was before the parallel parse: tobj reading the text through the line
//! feeder (`line_feeder.rs` in OBJ mode), and tobj's models turned into one `Mesh`. Kept
//! as the oracle that the tests, benches and the fuzzer compare the parallel loader with,
//! so it is built only for them: under `cfg(test)` or the `dev` feature, which they turn
//! on (Cargo.toml). The loader itself shares only `convert.rs` and the MTL reading.

use std::cell::RefCell;
use std::collections::HashSet;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::convert::{colour, finish_normals, triangulate, NormalSources};
use super::line_feeder::LineFeeder;
use super::mtl::{convert_materials, MaterialLibraries};
use super::{quote_name, warn, warn_dropped, LoadOptions, LoadedObj, ObjError};
use crate::scene::{Material, Mesh};

/// The loader as it was before the parallel parse: tobj reading through the line feeder.
/// Kept as the oracle that tests (and the fuzzer) compare the parallel loader with.
pub fn load_obj_from_str_tobj(
    text: &str,
    name: &str,
    base_dir: Option<&Path>,
    options: &LoadOptions,
) -> Result<LoadedObj, ObjError> {
    // A UTF-8 byte-order mark would glue itself to the first keyword.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let libs = MaterialLibraries {
        base_dir,
        obj_name: name,
        loaded: RefCell::default(),
        warnings: RefCell::default(),
    };
    let mut feeder = LineFeeder::new(text, name, true);

    let tobj_options = tobj::LoadOptions {
        single_index: true,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let parsed = tobj::load_obj_buf(&mut feeder, &tobj_options, |mtl| libs.load(mtl));
    let (models, materials) = match parsed {
        Ok(ok) => ok,
        Err(e) => return Err(feeder.into_error(e)),
    };
    let usemtl_names = std::mem::take(&mut feeder.usemtl_names);
    let mut warnings = libs.warnings.into_inner();
    warn_dropped(
        &mut warnings,
        name,
        &feeder.dropped_texcoords,
        "texture coordinate",
        "texture coordinates",
        "drawn without texture coordinates",
    );
    warn_dropped(
        &mut warnings,
        name,
        &feeder.dropped_normals,
        "normal",
        "normals",
        "drawn with computed normals",
    );
    // Errors of the libraries were already turned into warnings, one per library.
    let materials = materials.unwrap_or_default();
    let materials = convert_materials(&materials, &libs.loaded.into_inner(), &mut warnings);

    let known: HashSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    for missing in usemtl_names.iter().filter(|n| !known.contains(*n)) {
        warn(
            &mut warnings,
            format!("{name}: `usemtl {}` names no material of the loaded libraries; its faces use the default material", quote_name(missing)),
        );
    }

    let notes = FaceNotes {
        smoothing: &feeder.smoothing,
        dropped_texcoords: &feeder.dropped_texcoords.faces,
        dropped_normals: &feeder.dropped_normals.faces,
    };
    let mesh = build_mesh(text, name, &models, materials, notes, options)?;
    Ok(LoadedObj { mesh, warnings })
}

/// Number of triangles a tobj mesh makes once triangulated.
fn triangles_in(m: &tobj::Mesh) -> usize {
    if m.face_arities.is_empty() {
        m.indices.len() / 3
    } else {
        m.face_arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum()
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

#[cfg(test)]
mod tests {
    use super::*;

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
