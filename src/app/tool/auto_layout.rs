//! The BVH layout picked by measurement: the window's default when neither `--bvh` nor a
//! preset names one. Which layout traces fastest depends on the model, the view and the
//! GPU (on the H100 the wide tree wins on the knots and the dragon, its leaf-runs kernel on
//! Sponza, and on lavapipe the binary tree), so the tool times each on the frames it
//! traces anyway and keeps the fastest.
//!
//! The model is loaded with the binary tree first (the quickest first frame); the session
//! then loads it again with the wide tree too, and the trial traces the layouts in turn,
//! a few frames each. A layout changes only once a frame of the current one has been timed,
//! so a long frame is never restarted by the trial. The choice holds until the work
//! changes: another model, resolution, bounces, view or copies (not the camera or light).

use crate::render_settings::{Accel, BvhLayout, RenderSettings};

/// Timed frames of each layout before the choice.
const FRAMES_PER_LAYOUT: usize = 5;

/// How many layouts a trial times (`BvhLayout::ALL`).
const LAYOUTS: usize = BvhLayout::ALL.len();

/// Frames a trial may take before it settles for what it has (frames whose GPU time never
/// comes back, say).
const MAX_TRIAL_FRAMES: u32 = 90;

/// What a choice holds for: the frame's settings with the layout left out, and the scene
/// around them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Work {
    /// The frame's settings, `bvh` always binary.
    settings: RenderSettings,
    /// Copies of the model and whether the mirror box is there.
    models: u32,
    mirror_box: bool,
    /// Which load of the session the model is (a new model, or the same one loaded again).
    model: u64,
}

impl Work {
    /// The work of frames traced with `settings` in that scene.
    pub(crate) fn new(settings: RenderSettings, models: u32, mirror_box: bool, model: u64) -> Self {
        Self { settings: normalized(settings), models, mirror_box, model }
    }
}

fn normalized(settings: RenderSettings) -> RenderSettings {
    RenderSettings { bvh: BvhLayout::Binary, ..settings }
}

/// What the chooser is doing.
#[derive(Clone, Debug, PartialEq)]
enum Stage {
    /// Waiting for the model's wide tree (binary frames meanwhile).
    Waiting,
    /// Tracing `BvhLayout::ALL[current]`; the GPU times of each layout's frames so far.
    Trial { current: usize, times: [Vec<f64>; LAYOUTS], frames: u32 },
    /// Done: the layout kept and each layout's median time (None: not measured).
    Chosen { layout: BvhLayout, medians: [Option<f64>; LAYOUTS] },
}

impl Stage {
    /// The end of a trial with these times: the layout of the least median.
    fn chosen(times: &[Vec<f64>; LAYOUTS]) -> Stage {
        let medians = times.clone().map(median);
        Stage::Chosen { layout: fastest(medians), medians }
    }
}

/// The measured choice of BVH layout (see the module doc).
#[derive(Clone, Debug)]
pub(crate) struct AutoLayout {
    stage: Stage,
    /// The work the stage is for; a change starts over.
    work: Option<Work>,
}

impl Default for AutoLayout {
    fn default() -> Self {
        Self { stage: Stage::Waiting, work: None }
    }
}

impl AutoLayout {
    /// The layout the next frame traces, for `work`; `has_wide`: the model shown has its wide
    /// tree. None when the choice does not apply (our BVH is not traced).
    pub(crate) fn next_layout(&mut self, work: Work, has_wide: bool) -> Option<BvhLayout> {
        if work.settings.accel != Accel::Bvh {
            return None;
        }
        if self.work != Some(work) {
            self.work = Some(work);
            self.stage = Stage::Waiting;
        }
        if self.stage == Stage::Waiting && has_wide {
            self.stage = Stage::Trial { current: 0, times: Default::default(), frames: 0 };
        }
        match &mut self.stage {
            Stage::Waiting => Some(BvhLayout::Binary),
            Stage::Trial { current, times, frames } => {
                *frames += 1;
                if *frames <= MAX_TRIAL_FRAMES {
                    return Some(BvhLayout::ALL[*current]);
                }
                self.stage = Stage::chosen(times);
                self.next_layout(work, has_wide)
            }
            Stage::Chosen { layout, .. } => Some(*layout),
        }
    }

    /// A traced frame's GPU time, `ms`, with the settings it was traced with.
    pub(crate) fn frame_timed(&mut self, ms: f64, settings: RenderSettings) {
        let Stage::Trial { current, times, .. } = &mut self.stage else { return };
        if self.work.is_none_or(|w| w.settings != normalized(settings)) {
            return;
        }
        let Some(k) = BvhLayout::ALL.iter().position(|&l| l == settings.bvh) else { return };
        times[k].push(ms);
        // On to the next layout once this one has a frame timed; done when each has enough.
        if k == *current {
            *current = (k + 1) % LAYOUTS;
        }
        if times.iter().all(|t| t.len() >= FRAMES_PER_LAYOUT) {
            self.stage = Stage::chosen(times);
        }
    }

