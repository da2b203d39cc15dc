//! Cutting an OBJ text into chunks that can be parsed in parallel, and counting what a
//! chunk holds (lines, `v`/`vt`/`vn`) where its own parse could not: the counts before a
//! chunk are what its faces' absolute and relative indices are checked and resolved against.
//!
//! A chunk always starts at the start of a line. A line ending in `\` is never the last
//! line of a chunk (some writers continue a statement on the next line that way; tobj,
//! whose behaviour the loader keeps, reads every line on its own), and as chunks end just
//! after a `\n`, a CRLF is never split.

/// A corner index that is absent (`v//vn` has no texture coordinate).
pub(super) const NONE: u32 = u32::MAX;

/// Below this many bytes a file is parsed as one chunk: threads would cost more than they save.
const MIN_CHUNK_BYTES: usize = 1 << 20;

/// One piece of the text and where it starts in the whole file.
#[derive(Clone, Copy, Debug)]
pub(super) struct Chunk<'a> {
    /// Whole lines, the last one with its `\n` unless it is the file's last line.
    pub(super) text: &'a str,
    /// Byte offset of `text` in the whole text.
    pub(super) offset: usize,
}

/// What one chunk holds (and, summed, what the chunks before one hold).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Counts {
    /// Lines (a last line without `\n` counts).
    pub(super) lines: usize,
    pub(super) positions: usize,
    pub(super) texcoords: usize,
    pub(super) normals: usize,
}

impl Counts {
    /// The sum of both.
    pub(super) fn add(self, other: Counts) -> Counts {
        Counts {
            lines: self.lines + other.lines,
            positions: self.positions + other.positions,
            texcoords: self.texcoords + other.texcoords,
            normals: self.normals + other.normals,
        }
    }

    /// What `self` holds beyond `before` (which it includes).
    pub(super) fn minus(self, before: Counts) -> Counts {
        Counts {
            lines: self.lines - before.lines,
            positions: self.positions - before.positions,
            texcoords: self.texcoords - before.texcoords,
            normals: self.normals - before.normals,
        }
    }
}

/// The chunk size for a text: about four chunks per thread, none smaller than 1 MiB.
pub(super) fn default_chunk_bytes(text_len: usize) -> usize {
    (text_len / (4 * rayon::current_num_threads()).max(1)).max(MIN_CHUNK_BYTES)
}

/// Cut `bytes` into pieces of about `chunk_bytes` (at least one byte), at line starts
/// (just after a `\n` byte, which is never inside a UTF-8 sequence).
pub(super) fn split(bytes: &[u8], chunk_bytes: usize) -> Vec<(usize, &[u8])> {
    let mut pieces = Vec::new();
    let mut start = 0;
    while start < bytes.len() {
        let mut end = (start + chunk_bytes.max(1)).min(bytes.len());
        loop {
            // Extend to the end of the line that `end` falls in (or that ends just before it).
            end = match memchr(b'\n', &bytes[end - 1..]) {
                Some(i) => end + i,
                None => bytes.len(),
            };
            if end == bytes.len() || !continues(&bytes[start..end]) {
                break;
            }
            end += 1;
        }
        pieces.push((start, &bytes[start..end]));
        start = end;
    }
    pieces
}

/// True when the line ending at the end of `text` (its `\n` included) ends in `\`.
fn continues(text: &[u8]) -> bool {
    let line = text.strip_suffix(b"\n").unwrap_or(text);
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    line.ends_with(b"\\")
}

/// A piece as a chunk of text, or, when it is not UTF-8, the number of whole lines before
/// its first invalid byte.
pub(super) fn text_of(offset: usize, bytes: &[u8]) -> Result<Chunk<'_>, usize> {
    match std::str::from_utf8(bytes) {
        Ok(text) => Ok(Chunk { text, offset }),
        Err(e) => Err(bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count()),
    }
}

/// The text of a file that is not all UTF-8, where that is only in comments and in the
/// names of objects, groups, materials and libraries (old exporters write Latin-1 there):
/// those bytes become U+FFFD, as an MTL's do, so that `usemtl` names still match the
/// library's. Anywhere else, or with a NUL byte, it is not OBJ text: the error is the
/// line's number.
pub(super) fn lossy_text(bytes: &[u8]) -> Result<String, usize> {
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        if std::str::from_utf8(line).is_err() && (line.contains(&0) || !comment_or_name(line)) {
            return Err(i + 1);
        }
    }
    Ok(String::from_utf8_lossy(bytes).into_owned())
}

/// Whether `line` is a comment or a statement that only names something.
fn comment_or_name(line: &[u8]) -> bool {
    let mut words = line.split(|b| b.is_ascii_whitespace()).filter(|w| !w.is_empty());
    match words.next() {
        Some(word) if word.starts_with(b"#") => true,
        Some(word) => matches!(word, b"o" | b"g" | b"usemtl" | b"mtllib"),
        None => false,
    }
}

/// Lines and `v`/`vt`/`vn` statements of one chunk.
pub(super) fn count(text: &str) -> Counts {
    let mut counts = Counts::default();
    for line in lines(text) {
        counts.lines += 1;
        match keyword(line).as_bytes() {
            [b'v'] => counts.positions += 1,
            [b'v', b't'] => counts.texcoords += 1,
            [b'v', b'n'] => counts.normals += 1,
            _ => {}
        }
    }
    counts
}

/// The lines of `text` as tobj reads them: cut at `\n` (kept out), no empty line after a
/// final `\n`. A `\r` before the `\n` stays: every use splits at whitespace or trims.
pub(super) fn lines(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = text;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let (line, next) = match find_newline(rest.as_bytes()) {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (rest, ""),
        };
        rest = next;
        Some(line)
    })
}

