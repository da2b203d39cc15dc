//! The parallel reader of the common binary PLY layout (see [`read_binary_in_parallel`]).

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::{Attributes, Body, ColourColumns, Header, Property, Scalar};

/// Positions, the other vertex attributes and triangles of a binary file read on every core.
pub(super) type Columns = (Vec<Vec3>, Attributes, Vec<[u32; 3]>);

/// The common binary file (a vertex element of scalars, then a face element of triangles
/// alone) read with its records split between threads: every record has the same size, so
/// each is found by its index (a 10M-triangle file took 0.9 s on one thread). None when the
/// file is anything else or anything in it is wrong: `read_body` then reads it, and says what.
pub(super) fn read_binary_in_parallel(
    header: &Header,
    body: &[u8],
    big_endian: bool,
) -> Option<Columns> {
    let [vertex, face] = header.elements.as_slice() else { return None };
    if vertex.name != "vertex" || face.name != "face" {
        return None;
    }
    let scalars: Vec<Scalar> = vertex
        .properties
        .iter()
        .map(|(_, p)| if let Property::Scalar(s) = p { Some(*s) } else { None })
        .collect::<Option<_>>()?;
    let [(list_name, Property::List { count, item })] = face.properties.as_slice() else {
        return None;
    };
    if list_name != "vertex_indices" && list_name != "vertex_index" {
        return None;
    }
    let stride: usize = scalars.iter().map(|s| s.size()).sum();
    let record = count.size() + 3 * item.size();
    let (vertices, faces) =
        (usize::try_from(vertex.count).ok()?, usize::try_from(face.count).ok()?);
    let vertex_bytes = body.get(..vertices.checked_mul(stride)?)?;
    let face_bytes = body.get(vertex_bytes.len()..)?.get(..faces.checked_mul(record)?)?;
    let read =
        |data: &[u8], kind: Scalar| Body::Binary { data, pos: 0, big_endian }.next(kind).ok();
    let offsets: Vec<usize> =
        scalars.iter().scan(0, |at, s| Some(std::mem::replace(at, *at + s.size()))).collect();
    let value = |rec: &[u8], k: usize| read(&rec[offsets[k]..], scalars[k]).unwrap_or(0.0) as f32;
    let column = |names: &[&str]| vertex.find(names);
    let xyz = [column(&["x"])?, column(&["y"])?, column(&["z"])?];
    let n = [column(&["nx"]), column(&["ny"]), column(&["nz"])];
    let uv = [
        column(&["u", "s", "texture_u", "texture_s"]),
        column(&["v", "t", "texture_v", "texture_t"]),
    ];
    let records = || vertex_bytes.par_chunks_exact(stride.max(1)).take(vertices);
    let positions: Vec<Vec3> = records().map(|r| Vec3::from(xyz.map(|k| value(r, k)))).collect();
    if stride == 0 || !positions.par_iter().all(|p| p.is_finite()) {
        return None;
    }
    let normals = match n {
        [Some(a), Some(b), Some(c)] => {
            records().map(|r| Vec3::new(value(r, a), value(r, b), value(r, c))).collect()
        }
        _ => Vec::new(),
    };
    let texcoords = match uv {
        [Some(a), Some(b)] => records().map(|r| Vec2::new(value(r, a), value(r, b))).collect(),
        _ => Vec::new(),
    };
    // A colour property that is a list is an error `read_body` reports.
    let colors = match ColourColumns::of(vertex).ok()? {
        Some(columns) => records()
            .map(|r| columns.rgba(|k| read(&r[offsets[k]..], scalars[k]).unwrap_or(0.0)))
            .collect(),
        None => Vec::new(),
    };
    // Collected as an indexed iterator (each record written in place by its thread) with a
    // flag for a bad one: collecting `Option`s would gather pieces and join them on one thread.
    let bad = std::sync::atomic::AtomicBool::new(false);
    let triangles: Vec<[u32; 3]> = face_bytes
        .par_chunks_exact(record)
        .map(|r| {
            let corner = |k: usize| {
                read(&r[count.size() + k * item.size()..], *item)
                    .filter(|&c| c >= 0.0 && c < vertices as f64)
                    .map(|c| c as u32)
            };
            let triangle = (read(r, *count) == Some(3.0))
                .then(|| Some([corner(0)?, corner(1)?, corner(2)?]))
                .flatten();
            triangle.unwrap_or_else(|| {
                bad.store(true, std::sync::atomic::Ordering::Relaxed);
                [0; 3]
            })
        })
        .collect();
    if bad.into_inner() {
        return None;
    }
    Some((positions, Attributes { normals, texcoords, colors }, triangles))
}