    /// What the panel says of it: the layout in use and why.
    pub(crate) fn describe(&self) -> String {
        match &self.stage {
            Stage::Waiting => "building the wide tree, binary meanwhile".into(),
            Stage::Trial { current, .. } => {
                format!("timing each layout, now {}", BvhLayout::ALL[*current])
            }
            Stage::Chosen { layout, medians } => {
                let times: Vec<String> = BvhLayout::ALL
                    .iter()
                    .zip(medians)
                    .filter_map(|(l, m)| m.map(|ms| format!("{l} {ms:.2}")))
                    .collect();
                format!("fastest here: {layout}; GPU ms a frame:\n{}", times.join(", "))
            }
        }
    }

    /// The layout chosen, once the trial is over.
    #[cfg(test)]
    fn chosen(&self) -> Option<BvhLayout> {
        match self.stage {
            Stage::Chosen { layout, .. } => Some(layout),
            _ => None,
        }
    }
}

/// The median of `times` (None when empty).
fn median(mut times: Vec<f64>) -> Option<f64> {
    if times.is_empty() {
        return None;
    }
    times.sort_by(f64::total_cmp);
    Some(times[times.len() / 2])
}

/// The layout of the least median; binary when none was measured.
fn fastest(medians: [Option<f64>; LAYOUTS]) -> BvhLayout {
    BvhLayout::ALL
        .iter()
        .zip(medians)
        .filter_map(|(&l, m)| m.map(|ms| (l, ms)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(BvhLayout::Binary, |(l, _)| l)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn work(model: u64) -> Work {
        Work::new(RenderSettings::default(), 1, true, model)
    }

    /// Run frames through the chooser, each timed by `ms_of` right after it is traced;
    /// returns the layouts traced.
    fn run(
        auto: &mut AutoLayout,
        w: Work,
        frames: usize,
        ms_of: impl Fn(BvhLayout) -> f64,
    ) -> Vec<BvhLayout> {
        (0..frames)
            .map(|_| {
                let layout = auto.next_layout(w, true).unwrap();
                auto.frame_timed(ms_of(layout), RenderSettings { bvh: layout, ..w.settings });
                layout
            })
            .collect()
    }

    #[test]
    fn binary_until_the_wide_tree_is_there_then_each_layout_then_the_fastest() {
        let mut auto = AutoLayout::default();
        assert_eq!(auto.next_layout(work(1), false), Some(BvhLayout::Binary));
        assert_eq!(auto.next_layout(work(1), false), Some(BvhLayout::Binary));
        let ms = |l: BvhLayout| match l {
            BvhLayout::Binary => 3.0,
            BvhLayout::Wide => 2.0,
            BvhLayout::WideRuns => 2.5,
        };
        let traced = run(&mut auto, work(1), 40, ms);
        for layout in BvhLayout::ALL {
            assert!(
                traced.iter().filter(|&&l| l == layout).count() >= FRAMES_PER_LAYOUT,
                "{layout} tried"
            );
        }
        assert_eq!(auto.chosen(), Some(BvhLayout::Wide));
        assert!(traced[30..].iter().all(|&l| l == BvhLayout::Wide), "{traced:?}");
        assert_eq!(
            auto.describe(),
            "fastest here: wide; GPU ms a frame:\nbinary 3.00, wide 2.00, wide-runs 2.50"
        );
    }

    #[test]
    fn a_layout_is_kept_until_a_frame_of_it_is_timed() {
        // Times come back late (frames in flight) or not yet (a frame traced in bands).
        let mut auto = AutoLayout::default();
        let w = work(1);
        for _ in 0..5 {
            assert_eq!(auto.next_layout(w, true), Some(BvhLayout::Binary));
        }
        auto.frame_timed(1.0, w.settings);
        assert_eq!(auto.next_layout(w, true), Some(BvhLayout::Wide));
        // A time of another work (before a resolution change) counts for nothing.
        auto.frame_timed(1.0, RenderSettings { width: 7, bvh: BvhLayout::Wide, ..w.settings });
        assert_eq!(auto.next_layout(w, true), Some(BvhLayout::Wide));
    }

    #[test]
    fn new_work_starts_over_and_a_trial_without_times_settles_on_binary() {
        let mut auto = AutoLayout::default();
        run(&mut auto, work(1), 40, |l| if l == BvhLayout::WideRuns { 1.0 } else { 2.0 });
        assert_eq!(auto.chosen(), Some(BvhLayout::WideRuns));
        // Another model: the trial again, and no times at all this time.
        let w = work(2);
        for _ in 0..=MAX_TRIAL_FRAMES {
            assert_eq!(auto.next_layout(w, true), Some(BvhLayout::Binary));
        }
        assert_eq!(auto.chosen(), Some(BvhLayout::Binary));
        // Not our BVH: no choice to make.
        let brute = Work::new(
            RenderSettings { accel: Accel::Brute, ..RenderSettings::default() },
            1,
            true,
            2,
        );
        assert_eq!(auto.next_layout(brute, true), None);
    }
}