/// The first `\n` in `bytes`, eight bytes at a time. `str::find('\n')` set up a char
/// searcher (a memchr and a memcmp) for every line: 15% of a 2M-triangle file's parse on one
/// thread, for lines of 20 to 40 bytes.
pub(super) fn find_newline(bytes: &[u8]) -> Option<usize> {
    const ONES: u64 = u64::from_ne_bytes([1; 8]);
    const HIGHS: u64 = u64::from_ne_bytes([0x80; 8]);
    const NEWLINES: u64 = u64::from_ne_bytes([b'\n'; 8]);
    let mut words = bytes.chunks_exact(8);
    let mut at = 0;
    for word in &mut words {
        let x = u64::from_le_bytes(word.try_into().unwrap_or_default()) ^ NEWLINES;
        // A byte of x is zero where a `\n` was: the classic test for a zero byte. It can
        // flag a byte above a true zero too, so the exact place is found byte by byte.
        if x.wrapping_sub(ONES) & !x & HIGHS != 0 {
            return word.iter().position(|&b| b == b'\n').map(|i| at + i);
        }
        at += 8;
    }
    words.remainder().iter().position(|&b| b == b'\n').map(|i| at + i)
}

/// A number as `str::parse::<f32>` reads it, with the usual words of an OBJ (a decimal of
/// at most 8 digits, no exponent) read directly (`scene/decimal.rs`).
#[inline(always)]
pub(super) fn parse_f32(word: &str) -> Option<f32> {
    crate::scene::decimal::short_f32(word.as_bytes()).or_else(|| slow_f32(word))
}

/// The rare words: `str::parse`, out of line so that [`parse_f32`] inlines.
#[cold]
#[inline(never)]
fn slow_f32(word: &str) -> Option<f32> {
    word.parse().ok()
}

/// The first word of a line as `split_whitespace` gives it ("" for a blank line), with a
/// fast path for ASCII.
pub(super) fn keyword(line: &str) -> &str {
    let bytes = line.as_bytes();
    let mut i = 0;
    while i < bytes.len() && is_ascii_space(bytes[i]) {
        i += 1;
    }
    let start = i;
    while i < bytes.len() && !is_ascii_space(bytes[i]) && bytes[i] < 0x80 {
        i += 1;
    }
    if bytes.get(start).is_some_and(|&b| b >= 0x80) || bytes.get(i).is_some_and(|&b| b >= 0x80) {
        return line.split_whitespace().next().unwrap_or("");
    }
    &line[start..i]
}

/// The ASCII characters that `char::is_whitespace` accepts (vertical tab and form feed
/// included, unlike `u8::is_ascii_whitespace`).
pub(super) fn is_ascii_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c)
}

/// The first `needle` in `haystack` (only used to place the few chunk ends).
fn memchr(needle: u8, haystack: &[u8]) -> Option<usize> {
    haystack.iter().position(|&b| b == needle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_cover_the_text_at_line_starts_and_keep_continued_lines_together() {
        let text = "v 1 2 3\r\nf 1 \\\r\n 2 3\nvt 0 0\n\nlast";
        for size in 1..text.len() + 2 {
            let chunks: Vec<Chunk> =
                split(text.as_bytes(), size).iter().map(|&(o, b)| text_of(o, b).unwrap()).collect();
            assert_eq!(chunks.iter().map(|c| c.text).collect::<String>(), text);
            for c in &chunks {
                assert!(
                    c.offset == 0 || text.as_bytes()[c.offset - 1] == b'\n',
                    "size {size}: {c:?}"
                );
                assert!(
                    !continues(c.text.as_bytes()) || c.offset + c.text.len() == text.len(),
                    "size {size}: {c:?}"
                );
            }
            let total = chunks.iter().fold(Counts::default(), |sum, c| sum.add(count(c.text)));
            assert_eq!(total, Counts { lines: 6, positions: 1, texcoords: 1, normals: 0 });
        }
    }

    #[test]
    fn invalid_utf8_is_found_after_the_lines_before_it() {
        assert_eq!(text_of(5, b"v 1 2 3\nv 1 2 3\nv \xff 2 3\nv\n").err(), Some(2));
        assert_eq!(text_of(0, b"\xff\n").err(), Some(0));
    }

    #[test]
    fn newlines_are_found_as_find_finds_them() {
        let text = b"v 1 2 3\nf 1 2 3 4 5 6 7 8 9 10 11\n\n\xc3\xa9\x8a\x0a\x8a";
        for start in 0..text.len() {
            for end in start..=text.len() {
                let bytes = &text[start..end];
                let plain = bytes.iter().position(|&b| b == b'\n');
                assert_eq!(find_newline(bytes), plain, "{start}..{end}");
            }
        }
    }

    #[test]
    fn numbers_are_what_str_parse_gives() {
        for w in crate::scene::decimal::tests::words() {
            let plain = w.parse::<f32>().ok().map(f32::to_bits);
            assert_eq!(parse_f32(&w).map(f32::to_bits), plain, "{w:?}");
        }
    }

    #[test]
    fn keywords_are_split_as_split_whitespace_splits() {
        for line in
            ["v 1", "  vt\t1", "\u{3000}vn 1", "f\u{a0}1", "", "   ", "#x", "g\r", "é 1", "vé 1"]
        {
            assert_eq!(keyword(line), line.split_whitespace().next().unwrap_or(""), "{line:?}");
        }
    }
}
