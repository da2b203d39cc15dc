//! The one-pass readers of an OBJ chunk's common lines (`v`, `vt`, `vn` of short decimals,
//! faces of well-formed indices): each reads its line's bytes once, where splitting it into
//! words and parsing each would take several; anything else falls back to the plain reader
//! in `parse_chunk.rs`, which words what is wrong.

use super::chunks::{find_newline, is_ascii_space, NONE};
use crate::scene::decimal::short_f32_prefix;

/// The fast path for a line's first `N` numbers when each is a short decimal
/// (`scene/decimal.rs`; nearly every `v`, `vt` and `vn` line): the numbers and where the
/// text after them begins, or None for [`numbers`] to read them (and word what is wrong).
/// One pass over the bytes, where `words` and `str::parse` would take several. `text` may
/// run on past the line: its `\n` ends it.
#[inline(always)]
pub(super) fn short_numbers<const N: usize>(text: &[u8]) -> Option<([f32; N], usize)> {
    let (mut out, mut i) = ([0.0; N], 0);
    for slot in &mut out {
        i = skip_blanks(text, i);
        let (value, len) = short_f32_fast(&text[i..])?;
        i += len;
        // The number must be the whole word.
        if text.get(i).is_some_and(|&b| !is_ascii_space(b)) {
            return None;
        }
        *slot = value;
    }
    Some((out, i))
}

/// [`short_f32_prefix`], with the usual shape of a number (`-1.234567`: an optional minus,
/// digits, a point, digits, at most 8 in all) read eight bytes at a time: a byte at a
/// time took about 20 instructions a byte, two thirds of a `v` line's. Anything else, and
/// text too near the end of the chunk, goes to `short_f32_prefix`.
#[inline(always)]
pub(super) fn short_f32_fast(text: &[u8]) -> Option<(f32, usize)> {
    /// Powers of ten, exact as u64 and as f32 (5^7 < 2^24).
    const POWERS: [(u64, f32); 8] = [
        (1, 1e0),
        (10, 1e1),
        (100, 1e2),
        (1000, 1e3),
        (1e4 as u64, 1e4),
        (1e5 as u64, 1e5),
        (1e6 as u64, 1e6),
        (1e7 as u64, 1e7),
    ];
    let negative = text.first() == Some(&b'-');
    let mut i = usize::from(negative);
    let (integer, n) = match text.get(i..i + 2) {
        // One digit before the point (`-0.123456`, the usual shape): no eight-byte read.
        Some(&[d, b'.']) if d.is_ascii_digit() => (u64::from(d - b'0'), 1),
        _ => leading_digits(text.get(i..).unwrap_or_default()),
    };
    // No digit (a plus, a point first...) or 8 of them (perhaps more): the plain reading.
    if n == 0 || n == 8 {
        return plain_f32(text);
    }
    // Fewer than 8 digits out of 8 bytes read: a byte that is no digit follows them.
    i += n;
    let (mantissa, scale) = if text.get(i) == Some(&b'.') {
        let (fraction, m) = leading_digits(text.get(i + 1..).unwrap_or_default());
        // `5.`, more than 8 digits in all, or the chunk's end near: the plain reading.
        let Some(&(power, _)) = POWERS.get(m).filter(|_| m > 0 && n + m <= 8) else {
            return plain_f32(text);
        };
        // At most 7 digits after the point (there is one before), so again a byte that is
        // no digit follows, where the plain reading stops too (a second point included).
        i += 1 + m;
        (integer * power + fraction, m)
    } else {
        (integer, 0)
    };
    // Past f32's exact integers: the plain reading says no the same way.
    if mantissa > 1 << 24 {
        return plain_f32(text);
    }
    let v = mantissa as f32 / POWERS[scale].1;
    Some((if negative { -v } else { v }, i))
}

/// The rare shapes: `short_f32_prefix`, out of line, so that [`short_f32_fast`]'s inlined
/// copies stay small (fewer registers spilled in the line loop).
#[cold]
#[inline(never)]
fn plain_f32(text: &[u8]) -> Option<(f32, usize)> {
    short_f32_prefix(text)
}

