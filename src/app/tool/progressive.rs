//! Frames too long for one submission (brute force on a big mesh), traced in bands over
//! several display frames so that the window keeps drawing and answering input while the
//! image fills in. A band is a run of work groups in reading order: part of one strip of
//! group-high rows while groups are few, whole strips once they are many; and where one
//! group is already too long (brute force over a big scene on a CPU device: seconds), a run
//! of one group's lanes, down to one pixel. A split frame's bands run across the line: each
//! band traces its pixels on both sides, each side with its own settings.

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
    /// The first column not yet finished in that strip (a multiple of the group width).
    next_column: u32,
    /// The first lane not yet traced of the group at (`next_column`, `next_row`): 0 unless
    /// bands finer than a group have traced part of it.
    next_lane: u32,
    /// The work-group size: bands start on multiples of it.
    group: GroupSize,
    /// When the frame began, for the time-left estimate.
    started: std::time::Instant,
}

impl Progressive {
    /// A frame not yet begun, traced in work groups of `group` pixels.
    pub(crate) fn new(frame: FrameTrace, group: GroupSize) -> Self {
        let group = GroupSize { width: group.width.max(1), height: group.height.max(1) };
        Self {
            frame,
            next_row: 0,
            next_column: 0,
            next_lane: 0,
            group,
            started: std::time::Instant::now(),
        }
    }

    /// The frame's width and height.
    fn size(&self) -> [u32; 2] {
        [self.frame.params.settings.width, self.frame.params.settings.height]
    }

    /// Lanes of one work group (pixels of its tile).
    fn lanes(&self) -> u32 {
        self.group.width * self.group.height
    }

    /// The pixels of the group at (`next_column`, `next_row`) inside the frame, across and
    /// down (a group at the right or bottom edge overhangs it).
    fn group_extent(&self) -> [u32; 2] {
        let [width, height] = self.size();
        [
            self.group.width.min(width - self.next_column),
            self.group.height.min(height - self.next_row),
        ]
    }

    /// Pixels inside the frame among lanes `0..lane` of the current group.
    fn pixels_before_lane(&self, lane: u32) -> u64 {
        let [w, _] = self.group_extent();
        let (rows, rest) = (lane / self.group.width, lane % self.group.width);
        (rows * w + rest.min(w)) as u64
    }

    /// Share of the frame's pixels traced so far, in [0, 1].
    pub(crate) fn progress(&self) -> f32 {
        let [width, height] = self.size();
        if self.next_row >= height {
            return 1.0;
        }
        let strip = self.group.height.min(height - self.next_row);
        let done = self.next_row as u64 * width as u64
            + self.next_column as u64 * strip as u64
            + self.pixels_before_lane(self.next_lane);
        (done as f64 / (width as u64 * height as u64).max(1) as f64).min(1.0) as f32
    }

    /// Seconds the frame still needs at the pace so far (None before any progress).
    pub(crate) fn seconds_left(&self) -> Option<f64> {
        let p = self.progress() as f64;
        (p > 0.0).then(|| self.started.elapsed().as_secs_f64() * (1.0 - p) / p)
    }

