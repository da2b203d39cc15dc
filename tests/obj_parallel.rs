//! The parallel OBJ parse against itself and against the loader it replaced: cutting the
//! text into chunks at every line (and at other sizes) gives exactly the one-chunk
//! result, and that equals the serial tobj loader's (kept as a hidden oracle), on every
//! OBJ of `tests/data/`, on hand-written texts covering what crosses a chunk boundary
//! (relative indices, `\` lines, CRLF, comments, `usemtl`/`s`/`g`/`o`, errors, warnings)
//! and on generated random texts.

use std::path::{Path, PathBuf};

use meshtracer::scene::obj::{
    load_obj_from_str_chunked, load_obj_from_str_tobj, LoadOptions, LoadedObj, ObjError,
};

/// Everything a load gives, exactly: the mesh (floats as written by Debug, which
/// round-trips them) and warnings, or the error's sentence.
fn outcome(result: Result<LoadedObj, ObjError>) -> String {
    match result {
        Ok(loaded) => format!("{:?}\n{:?}", loaded.mesh, loaded.warnings),
        Err(e) => format!("error: {e}"),
    }
}

/// Check one text: chunks of every size in `sizes` and one chunk agree with tobj. True
/// when it loaded.
fn check(
    text: &str,
    base_dir: Option<&Path>,
    options: &LoadOptions,
    sizes: impl IntoIterator<Item = usize>,
) -> bool {
    let expected = outcome(load_obj_from_str_tobj(text, "t.obj", base_dir, options));
    let whole = outcome(load_obj_from_str_chunked(text, "t.obj", base_dir, options, usize::MAX));
    assert_eq!(whole, expected, "one chunk differs from tobj on:\n{text}");
    for size in sizes {
        let chunked = outcome(load_obj_from_str_chunked(text, "t.obj", base_dir, options, size));
        assert_eq!(chunked, expected, "chunks of {size} bytes differ on:\n{text}");
    }
    !expected.starts_with("error: ")
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

fn obj_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            obj_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "obj") {
            out.push(path);
        }
    }
}

#[test]
fn every_test_file_parses_the_same_cut_at_every_line_and_matches_tobj() {
    let mut files = Vec::new();
    obj_files(&data_dir(), &mut files);
    assert!(files.len() >= 5, "{files:?}");
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        for options in [LoadOptions::default(), LoadOptions { crease_angle: Some(30.0) }] {
            check(&text, path.parent(), &options, [1, 2, 7, 64, 1000]);
        }
    }
}

/// Texts that exercise what a chunk boundary could break.
const CASES: &[&str] = &[
    // relative indices across lines
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nvt 0 0\nvt 1 1\nvn 0 0 1\nf -4/-2/-1 -3/-1/-1 -1/-2/-1\n",
    // `\` ends and CRLF
    "v 0 0 0 \\\r\nv 1 0 0\r\nv 0 1 0\r\n# comment \\\r\nf 1 2 3\r\nf 1 2 \\\n3\n",
    // materials, smoothing groups, groups and objects switching
    "mtllib materials/cube.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 1\no a\nusemtl red\ns 1\nf 1 2 3\ns off\nf 1 3 4\ng b\nusemtl blue\nf 2 3 4\nusemtl nothing\ns 2\nf 1 2 4\nusemtl blue\ns 2\nf 4 3 2 1\ng\no\nf 1 2 3\n",
    // attributes out of range: warnings with lines
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1/1 2/1/1 3/1/1\nf 1/2 2/1 3/1\nvn 0 0 1\nf 1//1 2//2 3//1\nl 1 2\nf 1/1/1 2/1/1 3/1/1\n",
    // vertex weights and colours
    "v 0 0 0 1\nv 1 0 0 2\nv 0 1 0 0.5\nf 1 2 3\n",
    "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
    "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng x\nf 1 2 3\nv 1 1 1 1 1 1\nf 1 2 3\n",
    "v 0 0 0 1 0 0\nv 1 0 0 1 0 0\nv 0 1 0\nf 1 2 3\ng x\nv 0 x 0\n",
    // errors: first in file order wins
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\nv x 0 0\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0\nf 1 2 4\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nvn 0 0\n\n  \n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/4/5/6\nf 1 2 a\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl \nf 1 2 3\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 0 0 0 1 2\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 2 3\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 2 3\n",
    // non-finite values, located
    "v 0 0 0\nv 1 0 0 1e-45\nv 0 1 0\nv nan 0 0\nf 1 2 4\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn inf 0 0\nvt 0 nan\nf 1/1/1 2/1/1 3/1/1\n",
    // nothing to trace
    "v 0 0 0\nv 1 0 0\nl 1 2\n",
    "",
    // odd whitespace and a byte-order mark
    "\u{feff}v 0 0 0\nv\u{3000}1 0 0\nv 0\u{a0}1 0\n\tf 1 2 3\u{85}\n",
];

#[test]
fn hand_written_cases_parse_the_same_at_every_cut() {
    let base = data_dir().join("obj");
    for text in CASES {
        check(text, Some(&base), &LoadOptions::default(), 1..=text.len() + 1);
        check(text, None, &LoadOptions { crease_angle: Some(45.0) }, [1, 5]);
    }
}

