//! The ASCII PLY body read on every core gives what the plain serial reader gives: the same
//! mesh (bit for bit), the same warnings, the same one-line error naming the same line, on
//! generated files, their variants (CRLF, extra white space, other elements, every face
//! size) and hostile ones (cut short, wrong counts, records over two lines, random edits).

use meshtracer::scene::obj::{LoadedObj, ObjError};
use meshtracer::scene::ply::load_ply_from_bytes_chunked;

/// Every cut the tests try: every line its own piece, odd sizes, the program's.
const CUTS: [usize; 5] = [1, 7, 40, 1000, 256 << 10];

/// A mesh as bits, so that two loads compare exactly (NaN and -0 included).
fn fingerprint(loaded: &Result<LoadedObj, ObjError>) -> Result<Vec<String>, String> {
    let LoadedObj { mesh: m, warnings } = loaded.as_ref().map_err(|e| e.to_string())?;
    let bits = |v: &[f32]| format!("{:?}", v.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
    let flat3 = |v: &[glam::Vec3]| bits(&v.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
    let flat2 = |v: &[glam::Vec2]| bits(&v.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
    Ok(vec![
        flat3(&m.positions),
        flat3(&m.normals),
        flat2(&m.texcoords),
        format!("{:?}", m.colors),
        format!("{:?}", m.triangles),
        format!("{:?} {:?}", m.triangle_materials, m.materials),
        format!("{} {:?}", m.has_file_normals, warnings),
    ])
}

/// Load `bytes` with every cut and with the serial reader; they must agree. Returns the
/// serial reader's result.
fn same_every_way(bytes: &[u8], what: &str) -> Result<Vec<String>, String> {
    let serial = fingerprint(&load_ply_from_bytes_chunked(bytes, "t.ply", None));
    for cut in CUTS {
        let parallel = fingerprint(&load_ply_from_bytes_chunked(bytes, "t.ply", Some(cut)));
        assert_eq!(parallel, serial, "{what}, cut {cut}: {}", String::from_utf8_lossy(bytes));
    }
    serial
}

/// A header for `vertex` properties and the face element's properties, with extra lines.
fn header(vertices: usize, vertex_props: &str, faces: usize, face_props: &str) -> String {
    format!(
        "ply\nformat ascii 1.0\ncomment written by the test\nelement vertex {vertices}\n{vertex_props}element face {faces}\n{face_props}end_header\n"
    )
}

const XYZ: &str = "property float x\nproperty float y\nproperty float z\n";
const LIST: &str = "property list uchar int vertex_indices\n";

/// A grid of `n` x `n` vertices with normals, texture coordinates and colours; its faces
/// cycle through triangles, quads and pentagons.
fn grid(n: usize) -> String {
    let props = format!(
        "{XYZ}property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
    );
    let mut body = String::new();
    for i in 0..n * n {
        let (x, y) = ((i % n) as f32 / n as f32, (i / n) as f32 / n as f32);
        let z = (x * 7.0).sin() * (y * 3.0).cos();
        body += &format!("{x:.6} {y:.6} {z} 0 0 1 {x} {y:.3} {} {} 7\n", i % 256, (i * 7) % 256);
    }
    let mut faces = 0;
    for j in 0..n - 2 {
        for i in 0..n - 2 {
            let a = j * n + i;
            body += &match (i + j) % 3 {
                0 => format!("3 {a} {} {}\n", a + 1, a + n),
                1 => format!("4 {a} {} {} {}\n", a + 1, a + n + 1, a + n),
                _ => format!("5 {a} {} {} {} {}\n", a + 1, a + 2, a + n + 1, a + n),
            };
            faces += 1;
        }
    }
    header(n * n, &props, faces, LIST) + &body
}

#[test]
fn generated_files_and_their_variants_read_the_same() {
    let text = grid(12);
    let plain = same_every_way(text.as_bytes(), "grid").expect("the grid loads");
    assert!(plain[4].len() > 100, "the grid has triangles");
    let (head, body) = text.split_at(text.find("end_header\n").unwrap() + 11);
    let variants = [
        ("crlf", text.replace('\n', "\r\n")),
        ("crlf body", format!("{head}{}", body.replace('\n', "\r\n"))),
        ("tabs and spaces", format!("{head}{}", body.replace(' ', " \t ").replace('\n', "  \n\t"))),
        ("form feeds", format!("{head}{}", body.replace(' ', "\x0c"))),
        ("no last line end", text.trim_end().to_owned()),
        ("lines after the records", format!("{text}\n\nwhatever follows # is not read\n")),
        ("blank line inside", format!("{head}\n{body}")),
        ("comment in the body", format!("{head}comment hi\n{body}")),
        ("leading zeros and signs", format!("{head}{}", body.replace(" 0 0 1 ", " +0 -0 001 "))),
        ("exponents", format!("{head}{}", body.replace(" 0 0 1 ", " 0e0 0E-3 1e+0 "))),
        ("bare points", format!("{head}{}", body.replace(" 0 0 1 ", " .0 0. 1. "))),
        (
            "long decimals",
            format!("{head}{}", body.replace(" 0 0 1 ", " 0.12345678901234567 0 1 ")),
        ),
        ("vertical tab", format!("{head}{}", body.replacen(' ', "\x0b", 5))),
        ("not UTF-8", format!("{head}{}", body.replacen('7', "\u{e9}", 1))),
        ("nbsp", format!("{head}{}", body.replacen(' ', "\u{a0}", 3))),
    ];
    for (what, text) in variants {
        same_every_way(text.as_bytes(), what).ok();
    }
    assert_eq!(
        same_every_way(text.replace('\n', "\r\n").as_bytes(), "crlf").unwrap()[..6],
        plain[..6],
        "CRLF line ends change nothing"
    );
    let latin1: Vec<u8> =
        text.replacen("7\n", "\u{e9}\n", 1).bytes().filter(|&b| b != 0xc3).collect();
    same_every_way(&latin1, "a Latin-1 byte").unwrap_err();
}

#[test]
fn other_elements_and_properties_read_the_same() {
    let v = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
    let f = "3 0 1 2\n3 0 2 3\n";
    let files = [
        // An element before the vertices, one between, one after; lists in skipped elements.
        format!("ply\nformat ascii 1.0\nelement material 2\nproperty float k\nproperty list uchar float w\nelement vertex 4\n{XYZ}element edge 1\nproperty int a\nproperty int b\nelement face 2\n{LIST}element extra 1\nproperty uchar q\nend_header\n0.5 2 1 2\n1 0\n{v}0 1\n{f}9\n"),
        // A list among the vertex's properties, a face with properties around its list.
        format!("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty list uchar int tags\nproperty float y\nproperty float z\nelement face 2\nproperty uchar flag\n{LIST}property float quality\nend_header\n0 2 5 6 0 0\n1 0 0 0\n1 1 9 1 0\n0 0 1 0\n1 3 0 1 2 0.5\n0 3 0 2 3 0.25\n"),
        // `vertex_index`, an int count, unsigned indices; faces before the vertices.
        format!("ply\nformat ascii 1.0\nelement face 2\nproperty list int uint vertex_index\nelement vertex 4\n{XYZ}end_header\n{f}{v}"),
        // An empty element, zero faces, an element of no properties.
        format!("ply\nformat ascii 1.0\nelement vertex 4\n{XYZ}element none 0\nelement face 2\n{LIST}end_header\n{v}{f}"),
        format!("ply\nformat ascii 1.0\nelement vertex 4\n{XYZ}element face 0\n{LIST}end_header\n{v}"),
        format!("ply\nformat ascii 1.0\nelement vertex 4\n{XYZ}element nothing 3\nelement face 2\n{LIST}end_header\n{v}{f}"),
        // Two vertex elements, two face elements (the first empty).
        format!("ply\nformat ascii 1.0\nelement vertex 4\n{XYZ}element vertex 1\n{XYZ}element face 0\n{LIST}element face 2\n{LIST}end_header\n{v}5 5 5\n{f}"),
        // No face element, no vertex element, a face element without its list.
        format!("ply\nformat ascii 1.0\nelement vertex 4\n{XYZ}end_header\n{v}"),
        format!("ply\nformat ascii 1.0\nelement face 2\n{LIST}end_header\n{f}"),
        format!("ply\nformat ascii 1.0\nelement vertex 4\n{XYZ}element face 2\nproperty list uchar int corners\nend_header\n{v}{f}"),
        // Vertices without y; colours as a list.
        format!("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float z\nelement face 2\n{LIST}end_header\n0 0\n1 0\n1 1\n0 1\n{f}"),
        format!("ply\nformat ascii 1.0\nelement vertex 4\n{XYZ}property list uchar uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\n{LIST}end_header\n0 0 0 0 1 1\n1 0 0 0 1 1\n1 1 0 0 1 1\n0 1 0 0 1 1\n{f}"),
    ];
    let mut loaded = 0;
    for (i, text) in files.iter().enumerate() {
        loaded += usize::from(same_every_way(text.as_bytes(), &format!("file {i}")).is_ok());
    }
    assert!(loaded >= 5, "most of these files load ({loaded})");
}

#[test]
fn faulty_bodies_fail_alike_naming_the_same_line() {
    let v = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
    let head = |nv: usize, nf: usize| header(nv, XYZ, nf, LIST);
    let cases = [
        (format!("{}{v}3 0 1 2\n3 0 2 9\n", head(4, 2)), "t.ply line 16: face 1: vertex index 9"),
        (format!("{}{v}3 0 1 2\n2 0 2\n", head(4, 2)), "t.ply line 16: face 1: it has 2 corners"),
        (
            format!("{}{v}3 0 1 2\n3 0 2 3 3\n", head(4, 2)),
            "t.ply line 16: face 1: its vertex count says 3",
        ),
        (
            format!("{}{v}3 0 1 2\n-3 0 2 3\n", head(4, 2)),
            "t.ply line 16: `-3` is not a valid uchar",
        ),
        (
            format!("{}{v}3 0 1 2\n256 0 2 3\n", head(4, 2)),
            "t.ply line 16: `256` is not a valid uchar",
        ),
        (format!("{}{v}3 0 1 2\n3 0 2 x\n", head(4, 2)), "t.ply line 16: `x` is not a valid int"),
        (format!("{}{v}3 0 1 2\n", head(4, 2)), "t.ply line 15: the file ends here"),
        (format!("{}{v}3 0 1 2\n      \n", head(4, 2)), "t.ply line 15: the file ends here"),
        (
            format!("{}0 0 0\n1 0 nan\n1 1 0\n0 1 0\n3 0 1 2\n", head(4, 1)),
            "t.ply line 12: a vertex position",
        ),
        (
            format!("{}0 0 0\n1 0 1e39\n1 1 0\n0 1 0\n3 0 1 2\n", head(4, 1)),
            "t.ply line 12: a vertex position",
        ),
        (format!("{}0 0 0\n1 0 0 0\n1 1 0\n0 1 0\n3 0 1 2\n", head(4, 1)), "t.ply line"),
        // Values over lines: the serial reader reads them as one stream.
        (format!("{}0 0 0\n1 0\n0 1 1 0\n0 1 0\n3 0 1 2\n", head(4, 1)), ""),
        (format!("{}0 0 0 1 0 0 1 1 0 0 1 0\n3 0 1 2\n", head(4, 1)), ""),
        (format!("{}0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0\n1 2\n", head(4, 1)), ""),
        (format!("{}{v}3 0 1 2\n3 0 2 3\n", head(5, 2)), "t.ply line"),
        (format!("{}{v}3 0 1 2\n3 0 2 3\n", head(3, 2)), "t.ply line"),
        (format!("{}{v}3 0 1 2\n3 0 2 3\n", head(4, 3)), "t.ply line 16: the file ends here"),
        (format!("{}{v}3 0 1 2\n3 0 2 3\n", head(4, 1)), ""),
        (
            format!(
                "{}{v}3 0 1 2\n4294967295 0 2 3\n",
                header(4, XYZ, 2, "property list uint int vertex_indices\n")
            ),
            "t.ply line 16: the file ends here",
        ),
    ];
    let mut wrong = Vec::new();
    for (i, (text, expected)) in cases.iter().enumerate() {
        match same_every_way(text.as_bytes(), &format!("case {i}")) {
            Err(e) if e.starts_with(expected) && !e.contains('\n') => {}
            Ok(_) if expected.is_empty() => {}
            other => wrong.push(format!("case {i}: expected {expected:?}, got {other:?}")),
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn every_cut_short_file_fails_or_loads_alike() {
    let text = grid(4);
    for len in 0..=text.len() {
        same_every_way(&text.as_bytes()[..len], &format!("the first {len} bytes")).ok();
    }
}

#[test]
fn random_edits_read_the_same() {
    let text = grid(5).into_bytes();
    let start = text.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let alphabet = b" \n\r\t0123456789.-+eE#x\x0c";
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move |n: usize| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed % n as u64) as usize
    };
    let mut loads = 0;
    for round in 0..600 {
        let mut bytes = text.clone();
        for _ in 0..1 + round % 4 {
            let at = start + next(bytes.len() - start);
            let b = alphabet[next(alphabet.len())];
            match next(3) {
                0 => bytes[at] = b,
                1 => bytes.insert(at, b),
                _ => {
                    bytes.remove(at);
                }
            }
        }
        loads += usize::from(same_every_way(&bytes, &format!("round {round}")).is_ok());
    }
    assert!(loads > 10 && loads < 590, "some edits load and some fail ({loads})");
}
