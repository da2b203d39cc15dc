//! The shapes a trace is dispatched in: the work group's tile of pixels ([`GROUP`]), a
//! band of a frame's pixels that one dispatch covers ([`Band`]), and a frame traced whole
//! or split in two at a column ([`FrameTrace`]). A leaf: the trace pass, the tile order
//! and the vendor's passes all speak in these.

use std::ops::Range;

use super::shader_layout::{GROUP_HEIGHT, GROUP_WIDTH};
use crate::tracer::frame::FrameParams;

/// The tile of pixels one work group traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GroupSize {
    /// Pixels across.
    pub width: u32,
    /// Pixels down.
    pub height: u32,
}

/// Work-group size of the shader (`local_size_x/y`), reflected from the compiled shader.
pub const GROUP: GroupSize = GroupSize { width: GROUP_WIDTH, height: GROUP_HEIGHT };

/// Invocations (pixels) of one work group, numbered `y * width + x` in its tile: the lanes
/// a band finer than a group picks from.
pub(crate) const GROUP_LANES: u32 = GROUP_WIDTH * GROUP_HEIGHT;

// A band's lanes travel in a byte each (contract::LANE_MASK).
const _: () = assert!(GROUP_LANES <= crate::contract::LANE_MASK + 1);

/// The pixels of a frame traced by one dispatch: a rectangle whose start row and column are
/// multiples of the work-group size and whose end is one too, or the frame's edge; of each
/// group in it, the `lanes` only. A band finer than a group (some of its lanes) is one
/// group: one pixel of brute force over a big scene can take a CPU device tens of ms.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Band {
    /// The frame's rows in the band.
    pub(crate) rows: Range<u32>,
    /// The frame's columns in the band.
    pub(crate) columns: Range<u32>,
    /// The lanes of each group traced: `0..GROUP_LANES` but in a band finer than a group.
    pub(crate) lanes: Range<u32>,
}

impl Band {
    /// Whole groups over `rows` and `columns`.
    pub(crate) fn rect(rows: Range<u32>, columns: Range<u32>) -> Self {
        Self { rows, columns, lanes: 0..GROUP_LANES }
    }

    /// Whole rows `rows` of a frame `width` pixels wide.
    pub(crate) fn rows(rows: Range<u32>, width: u32) -> Self {
        Self::rect(rows, 0..width)
    }

    /// Only some lanes of its one group.
    pub(crate) fn is_finer_than_a_group(&self) -> bool {
        self.lanes != (0..GROUP_LANES)
    }

    /// Its first pixel is the frame's first (where adaptive sampling's pre-pass runs).
    pub(crate) fn starts_frame(&self) -> bool {
        self.rows.start == 0 && self.columns.start == 0 && self.lanes.start == 0
    }

    /// Pixels in the band (of a band finer than a group, its lanes inside the frame).
    pub(crate) fn pixels(&self) -> u64 {
        if !self.is_finer_than_a_group() {
            return self.rows.len() as u64 * self.columns.len() as u64;
        }
        let (w, h) = (self.columns.len() as u32, self.rows.len() as u32);
        self.lanes.clone().filter(|l| l % GROUP.width < w && l / GROUP.width < h).count() as u64
    }

    /// The part of the band in `columns` (None when they do not meet).
    pub(crate) fn within(&self, columns: &Range<u32>) -> Option<Band> {
        let columns = self.columns.start.max(columns.start)..self.columns.end.min(columns.end);
        (!columns.is_empty() && !self.rows.is_empty()).then(|| Band {
            rows: self.rows.clone(),
            columns,
            lanes: self.lanes.clone(),
        })
    }
}

/// The right part of a frame split in two (the tool's A/B split view): the columns from
/// `column` on are traced with `params`, a second set of settings for the same view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitTrace {
    /// The first column of the right part: a multiple of the work-group size, or the width.
    pub column: u32,
    /// The right part's parameters.
    pub params: FrameParams,
}

/// How a frame's pixels are traced: all with `params`, or split in two at a column.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameTrace {
    /// The whole frame's parameters, or the left part's.
    pub params: FrameParams,
    /// The right part, if split.
    pub split: Option<SplitTrace>,
}

impl FrameTrace {
    /// The whole frame traced with `params`.
    pub fn whole(params: FrameParams) -> Self {
        Self { params, split: None }
    }

    /// The frame's parts, left to right, each with its parameters and columns (0, 1 or 2
    /// of them; an empty part is left out). Together they cover every column once.
    pub fn parts(&self) -> Vec<(usize, &FrameParams, Range<u32>)> {
        let width = self.params.settings.width;
        let column = self.split.map_or(width, |s| s.column.min(width));
        let mut parts = vec![(0, &self.params, 0..column)];
        if let Some(split) = &self.split {
            parts.push((1, &split.params, column..width));
        }
        parts.retain(|(_, _, columns)| !columns.is_empty());
        parts
    }
}
