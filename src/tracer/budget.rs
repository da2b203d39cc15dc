//! How much work one submission may ask of the GPU, in ray-triangle tests: the one budget
//! the window, `render` and `bench` share. A frame over the device's budget
//! ([`tests_per_submission`]) is split into bands (row bands in `render` and `bench`; the
//! window's may be finer, down to one pixel), each its own submission, so no single
//! dispatch runs long enough to trip a driver's watchdog or to keep the window from
//! answering; a frame over [`MAX_TESTS_PER_FRAME`] is refused, since it would take minutes
//! on any GPU.

use crate::render_settings::{Accel, RenderSettings};

/// Most ray-triangle tests one submission may ask of a GPU (well under a second on a fast
/// one).
pub const TESTS_PER_SUBMISSION: f64 = 4.0e9;

/// Most ray-triangle tests one submission may ask of a CPU device (lavapipe). The budget
/// follows the device's kind rather than measured times: it is known before the first
/// frame, so `render` and `bench` band exactly as the window does and a GPU's budget (and
/// its `bench` figures) stays as it was. It decides which frames are banded at all; the
/// window then sizes each band of a long frame from its measured time (about 40 ms,
/// `app::tool::progressive`). On 2 cores lavapipe runs 0.6e9 to 0.9e9 estimated tests a
/// second (a 1024², 8-bounce BVH frame of 2.4e9: 2.7 s for armadillo, 4.2 s for a
/// 300k-triangle knot with other work running), so a submission takes 0.3 to 0.4 s. Set
/// just above the default 512², 2-bounce BVH view (2.0e8), which stays one submission
/// (a few hundred ms, drawn whole as before); anything longer is banded.
pub const CPU_TESTS_PER_SUBMISSION: f64 = 2.5e8;

/// The kind of device a budget is for (the tracer cannot see the GPU module's types).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceKind {
    /// A GPU, discrete or integrated.
    Gpu,
    /// A CPU implementation of Vulkan (lavapipe), about a thousand times slower.
    Cpu,
}

/// The submission budget in use on `device`: [`TESTS_PER_SUBMISSION`] or
/// [`CPU_TESTS_PER_SUBMISSION`], or the environment's `MESHTRACER_TESTS_PER_SUBMISSION` on
/// any device (tests use a small one to band small frames).
pub fn tests_per_submission(device: DeviceKind) -> f64 {
    static OVERRIDE: std::sync::OnceLock<Option<f64>> = std::sync::OnceLock::new();
    let given = *OVERRIDE.get_or_init(|| {
        std::env::var("MESHTRACER_TESTS_PER_SUBMISSION")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| *v >= 1.0)
    });
    given.unwrap_or(default_budget(device))
}

/// The budget of `device` when the environment sets none.
fn default_budget(device: DeviceKind) -> f64 {
    match device {
        DeviceKind::Gpu => TESTS_PER_SUBMISSION,
        DeviceKind::Cpu => CPU_TESTS_PER_SUBMISSION,
    }
}

/// Most ray-triangle tests one frame may ask for (minutes on an H100 beyond this).
pub const MAX_TESTS_PER_FRAME: f64 = 2.0e12;

/// A pessimistic count of the triangle tests and node visits one BVH ray costs, for the
/// estimate only (the cost AOV measures the real figure).
const BVH_TESTS_PER_RAY: f64 = 256.0;

/// What one brute-force ray-triangle test costs on a CPU device, in the BVH estimate's
/// tests: the budget is in those, and a BVH ray's real tests are far fewer than its
/// estimate. Measured on lavapipe, 2 cores (2026-11-28): brute force runs 27e6 to 51e6
/// tests a second (geosphere at 256², knots of 2k and 20k triangles at 128²) against 0.45e9
/// to 0.9e9 estimated BVH tests, so a brute-force band of the CPU budget takes 0.2 to 0.4 s
/// as a BVH band does, rather than 5 to 7 s.
pub const CPU_BRUTE_TEST_COST: f64 = 24.0;

/// What one submission may ask of a device, in BVH-estimate tests ("work").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Work per submission: [`tests_per_submission`].
    pub work: f64,
    /// Work of one brute-force ray-triangle test: [`CPU_BRUTE_TEST_COST`] on a CPU device,
    /// 1 on a GPU (whose budget and `bench` figures stay as they were).
    pub brute_cost: f64,
}

impl Budget {
    /// The budget in use on `device` (the environment may set its work).
    pub fn of(device: DeviceKind) -> Self {
        Self { work: tests_per_submission(device), brute_cost: brute_test_cost(device) }
    }

    /// Brute-force ray-triangle tests one submission may ask for.
    pub fn brute_tests(&self) -> f64 {
        self.work / self.brute_cost
    }
}