/// The first byte at or after `i` that is not whitespace, or is a `\n`.
#[inline(always)]
pub(super) fn skip_blanks(text: &[u8], mut i: usize) -> usize {
    while i < text.len() && text[i] != b'\n' && is_ascii_space(text[i]) {
        i += 1;
    }
    i
}

/// The length of the line in `text` (its `\n` included) when nothing but whitespace
/// follows `i` on it.
#[inline(always)]
pub(super) fn blank_to_line_end(text: &[u8], i: usize) -> Option<usize> {
    let i = skip_blanks(text, i);
    match text.get(i) {
        None => Some(i),
        Some(b'\n') => Some(i + 1),
        Some(_) => None,
    }
}

/// The length of the line in `text` (its `\n` included), from `i` on it.
#[inline(always)]
pub(super) fn rest_of_line(text: &[u8], i: usize) -> usize {
    find_newline(&text[i..]).map_or(text.len(), |n| i + n + 1)
}

/// The fast path for a face whose corners are all well-formed ASCII with indices in range
/// (nearly every face): `text` is the face after its `f` and may run on past the line
/// (its `\n` ends it). Gives the corners, resolved, in `out` and the largest index of each
/// kind in `largest`, and returns the number of corners and the line's length with its
/// `\n`; or None (with `out` perhaps grown) when [`check_face`] has something to say, or,
/// without `relative`, for a negative index.
pub(super) fn fast_face(
    text: &[u8],
    available: [u64; 3],
    relative: bool,
    largest: &mut [u64; 3],
    out: &mut Vec<[u32; 3]>,
) -> Option<(u32, usize)> {
    let (n, mut i, mut count) = (text.len(), 0, 0u32);
    loop {
        i = skip_blanks(text, i);
        match text.get(i) {
            None => return (count >= 3).then_some((count, i)),
            Some(b'\n') => return (count >= 3).then_some((count, i + 1)),
            Some(_) => {}
        }
        count += 1;
        let mut corner = [NONE; 3];
        // One corner: up to three slash-separated indices, v required.
        for (slot, &available) in available.iter().enumerate() {
            let negative = text.get(i) == Some(&b'-');
            if negative && !relative {
                return None;
            }
            let signed = negative || text.get(i) == Some(&b'+');
            i += usize::from(signed);
            let (start, (mut value, digits)) = (i, leading_digits(&text[i..]));
            i += digits;
            // Past the eighth digit, or near the end of the chunk: a digit at a time.
            while i < n && text[i].is_ascii_digit() {
                value = value.wrapping_mul(10).wrapping_add(u64::from(text[i] - b'0'));
                i += 1;
            }
            // More digits than u64 surely holds: out of range, for `check_face` to say so
            // (the plain multiply-add is what makes this loop fast).
            if i - start > 18 {
                return None;
            }
            if i == start {
                // Only texture coordinates and normals may be left out, and without a sign.
                if slot == 0 || signed {
                    return None;
                }
            } else if (1..=available).contains(&value) {
                corner[slot] = if negative { available - value } else { value - 1 } as u32;
                largest[slot] = largest[slot].max(value);
            } else {
                return None;
            }
            match text.get(i) {
                Some(b'/') if slot < 2 => i += 1,
                None => break,
                Some(&b) if is_ascii_space(b) => break,
                Some(_) => return None,
            }
        }
        out.push(corner);
    }
}

/// The fast path for a face of position indices alone (`f 1 2 3`, the faces of most large
/// files): what [`fast_face`] reads of such a face, without its work on slashes and signs
/// (a face with either is left to it). The 0-based indices in `out` (which may run past
/// `available` as `u32`: `largest` then says so), the largest index in `largest`; returns
/// the number of corners and the line's length with its `\n`, or None (with `out` perhaps
/// grown).
#[inline(always)]
pub(super) fn plain_face(
    text: &[u8],
    available: u64,
    largest: &mut u64,
    out: &mut Vec<u32>,
) -> Option<(u32, usize)> {
    // The first three corners in registers (nearly every face is a triangle), stored at once.
    let (a, i) = plain_index(text, 0, available)?;
    let (b, i) = plain_index(text, i, available)?;
    let (c, mut i) = plain_index(text, i, available)?;
    *largest = (*largest).max(a.max(b).max(c));
    out.extend_from_slice(&[a, b, c].map(|v| (v - 1) as u32));
    let mut count = 3;
    loop {
        i = skip_blanks(text, i);
        match text.get(i) {
            None => return Some((count, i)),
            Some(b'\n') => return Some((count, i + 1)),
            Some(_) => {}
        }
        let (v, next) = plain_index(text, i, available)?;
        *largest = (*largest).max(v);
        out.push((v - 1) as u32);
        (i, count) = (next, count + 1);
    }
}

