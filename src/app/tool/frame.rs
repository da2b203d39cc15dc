//! The frame and its bands: what each display frame traces and shows, the pictures made
//! on the CPU (views other than colour, or colour traced on another device), and the state
//! of a long frame traced in bands over several display frames.

use crate::app::state::ViewMode;
use crate::app::tool::devices::Gpu;
use crate::app::tool::progressive::{adapt_pixels, BandTimes, Progressive};
use crate::app::views::aov;
use crate::app::views::cost::heat_map;
use crate::gpu::dispatch::{GROUP, GROUP_LANES};
use crate::gpu::{Band, ComputeTracer, FrameTrace};
use crate::render_settings::RenderSettings;

/// A picture made or read back on the CPU: a view other than colour (cost heat map,
/// depth, ...), or the colour traced on a device other than the window's. Its pixels (for
/// F12) and its legend.
pub(super) struct Picture {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) rgba: Vec<u8>,
    /// (scale top, max, mean) of a heat map, for the panel's legend.
    pub(super) stats: Option<(f32, f32, f32)>,
    /// What the colours mean, for the other views.
    pub(super) note: Option<String>,
}

/// What the image area shows, decided before the frame is drawn.
#[derive(Clone, Copy)]
pub(super) enum Shown {
    Nothing,
    /// The tracer's colour output.
    Output,
    /// The pixels in `Frames::picture`.
    Picture,
}

/// What one display frame traces and shows.
pub(super) struct Prepared {
    /// Pixels to trace in the frame's command buffer.
    pub(super) trace: Option<(FrameTrace, Band)>,
    pub(super) show: Shown,
    /// GPU time of a trace done before the frame (the cost view's synchronous trace).
    pub(super) gpu_ms: Option<f64>,
    /// That trace's time per half of a split frame.
    pub(super) part_ms: Option<[f64; 2]>,
    /// This display frame finishes a traced frame (the last or only band).
    pub(super) completes: bool,
}

impl Prepared {
    /// Nothing traced, nothing shown.
    pub(super) const NOTHING: Prepared = Prepared {
        trace: None,
        show: Shown::Nothing,
        gpu_ms: None,
        part_ms: None,
        completes: false,
    };
}

/// What the frames shown so far left behind for the next.
pub(super) struct Frames {
    /// The picture shown when the image is not the tracer's colour output.
    pub(super) picture: Option<Picture>,
    /// The long frame being traced in bands, if any.
    pub(super) progressive: Option<Progressive>,
    /// Pixels per band of a long frame (adapted to the GPU's speed; under a work group's
    /// where one group is too long).
    pub(super) band_pixels: u64,
    /// Frames traced to their last pixel so far.
    pub(super) traced_frames: u64,
    /// The number of the frame being traced, which its bands' GPU times come back tagged
    /// with: a new one for every whole frame and every banded frame begun, so that the bands
    /// of a frame a change cut short never add to the next frame's time (`traced_frames`
    /// counts finished frames only: a brute-force frame's 30 s of bands once came back as
    /// the next BVH frame's time and skewed the layout trial).
    pub(super) number: u64,
    /// The GPU time of the frame whose bands are being timed.
    pub(super) band_times: BandTimes,
    /// A frame has been traced: F12 has something to save.
    pub(super) traced: bool,
    /// The settings of the last few frames by number, so that a GPU time that comes back
    /// later is shown with the rays of its own frame (not those of a newer resolution).
    pub(super) settings_by_frame: std::collections::VecDeque<(u64, RenderSettings)>,
}

impl Default for Frames {
    fn default() -> Self {
        Self {
            picture: None,
            progressive: None,
            band_pixels: GROUP_LANES as u64,
            traced_frames: 0,
            number: 0,
            band_times: BandTimes::default(),
            traced: false,
            settings_by_frame: Default::default(),
        }
    }
}

impl Frames {
    /// Remember that frame `number` traces with `settings` (the last eight are kept).
    pub(super) fn note_settings(&mut self, number: u64, settings: RenderSettings) {
        if self.settings_by_frame.back().is_some_and(|b| b.0 == number) {
            self.settings_by_frame.pop_back();
        }
        self.settings_by_frame.push_back((number, settings));
        while self.settings_by_frame.len() > 8 {
            self.settings_by_frame.pop_front();
        }
    }

    /// The settings frame `number` traced with, if it is recent.
    pub(super) fn settings_of(&self, number: u64) -> Option<RenderSettings> {
        self.settings_by_frame.iter().rev().find(|(n, _)| *n == number).map(|(_, s)| *s)
    }

