//! Stanford PLY loading: ASCII, binary little- and big-endian, read by our own parser.
//!
//! The header says what the body holds; nothing is allocated on its word alone. A binary
//! body's smallest possible size follows from the header and is checked against the bytes
//! present before anything is read (an ASCII body against its length in the same way),
//! and vectors start at a capped capacity. From `element vertex` we keep x/y/z, nx/ny/nz
//! and u/v (or s/t) and colours (`red green blue`, optional `alpha`: see `colours.rs`);
//! anything else is skipped by its declared type, as are
//! elements other than `vertex` and `face`. Faces (`vertex_indices` or `vertex_index`, any
//! count and index type) are split as the OBJ loader splits them: quads as the paper
//! does, larger polygons into fans. Errors name the file and the line (ASCII) or the
//! element (binary).
//!
//! The common files are read on every core (`ascii.rs`: one record a line; `binary.rs`:
//! fixed-size records); anything else, and any file with a fault, by the serial reader in
//! `body.rs`, which alone writes the messages.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::obj::{LoadedObj, ObjError};
use super::{Material, Mesh};

mod ascii;
mod binary;
mod body;
mod colours;
mod number;

use ascii::read_ascii_in_parallel;
use binary::read_binary_in_parallel;
use body::{read_body, Body};
use colours::ColourColumns;

/// The most vertices or triangles reserved up front; beyond this vectors grow as they fill.
const MAX_INITIAL_CAPACITY: usize = 1 << 20;
/// The longest header read (comments included) before the body must begin.
const MAX_HEADER_BYTES: usize = 1 << 20;

/// Load a PLY (ASCII or binary) from bytes already in memory (`name` is used in messages):
/// a file's are read by `formats::load_model`, and the tests and the fuzzer give theirs.
pub fn load_ply_from_bytes(bytes: &[u8], name: &str) -> Result<LoadedObj, ObjError> {
    load_ply_from_bytes_chunked(bytes, name, Some(ascii::CHUNK_BYTES))
}

/// [`load_ply_from_bytes`] with an ASCII body cut into pieces of about `ascii_chunk_bytes`
/// (1 cuts at every line), or with every file read by the plain serial reader alone (None):
/// for the tests and the fuzzer, which check that every cut gives what the plain reader gives.
#[doc(hidden)]
pub fn load_ply_from_bytes_chunked(
    bytes: &[u8],
    name: &str,
    ascii_chunk_bytes: Option<usize>,
) -> Result<LoadedObj, ObjError> {
    let fail = |location: Location, reason: String| match location {
        Location::Line(line) => ObjError::Parse { name: name.to_owned(), line, reason },
        Location::Element(what) => {
            ObjError::Invalid { name: name.to_owned(), reason: format!("{what}: {reason}") }
        }
        Location::File => ObjError::Invalid { name: name.to_owned(), reason },
    };
    let header = parse_header(bytes).map_err(|(l, r)| fail(l, r))?;
    let body = &bytes[header.body_start..];
    check_body_size(&header, body).map_err(|r| fail(Location::File, r))?;
    let mut warnings = Vec::new();
    let fast = match (header.format, ascii_chunk_bytes) {
        (_, None) => None,
        (Format::Binary { big_endian }, Some(_)) => {
            read_binary_in_parallel(&header, body, big_endian)
        }
        (Format::Ascii, Some(size)) => read_ascii_in_parallel(&header, body, size),
    };
    let mesh = match fast {
        Some((positions, attributes, triangles)) => {
            let mesh = Mesh {
                name: name.to_owned(),
                materials: vec![Material::default()],
                positions,
                triangles,
                ..Default::default()
            };
            finish_mesh(mesh, attributes, &header, name, &mut warnings)
        }
        None => {
            let mut reader = match header.format {
                Format::Ascii => Body::Ascii { text: body, pos: 0, line: header.body_line },
                Format::Binary { big_endian } => Body::Binary { data: body, pos: 0, big_endian },
            };
            read_body(&header, &mut reader, name, &mut warnings)
        }
    }
    .map_err(|(l, r)| fail(l, r))?;
    Ok(LoadedObj { mesh, warnings })
}

/// Where a problem is: a line of an ASCII file, an element of a binary one, or the whole file.
enum Location {
    Line(usize),
    Element(String),
    File,
}

type Failure = (Location, String);

