//! Frames too long for one submission (brute force on a big mesh), traced in bands over
//! several display frames so that the window keeps drawing and answering input while the
//! image fills in. A band is a run of work groups in reading order: part of one strip of
//! group-high rows while groups are few, whole strips once they are many. A split frame's
//! bands run across the line: each band traces its pixels on both sides, each side with
//! its own settings.

use crate::gpu::present::BandTag;
use crate::gpu::{Band, FrameTrace, GroupSize, PartTimes};

/// GPU milliseconds a band should take, so that the window stays responsive.
pub(crate) const BAND_TARGET_MS: f64 = 40.0;

/// A long frame being traced band by band.
#[derive(Clone, Debug)]
pub(crate) struct Progressive {
    /// The frame's parameters (both halves of a split), fixed when it began.
    pub(crate) frame: FrameTrace,
    /// The first row of the strip not yet finished (a multiple of the group height).
    next_row: u32,
    /// The first column not yet traced in that strip (a multiple of the group width).
    next_column: u32,
    /// The work-group size: bands start on multiples of it.
    group: GroupSize,
    /// When the frame began, for the time-left estimate.
    started: std::time::Instant,
}

impl Progressive {
    /// A frame not yet begun, traced in work groups of `group` pixels.
    pub(crate) fn new(frame: FrameTrace, group: GroupSize) -> Self {
        let group = GroupSize { width: group.width.max(1), height: group.height.max(1) };
        Self { frame, next_row: 0, next_column: 0, group, started: std::time::Instant::now() }
    }

    /// Share of the frame's pixels traced so far, in [0, 1].
    pub(crate) fn progress(&self) -> f32 {
        let s = &self.frame.params.settings;
        let strip = self.group.height.min(s.height.saturating_sub(self.next_row));
        let done = self.next_row as u64 * s.width as u64 + self.next_column as u64 * strip as u64;
        (done as f64 / (s.width as u64 * s.height as u64).max(1) as f64).min(1.0) as f32
    }

    /// Seconds the frame still needs at the pace so far (None before any progress).
    pub(crate) fn seconds_left(&self) -> Option<f64> {
        let p = self.progress() as f64;
        (p > 0.0).then(|| self.started.elapsed().as_secs_f64() * (1.0 - p) / p)
    }

    /// Take the next band of about `groups` work groups; `None` once the frame is done.
    pub(crate) fn next_band(&mut self, groups: u32) -> Option<Band> {
        let group = self.group;
        let (width, height) = (self.frame.params.settings.width, self.frame.params.settings.height);
        if self.next_row >= height {
            return None;
        }
        let per_strip = width.div_ceil(group.width).max(1);
        let groups = groups.max(1);
        let band = if self.next_column > 0 || groups < per_strip {
            // Part of one strip: columns from where the last band stopped.
            let end = (self.next_column + groups * group.width).min(width);
            Band {
                rows: self.next_row..(self.next_row + group.height).min(height),
                columns: self.next_column..end,
            }
        } else {
            let strips = groups / per_strip;
            Band::rows(self.next_row..(self.next_row + strips * group.height).min(height), width)
        };
        if band.columns.end >= width {
            self.next_row = band.rows.end;
            self.next_column = 0;
        } else {
            self.next_column = band.columns.end;
        }
        Some(band)
    }

    /// `frame` is this frame's: a moving light does not restart a long frame (it would
    /// never finish), so the light is not compared; any other change is a new frame.
    pub(crate) fn continues(&self, frame: &FrameTrace) -> bool {
        let mut other = *frame;
        other.params.light_position = self.frame.params.light_position;
        if let (Some(theirs), Some(ours)) = (&mut other.split, &self.frame.split) {
            theirs.params.light_position = ours.params.light_position;
        }
        other == self.frame
    }

    /// The frame is traced to its last pixel.
    pub(crate) fn is_done(&self) -> bool {
        self.next_row >= self.frame.params.settings.height
    }
}

