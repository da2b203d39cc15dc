//! From tobj's models to one `Mesh`: triangulation (quads as the paper splits them,
//! fans beyond), merging all models with their materials, normals from the file or
//! smoothed by position, and locating the line of a non-finite value or of a vertex
//! colour mismatch once tobj's output shows there is one.

use glam::{Vec2, Vec3};

use super::ObjError;
use crate::scene::{Material, Mesh};

/// Number of triangles a tobj mesh makes once triangulated.
fn triangles_in(m: &tobj::Mesh) -> usize {
    if m.face_arities.is_empty() {
        m.indices.len() / 3
    } else {
        m.face_arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum()
    }
}

/// Append the triangles of one tobj mesh, offset by `base`. Quads split as the paper
/// says, (1,2,4) and (2,3,4); larger polygons become fans around their first corner.
fn triangulate(indices: &[u32], arities: &[u32], base: u32, out: &mut Vec<[u32; 3]>) {
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

pub(super) fn build_mesh(text: &str, name: &str, models: &[tobj::Model], mut materials: Vec<Material>) -> Result<Mesh, ObjError> {
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
    // model has them for every vertex exactly when the counts agree.
    let has = |attr: &[f32], width: usize, m: &tobj::Mesh| !m.positions.is_empty() && attr.len() / width == m.positions.len() / 3;
    let with_normals = models.iter().filter(|m| !m.mesh.positions.is_empty()).all(|m| has(&m.mesh.normals, 3, &m.mesh));
    let with_texcoords = models.iter().any(|m| has(&m.mesh.texcoords, 2, &m.mesh));

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
    for model in models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32; // fits: checked against u32 above
        mesh.positions.extend(m.positions.chunks_exact(3).map(Vec3::from_slice));
        if with_normals {
            mesh.normals.extend(m.normals.chunks_exact(3).map(Vec3::from_slice));
        }
        if with_texcoords {
            if has(&m.texcoords, 2, m) {
                mesh.texcoords.extend(m.texcoords.chunks_exact(2).map(Vec2::from_slice));
            } else {
                mesh.texcoords.resize(mesh.positions.len(), Vec2::ZERO);
            }
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

    let models_with_faces = models.iter().filter(|m| !m.mesh.indices.is_empty()).count();
    if with_normals {
        // File normals need not be unit length; a zero one takes the computed normal.
        let file_normals = std::mem::take(&mut mesh.normals);
        let computed = if file_normals.iter().any(|n| n.try_normalize().is_none()) {
            mesh.compute_vertex_normals();
            std::mem::take(&mut mesh.normals)
        } else {
            Vec::new()
        };
        mesh.normals = file_normals.iter().enumerate().map(|(i, n)| n.try_normalize().unwrap_or_else(|| computed[i])).collect();
        mesh.has_file_normals = true;
    } else if models_with_faces > 1 || with_texcoords {
        // tobj splits vertices at every `usemtl`/`o`/`g` and at texture seams: averaging
        // per vertex would leave shading seams there, so average per position instead.
        smooth_normals_by_position(&mut mesh);
    } else {
        mesh.compute_vertex_normals();
    }
    Ok(mesh)
}

/// Area-weighted normals like [`Mesh::compute_vertex_normals`], but shared by all
/// vertices at the same position.
fn smooth_normals_by_position(mesh: &mut Mesh) {
    let mut slots = std::collections::HashMap::with_capacity(mesh.positions.len());
    // `+ 0.0` turns -0.0 into 0.0, so that the two zeros share a slot.
    let slot_of: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let next = slots.len() as u32;
            *slots.entry((*p + 0.0).to_array().map(f32::to_bits)).or_insert(next)
        })
        .collect();
    let mut sums = vec![Vec3::ZERO; slots.len()];
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
                let (has, lacks) = if first_coloured { (first_line, i + 1) } else { (i + 1, first_line) };
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
        assert_eq!(out, [[10, 11, 12], [13, 14, 16], [14, 15, 16], [17, 18, 19], [17, 19, 20], [17, 20, 21]]);
    }

    #[test]
    fn non_finite_values_are_found_on_their_line() {
        let text = "v 0 0 0\nvn 0 0 1\nv 1 0 0 1e-45\nv nan 0 0\n";
        match locate_non_finite(text, "t.obj", [true, false, false]) {
            ObjError::NonFinite { line, what, .. } => assert_eq!((line, what), (3, "a vertex position")),
            other => panic!("{other}"),
        }
    }
}