/// A scalar type of the PLY format.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(word: &str) -> Option<Self> {
        Some(match word {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The type as the header spells it, for messages.
    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// A property of an element: one value, or a list with its count type and item type.
#[derive(Clone, Debug)]
enum Property {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

/// An `element` line and its properties: `count` records of them follow in the body.
#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<(String, Property)>,
}

impl Element {
    /// The position of the first scalar property called any of `names`.
    fn find(&self, names: &[&str]) -> Option<usize> {
        self.properties
            .iter()
            .position(|(n, p)| names.contains(&n.as_str()) && matches!(p, Property::Scalar(_)))
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    Binary { big_endian: bool },
}

/// What the header says: the encoding, the elements in body order, where the body starts.
struct Header {
    format: Format,
    elements: Vec<Element>,
    body_start: usize,
    /// The line the body starts on (ASCII).
    body_line: usize,
}

/// Whether a header line is a `comment` or `obj_info` line.
fn is_comment(line: &[u8]) -> bool {
    let first = line.split(|b| b.is_ascii_whitespace()).find(|w| !w.is_empty());
    matches!(first, Some(b"comment" | b"obj_info"))
}

/// Read the header up to `end_header`; any line we do not know is an error naming it.
fn parse_header(bytes: &[u8]) -> Result<Header, Failure> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut pos = 0;
    let mut line_no = 0;
    loop {
        line_no += 1;
        if pos >= bytes.len() || pos > MAX_HEADER_BYTES {
            let why = if pos >= bytes.len() { "the file ends" } else { "more than 1 MiB passes" };
            return Err((Location::File, format!("{why} before the header's `end_header`")));
        }
        let end = bytes[pos..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| pos + i);
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        let line = match std::str::from_utf8(raw) {
            Ok(line) => line,
            // A comment may be in any encoding (old exporters write Latin-1): skipped.
            Err(_) if line_no > 1 && is_comment(raw) => continue,
            Err(_) => return Err((Location::Line(line_no), "the header is not text".to_owned())),
        };
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        let bad = |reason: String| (Location::Line(line_no), reason);
        if line_no == 1 {
            if line.trim_end_matches('\r') != "ply" {
                return Err((
                    Location::File,
                    "not a PLY file (it does not begin with `ply`)".to_owned(),
                ));
            }
            continue;
        }
        match words.as_slice() {
            [] => {}
            ["comment" | "obj_info", ..] => {}
            ["format", kind, version] => {
                format = Some(match *kind {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Binary { big_endian: false },
                    "binary_big_endian" => Format::Binary { big_endian: true },
                    _ => {
                        return Err(bad(format!(
                            "unknown format {} (ascii, binary_little_endian or binary_big_endian)",
                            quote(kind)
                        )))
                    }
                });
                if !version.starts_with('1') {
                    return Err(bad(format!("unknown format version {}", quote(version))));
                }
            }
            ["element", elem, count] => {
                let count = count
                    .parse::<u64>()
                    .map_err(|_| bad(format!("element count {} is not a number", quote(count))))?;
                elements.push(Element { name: elem.to_string(), count, properties: Vec::new() });
            }
            ["property", rest @ ..] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| bad("a property before any element".to_owned()))?;
                let scalar = |w: &str| {
                    Scalar::parse(w)
                        .ok_or_else(|| bad(format!("unknown property type {}", quote(w))))
                };
                let property = match rest {
                    ["list", count, item, pname] => {
                        let count = scalar(count)?;
                        if !count.is_integer() {
                            return Err(bad(format!(
                                "list {} has a count type that is not an integer",
                                quote(pname)
                            )));
                        }
                        (pname.to_string(), Property::List { count, item: scalar(item)? })
                    }
                    [kind, pname] => (pname.to_string(), Property::Scalar(scalar(kind)?)),
                    _ => return Err(bad(format!("malformed property {}", quote(line)))),
                };
                element.properties.push(property);
            }
            ["end_header"] => break,
            _ => return Err(bad(format!("unknown header line {}", quote(line)))),
        }
    }
    let format = format.ok_or((Location::File, "the header has no `format` line".to_owned()))?;
    Ok(Header { format, elements, body_start: pos, body_line: line_no + 1 })
}

