//! Fuzz target: arbitrary bytes -> the PLY reader (`scene::ply::load_ply_from_bytes`), in
//! all three encodings. Nothing a file holds may panic or allocate what the file cannot
//! back (a header's counts are checked against the body first), and the readers that run
//! on every core give what the plain serial reader gives, with every line its own piece too.
#![no_main]

use libfuzzer_sys::fuzz_target;
use meshtracer::scene::obj::{LoadedObj, ObjError};
use meshtracer::scene::ply::{load_ply_from_bytes, load_ply_from_bytes_chunked};

/// A load as comparable text: the error, or the mesh's arrays bit for bit.
fn fingerprint(loaded: &Result<LoadedObj, ObjError>) -> String {
    match loaded {
        Err(e) => e.to_string(),
        Ok(LoadedObj { mesh: m, warnings }) => {
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let p: Vec<f32> = m.positions.iter().flat_map(|p| p.to_array()).collect();
            let n: Vec<f32> = m.normals.iter().flat_map(|p| p.to_array()).collect();
            let t: Vec<f32> = m.texcoords.iter().flat_map(|p| p.to_array()).collect();
            format!(
                "{:?} {:?} {:?} {:?} {:?} {warnings:?}",
                bits(&p),
                bits(&n),
                bits(&t),
                m.colors,
                m.triangles
            )
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let loaded = load_ply_from_bytes(data, "fuzz.ply");
    if let Ok(loaded) = &loaded {
        let mesh = &loaded.mesh;
        // What loads is a consistent mesh: every index in range, one normal per vertex.
        assert_eq!(mesh.normals.len(), mesh.positions.len());
        assert!(mesh.texcoords.is_empty() || mesh.texcoords.len() == mesh.positions.len());
        assert_eq!(mesh.triangle_materials.len(), mesh.triangles.len());
        assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < mesh.positions.len()));
    }
    let plain = fingerprint(&load_ply_from_bytes_chunked(data, "fuzz.ply", None));
    assert_eq!(fingerprint(&loaded), plain, "the parallel reader differs");
    let cut = fingerprint(&load_ply_from_bytes_chunked(data, "fuzz.ply", Some(1)));
    assert_eq!(cut, plain, "the parallel reader, a line a piece, differs");
});
