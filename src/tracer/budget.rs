//! How much work one frame may ask of the GPU, in ray-triangle tests: the one budget the
//! window, `render` and `bench` share. A frame over [`TESTS_PER_SUBMISSION`] is split into
//! row bands, each its own submission, so no single dispatch runs long enough to trip a
//! driver's watchdog (brute force on big meshes); a frame over [`MAX_TESTS_PER_FRAME`] is
//! refused, since it would take minutes on any GPU.

use crate::render_settings::{Accel, RenderSettings};

/// Most ray-triangle tests one submission may ask for (well under a second on a fast GPU).
pub const TESTS_PER_SUBMISSION: f64 = 4.0e9;

/// The submission budget in use: [`TESTS_PER_SUBMISSION`], or the environment's
/// `MESHTRACER_TESTS_PER_SUBMISSION` (tests use a small one to band small frames).
pub fn tests_per_submission() -> f64 {
    static BUDGET: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *BUDGET.get_or_init(|| {
        std::env::var("MESHTRACER_TESTS_PER_SUBMISSION").ok().and_then(|v| v.parse::<f64>().ok()).filter(|v| *v >= 1.0).unwrap_or(TESTS_PER_SUBMISSION)
    })
}

/// Most ray-triangle tests one frame may ask for (minutes on an H100 beyond this).
pub const MAX_TESTS_PER_FRAME: f64 = 2.0e12;

/// A pessimistic count of the triangle tests and node visits one BVH ray costs, for the
/// estimate only (the cost AOV measures the real figure).
const BVH_TESTS_PER_RAY: f64 = 256.0;

/// Tests a ray costs with `accel` in a world of `triangles` triangles (all instances).
pub fn tests_per_ray(accel: Accel, triangles: u64) -> f64 {
    match accel {
        Accel::Brute => triangles.max(1) as f64,
        Accel::Bvh | Accel::Vendor => BVH_TESTS_PER_RAY,
    }
}

/// Tests one frame of `settings` asks for at most.
pub fn tests_per_frame(settings: &RenderSettings, triangles: u64) -> f64 {
    settings.max_rays() as f64 * tests_per_ray(settings.accel, triangles)
}

/// Why a frame is refused, if it is: one sentence for the panel or the command line.
pub fn refusal(settings: &RenderSettings, triangles: u64) -> Option<String> {
    let tests = tests_per_frame(settings, triangles);
    (tests > MAX_TESTS_PER_FRAME).then(|| format!("{} would test {tests:.1e} ray-triangle pairs per frame (minutes per frame)", settings.accel))
}

/// Rows per submission so that each stays under [`tests_per_submission`], rounded up to a
/// multiple of `row_multiple` (the shader's work-group height) and at most the frame.
pub fn rows_per_submission(settings: &RenderSettings, triangles: u64, row_multiple: u32) -> u32 {
    let per_row = settings.width as f64 * (settings.bounces as f64 + 1.0) * settings.spp as f64 * tests_per_ray(settings.accel, triangles);
    let rows = (tests_per_submission() / per_row).floor() as u32;
    let rows = rows.max(1).div_ceil(row_multiple) * row_multiple;
    rows.min(settings.height.div_ceil(row_multiple) * row_multiple)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bvh_frames_are_one_band_and_brute_force_splits() {
        let s = RenderSettings { width: 1024, height: 1024, ..Default::default() };
        assert_eq!(rows_per_submission(&s, 10_000_000, 8), 1024);
        let brute = RenderSettings { accel: Accel::Brute, ..s };
        let rows = rows_per_submission(&brute, 1_000_000, 8);
        assert!(rows < 1024 && rows % 8 == 0, "{rows}");
        // Every band but the last stays under the budget (bands are at least one group high).
        assert!(rows == 8 || rows as f64 * 1024.0 * 3.0 * 1e6 <= TESTS_PER_SUBMISSION + 8.0 * 1024.0 * 3.0 * 1e6);
    }

    #[test]
    fn only_frames_of_minutes_are_refused() {
        let s = RenderSettings { width: 1024, height: 1024, accel: Accel::Brute, ..Default::default() };
        assert!(refusal(&s, 100_000).is_none());
        let why = refusal(&s, 10_000_000).unwrap();
        assert!(why.starts_with("brute would test"), "{why}");
        assert!(refusal(&RenderSettings { accel: Accel::Bvh, ..s }, 10_000_000).is_none());
    }
}