    /// Trace or band what `params` asks for on `gpu` (prepared already), for `view`:
    /// see `Tool::prepare_image`.
    pub(super) fn trace(
        &mut self,
        gpu: &mut Gpu,
        params: FrameTrace,
        view: ViewMode,
    ) -> anyhow::Result<Prepared> {
        let (width, height) = (params.params.settings.width, params.params.settings.height);
        // Views other than colour are pictures made on the CPU from the float output.
        let cost = (view != ViewMode::Color).then_some(view);
        if gpu.tracer.fits_one_submission(&params) {
            self.progressive = None;
            self.number += 1;
            if let Some(view) = cost {
                let (image, timing) = gpu.tracer.render_frame(&params)?;
                self.set_picture(&image, view);
                return Ok(Prepared {
                    trace: None,
                    show: Shown::Picture,
                    gpu_ms: timing.gpu_ms,
                    part_ms: timing.parts_ms,
                    completes: true,
                });
            }
            if gpu.traces_elsewhere() {
                let timing = gpu.tracer.trace_frame(&params)?;
                self.read_back_colour(&gpu.tracer)?;
                return Ok(Prepared {
                    trace: None,
                    show: Shown::Picture,
                    gpu_ms: timing.gpu_ms,
                    part_ms: timing.parts_ms,
                    completes: true,
                });
            }
            self.picture = None;
            let whole = Band::rows(0..height, width);
            return Ok(Prepared {
                trace: Some((params, whole)),
                show: Shown::Output,
                gpu_ms: None,
                part_ms: None,
                completes: true,
            });
        }
        // A moving light does not restart a long frame: the frame keeps the light it began
        // with; any other change starts afresh.
        if !self.progressive.as_ref().is_some_and(|p| p.continues(&params)) {
            self.progressive = Some(Progressive::new(params, GROUP));
            self.number += 1;
            // A new frame's first band stays within the submission budget, which may be a
            // few pixels (brute force over a big scene on a CPU device): not sized from a
            // cheaper frame's bands, nor a whole group of seconds.
            self.band_pixels = self.band_pixels.min(gpu.tracer.pixels_per_submission(&params));
        }
        // Bands then grow with their measured time up to the budget's rows (at least one
        // strip of groups), as `render` and `bench` band.
        let most = (gpu.tracer.rows_per_submission(&params) / GROUP.height) as u64
            * width.div_ceil(GROUP.width) as u64
            * GROUP_LANES as u64;
        self.band_pixels = self.band_pixels.clamp(1, most.max(1));
        let progressive = self.progressive.as_mut().expect("set above");
        let params = progressive.frame;
        let band =
            progressive.next_band(self.band_pixels).expect("a frame in progress has pixels left");
        let completes = progressive.is_done();
        if completes {
            self.progressive = None;
        }
        if gpu.traces_elsewhere() {
            let ms = gpu.tracer.trace_band(&params, &band)?;
            let total: f64 = ms.iter().flatten().sum();
            self.band_pixels = adapt_pixels(band.pixels(), total, u64::MAX);
            match cost {
                None => self.read_back_colour(&gpu.tracer)?,
                Some(view) if completes => {
                    let image = gpu.tracer.read_image()?;
                    self.set_picture(&image, view);
                }
                Some(_) => {}
            }
            let show = if self.picture.is_some() { Shown::Picture } else { Shown::Nothing };
            let part_ms = params.split.is_some().then(|| ms.map(|m| m.unwrap_or(0.0)));
            return Ok(Prepared { trace: None, show, gpu_ms: Some(total), part_ms, completes });
        }
        let show = match cost {
            Some(_) if self.picture.is_some() => Shown::Picture,
            Some(_) => Shown::Nothing,
            None => {
                self.picture = None;
                Shown::Output
            }
        };
        Ok(Prepared { trace: Some((params, band)), show, gpu_ms: None, part_ms: None, completes })
    }

    /// Show the tracer's colour output as it is now, read back from the tracing device.
    fn read_back_colour(&mut self, tracer: &ComputeTracer) -> anyhow::Result<()> {
        let image = tracer.read_rgba8()?;
        let (width, height) = image.dimensions();
        self.picture =
            Some(Picture { width, height, rgba: image.into_raw(), stats: None, note: None });
        Ok(())
    }

    /// Make the picture of a view other than colour, traced into `image`, the one shown.
    pub(super) fn set_picture(&mut self, image: &crate::tracer::Image, view: ViewMode) {
        let (width, height) = (image.width, image.height);
        self.picture = match (view, aov::picture(image, view)) {
            (ViewMode::Cost(metric), _) => {
                let map = heat_map(bytemuck::cast_slice(&image.pixels), metric);
                Some(Picture {
                    width,
                    height,
                    rgba: map.rgba,
                    stats: Some((map.scale_max, map.max, map.mean)),
                    note: None,
                })
            }
            (_, Some(p)) => {
                Some(Picture { width, height, rgba: p.rgba, stats: p.heat, note: p.note })
            }
            (_, None) => None,
        };
    }
}
