//! What the loader (and its tobj oracle, `oracle.rs`) share on the way to one `Mesh`:
//! triangulation (quads as the paper splits them, fans beyond), vertex colours, normals
//! from the file or computed (by smoothing group, crease angle or position), and locating
//! the line of a vertex colour mismatch.

use glam::Vec3;
use rayon::prelude::*;

use super::{LoadOptions, ObjError};
use crate::scene::Mesh;

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
    // On every core: these are passes over every vertex of the mesh.
    if all_normals && mesh.normals.par_iter().all(|n| n.try_normalize().is_some()) {
        // File normals need not be unit length.
        mesh.normals.par_iter_mut().for_each(|n| *n = n.normalize());
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
}
