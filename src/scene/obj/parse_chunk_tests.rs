use super::*;
use crate::scene::decimal::short_f32_prefix;
use crate::scene::obj::fast_lines::{
    every_text_after, fast_face, leading_digits, plain_face, short_f32_fast,
};

#[test]
fn fast_face_path_agrees_with_the_diagnosing_one() {
    // Every corner list up to 5 characters over a troublesome alphabet, after two
    // good corners, against 2 vertices, 1 texture coordinate and no normals.
    for corners in every_text_after(b"1/1 -2 ", b"12-/ 0x+", 5) {
        let corners = String::from_utf8(corners).unwrap();
        let slow = matches!(check_face(words(&corners), [2, 1, 0], "f"), Ok((None, None)));
        let mut out = Vec::new();
        let fast = fast_face(corners.as_bytes(), [2, 1, 0], true, &mut [0; 3], &mut out);
        assert_eq!(fast.is_some(), slow, "f {corners}");
        if let Some((n, len)) = fast {
            assert_eq!(len, corners.len(), "f {corners}");
            assert_eq!(
                (out.len(), out[0], out[1]),
                (n as usize, [0, 0, NONE], [0, NONE, NONE]),
                "f {corners}"
            );
        }
    }
}

#[test]
fn plain_face_path_takes_what_the_general_one_takes_alike() {
    // Every corner list up to 6 characters over a troublesome alphabet (signs, slashes,
    // CR, tabs, a newline), after one good corner, against 3 vertices; and long indices.
    let alphabet = b"13-/ 0+\r\t\n9";
    let mut texts =
        vec![b"1 2 3".to_vec(), b"3 2 1 \r\n".to_vec(), b"1 2 00000000000000000003".to_vec()];
    texts.push(b"1 2 9999999999999999999".to_vec());
    texts.push(b"1 2 33333333\n".to_vec());
    texts.extend(every_text_after(b"1 ", alphabet, 6));
    let mut taken = 0;
    for text in &texts {
        for available in [3, u64::MAX] {
            let (mut plain, mut largest) = (Vec::new(), 0);
            let Some(read) = plain_face(text, available, &mut largest, &mut plain) else {
                continue;
            };
            taken += 1;
            let (mut full, mut largest_full) = (Vec::new(), [0; 3]);
            let general = fast_face(text, [available, 0, 0], true, &mut largest_full, &mut full);
            let shown = String::from_utf8_lossy(text);
            assert_eq!(Some(read), general, "f {shown}");
            assert_eq!(
                plain.iter().map(|&v| [v, NONE, NONE]).collect::<Vec<_>>(),
                full,
                "f {shown}"
            );
            assert_eq!([largest, 0, 0], largest_full, "f {shown}");
        }
    }
    assert!(taken > 1000, "{taken}");
}

#[test]
fn corners_turn_into_triples_at_the_first_that_needs_one() {
    use crate::scene::obj::corners::Corners;
    let mut corners = Corners::default();
    corners.extend(&[[1, NONE, NONE], [2, NONE, NONE]]);
    assert!(matches!(&corners, Corners::Plain(p) if p == &[1, 2]));
    corners.extend(&[[3, NONE, 0]]);
    corners.extend(&[[4, NONE, NONE]]);
    corners.truncate(3);
    assert_eq!(corners.len(), 3);
    assert_eq!(corners.into_full(), [[1, NONE, NONE], [2, NONE, NONE], [3, NONE, 0]]);
}

#[test]
fn numbers_eight_bytes_at_once_are_what_the_plain_reading_gives() {
    let mut fast = 0;
    for word in crate::scene::decimal::tests::words() {
        // What may follow a number on a line, and the end of the chunk.
        for after in ["", " ", "\n", "\r\n", " 1.5 2.5\n", "x", ".5 ", "/", "0", "12345678 "] {
            let text = format!("{word}{after}");
            let plain = short_f32_prefix(text.as_bytes()).map(|(v, n)| (v.to_bits(), n));
            let read = short_f32_fast(text.as_bytes()).map(|(v, n)| (v.to_bits(), n));
            assert_eq!(read, plain, "{text:?}");
            fast += usize::from(read.is_some());
        }
    }
    assert!(fast > 100_000, "{fast}");
}

#[test]
fn eight_digits_at_once_are_what_a_digit_at_a_time_gives() {
    let alphabet = b"0123456789/ \n-+:\xc3\xff\x00";
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for round in 0..200_000 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        // Mostly digits, so that every count from 0 to 8 comes up.
        let text: Vec<u8> = (0..6 + round % 8)
            .map(|k| {
                let pick = (seed >> (k * 5)) as usize;
                if pick % 4 == 0 {
                    alphabet[pick / 4 % alphabet.len()]
                } else {
                    b'0' + (pick / 4 % 10) as u8
                }
            })
            .collect();
        let count = text.iter().take(8).take_while(|b| b.is_ascii_digit()).count();
        let value = text[..count].iter().fold(0u64, |v, &b| v * 10 + u64::from(b - b'0'));
        let expected = if text.len() < 8 { (0, 0) } else { (value, count) };
        assert_eq!(leading_digits(&text), expected, "{:?}", String::from_utf8_lossy(&text));
    }
}

#[test]
fn words_split_as_split_whitespace_splits() {
    for text in [" a  b\tc\r", "", "  ", "x\u{3000}y z", "\u{85}q"] {
        assert_eq!(
            words(text).collect::<Vec<_>>(),
            text.split_whitespace().collect::<Vec<_>>(),
            "{text:?}"
        );
    }
}