/// The index of a plain face corner at or after `i` (blanks skipped), 1-based, and where
/// the text after it begins; None at the line's end, or for anything but up to 18 digits
/// of a value in `1..=available` followed by a blank or the end.
#[inline(always)]
fn plain_index(text: &[u8], i: usize, available: u64) -> Option<(u64, usize)> {
    let start = skip_blanks(text, i);
    let (mut value, digits) = leading_digits(text.get(start..).unwrap_or_default());
    let mut i = start + digits;
    // Fewer than 8 digits out of 8 bytes read: a byte that is no digit follows them.
    // Otherwise (past the eighth digit, or near the end of the chunk) a digit at a time.
    if digits == 0 || digits == 8 {
        while i < text.len() && text[i].is_ascii_digit() {
            value = value.wrapping_mul(10).wrapping_add(u64::from(text[i] - b'0'));
            i += 1;
        }
    }
    // No digit (a sign, a slash, the line's end...), too many, or out of range: `fast_face`
    // decides (the plain multiply-add above is exact up to 18 digits).
    if i == start || i - start > 18 || !(1..=available).contains(&value) {
        return None;
    }
    if text.get(i).is_some_and(|&b| !is_ascii_space(b)) {
        return None;
    }
    Some((value, i))
}

/// The value and number of the decimal digits that `text` starts with, up to 8 of them,
/// read eight bytes at once (indices are the bulk of a face; a loop took about 8
/// instructions a digit); (0, 0) when fewer than 8 bytes are left.
#[inline(always)]
pub(super) fn leading_digits(text: &[u8]) -> (u64, usize) {
    const SPREAD: u64 = u64::from_ne_bytes([0x80; 8]);
    let Some(word) = text.first_chunk::<8>() else { return (0, 0) };
    // Each byte minus '0' (as an xor: a digit is 0x30..=0x39): 0..=9 for a digit.
    let t = u64::from_le_bytes(*word) ^ u64::from_ne_bytes([b'0'; 8]);
    // The top bit of a byte is set where it is 10 or more. Adding may carry into the next
    // byte, but only from a byte that is no digit, so the first such byte is still found.
    let not_digit = (t.wrapping_add(u64::from_ne_bytes([0x76; 8])) | t) & SPREAD;
    let count = (not_digit.trailing_zeros() / 8) as usize;
    if count == 0 {
        return (0, 0);
    }
    // The digits to the top bytes, zeros before them, then pairs, fours and eights
    // combined (the first byte is the most significant digit).
    let t = t << (8 * (8 - count));
    let t = (t & 0x0f0f_0f0f_0f0f_0f0f).wrapping_mul(2561) >> 8;
    let t = (t & 0x00ff_00ff_00ff_00ff).wrapping_mul(6_553_601) >> 16;
    let t = (t & 0x0000_ffff_0000_ffff).wrapping_mul(42_949_672_960_001) >> 32;
    (t, count)
}

/// `prefix` followed by every string of at most `max_len` bytes over `alphabet`: the short
/// inputs on which tests hold a one-pass reader to the plain reading, every one of them.
#[cfg(test)]
pub(super) fn every_text_after<'a>(
    prefix: &'a [u8],
    alphabet: &'a [u8],
    max_len: u32,
) -> impl Iterator<Item = Vec<u8>> + 'a {
    (0..=max_len).flat_map(move |len| {
        (0..alphabet.len().pow(len)).map(move |mut code| {
            let mut text = prefix.to_vec();
            for _ in 0..len {
                text.push(alphabet[code % alphabet.len()]);
                code /= alphabet.len();
            }
            text
        })
    })
}
