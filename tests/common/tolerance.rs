//! How close two images of one scene must be, for each pair of tracers the tests compare,
//! and why. Every test that compares images goes through [`assert_within`] (or
//! [`assert_close`], its most common case), so a tolerance is written once, here.
//!
//! A comparison measures, per pixel, the largest difference of the three colour channels
//! ([`Image::compare`]), then allows a share of pixels over a threshold and a mean over
//! all pixels.

use meshtracer::tracer::Image;

/// How far two images may differ: at most `fraction_over` of the pixels may differ by more
/// than `threshold` in some channel, and the mean difference may be at most `mean`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// A pixel differs when a channel differs by more than this.
    pub threshold: f32,
    /// The share of pixels (0..1) that may differ.
    pub fraction_over: f32,
    /// The largest mean difference over all pixels.
    pub mean: f32,
}

/// Our GPU tracer against the CPU reference, and one of our traversals against another
/// (wide against binary BVH, brute force against the BVH). They run the same float maths
/// but not bit for bit (FMA contraction, `pow`/`normalize` precision): on lavapipe the
/// largest difference seen is 4e-6. A ray grazing an edge may still pick the neighbouring
/// triangle on some driver, so 0.2% of pixels may differ by more than 1e-4 (1/40 of an
/// 8-bit step), and the mean difference stays within 1e-4.
pub const SAME_MATHS: Tolerance = Tolerance { threshold: 1e-4, fraction_over: 0.002, mean: 1e-4 };

/// [`SAME_MATHS`] for a field of hundreds of small turned copies seen by primary rays: the
/// image is mostly silhouettes, and the transforms add rounding (fused on the GPU, not on
/// the CPU) to each ray carried into a mesh, so the 0.2% of pixels that may pick another
/// triangle at a grazed edge, each by up to a whole colour, lift the mean to about 1.5e-4
/// (measured on lavapipe: 5 of 9,216 pixels at 96², 11 of 16,384 at 128²).
pub const SAME_MATHS_FIELD: Tolerance = Tolerance { mean: 5e-4, ..SAME_MATHS };

/// The vendor's ray tracing (`--accel vendor`) against our compute BVH: the same shading
/// source on the same rays, only the closest-hit query differs. The driver's triangle test
/// is watertight and ours is Möller–Trumbore on (v0, e1, e2), so a ray through a shared
/// edge or a silhouette may pick the neighbouring triangle or miss: 1% of pixels may
/// differ by more than 1e-3, and the mean difference stays within 1e-3.
pub const VENDOR: Tolerance = Tolerance { threshold: 1e-3, fraction_over: 0.01, mean: 1e-3 };

/// [`VENDOR`] for the depth, triangle-id and normal views: a pixel that picked the
/// neighbouring triangle differs there by a whole id or a jump in depth, so only the share
/// of pixels that differ is bounded, not the mean.
pub const VENDOR_IDS: Tolerance =
    Tolerance { threshold: 1e-3, fraction_over: 0.01, mean: f32::INFINITY };

/// The ambient-occlusion view, our GPU tracer against the CPU reference (and one BVH
/// layout against another). The AO rays' directions come from the same PCG hash of
/// (pixel, camera sample, frame, ray index) on both sides, so the tracers cast the same
/// rays up to float rounding (`sin`/`cos`/`sqrt` and FMA contraction differ in the last
/// bits). A ray that grazes an occluder's edge, or meets one at the radius, can still go
/// the other way, which moves that pixel by 1/N (N rays per hit): 2% of pixels may differ
/// by more than 1e-4, and the mean difference stays within 2e-3. Measured on lavapipe:
/// every AO comparison of the tests is identical; the Stanford bunny at 256², 32 rays,
/// 4 frames accumulated, differs from the CPU's in 1 of 65,536 PNG pixels by 2/255.
pub const AO: Tolerance = Tolerance { threshold: 1e-4, fraction_over: 0.02, mean: 2e-3 };

/// The vendor's AO (any-hit queries) against ours: [`AO`]'s allowance at [`VENDOR`]'s
/// threshold, since the vendor's triangle test is watertight and ours is not. Measured on
/// lavapipe: the bunny above differs from the vendor's in 4 pixels, by 2/255.
pub const AO_VENDOR: Tolerance = Tolerance { threshold: 1e-3, ..AO };

/// Fail unless `a` and `b` are within `tolerance`; `what` names the comparison.
pub fn assert_within(a: &Image, b: &Image, tolerance: Tolerance, what: &str) {
    let d = a.compare(b, tolerance.threshold);
    assert!(
        d.fraction_over <= tolerance.fraction_over && d.mean <= tolerance.mean,
        "{what}: the images differ beyond {tolerance:?}: {d:?}"
    );
}

/// [`assert_within`] [`SAME_MATHS`]: our GPU tracer against the CPU reference, or one of
/// our traversals against another.
pub fn assert_close(a: &Image, b: &Image, what: &str) {
    assert_within(a, b, SAME_MATHS, what);
}

/// The cost view (`Aov::Cost`: nodes and triangles per pixel) of our GPU tracer against the
/// CPU reference, which walks the packed nodes in the shader's order: both count the same,
/// but a ray grazing a box edge may go either way on a driver, so [`SAME_MATHS`]'s share of
/// pixels may count otherwise.
pub fn assert_same_cost(gpu: &Image, cpu: &Image, what: &str) {
    let differ = gpu.pixels.iter().zip(&cpu.pixels).filter(|(g, c)| g[..2] != c[..2]).count();
    assert!(
        differ as f32 <= SAME_MATHS.fraction_over * gpu.pixels.len() as f32,
        "{what}: cost differs on {differ} of {} pixels",
        gpu.pixels.len()
    );
}