/// Texts for the one-pass reading of a chunk on its own (`parse_alone`) and its way back
/// to the exact one: faces whose indices are only proven in range once the chunks before
/// are counted, indices out of range before their line but not at the end of the file,
/// lines that the one-pass reading must leave to the plain one.
const ALONE_CASES: &[&str] = &[
    // in range only through the chunks before; then one past the count at its line
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3 2 1\n",
    "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\nf 1 2 3\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/2/1 3/1/2\nvt 1 1\nvn 1 0 0\nf 1/2/2 2/1/1 3/2/2\n",
    // tabs, spaces and CR around every word; no newline at the end
    "v\t0\t0\t0 \r\nv 1  0\t 0\t\r\nv 0 1 0\nvt 0.5 0.5 0.0\r\nvn 0 0 1 extra\nf\t1/1/1\t2/1/1  3/1/1 \r\nf 1 2 3",
    // more than three corners, mixed forms, long and odd numbers
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\nvt 0 0\nf 1 2 3 4 5\nf 1/1 2/1 3/1 4/1\nf 00000000000000000001 2 3\nf 1 2 99999999999999999999\n",
    // words the one pass leaves to the plain reading
    "v 1.5e3 2 3\nv 1 2 3 4\nv 1 2 3x\nv +1 -2. .5\nv 0.000000001 16777217 -0\nf 1 2 3\nf 1 2 -1\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf \nf 1 2\nf 1 2 3\n",
    "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 x\nf 1 2 3\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\n\n   \n# f 9 9 9\nf 1 2 3\nf 1 2 0\n",
    "\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\nv 0 0 1\n",
];

#[test]
fn chunks_read_alone_parse_as_the_plain_reading_at_every_cut() {
    for text in ALONE_CASES {
        check(text, None, &LoadOptions::default(), 1..=text.len() + 1);
    }
}

/// Texts for the readers of faces of position indices alone (`plain_face`) and of numbers
/// eight bytes at a time (`short_f32_fast`): what they take and what they must leave to
/// the general readers, near the end of a chunk and far from it.
const PLAIN_CASES: &[&str] = &[
    // long indices (8 digits and more, leading zeros), the last position, signs, slashes
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 00000001 00000002 000000003\nf 3 2 1 00000000000000000002\nf +1 2 3\nf 1/ 2// 3\nf 1 2 3 \t\r\nf 1\t2 3",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 100000000\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 0\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf 1 2 3\n",
    // numbers: one digit before the point, more, none, eight digits, nine, a second point
    "v -0.1234567 1.500000 -2.25\nv 12.345678 -123.5 .5\nv 5. -0 +1.5\nv 1.2345678 12345678 0.0000001\nf 1 2 3\n",
    "v 1.23456789 0 0\nv 0 1.2.3 0\nv 0 0 1\nf 1 2 3\n",
    "v 0.000001 -0.000000 16777216\nv 1677721.6 0.9999999 1\nv 0 0 1\nvt 0.5 0.25\nvn 0.0 -1.0 0.0\nf 1/1/1 2/1/1 3/1/1\n",
];

#[test]
fn plain_faces_and_short_numbers_parse_as_the_plain_reading_at_every_cut() {
    for text in PLAIN_CASES {
        check(text, None, &LoadOptions::default(), 1..=text.len() + 1);
    }
}

/// A small deterministic random number generator (xorshift), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n as u64) as usize
    }

    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[self.below(items.len())]
    }
}

