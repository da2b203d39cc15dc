//! The OBJ loader from the outside: the paper's parsing rules (3.1), real-world features
//! (materials, textures, several objects), every class of bad input, and the paper's
//! models written to `assets/` and read back.
//!
//! Fixture files live in `tests/data/obj/`; everything else is inline text.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use meshtracer::scene::obj::{
    load_obj, load_obj_from_str, load_obj_with, LoadOptions, LoadedObj, ObjError,
};
use meshtracer::scene::primitives::{write_obj, PaperModel};
use meshtracer::scene::Mesh;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/obj").join(name)
}

fn load(text: &str) -> LoadedObj {
    load_obj_from_str(text, "test.obj", None).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(text: &str) -> ObjError {
    match load_obj_from_str(text, "test.obj", None) {
        Ok(_) => panic!("loaded, but should have failed:\n{text}"),
        Err(e) => e,
    }
}

/// The triangles as corner positions, so tests do not depend on vertex order.
fn triangle_corners(mesh: &Mesh) -> Vec<[Vec3; 3]> {
    (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect()
}

const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

// --- The paper's parsing rules ---------------------------------------------------------

#[test]
fn quad_splits_into_124_and_234() {
    let mesh = load(&format!("{SQUARE}f 1 2 3 4\n")).mesh;
    let [p1, p2, p3, p4] = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)];
    assert_eq!(triangle_corners(&mesh), [[p1, p2, p4], [p2, p3, p4]]);
    assert_eq!(mesh.vertex_count(), 4);
}

#[test]
fn polygon_with_more_corners_becomes_a_fan() {
    let text = "v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5\n";
    let mesh = load(text).mesh;
    let p = [v(0., 0., 0.), v(2., 0., 0.), v(3., 1., 0.), v(1., 2., 0.), v(-1., 1., 0.)];
    assert_eq!(
        triangle_corners(&mesh),
        [[p[0], p[1], p[2]], [p[0], p[2], p[3]], [p[0], p[3], p[4]]]
    );
}

#[test]
fn negative_indices_count_back_from_the_last_vertex() {
    let absolute =
        load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n").mesh;
    let relative =
        load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n").mesh;
    assert_eq!(triangle_corners(&relative), triangle_corners(&absolute));
    assert_eq!(relative.triangle_count(), 2);
    assert_eq!(relative.corners(1)[0], v(0., 0., 1.));
}

#[test]
fn every_corner_form_is_read() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\n";

    let plain = load(&format!("{head}f 1 2 3\n")).mesh;
    assert!(plain.texcoords.is_empty() && !plain.has_file_normals);

    let with_vt = load(&format!("{head}f 1/1 2/2 3/3\n")).mesh;
    assert!(!with_vt.has_file_normals);
    assert_eq!(with_vt.texcoords.len(), 3);
    let uv_of = |m: &Mesh, p: Vec3| m.texcoords[m.positions.iter().position(|&q| q == p).unwrap()];
    assert_eq!(uv_of(&with_vt, v(1., 0., 0.)), Vec2::new(1., 0.));

    let with_vn = load(&format!("{head}f 1//1 2//1 3//1\n")).mesh;
    assert!(with_vn.has_file_normals && with_vn.texcoords.is_empty());
    // File normals are normalised.
    assert!(with_vn.normals.iter().all(|&n| n == Vec3::Z));

    // A zero file normal takes the computed one.
    let zero = load(&format!("{head}vn 0 0 0\nf 1//1 2//2 3//1\n")).mesh;
    assert!(zero.has_file_normals);
    assert!(zero.normals.iter().all(|&n| n == Vec3::Z), "{:?}", zero.normals);

    let full = load(&format!("{head}f 1/1/1 2/2/1 3/3/1\n")).mesh;
    assert!(full.has_file_normals);
    assert_eq!(full.texcoords.len(), full.vertex_count());
    assert_eq!(uv_of(&full, v(0., 1., 0.)), Vec2::new(0., 1.));
}

#[test]
fn faces_without_normals_get_computed_ones_and_the_others_keep_the_files() {
    // The second face has no normals: its corners get the computed one, the first face's
    // keep the file's (even where they share a position).
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 1 0 0\nf 1//1 2//1 3//1\nf 2 4 3\n";
    let mesh = load(text).mesh;
    assert!(!mesh.has_file_normals, "not every vertex has a file normal");
    let corner_normals = |t: usize| mesh.triangles[t].map(|k| mesh.normals[k as usize]);
    assert_eq!(corner_normals(0), [Vec3::X; 3]);
    assert!(corner_normals(1).iter().all(|n| (*n - Vec3::Z).length() < 1e-6), "{:?}", mesh.normals);
}