/// The body must hold at least what the header claims before anything is allocated: every
/// scalar and list count takes its size in bytes (binary) or a number and a space (ASCII).
fn check_body_size(header: &Header, body: &[u8]) -> Result<(), String> {
    let mut least: u128 = 0;
    for e in &header.elements {
        let per: u128 = e
            .properties
            .iter()
            .map(|(_, p)| match (header.format, p) {
                (Format::Ascii, _) => 2,
                (Format::Binary { .. }, Property::Scalar(s)) => s.size() as u128,
                (Format::Binary { .. }, Property::List { count, .. }) => count.size() as u128,
            })
            .sum();
        least += per * e.count as u128;
    }
    // The last ASCII number needs no separator after it.
    let least = if header.format == Format::Ascii { least.saturating_sub(1) } else { least };
    if least > body.len() as u128 {
        let claims: Vec<String> =
            header.elements.iter().map(|e| format!("{} {}", e.count, quote(&e.name))).collect();
        return Err(format!(
            "the header claims {} elements (at least {least} bytes), but the body holds only {} bytes: the file is cut short or its header is wrong",
            claims.join(" and "),
            body.len()
        ));
    }
    Ok(())
}

/// The vertex attributes besides positions, each empty when the file has none.
#[derive(Debug, Default)]
struct Attributes {
    normals: Vec<Vec3>,
    texcoords: Vec<Vec2>,
    colors: Vec<[u8; 4]>,
}

/// What every reading ends with: the check for faces, the warnings for skipped elements and
/// unusable texture coordinates, the colours (with a white diffuse, so that they are what
/// is seen), and the file's normals (or computed ones).
fn finish_mesh(
    mut mesh: Mesh,
    attributes: Attributes,
    header: &Header,
    name: &str,
    warnings: &mut Vec<String>,
) -> Result<Mesh, Failure> {
    let Attributes { normals, texcoords, colors } = attributes;
    if mesh.triangles.is_empty() {
        return Err((
            Location::File,
            "the file has no faces, so there is nothing to trace".to_owned(),
        ));
    }
    if header
        .elements
        .iter()
        .filter(|e| e.name != "vertex" && e.name != "face")
        .any(|e| e.count > 0)
    {
        let skipped: Vec<String> = header
            .elements
            .iter()
            .filter(|e| e.name != "vertex" && e.name != "face")
            .map(|e| quote(&e.name))
            .collect();
        warnings.push(format!("{name}: elements {} are not used", skipped.join(", ")));
    }
    mesh.triangle_materials = vec![0; mesh.triangles.len()];
    if !colors.is_empty() {
        // The diffuse colour multiplies the vertex colours: white shows them as they are.
        mesh.materials.iter_mut().for_each(|m| m.diffuse = Vec3::ONE);
        mesh.colors = colors;
    }
    if !texcoords.par_iter().all(|t| t.is_finite()) {
        warnings.push(format!("{name}: a texture coordinate is not a finite number; the model is drawn without texture coordinates"));
    } else {
        mesh.texcoords = texcoords;
    }
    if !normals.is_empty()
        && normals.par_iter().all(|n| n.is_finite() && n.try_normalize().is_some())
    {
        mesh.normals = normals.into_par_iter().map(Vec3::normalize).collect();
        mesh.has_file_normals = true;
    } else {
        mesh.compute_vertex_normals();
    }
    Ok(mesh)
}

/// A word from the file for a message, cut and escaped (see `files::shown`).
fn quote(word: &str) -> String {
    format!("`{}`", crate::files::shown(word.trim(), 60))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_ascii_quad_splits_as_the_paper_does() {
        let text = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n4 0 1 2 3\n";
        let mesh = load_ply_from_bytes(text.as_bytes(), "q.ply").unwrap().mesh;
        assert_eq!(mesh.triangles, vec![[0, 1, 3], [1, 2, 3]]);
        assert_eq!(mesh.normals.len(), 4);
        assert!(!mesh.has_file_normals);
    }

    #[test]
    fn bad_headers_and_bodies_are_one_line_naming_the_file() {
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        for (text, expected) in [
            (
                format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
                "t.ply line 13: face 0: vertex index 7 is out of range",
            ),
            (format!("{head}0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), "t.ply line 13: face 0: it has 2 corners"),
            (
                format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1 2 7 7 7\n"),
                "t.ply line 13: face 0: its vertex count says 3 but the line holds more values (`7 7 7`)",
            ),
            (format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1\n"), "t.ply line 13: the file ends here"),
            (head.replace("ascii", "utf16"), "t.ply line 2: unknown format `utf16`"),
            (head.replace("float x", "half x"), "t.ply line 4: unknown property type `half`"),
            (
                head.replace("vertex 3", "vertex 3000000000"),
                "t.ply: the header claims 3000000000 `vertex`",
            ),
        ] {
            let e = load_ply_from_bytes(text.as_bytes(), "t.ply").unwrap_err().to_string();
            assert!(e.starts_with(expected), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
