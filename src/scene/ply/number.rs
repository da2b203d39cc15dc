//! The values of an ASCII body: what both ASCII readers parse a word with ([`value`]), so
//! that they read the same numbers.

use super::Scalar;

/// A word as a value of `kind`, widened to f64: what Rust's `str::parse` gives (i64 for
/// integer types, f64 for floats), None where it fails or an integer is out of `kind`'s range.
/// The usual words (a short integer, a decimal of at most 15 digits) are read without it.
#[inline(always)]
pub(super) fn value(word: &[u8], kind: Scalar) -> Option<f64> {
    if kind.is_integer() {
        let v = match short_integer(word) {
            Some(v) => v,
            None => parsed::<i64>(word)?,
        } as f64;
        (int_min(kind)..=int_max(kind)).contains(&v).then_some(v)
    } else {
        match short_decimal(word) {
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

/// Powers of ten that f64 holds exactly.
const EXACT_POWERS: [f64; 16] =
    [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15];

/// A decimal of 1 to 15 digits with an optional sign and point and no exponent (`-0.123456`).
/// Its digits as an integer and the power of ten are both exact in f64, so the one division
/// rounds correctly: the very value `str::parse::<f64>` gives (Clinger's fast path, which it
/// takes too).
#[inline(always)]
fn short_decimal(word: &[u8]) -> Option<f64> {
    let (negative, rest) = sign(word);
    let (mut mantissa, mut digits, mut fraction) = (0u64, 0usize, None::<usize>);
    for (i, &b) in rest.iter().enumerate() {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u64::from(b - b'0');
                digits += 1;
                if digits > 15 {
                    return None;
                }
            }
            b'.' if fraction.is_none() => fraction = Some(i),
            _ => return None,
        }
    }
    if digits == 0 {
        return None;
    }
    let scale = fraction.map_or(0, |at| rest.len() - at - 1);
    let v = mantissa as f64 / EXACT_POWERS[scale];
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
        let mut words: Vec<String> = [
            "0",
            "-0",
            "+0",
            "1",
            "-1",
            "+7",
            "255",
            "256",
            "-129",
            "65535",
            "4294967295",
            "4294967296",
            "-2147483648",
            "999999999999999999",
            "9999999999999999999",
            "",
            "-",
            "+",
            ".",
            "-.",
            "1.",
            ".5",
            "-.5",
            "1..2",
            "1e5",
            "1E-3",
            "inf",
            "-inf",
            "NaN",
            "nan",
            "infinity",
            "0x10",
            "1_000",
            "١",
            "3.0",
            "0.1",
            "0.3",
            "-0.000000",
            "1.350000",
            "123456789012345",
            "1234567890123456",
            "0.123456789012345",
            "0.1234567890123456",
            "9007199254740993",
            "00000000000000000001",
            "1 ",
            "--1",
            "+-1",
            "1-",
            "1.2.3",
            "\u{feff}1",
        ]
        .map(String::from)
        .to_vec();
        // Decimals as exporters print them, with every number of digits and signs.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..20_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let digits = (seed % 17) as usize;
            let point = (seed >> 8) as usize % (digits + 1);
            let mut w: String = if seed >> 40 & 1 == 1 { "-".into() } else { String::new() };
            for i in 0..digits {
                if i == point {
                    w.push('.');
                }
                w.push(char::from(b'0' + ((seed >> (i * 3 % 60)) % 10) as u8));
            }
            words.push(w);
        }
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
