//! The values of an ASCII body: what both ASCII readers parse a word with ([`value`]), so
//! that they read the same numbers.

use super::Scalar;

/// A word as a value of `kind`, widened to f64: what Rust's `str::parse` gives (i64 for
/// integer types, f64 for floats), None where it fails or an integer is out of `kind`'s range.
/// The usual words (a short integer, a decimal of at most 15 digits: `scene/decimal.rs`) are
/// read without it.
#[inline(always)]
pub(super) fn value(word: &[u8], kind: Scalar) -> Option<f64> {
    if kind.is_integer() {
        let v = match short_integer(word) {
            Some(v) => v,
            None => parsed::<i64>(word)?,
        } as f64;
        (int_min(kind)..=int_max(kind)).contains(&v).then_some(v)
    } else {
        match crate::scene::decimal::short_f64(word) {
            Some(v) => Some(v),
            None => parsed::<f64>(word),
        }
    }
}

/// A word `str::parse` reads: the rare words, kept out of line so that [`value`] inlines.
#[cold]
#[inline(never)]
fn parsed<T: std::str::FromStr>(word: &[u8]) -> Option<T> {
    std::str::from_utf8(word).ok()?.parse().ok()
}

/// The sign of a number and its digits after it.
#[inline]
fn sign(word: &[u8]) -> (bool, &[u8]) {
    match word.first() {
        Some(b'-') => (true, &word[1..]),
        Some(b'+') => (false, &word[1..]),
        _ => (false, word),
    }
}

/// An integer of 1 to 18 digits after an optional sign (so that it cannot overflow).
#[inline(always)]
fn short_integer(word: &[u8]) -> Option<i64> {
    let (negative, digits) = sign(word);
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        v = v * 10 + i64::from(d - b'0');
    }
    Some(if negative { -v } else { v })
}

/// The least value of an integer type.
fn int_min(kind: Scalar) -> f64 {
    match kind {
        Scalar::I8 => i8::MIN as f64,
        Scalar::I16 => i16::MIN as f64,
        Scalar::I32 => i32::MIN as f64,
        _ => 0.0,
    }
}

/// The greatest value of an integer type (of u32 for the floats, which are not asked).
fn int_max(kind: Scalar) -> f64 {
    match kind {
        Scalar::I8 => i8::MAX as f64,
        Scalar::U8 => u8::MAX as f64,
        Scalar::I16 => i16::MAX as f64,
        Scalar::U16 => u16::MAX as f64,
        Scalar::I32 => i32::MAX as f64,
        _ => u32::MAX as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `Body::next` did before the short paths: `str::parse`.
    fn plain(word: &str, kind: Scalar) -> Option<f64> {
        let v = if kind.is_integer() {
            word.parse::<i64>().ok().map(|v| v as f64)
        } else {
            word.parse::<f64>().ok()
        }?;
        (!kind.is_integer() || (int_min(kind)..=int_max(kind)).contains(&v)).then_some(v)
    }

    #[test]
    fn values_are_what_str_parse_gives() {
        let mut words = crate::scene::decimal::tests::words();
        words.extend(
            ["255", "256", "-129", "65535", "4294967295", "4294967296", "-2147483648"]
                .map(String::from),
        );
        words.extend(["999999999999999999", "9999999999999999999"].map(String::from));
        for w in &words {
            for kind in [Scalar::F32, Scalar::F64, Scalar::U8, Scalar::I8, Scalar::I32, Scalar::U32]
            {
                let (ours, theirs) = (value(w.as_bytes(), kind), plain(w, kind));
                assert_eq!(ours.map(f64::to_bits), theirs.map(f64::to_bits), "{w:?} as {kind:?}");
            }
        }
        assert_eq!(value(b"\xff1", Scalar::F32), None, "bytes that are not UTF-8");
    }
}
