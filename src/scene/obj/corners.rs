//! Face corners, stored as compactly as the file allows: a file whose faces name positions
//! only (`f 1 2 3`, most large scans) keeps one `u32` a corner, where (v, vt, vn) triples
//! take three times the memory, written once and read by every pass of the assembly.

use std::hash::Hash;

use super::chunks::NONE;

/// One face corner as stored: a position index alone, or a (v, vt, vn) triple.
pub(super) trait Corner: Copy + Eq + Hash + Send + Sync {
    /// The position index, 0-based.
    fn position(self) -> u32;
    /// (v, vt, vn), [`NONE`] for what is absent.
    fn full(self) -> [u32; 3];
}

impl Corner for u32 {
    #[inline(always)]
    fn position(self) -> u32 {
        self
    }

    #[inline(always)]
    fn full(self) -> [u32; 3] {
        [self, NONE, NONE]
    }
}

impl Corner for [u32; 3] {
    #[inline(always)]
    fn position(self) -> u32 {
        self[0]
    }

    #[inline(always)]
    fn full(self) -> [u32; 3] {
        self
    }
}

/// A chunk's corners in file order: position indices while no corner of the chunk names a
/// texture coordinate or normal, triples from the first that does.
#[derive(Debug)]
pub(super) enum Corners {
    Plain(Vec<u32>),
    Full(Vec<[u32; 3]>),
}

impl Default for Corners {
    fn default() -> Self {
        Corners::Plain(Vec::new())
    }
}

impl Corners {
    /// How many corners.
    pub(super) fn len(&self) -> usize {
        match self {
            Corners::Plain(c) => c.len(),
            Corners::Full(c) => c.len(),
        }
    }

    /// Drop the corners from `len` on (those of a face that was not taken after all).
    pub(super) fn truncate(&mut self, len: usize) {
        match self {
            Corners::Plain(c) => c.truncate(len),
            Corners::Full(c) => c.truncate(len),
        }
    }

    /// Append `corners`, turning the store into triples when one of them needs it.
    pub(super) fn extend(&mut self, corners: &[[u32; 3]]) {
        match self {
            Corners::Plain(plain)
                if corners.iter().all(|&[_, vt, vn]| vt == NONE && vn == NONE) =>
            {
                plain.extend(corners.iter().map(|c| c[0]));
            }
            Corners::Plain(plain) => {
                let mut full: Vec<[u32; 3]> = plain.iter().map(|&v| v.full()).collect();
                full.extend_from_slice(corners);
                *self = Corners::Full(full);
            }
            Corners::Full(full) => full.extend_from_slice(corners),
        }
    }

    /// The corners as triples.
    pub(super) fn into_full(self) -> Vec<[u32; 3]> {
        match self {
            Corners::Plain(plain) => plain.into_iter().map(u32::full).collect(),
            Corners::Full(full) => full,
        }
    }
}