/// The next band's size in groups, from the last band's size and GPU time: about
/// [`BAND_TARGET_MS`] per band, changing by at most 4x a step, within `1..=most`.
pub(crate) fn adapt_groups(groups: u32, gpu_ms: f64, most: u32) -> u32 {
    let scaled = if gpu_ms > 0.0 {
        groups as f64 * (BAND_TARGET_MS / gpu_ms).clamp(0.25, 4.0)
    } else {
        groups as f64
    };
    (scaled.round() as u32).clamp(1, most.max(1))
}

/// A traced frame's GPU time, added up from its bands' times as they arrive (a frame or two
/// after their bands, in the window's frames in flight): the time the frame took, as
/// `bench` and `render` count it, rather than its last band's.
#[derive(Debug, Default)]
pub(crate) struct BandTimes {
    /// The frame being added up, its milliseconds so far, and per part of a split frame
    /// (None for a part no band has timed yet).
    open: Option<(u64, f64, PartTimes)>,
}

impl BandTimes {
    /// Add the time of a band of `tag`'s frame (`parts`: per part of a split frame); the
    /// frame's total and parts once its last band is in. A band of another frame drops a
    /// frame left unfinished (restarted by a change).
    pub(crate) fn add(
        &mut self,
        tag: BandTag,
        ms: f64,
        parts: PartTimes,
    ) -> Option<(f64, PartTimes)> {
        let (frame, total, sums) = match self.open.take() {
            Some(open) if open.0 == tag.frame => open,
            _ => (tag.frame, 0.0, [None; 2]),
        };
        let sums = [0, 1].map(|i| match (sums[i], parts[i]) {
            (Some(a), Some(b)) => Some(a + b),
            (a, b) => a.or(b),
        });
        if tag.last {
            return Some((total + ms, sums));
        }
        self.open = Some((frame, total + ms, sums));
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render_settings::RenderSettings;
    use crate::tracer::frame::FrameParams;

    #[test]
    fn a_frames_time_is_the_sum_of_its_bands() {
        let mut times = BandTimes::default();
        let band = |frame, last| BandTag { frame, last };
        // A whole frame: its one band's time.
        assert_eq!(
            times.add(band(0, true), 1.5, [Some(1.5), None]),
            Some((1.5, [Some(1.5), None]))
        );
        // Three bands of a split frame (the first on the right of the line only).
        assert_eq!(times.add(band(1, false), 2.0, [None, Some(2.0)]), None);
        assert_eq!(times.add(band(1, false), 3.0, [Some(2.0), Some(1.0)]), None);
        assert_eq!(
            times.add(band(1, true), 1.0, [Some(0.5), Some(0.5)]),
            Some((6.0, [Some(2.5), Some(3.5)]))
        );
        // A frame restarted part-way: the next frame's bands count alone.
        assert_eq!(times.add(band(2, false), 9.0, [Some(9.0), None]), None);
        assert_eq!(times.add(band(3, false), 2.0, [Some(2.0), None]), None);
        assert_eq!(
            times.add(band(3, true), 2.0, [Some(2.0), None]),
            Some((4.0, [Some(4.0), None]))
        );
    }

    const SQUARE: GroupSize = GroupSize { width: 8, height: 8 };

    fn frame_in_groups(width: u32, height: u32, group: GroupSize) -> Progressive {
        let scene = crate::scene::paper::paper_scene(
            crate::scene::primitives::geosphere(0),
            1,
            Default::default(),
        );
        let settings = RenderSettings { width, height, ..RenderSettings::default() };
        Progressive::new(FrameTrace::whole(FrameParams::new(&scene, settings)), group)
    }

    fn frame(width: u32, height: u32) -> Progressive {
        frame_in_groups(width, height, SQUARE)
    }

    /// Bands of any size cover every pixel of the frame exactly once, in square groups and
    /// in oblong ones.
    #[test]
    fn bands_tile_the_frame_exactly_once() {
        let groups =
            [SQUARE, GroupSize { width: 16, height: 8 }, GroupSize { width: 8, height: 16 }];
        for ((w, h), group) in [(64, 64), (100, 37), (8, 8), (1, 300), (257, 9)]
            .into_iter()
            .flat_map(|s| groups.map(|g| (s, g)))
        {
            for sizes in [vec![1], vec![3], vec![1, 5, 2, 40, 1000], vec![1000]] {
                let mut p = frame_in_groups(w, h, group);
                let mut seen = vec![0u8; (w * h) as usize];
                let mut i = 0;
                while let Some(b) = p.next_band(sizes[i % sizes.len()]) {
                    assert!(
                        b.rows.start % group.height == 0 && b.columns.start % group.width == 0,
                        "{b:?} in {group:?}"
                    );
                    assert!(b.pixels() > 0);
                    for y in b.rows.clone() {
                        for x in b.columns.clone() {
                            seen[(y * w + x) as usize] += 1;
                        }
                    }
                    i += 1;
                }
                assert!(p.is_done());
                assert!(seen.iter().all(|&n| n == 1), "{w}x{h} in {group:?} with {sizes:?}");
                assert_eq!(p.progress(), 1.0);
            }
        }
    }

    /// Progress grows band by band and a band of few groups stays inside one strip.
    #[test]
    fn progress_grows_and_small_bands_stay_small() {
        let mut p = frame(64, 64);
        let mut last = p.progress();
        assert_eq!(last, 0.0);
        while let Some(b) = p.next_band(3) {
            assert!(b.pixels() <= 3 * 64);
            let now = p.progress();
            assert!(now > last, "{now} after {last}");
            last = now;
        }
    }

    /// A split frame goes on while only the light moves; a change to either half restarts it.
    #[test]
    fn a_split_frame_goes_on_unless_a_half_changes() {
        use crate::app::split::{SplitB, SplitView};
        let split = SplitView {
            enabled: true,
            position: 0.5,
            b: SplitB { bounces: Some(0), ..Default::default() },
        };
        // Wide enough that the two lines below snap to different work-group columns.
        let p = Progressive::new(split.frame(frame(256, 64).frame.params), SQUARE);
        let mut moved = p.frame;
        moved.params.light_position += glam::Vec3::X;
        if let Some(s) = &mut moved.split {
            s.params.light_position += glam::Vec3::X;
        }
        assert!(p.continues(&moved), "the light alone does not restart a long frame");
        let other_b =
            SplitView { b: SplitB { bounces: Some(1), ..split.b }, ..split }.frame(p.frame.params);
        assert!(!p.continues(&other_b));
        let moved_line = SplitView { position: 0.25, ..split }.frame(p.frame.params);
        assert_ne!(
            moved_line.split.unwrap().column,
            p.frame.split.unwrap().column,
            "the test must move the line"
        );
        assert!(!p.continues(&moved_line));
        assert!(
            !p.continues(&FrameTrace::whole(p.frame.params)),
            "turning the split off is a new frame"
        );
    }

    #[test]
    fn band_size_follows_the_gpu_time() {
        assert_eq!(adapt_groups(8, 40.0, 1000), 8);
        assert_eq!(adapt_groups(8, 80.0, 1000), 4);
        assert_eq!(adapt_groups(8, 1.0, 1000), 32, "at most 4x bigger a step");
        assert_eq!(adapt_groups(8, 1000.0, 1000), 2, "at most 4x smaller a step");
        assert_eq!(adapt_groups(1, 1000.0, 1000), 1, "never empty");
        assert_eq!(adapt_groups(500, 1.0, 100), 100, "never past the submission budget");
        assert_eq!(adapt_groups(8, 0.0, 1000), 8, "no timing: unchanged");
    }
}
