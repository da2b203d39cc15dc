use super::*;
use crate::scene::obj::fast_lines::{fast_face, leading_digits};

#[test]
fn fast_face_path_agrees_with_the_diagnosing_one() {
    // Every corner list up to 5 characters over a troublesome alphabet, after two
    // good corners, against 2 vertices, 1 texture coordinate and no normals.
    let alphabet = b"12-/ 0x+";
    let mut tail = Vec::new();
    for len in 0..=5u32 {
        for mut code in 0..alphabet.len().pow(len) {
            tail.clear();
            for _ in 0..len {
                tail.push(alphabet[code % alphabet.len()]);
                code /= alphabet.len();
            }
            let corners = String::from_utf8([b"1/1 -2 ".as_slice(), &tail].concat()).unwrap();
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
