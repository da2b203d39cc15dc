//! The line feeder's unit tests (kept apart so that `line_feeder.rs` stays short).

use super::*;

#[test]
fn index_parsing_accepts_signs_and_saturates() {
    assert_eq!(parse_index(b"12"), Some(12));
    assert_eq!(parse_index(b"-3"), Some(-3));
    assert_eq!(parse_index(b"+7"), Some(7));
    assert_eq!(parse_index(b"99999999999999999999999"), Some(i64::MAX));
    for bad in ["", "-", "1a", "1.0", " 1", "+-1"] {
        assert_eq!(parse_index(bad.as_bytes()), None, "{bad:?}");
    }
}

#[test]
fn fast_face_check_agrees_with_the_diagnosing_one() {
    // Every corner list up to 5 characters over a troublesome alphabet, after two
    // good corners, against 2 vertices, 1 texture coordinate and no normals.
    let mut feeder = LineFeeder::new("", "t.obj", true);
    (feeder.vertices, feeder.texcoords, feeder.normals) = (2, 1, 0);
    for corners in super::super::fast_lines::every_text_after(b"1/1 -2 ", b"12-/ 0x+", 5) {
        let words = corners.split(|&b| is_ascii_space(b)).filter(|w| !w.is_empty());
        let slow = matches!(feeder.check_face(words), Ok((None, None)));
        let text = String::from_utf8_lossy(&corners);
        assert_eq!(face_is_valid(&corners, [2, 1, 0], &mut Vec::new()), slow, "f {text}");
    }
}

#[test]
fn polylines_are_recognised_as_tobj_reads_them() {
    for yes in ["l 1 2", "  l 1 2 3\n", "\u{3000}l\t1 2", "l", "l\n"] {
        assert!(starts_polyline(yes), "{yes:?}");
    }
    for no in ["", "\nl 1 2", "ln 1 2", "f 1 2 3", "# l 1 2", "lod 1"] {
        assert!(!starts_polyline(no), "{no:?}");
    }
}

#[test]
fn faces_are_handed_out_without_the_attributes_they_name_out_of_range() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1/1 2/1/1 3/1/1\n  f 1/2 2/1 3/1\r\nl 1 2\ns 1\nf 1 2 3\ns off\nf 3/1 2/1 1/1";
    let mut feeder = LineFeeder::new(text, "t.obj", true);
    let mut lines = Vec::new();
    let mut buf = String::new();
    while feeder.read_line(&mut buf).unwrap() > 0 {
        lines.push((feeder.line, std::mem::take(&mut buf)));
    }
    let handed: Vec<(usize, &str)> = lines.iter().map(|(n, l)| (*n, l.as_str())).collect();
    assert_eq!(
        handed[4..],
        [
            (5, "f 1/1 2/1 3/1\n"),
            (6, "f 1 2 3\n"),
            (7, "\n"),
            (8, "s 1\n"),
            (9, "f 1 2 3\n"),
            (10, "s off\n"),
            (11, "f 3/1 2/1 1/1")
        ]
    );
    assert_eq!((feeder.faces, feeder.smoothing.as_slice()), (4, [(2, 1), (3, 0)].as_slice()));
    assert_eq!(feeder.dropped_normals.faces, [0]);
    assert_eq!(feeder.dropped_texcoords.faces, [1]);
    let first = feeder.dropped_texcoords.first.as_ref().unwrap();
    assert_eq!((first.line, first.index.as_str(), first.count), (6, "2", 1));
    assert!(feeder.error.is_none());
}

#[test]
fn feeder_hands_out_one_line_at_a_time_and_counts_them() {
    let mut feeder = LineFeeder::new("a\nbb\r\n\nccc", "x", false);
    let mut lines = Vec::new();
    let mut buf = String::new();
    while feeder.read_line(&mut buf).unwrap() > 0 {
        lines.push((feeder.line, std::mem::take(&mut buf)));
    }
    assert_eq!(
        lines,
        [(1, "a\n".into()), (2, "bb\r\n".into()), (3, "\n".into()), (4, "ccc".into())]
    );
}