    /// Take the next band of about `pixels` pixels (whole work groups from a group's worth
    /// on, lanes of one group below that); `None` once the frame is done.
    pub(crate) fn next_band(&mut self, pixels: u64) -> Option<Band> {
        let [width, height] = self.size();
        if self.next_row >= height {
            return None;
        }
        let pixels = pixels.max(1);
        if self.next_lane > 0 || pixels < self.lanes() as u64 {
            return Some(self.lanes_of_group(pixels));
        }
        let group = self.group;
        let groups = (pixels / self.lanes() as u64).min(u32::MAX as u64) as u32;
        let per_strip = width.div_ceil(group.width).max(1);
        let band = if self.next_column > 0 || groups < per_strip {
            // Part of one strip: columns from where the last band stopped.
            let end = self.next_column.saturating_add(groups.saturating_mul(group.width));
            Band::rect(
                self.next_row..(self.next_row + group.height).min(height),
                self.next_column..end.min(width),
            )
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

    /// A band of the current group's lanes from `next_lane` on: up to `pixels` of them
    /// inside the frame (lanes over the frame's edge ride along, traced as nothing), and
    /// the group's end.
    fn lanes_of_group(&mut self, pixels: u64) -> Band {
        let [w, h] = self.group_extent();
        let inside = |lane: u32| lane % self.group.width < w;
        // Lanes of rows past the frame's bottom are all outside it.
        let end_of_group = self.group.width * h;
        let first = self.next_lane;
        let mut end = first;
        let mut taken = 0;
        while end < end_of_group && taken < pixels {
            taken += inside(end) as u64;
            end += 1;
        }
        let rows = self.next_row..self.next_row + h;
        let columns = self.next_column..self.next_column + w;
        // Lanes past the frame's right edge start no band: step over them.
        let mut next = end;
        while next < end_of_group && !inside(next) {
            next += 1;
        }
        if next >= end_of_group {
            self.next_lane = 0;
            if columns.end >= self.size()[0] {
                self.next_row = rows.end;
                self.next_column = 0;
            } else {
                self.next_column = columns.end;
            }
        } else {
            self.next_lane = next;
        }
        Band { rows, columns, lanes: first..end }
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

/// The next band's size in pixels, from a band of `pixels` that took `gpu_ms`: about
/// [`BAND_TARGET_MS`], within `1..=most`. It grows at most 4x a step (a short band's time
/// is mostly overhead) but shrinks at once: a band far over the target would hold the
/// window that long again (one work group of brute force over Crytek Sponza took lavapipe
/// 6.6 s).
pub(crate) fn adapt_pixels(pixels: u64, gpu_ms: f64, most: u64) -> u64 {
    let pixels = pixels.max(1);
    let scaled = if gpu_ms > 0.0 {
        pixels as f64 * (BAND_TARGET_MS / gpu_ms).min(4.0)
    } else {
        pixels as f64
    };
    (scaled.round() as u64).clamp(1, most.max(1))
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
    use crate::gpu::GROUP;
    use crate::render_settings::RenderSettings;
    use crate::tracer::frame::FrameParams;

    #[test]
    fn a_frames_time_is_the_sum_of_its_bands() {
        let mut times = BandTimes::default();
        let band = |frame, last| BandTag { frame, last, pixels: 1 };
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

    /// The frame's pixels (x, y) that band `b` traces, in work groups of `group`: all of
    /// its rectangle, or of a band finer than a group (one group), its lanes.
    fn traced(b: &Band, group: GroupSize) -> Vec<(u32, u32)> {
        let lane = |x: u32, y: u32| (y - b.rows.start) * group.width + (x - b.columns.start);
        let finer = b.is_finer_than_a_group();
        if finer {
            assert!(b.rows.len() as u32 <= group.height && b.columns.len() as u32 <= group.width);
            assert!(b.lanes.end <= group.width * group.height, "{b:?} in {group:?}");
        }
        let rows = b.rows.clone();
        rows.flat_map(|y| b.columns.clone().map(move |x| (x, y)))
            .filter(|&(x, y)| !finer || b.lanes.contains(&lane(x, y)))
            .collect()
    }

    /// Bands of any size cover every pixel of the frame exactly once, to its end, in square
    /// groups and in oblong ones: whole groups, and bands finer than a group (1, 7 or 50
    /// pixels, running on over group and strip boundaries, mixed with bigger ones).
    #[test]
    fn bands_tile_the_frame_exactly_once() {
        let groups =
            [SQUARE, GroupSize { width: 16, height: 8 }, GroupSize { width: 8, height: 16 }];
        for ((w, h), group) in [(64, 64), (100, 37), (8, 8), (1, 300), (257, 9)]
            .into_iter()
            .flat_map(|s| groups.map(|g| (s, g)))
        {
            let lanes = (group.width * group.height) as u64;
            let in_groups = |g: &[u64]| g.iter().map(|n| n * lanes).collect::<Vec<_>>();
            for sizes in [
                in_groups(&[1]),
                in_groups(&[3]),
                in_groups(&[1, 5, 2, 40, 1000]),
                in_groups(&[1000]),
                vec![1],
                vec![7],
                vec![50],
                vec![1, 7, 50, lanes * 3, 2, lanes + 1],
            ] {
                let mut p = frame_in_groups(w, h, group);
                let mut seen = vec![0u8; (w * h) as usize];
                let mut i = 0;
                while let Some(b) = p.next_band(sizes[i % sizes.len()]) {
                    assert!(
                        b.rows.start % group.height == 0 && b.columns.start % group.width == 0,
                        "{b:?} in {group:?}"
                    );
                    let pixels = traced(&b, group);
                    assert!(!pixels.is_empty(), "{b:?}");
                    assert!(pixels.len() as u64 <= sizes[i % sizes.len()].max(lanes), "{b:?}");
                    for (x, y) in pixels {
                        seen[(y * w + x) as usize] += 1;
                    }
                    i += 1;
                }
                assert!(p.is_done());
                assert!(seen.iter().all(|&n| n == 1), "{w}x{h} in {group:?} with {sizes:?}");
                assert_eq!(p.progress(), 1.0);
            }
        }
    }

    /// With the real work group, a band finer than it counts its pixels (`Band::pixels`,
    /// what the window sizes the next band from) as the lanes inside the frame.
    #[test]
    fn a_band_finer_than_a_group_counts_its_pixels_inside_the_frame() {
        // 40 wide: the second group of a strip overhangs the edge by 24 columns.
        let mut p = frame_in_groups(40, 6, GROUP);
        let mut pixels = 0;
        while let Some(b) = p.next_band(7) {
            assert!(b.is_finer_than_a_group());
            assert_eq!(b.pixels(), traced(&b, GROUP).len() as u64, "{b:?}");
            assert!((1..=7).contains(&b.pixels()), "{b:?}");
            pixels += b.pixels();
        }
        assert_eq!(pixels, 40 * 6);
    }

    /// Progress grows band by band, a band of few groups stays inside one strip, and a band
    /// of a few pixels inside one group.
    #[test]
    fn progress_grows_and_small_bands_stay_small() {
        for (size, most) in [(3 * 64, 3 * 64), (5, 5)] {
            let mut p = frame(64, 64);
            let mut last = p.progress();
            assert_eq!(last, 0.0);
            while let Some(b) = p.next_band(size) {
                assert!(traced(&b, SQUARE).len() as u64 <= most);
                let now = p.progress();
                assert!(now > last, "{now} after {last}");
                last = now;
            }
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
        assert_eq!(adapt_pixels(800, 40.0, 10_000), 800);
        assert_eq!(adapt_pixels(800, 80.0, 10_000), 400);
        assert_eq!(adapt_pixels(800, 1.0, 10_000), 3200, "at most 4x bigger a step");
        assert_eq!(adapt_pixels(800, 1000.0, 10_000), 32, "smaller at once");
        assert_eq!(adapt_pixels(1, 1000.0, 10_000), 1, "never empty");
        assert_eq!(adapt_pixels(500, 1.0, 100), 100, "never past the submission budget");
        assert_eq!(adapt_pixels(800, 0.0, 10_000), 800, "no timing: unchanged");
    }

    /// Issue #43: one work group of brute force over Crytek Sponza at 4 spp took lavapipe
    /// 6.6 s. Timed so, the next band is a few pixels of one group, and the frame's bands
    /// then tile it exactly, each under the target at that pace.
    #[test]
    fn a_group_far_over_the_target_makes_the_next_bands_finer_than_a_group() {
        let lanes = (GROUP.width * GROUP.height) as u64;
        let next = adapt_pixels(lanes, 6600.0, u64::MAX);
        assert!(next < lanes, "{next} pixels");
        let ms_per_pixel = 6600.0 / lanes as f64;
        assert!(next as f64 * ms_per_pixel <= BAND_TARGET_MS * 1.5, "{next} pixels");
        let (w, h) = (40, 9);
        let mut p = frame_in_groups(w, h, GROUP);
        let first = p.next_band(lanes).unwrap();
        assert!(!first.is_finer_than_a_group());
        let mut seen = vec![0u8; (w * h) as usize];
        for (x, y) in traced(&first, GROUP) {
            seen[(y * w + x) as usize] += 1;
        }
        let mut size = next;
        while let Some(b) = p.next_band(size) {
            assert!(b.is_finer_than_a_group(), "{b:?}");
            for (x, y) in traced(&b, GROUP) {
                seen[(y * w + x) as usize] += 1;
            }
            // Timed at the same pace, the size holds.
            size = adapt_pixels(b.pixels(), b.pixels() as f64 * ms_per_pixel, u64::MAX);
            assert!(size as f64 * ms_per_pixel <= BAND_TARGET_MS * 1.5, "{size}");
        }
        assert!(seen.iter().all(|&n| n == 1), "no gap, no overlap");
        assert_eq!(p.progress(), 1.0);
    }
}