#[test]
fn objects_and_groups_merge_into_one_mesh_in_file_order() {
    let text = "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\
                g second\nv 0 0 5\nv 1 0 5\nv 0 1 5\nv 1 1 5\nf 4 5 7 6\n\
                o third\nf 1 2 4\n";
    let mesh = load(text).mesh;
    assert_eq!(mesh.triangle_count(), 4);
    let first_z: Vec<f32> = triangle_corners(&mesh).iter().map(|t| t[0].z).collect();
    assert_eq!(first_z, [0.0, 5.0, 5.0, 0.0]);
    // tobj keeps vertices per object, so a shared vertex appears in each that uses it.
    assert_eq!(mesh.vertex_count(), 3 + 4 + 3);
    assert_eq!(mesh.triangle_materials, [0; 4]);
    assert_eq!(mesh.materials.len(), 1);
}

#[test]
fn lines_and_points_are_not_triangles() {
    let mesh = load(&format!("{SQUARE}l 1 2 3\np 4\nf 1 2 3\n")).mesh;
    assert_eq!(mesh.triangle_count(), 1);
}

#[test]
fn windows_line_endings_comments_and_a_bom_are_fine() {
    let mesh =
        load("\u{feff}# comment\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\ns off\r\nf 1 2 3\r\n").mesh;
    assert_eq!(mesh.triangle_count(), 1);
    assert_eq!(mesh.corners(0)[1], v(1., 0., 0.));
}

// --- Materials ----------------------------------------------------------------------