/// The work of one brute-force test on `device`: see [`Budget::brute_cost`].
fn brute_test_cost(device: DeviceKind) -> f64 {
    match device {
        DeviceKind::Gpu => 1.0,
        DeviceKind::Cpu => CPU_BRUTE_TEST_COST,
    }
}

/// Tests a ray costs with `accel` in a world of `triangles` triangles (all instances).
pub fn tests_per_ray(accel: Accel, triangles: u64) -> f64 {
    match accel {
        Accel::Brute => triangles.max(1) as f64,
        Accel::Bvh | Accel::Vendor => BVH_TESTS_PER_RAY,
    }
}

/// Work a ray costs with `accel` among `triangles` under `budget`: its tests, a brute-force
/// test weighted by what it costs on the device.
pub fn work_per_ray(accel: Accel, triangles: u64, budget: &Budget) -> f64 {
    let weight = if accel == Accel::Brute { budget.brute_cost } else { 1.0 };
    tests_per_ray(accel, triangles) * weight
}

/// Tests one frame of `settings` asks for at most.
pub fn tests_per_frame(settings: &RenderSettings, triangles: u64) -> f64 {
    settings.max_rays() as f64 * tests_per_ray(settings.accel, triangles)
}

/// Why a frame is refused, if it is: one sentence for the panel or the command line.
pub fn refusal(settings: &RenderSettings, triangles: u64) -> Option<String> {
    let tests = tests_per_frame(settings, triangles);
    (tests > MAX_TESTS_PER_FRAME).then(|| {
        format!(
            "{} would test {tests:.1e} ray-triangle pairs per frame (minutes per frame)",
            settings.accel
        )
    })
}

/// Pixels per submission so that each stays under `budget`'s work (at least one): what the
/// window's bands of a long frame may cover at most, down to part of a work group.
pub fn pixels_per_submission(settings: &RenderSettings, triangles: u64, budget: &Budget) -> u64 {
    let pixels = (settings.width as u64 * settings.height as u64).max(1);
    let per_pixel = settings.max_rays() as f64 / pixels as f64
        * work_per_ray(settings.accel, triangles, budget);
    ((budget.work / per_pixel).floor() as u64).clamp(1, pixels)
}

