//! Short decimals read without `str::parse`, for both text readers (OBJ, ASCII PLY): the
//! digits of a word like `-0.123456` as an integer and the power of ten of its point are
//! both exact in the float type, so one division rounds correctly and gives the very value
//! `str::parse` gives (Clinger's fast path, which the standard library takes too). Any
//! other word (an exponent, too many digits, `inf`) gives None, for `str::parse` to read.

/// Powers of ten that f64 holds exactly (up to the most digits [`short_f64`] reads).
const F64_POWERS: [f64; 16] =
    [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15];

/// Powers of ten that f32 holds exactly (5^10 < 2^24).
const F32_POWERS: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// `word` as an f64 when it is a decimal of 1 to 15 digits with an optional sign and point
/// and no exponent; None otherwise.
#[inline(always)]
pub(crate) fn short_f64(word: &[u8]) -> Option<f64> {
    let (negative, mantissa, scale) = parts(word, 15)?;
    let v = mantissa as f64 / F64_POWERS[scale];
    Some(if negative { -v } else { v })
}

/// `word` as an f32 when it is a decimal of 1 to 8 digits with an optional sign and point,
/// no exponent, at most 10 digits after the point and digits worth at most 2^24 as an
/// integer (so that f32 holds them exactly); None otherwise.
#[inline(always)]
pub(crate) fn short_f32(word: &[u8]) -> Option<f32> {
    short_f32_prefix(word).and_then(|(v, len)| (len == word.len()).then_some(v))
}

/// The decimal that `text` starts with (sign, digits and point, up to the first other
/// byte) as [`short_f32`] reads that word, and its length: for a parser that reads a line
/// in one pass and checks itself what follows the number.
#[inline(always)]
pub(crate) fn short_f32_prefix(text: &[u8]) -> Option<(f32, usize)> {
    let (negative, mantissa, scale, len) = leading_parts(text, 8)?;
    if mantissa > 1 << 24 || scale >= F32_POWERS.len() {
        return None;
    }
    let v = mantissa as f32 / F32_POWERS[scale];
    Some((if negative { -v } else { v }, len))
}

/// A decimal's sign, its digits as an integer and the number of digits after its point;
/// None when it has no digit, more than `max_digits`, or anything but digits and one point
/// after an optional sign.
#[inline(always)]
fn parts(word: &[u8], max_digits: usize) -> Option<(bool, u64, usize)> {
    let (negative, mantissa, scale, len) = leading_parts(word, max_digits)?;
    (len == word.len()).then_some((negative, mantissa, scale))
}

/// [`parts`] of the longest start of `text` made of an optional sign, digits and one
/// point, and that start's length; None when it has no digit or more than `max_digits`.
#[inline(always)]
fn leading_parts(text: &[u8], max_digits: usize) -> Option<(bool, u64, usize, usize)> {
    let negative = text.first() == Some(&b'-');
    let mut i = usize::from(matches!(text.first(), Some(b'-' | b'+')));
    let (mut mantissa, mut digits, mut point) = (0u64, 0usize, None);
    while let Some(&b) = text.get(i) {
        match b {
            b'0'..=b'9' if digits < max_digits => {
                mantissa = mantissa * 10 + u64::from(b - b'0');
                digits += 1;
            }
            b'0'..=b'9' => return None,
            b'.' if point.is_none() => point = Some(i),
            _ => break,
        }
        i += 1;
    }
    if digits == 0 {
        return None;
    }
    Some((negative, mantissa, point.map_or(0, |at| i - at - 1), i))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Edge words, and decimals as exporters print them (the readers' own tests use them too): every number of digits (0 to 16),
    /// the point anywhere, with and without a sign.
    pub(crate) fn words() -> Vec<String> {
        let mut words: Vec<String> = [
            "0",
            "-0",
            "+0",
            "1",
            "-1",
            "+7",
            "-1.5",
            ".5",
            "5.",
            "-.5",
            ".",
            "-",
            "+",
            "-.",
            "",
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
            "\u{e9}",
            "16777216",
            "16777217",
            "1677721.7",
            "0.0000000001",
            "0.00000000001",
            "1.350000",
            "-0.000000",
            "12345678",
            "123456789",
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
            "1..2",
            "1.2.3",
            "\u{feff}1",
        ]
        .map(String::from)
        .to_vec();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..50_000 {
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
        words
    }

    #[test]
    fn short_decimals_are_what_str_parse_gives_and_the_rest_are_left_to_it() {
        let (mut read_f64, mut read_f32) = (0, 0);
        for w in &words() {
            if let Some(v) = short_f64(w.as_bytes()) {
                assert_eq!(Some(v.to_bits()), w.parse::<f64>().ok().map(f64::to_bits), "{w:?}");
                read_f64 += 1;
            }
            if let Some(v) = short_f32(w.as_bytes()) {
                assert_eq!(Some(v.to_bits()), w.parse::<f32>().ok().map(f32::to_bits), "{w:?}");
                read_f32 += 1;
            }
        }
        // Most words take the fast paths (the test would pass vacuously otherwise).
        assert!(read_f64 > 40_000 && read_f32 > 20_000, "{read_f64} {read_f32}");
    }

    #[test]
    fn words_past_the_exact_range_are_left_to_str_parse() {
        for w in ["1234567890123456", "9007199254740993", "1e5", "inf", "", "-", "1.2.3"] {
            assert_eq!(short_f64(w.as_bytes()), None, "{w:?}");
        }
        for w in ["123456789", "16777217", "0.00000000001", "1e5", "."] {
            assert_eq!(short_f32(w.as_bytes()), None, "{w:?}");
        }
        assert_eq!(short_f32(b"16777216"), Some(16_777_216.0));
        assert_eq!(short_f64(b"-0.5"), Some(-0.5));
    }
}