#[test]
fn usemtl_assigns_materials_from_the_mtl() {
    let loaded = load_obj(&data("cube.obj")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let mesh = &loaded.mesh;
    assert_eq!(mesh.materials.len(), 2);
    let (red, blue) = (&mesh.materials[0], &mesh.materials[1]);
    assert_eq!(red.name, "red");
    assert_eq!(red.diffuse, v(0.8, 0.1, 0.1));
    assert_eq!(red.specular, v(0.2, 0.25, 0.3));
    assert_eq!(red.shininess, 64.0);
    assert_eq!(red.mirror, 1.0);
    // Resolved next to the .mtl (in materials/), not next to the .obj.
    assert_eq!(
        red.diffuse_texture.as_ref().and_then(|t| t.path()),
        Some(data("materials/checker.png").as_path())
    );
    assert_eq!((blue.name.as_str(), blue.diffuse, blue.shininess), ("blue", v(0.1, 0.2, 0.9), 8.0));
    assert_eq!(blue.diffuse_texture, None);
    // Three quads of each, two triangles per quad.
    assert_eq!(mesh.triangle_materials, [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1]);
}

#[test]
fn missing_mtl_is_a_warning_and_the_default_material_is_used() {
    let loaded = load_obj(&data("missing_mtl.obj")).unwrap();
    assert_eq!(loaded.mesh.triangle_count(), 1);
    assert_eq!(loaded.mesh.materials.len(), 1);
    assert_eq!(loaded.mesh.materials[0].diffuse, meshtracer::scene::Material::default().diffuse);
    assert_eq!(loaded.mesh.triangle_materials, [0]);
    assert!(
        loaded.warnings.iter().any(|w| w.contains("does-not-exist.mtl")),
        "{:?}",
        loaded.warnings
    );
    // And `usemtl shiny` found nothing to use.
    assert!(loaded.warnings.iter().any(|w| w.contains("usemtl shiny")), "{:?}", loaded.warnings);
}

#[test]
fn missing_texture_is_a_warning() {
    let loaded = load_obj(&data("missing_texture.obj")).unwrap();
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(loaded.warnings[0].contains("not-there.png"), "{}", loaded.warnings[0]);
    let material = &loaded.mesh.materials[0];
    assert_eq!(material.name, "painted");
    assert_eq!(material.diffuse_texture, None);
    // `Kd 0 0 0` meant "the texture supplies the colour": without it, not black.
    assert_ne!(material.diffuse, Vec3::ZERO);
    assert_eq!(material.shininess, 16.0);
}

#[test]
fn mtllib_without_a_folder_is_a_warning() {
    let loaded =
        load_obj_from_str("mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "inline.obj", None)
            .unwrap();
    assert_eq!(loaded.mesh.materials.len(), 1);
    assert!(
        loaded.warnings.iter().any(|w| w.contains("inline.obj") && w.contains("x.mtl")),
        "{:?}",
        loaded.warnings
    );
}

#[test]
fn malformed_mtl_colours_do_not_stop_the_load() {
    // tobj panics on a `Kd` with fewer than three numbers; the loader must not.
    let dir = std::env::temp_dir().join(format!("meshtracer-mtl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("odd.mtl"), "newmtl grey\nKd 0.25\nKs 1 2\nNs 5\n").unwrap();
    let obj = "mtllib odd.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl grey\nf 1 2 3\n";
    let loaded = load_obj_from_str(obj, "odd.obj", Some(&dir)).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let grey = &loaded.mesh.materials[0];
    assert_eq!(
        (grey.name.as_str(), grey.diffuse, grey.shininess),
        ("grey", Vec3::splat(0.25), 5.0)
    );
    assert!(loaded.warnings.iter().any(|w| w.contains("odd.mtl line 3")), "{:?}", loaded.warnings);
}

// --- Normals ------------------------------------------------------------------------

#[test]
fn computed_normals_point_outward_on_a_closed_cube() {
    let mesh = load_obj(&data("cube.obj")).unwrap().mesh;
    assert!(!mesh.has_file_normals);
    // Each material gets its own copy of the corners it uses (tobj splits at `usemtl`)...
    assert_eq!(mesh.vertex_count(), 16);
    // ...yet the copies share one smooth normal: no shading seam between the materials.
    for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
        // Outward: into the corner's own octant (area weighting favours the faces whose
        // two triangles both touch the corner, so it is not exactly the diagonal).
        assert!((n.length() - 1.0).abs() < 1e-5, "corner {p}: normal {n}");
        assert!((*n * *p).cmpgt(Vec3::ZERO).all(), "corner {p}: normal {n} does not point outward");
        for (q, m) in mesh.positions.iter().zip(&mesh.normals) {
            assert!(p != q || n == m, "corner {p}: copies have normals {n} and {m}");
        }
    }
    // The quads' split kept their winding: the signed volume is the cube's.
    let volume: f32 = (0..mesh.triangle_count())
        .map(|i| {
            let [a, b, c] = mesh.corners(i);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    assert!((volume - 8.0).abs() < 1e-4, "volume {volume}");
}

/// The normal of each corner of triangle `t`, and the triangle's own (face) normal.
fn corner_and_face_normals(mesh: &Mesh, t: usize) -> ([Vec3; 3], Vec3) {
    let [a, b, c] = mesh.corners(t);
    (mesh.triangles[t].map(|k| mesh.normals[k as usize]), (b - a).cross(c - a).normalize())
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn faces_naming_normals_the_file_never_defines_get_computed_ones() {
    let loaded = load_obj(&data("missing_normals.obj")).unwrap();
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    let w = &loaded.warnings[0];
    assert!(w.contains("missing_normals.obj line 18: face normal index 1 is out of range (the file has 0 normals so far)"), "{w}");
    assert!(w.contains("the face and 5 more like it are drawn with computed normals"), "{w}");
    let mesh = loaded.mesh;
    assert_eq!(mesh.triangle_count(), 12);
    assert!(!mesh.has_file_normals);
    // The texture coordinates stay.
    assert_eq!(mesh.texcoords.len(), mesh.vertex_count());
    // The same cube without the normal indices loads to the very same mesh.
    let text = std::fs::read_to_string(data("missing_normals.obj")).unwrap();
    let stripped: String = text
        .lines()
        .map(|l| {
            if l.starts_with("f ") {
                l.split(' ')
                    .map(|c| c.rsplit_once('/').map_or(c, |(head, _)| head))
                    .collect::<Vec<_>>()
                    .join(" ")
            } else {
                l.to_owned()
            }
        })
        .map(|l| l + "\n")
        .collect();
    let plain = load(&stripped).mesh;
    assert_eq!(
        (plain.positions, plain.normals, plain.texcoords, plain.triangles),
        (mesh.positions, mesh.normals, mesh.texcoords, mesh.triangles)
    );
}

#[test]
fn smoothing_groups_decide_which_faces_share_a_computed_normal() {
    let mesh = load_obj(&data("smoothing_groups.obj")).unwrap().mesh;
    assert!(!mesh.has_file_normals);
    assert_eq!(mesh.triangle_count(), 12);
    for t in 0..mesh.triangle_count() {
        let (corners, face) = corner_and_face_normals(&mesh, t);
        let positions = mesh.corners(t);
        if face.y.abs() > 0.5 {
            // Top (s 2, alone in its group) and bottom (s off): flat, hard edges all round.
            assert!(
                corners.iter().all(|&n| n == face),
                "triangle {t}: {corners:?} should all be {face}"
            );
        } else {
            // Sides (s 1): each corner averages the two sides that meet there (weighted by
            // the areas of their triangles at the corner), level since the top and bottom
            // take no part, pointing out between the two sides.
            for (n, p) in corners.iter().zip(positions) {
                assert!(
                    n.y == 0.0 && n.x * p.x > 0.1 && n.z * p.z > 0.1,
                    "triangle {t} corner {p}: {n}"
                );
            }
        }
    }
    // Each of the 8 corners is used with three normals: a side one, the top's or the
    // bottom's, so the mesh has 16 vertices.
    assert_eq!(mesh.vertex_count(), 16);
    // Without the `s` lines, the same box is smooth all over: no flat top.
    let text = std::fs::read_to_string(data("smoothing_groups.obj")).unwrap();
    let blob = load(
        &text
            .lines()
            .filter(|l| !l.starts_with("s "))
            .map(|l| format!("{l}\n"))
            .collect::<String>(),
    )
    .mesh;
    let (top, face) = corner_and_face_normals(&blob, 8);
    assert!(face.y > 0.99 && top.iter().all(|n| n.y < 0.9), "{top:?}");
}

#[test]
fn faces_before_the_first_smoothing_group_and_in_group_zero_are_flat() {
    // Two triangles folded along their shared edge: smooth in one group, flat otherwise.
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\n";
    let folded = |statements: [&str; 2]| {
        load(&format!("{head}{}f 1 2 3\n{}f 2 4 3\n", statements[0], statements[1])).mesh
    };
    for (statements, smooth) in [
        (["s 1\n", ""], true),
        (["s 4\n", "s 4\n"], true),
        (["s 1\n", "s 2\n"], false),
        (["", "s 1\n"], false),
        (["s 0\n", ""], false),
        (["s off\n", ""], false),
        (["s 1\n", "s off\n"], false),
    ] {
        let mesh = folded(statements);
        let (corners, face) = corner_and_face_normals(&mesh, 0);
        // Corner 2 of the first triangle (vertex 2) lies on the fold.
        assert_eq!(!close(corners[1], face), smooth, "{statements:?}: {corners:?} against {face}");
    }
}

#[test]
fn a_crease_angle_keeps_sharp_edges_in_files_without_normals_or_groups() {
    let cube = data("cube.obj");
    let smooth = load_obj(&cube).unwrap().mesh;
    let creased = load_obj_with(&cube, &LoadOptions { crease_angle: Some(30.0) }).unwrap().mesh;
    let wide = load_obj_with(&cube, &LoadOptions { crease_angle: Some(100.0) }).unwrap().mesh;
    for t in 0..creased.triangle_count() {
        let (corners, face) = corner_and_face_normals(&creased, t);
        assert!(
            corners.iter().all(|n| close(*n, face)),
            "triangle {t}: {corners:?} should all be {face}"
        );
        // Above 90 degrees every edge of the cube is smoothed, as without the option.
        assert_eq!(
            corner_and_face_normals(&wide, t).0,
            corner_and_face_normals(&smooth, t).0,
            "triangle {t}"
        );
    }
    assert_eq!(creased.vertex_count(), 24, "each corner of the cube with three normals");
    // Shallow bends smooth within the angle: a strip of three squares bent by 20 degrees
    // and then 80.
    let (c20, s20, c80, s80) = (
        20f32.to_radians().cos(),
        20f32.to_radians().sin(),
        100f32.to_radians().cos(),
        100f32.to_radians().sin(),
    );
    let text = format!(
        "v 0 0 0\nv 0 1 0\nv 1 0 0\nv 1 1 0\nv {x2} 0 {z2}\nv {x2} 1 {z2}\nv {x3} 0 {z3}\nv {x3} 1 {z3}\nf 1 3 4 2\nf 3 5 6 4\nf 5 7 8 6\n",
        x2 = 1.0 + c20,
        z2 = s20,
        x3 = 1.0 + c20 + c80,
        z3 = s20 + s80,
    );
    let bent = load_obj_from_str_with_crease(&text, 45.0);
    let normal_at = |t: usize, k: usize| corner_and_face_normals(&bent, t).0[k];
    let faces: Vec<Vec3> =
        (0..bent.triangle_count()).map(|t| corner_and_face_normals(&bent, t).1).collect();
    // Triangle 0 is (1, 3, 2) of the first square: its corner at vertex 3 is on the
    // 20-degree bend, where both triangles of the first square and one of the second meet.
    assert!(
        close(normal_at(0, 1), (2.0 * faces[0] + faces[2]).normalize()),
        "{:?}",
        normal_at(0, 1)
    );
    // Triangle 2 is (3, 5, 4) of the second square: its corner at vertex 5 is on the 80-degree bend, kept sharp.
    assert!(close(normal_at(2, 1), faces[2]), "{:?}", normal_at(2, 1));
}

fn load_obj_from_str_with_crease(text: &str, degrees: f32) -> Mesh {
    meshtracer::scene::obj::load_obj_from_str_with(
        text,
        "test.obj",
        None,
        &LoadOptions { crease_angle: Some(degrees) },
    )
    .unwrap()
    .mesh
}

#[test]
fn mtllib_reads_several_names_and_escaped_spaces() {
    let loaded = load_obj(&data("escaped_mtllib.obj")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let names: Vec<&str> = loaded.mesh.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["red", "green"]);
    assert_eq!(loaded.mesh.triangle_materials, [0, 0, 1, 1]);
    assert_eq!(loaded.mesh.materials[1].diffuse, v(0.1, 0.9, 0.1));
}

// --- Bad input ----------------------------------------------------------------------

/// The message names the file and, when given, the line.
fn assert_names(e: &ObjError, file: &str, line: Option<usize>) {
    let message = e.to_string();
    assert!(message.contains(file), "message does not name {file}: {message}");
    if let Some(n) = line {
        assert!(
            message.contains(&format!("line {n}:")),
            "message does not name line {n}: {message}"
        );
    }
    assert!(!message.contains('\n'), "message is not one sentence: {message}");
}

#[test]
fn missing_file_names_the_path_and_the_os_error() {
    let path = data("no-such-file.obj");
    let e = load_obj(&path).unwrap_err();
    assert!(matches!(e, ObjError::Io { .. }), "{e:?}");
    assert_names(&e, "no-such-file.obj", None);
    let not_found = std::io::Error::from(std::io::ErrorKind::NotFound).to_string();
    assert!(e.to_string().contains(&not_found) || e.to_string().contains("No such file"), "{e}");

    // A directory is not a file either.
    let e = load_obj(&data("materials")).unwrap_err();
    assert!(matches!(e, ObjError::Io { .. }), "{e:?}");
}

#[test]
fn binary_data_is_not_text() {
    let dir = std::env::temp_dir().join(format!("meshtracer-bin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("binary.obj");
    std::fs::write(&path, b"v 0 0 0\nv 1 0 0\n\xff\xfe\x00garbage\nf 1 2 3\n").unwrap();
    let e = load_obj(&path).unwrap_err();
    std::fs::remove_dir_all(&dir).ok();
    assert!(matches!(e, ObjError::NotText { line: 3, .. }), "{e:?}");
    assert_names(&e, "binary.obj", None);
    assert!(e.to_string().contains("line 3"), "{e}");
}

#[test]
fn face_index_out_of_range_names_the_line() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\nf 1 2 3\n\n# next\nf 1 2 9\n";
    let e = load_obj_from_str(text, "bunny.obj", None).unwrap_err();
    assert_eq!(
        e.to_string(),
        "bunny.obj line 12: face vertex index 9 is out of range (the file has 8 vertices so far)"
    );
    assert!(matches!(e, ObjError::IndexOutOfRange { line: 12, count: 8, .. }), "{e:?}");
}

#[test]
fn every_kind_of_bad_vertex_index_is_out_of_range() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    for face in [
        "f 1 2 4",                       // past the end
        "f 0 1 2",                       // OBJ counts from 1
        "f -4 -2 -1",                    // relative, before the first
        "f 1 2 99999999999999999999999", // does not fit any integer
        "f 1/1 2/1 4/1",                 // good texture coordinates do not save it
        "f 1/9 2/1 4/1",                 // nor do bad ones change the error
    ] {
        let e = load_err(&format!("{head}{face}\n"));
        assert!(
            matches!(e, ObjError::IndexOutOfRange { line: 6, kind: "vertex", .. }),
            "{face}: {e:?}"
        );
        assert_names(&e, "test.obj", Some(6));
    }
    // A face may only use what was defined before it.
    let e = load_err("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n");
    assert!(matches!(e, ObjError::IndexOutOfRange { line: 3, count: 2, .. }), "{e:?}");
}

#[test]
fn out_of_range_texture_coordinates_and_normals_are_left_out_with_a_warning() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    let cases = [
        ("f 1/2 2/1 3/1", "texture coordinate"), // vt past the end
        ("f 1/0 2/1 3/1", "texture coordinate"), // zero vt (overflows inside tobj)
        ("f 1//1 2//-2 3//1", "normal"),         // relative vn before the first
        ("f 1//4611686018427387904 2//1 3//1", "normal"), // overflows `3 * vn` inside tobj
    ];
    for (face, kind) in cases {
        let loaded = load(&format!("{head}{face}\n"));
        assert_eq!(loaded.mesh.triangle_count(), 1, "{face}");
        assert_eq!(loaded.warnings.len(), 1, "{face}: {:?}", loaded.warnings);
        let w = &loaded.warnings[0];
        assert!(
            w.starts_with("test.obj line 6: ") && w.contains(&format!("face {kind} index")),
            "{face}: {w}"
        );
        // The whole face goes without: no texture coordinates, computed normals.
        assert!(loaded.mesh.texcoords.is_empty(), "{face}");
        assert!(!loaded.mesh.has_file_normals, "{face}");
        assert_eq!(loaded.mesh.normals, [Vec3::Z; 3], "{face}");
    }
    // The message counts in good English.
    let w = &load(&format!("{head}f 1/2 2/1 3/1\n")).warnings[0];
    assert!(
        w.contains("index 2 is out of range (the file has 1 texture coordinate so far)"),
        "{w}"
    );
    // Texture coordinates and normals named when the file has none at all: one warning
    // each, naming the first face; every face is drawn.
    let loaded =
        load("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1/1/1 2/2/2 3/3/3\nf 2/2/2 4/4/4 3/3/3\n");
    assert_eq!(loaded.mesh.triangle_count(), 2);
    assert_eq!(loaded.warnings.len(), 2, "{:?}", loaded.warnings);
    assert!(loaded.warnings[0].contains("line 5: face texture coordinate index 1 is out of range (the file has 0 texture coordinates so far)"), "{}", loaded.warnings[0]);
    assert!(
        loaded.warnings[1].contains("line 5: face normal index 1")
            && loaded.warnings[1]
                .contains("the face and 1 more like it are drawn with computed normals"),
        "{}",
        loaded.warnings[1]
    );
}

#[test]
fn a_face_that_loses_its_attributes_leaves_the_other_faces_theirs() {
    // Two squares side by side: the first with texture coordinates and normals, the second
    // naming a normal that does not exist and a texture coordinate out of range.
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0.6 0.8\n\
                f 1/1/1 2/2/1 3/3/1 4/4/1\nf 2/1/1 5/2/9 6/3/1 3/9/1\n";
    let loaded = load(text);
    assert_eq!(loaded.warnings.len(), 2, "{:?}", loaded.warnings);
    assert!(loaded.warnings.iter().all(|w| w.contains("line 13:")), "{:?}", loaded.warnings);
    let mesh = loaded.mesh;
    assert_eq!(mesh.triangle_count(), 4);
    let uvs = |t: usize| mesh.triangles[t].map(|k| mesh.texcoords[k as usize]);
    let normals = |t: usize| mesh.triangles[t].map(|k| mesh.normals[k as usize]);
    // The first square keeps its file normal and texture coordinates (quad split 1 2 4).
    assert_eq!(uvs(0), [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)]);
    assert_eq!(normals(0), [Vec3::new(0.0, 0.6, 0.8); 3]);
    // The second has neither: computed normals, texture coordinates zero.
    assert_eq!(uvs(2), [Vec2::ZERO; 3]);
    assert!(normals(2).iter().all(|n| (*n - Vec3::Z).length() < 1e-6), "{:?}", normals(2));
}

#[test]
fn non_finite_coordinates_name_the_line() {
    for (bad, line, what) in [
        ("v nan 0 0", 2, "vertex position"),
        ("v 0 1e39 0", 2, "vertex position"), // overflows f32 to infinity
        ("v 0 0 inf", 2, "vertex position"),
        ("v 0 inf 0 1", 2, "vertex position"), // w is ignored, x, y, z still checked
    ] {
        let text = format!("v 0 0 0\n{bad}\nv 0 1 0\nf 1 2 3\n");
        let e = load_err(&text);
        assert!(matches!(e, ObjError::NonFinite { line: l, .. } if l == line), "{bad}: {e:?}");
        assert_names(&e, "test.obj", Some(line));
        assert!(e.to_string().contains(what), "{e}");
    }
    let e = load_err("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn NaN 0 1\nf 1//1 2//2 3//1\n");
    assert!(matches!(e, ObjError::NonFinite { line: 5, what: "a normal", .. }), "{e:?}");
}

#[test]
fn vertex_colours_on_some_vertices_only_name_the_first_odd_one() {
    // Colours are ignored, but tobj refuses a face using a vertex past the last colour.
    let e = load_err("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0\nv 1 1 0\nf 1 2 4\n");
    assert!(matches!(e, ObjError::Parse { line: 3, .. }), "{e:?}");
    assert!(e.to_string().contains("colour"), "{e}");
    // All or none is fine.
    assert_eq!(
        load("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n").mesh.triangle_count(),
        1
    );
}

#[test]
fn a_file_without_faces_is_refused() {
    for text in [
        "",
        "# nothing\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
        "v 0 0 0\nv 1 0 0\nl 1 2\n",
        "hello world\nthis is not an obj\n",
    ] {
        let e = load_err(text);
        assert!(matches!(e, ObjError::NoFaces { .. }), "{text:?}: {e:?}");
        assert_names(&e, "test.obj", None);
        assert!(e.to_string().contains("contains no faces"), "{e}");
    }
}

#[test]
fn a_truncated_last_line_is_reported_as_such() {
    let whole = format!("{SQUARE}f 1 2 3\nf 1 3 4\n");
    for (cut, line) in [("f 1 2", 7), ("v 1.0 2.", 7), ("f 1/", 7), ("vn 0 0", 7)] {
        let text = format!("{whole}{cut}");
        let e = load_err(&text);
        assert!(matches!(e, ObjError::Truncated { line: l, .. } if l == line), "{cut:?}: {e:?}");
        assert_names(&e, "test.obj", Some(line));
    }
    // With a trailing newline and blank lines it is still the last statement.
    let e = load_err(&format!("{whole}f 1 2\n\n"));
    assert!(matches!(e, ObjError::Truncated { line: 7, .. }), "{e:?}");
}

#[test]
fn a_vertex_weight_is_ignored() {
    // `v x y z w`: w weighs a rational curve's control point; a mesh keeps x, y, z (#29:
    // tinyobjloader's cube-vertex-w-component.obj drew a spike when divided by it).
    let plain = load_obj_from_str("v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n", "a.obj", None).unwrap();
    let weighted =
        load_obj_from_str("v 0 0 0 0\nv 2 0 0 0.5\nv 0 2 0 1e-45\nf 1 2 3\n", "b.obj", None)
            .unwrap();
    assert_eq!(plain.mesh.positions, weighted.mesh.positions);
    assert!(weighted.warnings.is_empty(), "{:?}", weighted.warnings);
}

#[test]
fn malformed_lines_in_the_middle_are_parse_errors() {
    for (bad, reason) in [
        ("v 1 x 3", "vertex position"),
        ("vn 0 1", "normal"),
        ("vt", "texture coordinate"),
        ("f 1 2", "three corners"),
        ("f 1 2 a", "not a face corner"),
        ("f 1//// 2 3", "more than three indices"),
        ("f /1 2 3", "not a face corner"),
        ("v 1 2 3 w", "vertex position"),
    ] {
        let text = format!("{SQUARE}{bad}\nf 1 2 3\n");
        let e = load_err(&text);
        assert!(matches!(e, ObjError::Parse { line: 5, .. }), "{bad:?}: {e:?}");
        assert_names(&e, "test.obj", Some(5));
        assert!(e.to_string().contains(reason), "{bad:?}: {e}");
    }
}

#[test]
fn no_input_makes_the_loader_panic() {
    // A cheap sweep before real fuzzing: every prefix of a file using all features, and
    // every line with one byte replaced by a troublesome one. Ok or Err, never a panic.
    let dir = data("");
    let text = "mtllib materials/cube.mtl\no a\nv 0 0 0\nv 1 0 0 1\nv 0 1 0\nv 1 1 1 0.5 0.5 0.5\nvt 0 0\nvt 1 1\n\
                vn 0 0 1\nusemtl red\nf 1/1/1 2/2/1 3/1/1\nf -1//1 -2//1 -3//1 -4//1\ng b\nf 1 2 3 4 1\nl 1 2\n";
    for end in 0..=text.len() {
        if text.is_char_boundary(end) {
            let _ = load_obj_from_str(&text[..end], "prefix.obj", Some(&dir));
        }
    }
    for (i, _) in text.char_indices() {
        for replacement in ["0", "-", "/", " ", "\n", "9999999999999999999", "nan", "f", "v"] {
            let mutated = format!("{}{replacement}{}", &text[..i], &text[i + 1..]);
            let _ = load_obj_from_str(&mutated, "mutated.obj", Some(&dir));
        }
    }
}

// --- The paper's models in assets/ ----------------------------------------------------

/// `assets/<name>.obj` must hold what the generators make. With
/// `MESHTRACER_WRITE_ASSETS=1` the files are (re)written first.
#[test]
fn paper_model_assets_load_back_with_the_generated_counts() {
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let rewrite = std::env::var_os("MESHTRACER_WRITE_ASSETS").is_some_and(|v| v == "1");
    for model in PaperModel::ALL {
        let generated = model.mesh();
        let path = assets.join(format!("{}.obj", model.name()));
        if rewrite {
            write_obj(&generated, &path).unwrap();
        }
        let loaded = load_obj(&path).unwrap_or_else(|e| {
            panic!("{e} (MESHTRACER_WRITE_ASSETS=1 cargo test --test obj_loader regenerates it)")
        });
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        let mesh = loaded.mesh;
        assert_eq!(mesh.vertex_count(), generated.vertex_count(), "{}", model.name());
        assert_eq!(mesh.triangle_count(), generated.triangle_count(), "{}", model.name());
        assert_eq!(mesh.triangle_count(), model.paper_counts().1, "{}", model.name());
        assert!(mesh.has_file_normals);
        // Same triangles, and floats written exactly: the file holds the generator's mesh.
        assert_eq!(
            triangle_corners(&mesh),
            triangle_corners(&generated),
            "{} is stale",
            path.display()
        );
    }
}

/// Text from the file in an error is escaped and cut: a face corner that writes escape
/// sequences (set the terminal's title, red text, clear the screen) or runs for megabytes
/// was quoted as it was.
#[test]
fn a_bad_face_corner_in_an_error_is_escaped_and_cut() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let long = "x".repeat(5 << 20);
    let digits = "9".repeat(5 << 20);
    for face in [
        "f 1 \x1b]0;PWNED\x07\x1b[31mRED\x1b[2J 3".to_owned(),
        format!("f 1 {long} 3"),
        format!("f 1 2/3/4/{long} 3"),
        format!("f 1 2 {digits}"),
    ] {
        let e = load_err(&format!("{head}{face}\n")).to_string();
        assert!(e.starts_with("test.obj line 4: "), "{}", &e[..e.len().min(300)]);
        assert!(!e.chars().any(char::is_control), "control characters reach the terminal: {e:?}");
        assert!(e.len() < 400, "a {}-byte error", e.len());
    }
    let e = load_err(&format!("{head}f 1 \x1b]0;PWNED\x07 3\n")).to_string();
    assert!(e.contains("`\\u{1b}]0;PWNED\\u{7}` is not a face corner"), "{e}");
}

/// One byte that is not UTF-8 in a comment (a Latin-1 "é", as old exporters write) or in
/// a name no longer rejects the whole file ("is not an OBJ text file"): the mesh is the
/// same as without it. In a statement that carries numbers it still does.
#[test]
fn latin1_in_comments_and_names_loads_the_same_mesh() {
    let load_bytes = |bytes: &[u8]| {
        let options = LoadOptions::default();
        meshtracer::scene::obj::load_obj_from_bytes(bytes.to_vec(), "l.obj", None, &options)
    };
    let plain = "# made by an old exporter\no cube\ng side\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
    let a = load_bytes(plain.as_bytes()).unwrap().mesh;
    let latin1 = plain
        .as_bytes()
        .iter()
        .flat_map(|&b| if b == b'e' { vec![0xe9] } else { vec![b] })
        .collect::<Vec<u8>>();
    // Only the comment and the two names have an "e" to turn into a Latin-1 "é".
    assert!(std::str::from_utf8(&latin1).is_err());
    let b = load_bytes(&latin1).unwrap_or_else(|e| panic!("{e}")).mesh;
    assert_eq!((&a.positions, &a.triangles, &a.normals), (&b.positions, &b.triangles, &b.normals));
    let e = load_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\xe9\nf 1 2 3\n").unwrap_err();
    assert!(matches!(e, ObjError::NotText { line: 3, .. }), "{e:?}");
    let e = load_bytes(b"# \xe9\x00 binary\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap_err();
    assert!(matches!(e, ObjError::NotText { line: 1, .. }), "{e:?}");
}