/// Rows per submission so that each stays under `budget`'s work (rays times the work per
/// ray: for brute force, times the triangles tested), rounded up to a multiple of
/// `row_multiple` (the shader's work-group height) and at most the frame.
pub fn rows_per_submission(
    settings: &RenderSettings,
    triangles: u64,
    row_multiple: u32,
    budget: &Budget,
) -> u32 {
    let rays_per_row = settings.max_rays() as f64 / settings.height.max(1) as f64;
    let per_row = rays_per_row * work_per_ray(settings.accel, triangles, budget);
    let rows = (budget.work / per_row).floor() as u32;
    let rows = rows.max(1).div_ceil(row_multiple) * row_multiple;
    rows.min(settings.height.div_ceil(row_multiple) * row_multiple)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The budgets of a GPU and a CPU device, whatever the environment says.
    const GPU: Budget = Budget { work: TESTS_PER_SUBMISSION, brute_cost: 1.0 };
    const CPU: Budget = Budget { work: CPU_TESTS_PER_SUBMISSION, brute_cost: CPU_BRUTE_TEST_COST };

    #[test]
    fn bvh_frames_are_one_band_and_brute_force_splits() {
        let s = RenderSettings { width: 1024, height: 1024, ..Default::default() };
        assert_eq!(rows_per_submission(&s, 10_000_000, 8, &GPU), 1024);
        let brute = RenderSettings { accel: Accel::Brute, ..s };
        let rows = rows_per_submission(&brute, 1_000_000, 8, &GPU);
        assert!(rows < 1024 && rows % 8 == 0, "{rows}");
        // Every band but the last stays under the budget (bands are at least one group high).
        assert!(
            rows == 8
                || rows as f64 * 1024.0 * 3.0 * 1e6
                    <= TESTS_PER_SUBMISSION + 8.0 * 1024.0 * 3.0 * 1e6
        );
    }

    #[test]
    fn only_frames_of_minutes_are_refused() {
        let s =
            RenderSettings { width: 1024, height: 1024, accel: Accel::Brute, ..Default::default() };
        assert!(refusal(&s, 100_000).is_none());
        let why = refusal(&s, 10_000_000).unwrap();
        assert!(why.starts_with("brute would test"), "{why}");
        assert!(refusal(&RenderSettings { accel: Accel::Bvh, ..s }, 10_000_000).is_none());
    }

    /// Issue #30: a 1024², 8-bounce BVH frame takes seconds on lavapipe, so a CPU device
    /// bands it (submissions of a few hundred ms) while a GPU traces it in one, as before.
    #[test]
    fn a_cpu_device_bands_a_long_bvh_frame_and_a_gpu_does_not() {
        let s = RenderSettings { width: 1024, height: 1024, bounces: 8, ..Default::default() };
        assert_eq!(
            default_budget(DeviceKind::Gpu),
            TESTS_PER_SUBMISSION,
            "a GPU's budget is unchanged"
        );
        assert_eq!(rows_per_submission(&s, 345_944, 8, &GPU), 1024);
        let rows = rows_per_submission(&s, 345_944, 8, &CPU);
        assert!(rows < 1024 && rows % 8 == 0, "{rows}");
        // Each band's estimate is within one work-group strip of the CPU budget.
        let per_row = 1024.0 * 9.0 * tests_per_ray(Accel::Bvh, 0);
        assert!(rows as f64 * per_row <= CPU_TESTS_PER_SUBMISSION + 8.0 * per_row, "{rows}");
        // Brute force bands on both, more finely on the CPU.
        let brute = RenderSettings { accel: Accel::Brute, ..s };
        let gpu_rows = rows_per_submission(&brute, 345_944, 8, &GPU);
        assert!(gpu_rows < 1024 && rows_per_submission(&brute, 345_944, 8, &CPU) <= gpu_rows);
        // The default 512², 2-bounce view still fits one submission on a CPU device.
        let view = RenderSettings { width: 512, height: 512, bounces: 2, ..Default::default() };
        assert_eq!(rows_per_submission(&view, 345_944, 8, &CPU), 512);
    }

    /// Issue #43: brute force over Crytek Sponza (262,267 triangles) at 4 spp and 2 bounces
    /// asks a few pixels per CPU submission, far under one work group (128 pixels), while
    /// a BVH view's budget is the whole frame.
    #[test]
    fn a_brute_force_pixel_can_be_most_of_a_submission() {
        let s = RenderSettings {
            width: 512,
            height: 512,
            accel: Accel::Brute,
            spp: 4,
            ..Default::default()
        };
        let pixels = pixels_per_submission(&s, 262_267, &CPU);
        assert!((1..16).contains(&pixels), "{pixels}");
        let work = pixels as f64 * 4.0 * 3.0 * 262_267.0 * CPU_BRUTE_TEST_COST;
        assert!(work <= CPU.work, "{work:e}");
        assert_eq!(pixels_per_submission(&s, 1_000_000_000, &CPU), 1, "at least one");
        let view = RenderSettings { width: 512, height: 512, ..Default::default() };
        assert_eq!(pixels_per_submission(&view, 262_267, &CPU), 512 * 512);
    }

    /// Issue #43: brute force on lavapipe runs about 24 times fewer ray-triangle tests a
    /// second than the BVH estimate's, so a brute-force frame of the geosphere (92
    /// triangles) at 256², 18e6 tests, took seconds as one submission. Bands are now sized
    /// by work (rays times triangles, weighted): there are several, and each band's
    /// weighted work stays within the CPU budget.
    #[test]
    fn a_brute_force_frame_is_banded_by_its_rays_times_triangles() {
        assert_eq!(Budget { work: default_budget(DeviceKind::Cpu), ..CPU }, CPU);
        assert_eq!(brute_test_cost(DeviceKind::Cpu), CPU.brute_cost);
        assert_eq!(brute_test_cost(DeviceKind::Gpu), GPU.brute_cost, "a GPU bands as before");
        for (triangles, side) in [(92, 256), (92, 512), (2_028, 256), (262_267, 1024)] {
            let s = RenderSettings {
                width: side,
                height: side,
                accel: Accel::Brute,
                ..Default::default()
            };
            let rows = rows_per_submission(&s, triangles, 4, &CPU);
            let bands = side.div_ceil(rows);
            assert!(bands >= 2, "{triangles} triangles at {side}²: {bands} band(s)");
            let rays = s.max_rays() as f64 * rows as f64 / side as f64;
            let work = rays * triangles as f64 * CPU_BRUTE_TEST_COST;
            let strip = s.max_rays() as f64 * 4.0 / side as f64 * triangles as f64;
            // Within one work-group strip of the budget (a band is at least one strip).
            assert!(work <= CPU.work + strip * CPU_BRUTE_TEST_COST, "{triangles} at {side}²");
            assert!(rays * triangles as f64 <= CPU.brute_tests() + strip);
        }
        // A BVH frame of the same size is still one submission on a CPU device.
        let view = RenderSettings { width: 256, height: 256, ..Default::default() };
        assert_eq!(rows_per_submission(&view, 92, 4, &CPU), 256);
    }
}