/// A random OBJ-like text: valid statements, and with `bad` now and then a bad one.
fn random_obj(rng: &mut Rng, bad: bool) -> String {
    let mut text = String::new();
    let lines = 1 + rng.below(40);
    let (mut v, mut vt, mut vn) = (0usize, 0usize, 0usize);
    // Faces name elements defined before them: out of range only when `bad` (or, for
    // texture coordinates and normals, as a warning).
    let index = |rng: &mut Rng, count: usize, strict: bool| -> String {
        match rng.below(if bad {
            14
        } else if strict {
            10
        } else {
            13
        }) {
            0..=2 if count > 0 => format!("-{}", 1 + rng.below(count)),
            10 => "0".into(),
            11 => format!("{}", count + 1),
            12 => format!("-{}", count + 1),
            13 => "x".into(),
            _ => format!("{}", 1 + rng.below(count.max(1))),
        }
    };
    for _ in 0..lines {
        let line = match rng.below(20) {
            0..=5 => {
                v += 1;
                let extras: &[&str] = if bad {
                    &[" 1", " 0.5 0.5 0.5", " nan", " 2 3", " x", " 0.5 x 1", ""]
                } else {
                    &["", "", "", " 1", " 2"]
                };
                let extra = rng.pick(extras);
                let y = rng.pick(if bad {
                    &["0", "1.5", "-2e1", "inf", "x"]
                } else {
                    &["0", "1.5", "-2e1", "0", "+3"]
                });
                format!("v {} {y} {}{extra}", rng.below(5), rng.below(3))
            }
            6 => {
                vt += 1;
                let second: &[&str] =
                    if bad { &["1", "0", "x", ""] } else { &["1", "0", "0.25 7"] };
                format!("vt 0.{} {}", rng.below(10), rng.pick(second))
            }
            7 => {
                vn += 1;
                format!(
                    "vn 0 {} 1",
                    rng.pick(if bad { &["0", "1", "-1", "nan"] } else { &["0", "1", "-1", "0"] })
                )
            }
            8..=12 if v > 0 => {
                let corners = if bad { 2 + rng.below(4) } else { 3 + rng.below(3) };
                let form = rng.below(4);
                let corner = |rng: &mut Rng| match form {
                    0 => index(rng, v, true),
                    1 => format!("{}/{}", index(rng, v, true), index(rng, vt, false)),
                    2 => format!("{}//{}", index(rng, v, true), index(rng, vn, false)),
                    _ => format!(
                        "{}/{}/{}",
                        index(rng, v, true),
                        index(rng, vt, false),
                        index(rng, vn, false)
                    ),
                };
                let list: Vec<String> = (0..corners).map(|_| corner(rng)).collect();
                format!("f {}", list.join(" "))
            }
            13 => {
                let names: &[&str] = if bad {
                    &["usemtl red", "usemtl blue", "usemtl other", "usemtl "]
                } else {
                    &["usemtl red", "usemtl blue", "usemtl other"]
                };
                rng.pick(names).into()
            }
            14 => rng.pick(&["s 1", "s off", "s 2", "s 0"]).into(),
            15 => rng.pick(&["o a", "g b", "g", "o"]).into(),
            16 => rng
                .pick(&["# comment", "", "   ", "l 1 2", "vp 1 2", "mtllib materials/cube.mtl"])
                .into(),
            _ => rng.pick(&["g a \\", "\tv 0 0 1", "# f 1 2 3 \\", "s 1 \\"]).into(),
        };
        text.push_str(&line);
        text.push_str(rng.pick(&["\n", "\n", "\r\n"]));
    }
    if rng.below(3) == 0 {
        text.pop();
    }
    text
}

#[test]
fn random_texts_parse_the_same_at_every_cut_and_match_tobj() {
    let base = data_dir().join("obj");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let rounds =
        std::env::var("OBJ_RANDOM_ROUNDS").ok().and_then(|n| n.parse().ok()).unwrap_or(600);
    let mut loaded = 0;
    for round in 0..rounds {
        let text = random_obj(&mut rng, round % 3 == 0);
        loaded += usize::from(check(&text, Some(&base), &LoadOptions::default(), [1, 3, 17, 64]));
    }
    // Both outcomes are well represented, or the comparison proves little.
    assert!(loaded > rounds / 3 && loaded < rounds * 9 / 10, "{loaded} of {rounds} texts loaded");
}

/// A grid of `n` x `m` positions whose faces name them in an order of their own (first
/// use is not file order), with triangles, quads and pentagons, relative indices, and a
/// group switch in the middle: faces of position indices alone, de-duplicated over many
/// chunks (`plain_dedup.rs`) and, with `extra`, with texture coordinates and normals too.
fn grid_obj(n: usize, m: usize, colours: bool, extra: bool) -> String {
    let mut text = String::new();
    for i in 0..n {
        for j in 0..m {
            let colour = if colours {
                format!(" {} 0.5 {}", (i % 2) as f32, (j % 3) as f32 / 2.0)
            } else {
                String::new()
            };
            text += &format!("v {}.{} {}.25 -{}.5{colour}\n", i, j, j, (i * j) % 7);
        }
    }
    if extra {
        text += "vt 0.5 0.5\nvn 0 0 1\n";
    }
    let at = |i: usize, j: usize| 1 + (i % n) * m + (j % m);
    let total = n * m;
    for i in (0..n).rev() {
        if i == n / 2 {
            text += "g middle\n";
        }
        for j in 0..m {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            let corner =
                |k: usize| if extra && k % 3 == 0 { format!("{k}/1/1") } else { k.to_string() };
            text += &match (i + j) % 5 {
                0 => format!("f {} {} {} {}\n", corner(a), corner(b), corner(c), corner(d)),
                1 => format!("f {} {} {}\r\n", corner(c), corner(b), corner(a)),
                2 => format!("f -{} {}\t{} \n", total + 1 - a, corner(c), corner(d)),
                3 => format!(
                    "f {} {} {} {} {}\n",
                    corner(a),
                    corner(b),
                    corner(c),
                    corner(d),
                    corner(a + 1)
                ),
                _ => format!("f {} {} {}\n", corner(d), corner(a), corner(c)),
            };
        }
    }
    text
}

#[test]
fn faces_of_positions_alone_over_many_chunks_match_tobj() {
    for (colours, extra) in [(false, false), (true, false), (false, true)] {
        let text = grid_obj(9, 7, colours, extra);
        assert!(check(&text, None, &LoadOptions::default(), [1, 13, 100, 700, 3000]));
    }
}
