//! `bench --fields`: 10,000 copies of a knot against one copy at the same screen coverage
//! (issue #44's row). A field's frame is dearer than one model's for two reasons: each ray
//! walks the top level and enters the copies whose boxes it crosses, and each pixel sees
//! more model. The second is not the two levels' cost, so the one copy is traced with its
//! camera moved along its view until it covers the share of the frame the field covers.

use std::sync::Arc;

use super::{Case, Coverage, Row};
use crate::gpu::{ComputeTracer, GpuError};
use crate::render_settings::{Accel, Aov, RenderSettings};
use crate::scene::camera::Camera;
use crate::scene::paper::{ModelSource, MODEL_RADIUS};
use crate::scene::primitives::large_torus_knot;
use crate::scene::Scene;
use crate::tracer::FrameParams;

/// Copies in a field row: the 10,000, the model count's limit.
pub const FIELD_COPIES: u32 = 10_000;

/// The knot of the field series when no `--triangles` is given: the 1M.
pub const DEFAULT_TRIANGLES: usize = 1_000_000;

/// Probes of the coverage search; the camera's distance is then within 2^-14 of its range.
const SEARCH_STEPS: u32 = 14;

/// A coverage this close to the field's ends the search early.
const CLOSE_ENOUGH: f64 = 0.002;

/// Per knot of `triangle_counts`, no mirror box, primary rays at `size`: the field of
/// [`FIELD_COPIES`] identical copies as the window frames it (its coverage the target),
/// one copy at that coverage, then the field turned and scaled (`scatter` seed 1).
pub fn field_cases(triangle_counts: &[usize], accels: &[Accel], size: u32) -> Vec<Case> {
    let mut cases = Vec::new();
    for &n in triangle_counts {
        let mesh = Arc::new(large_torus_knot(n));
        let rows = [
            (FIELD_COPIES, 0, Coverage::Target, "identical"),
            (1, 0, Coverage::Matched, "at the field's coverage"),
            (FIELD_COPIES, 1, Coverage::Measured, "turned and scaled"),
        ];
        for (copies, scatter, coverage, label) in rows {
            for &accel in accels {
                let settings = super::paper_tables::settings(size, 0, accel);
                let mut case = Case {
                    generated: Some(mesh.clone()),
                    coverage,
                    features: label.into(),
                    ..Case::new("field", ModelSource::default(), copies, settings)
                };
                case.spec.mirror_box = false;
                case.spec.scatter = scatter;
                cases.push(case);
            }
        }
    }
    cases
}

/// The share of `scene`'s frame at `settings` (size and camera) whose pixel sees the
/// model (mesh 0, every copy), from a primitive-id frame traced with our BVH, so that our
/// rows and the vendor's measure and match the same way.
pub(super) fn coverage(
    tracer: &mut ComputeTracer,
    scene: &Scene,
    settings: RenderSettings,
) -> Result<f64, GpuError> {
    let ids = RenderSettings { aov: Aov::PrimId, accel: Accel::Bvh, spp: 1, ..settings };
    let (image, _) = tracer.render(&FrameParams::new(scene, ids))?;
    let model_triangles = scene.meshes[0].triangle_count() as f32;
    let hits = image.pixels.iter().filter(|p| p[0] >= 0.0 && p[0] < model_triangles).count();
    Ok(hits as f64 / image.pixels.len().max(1) as f64)
}

/// `scene`'s camera moved along its view (towards or away from its target) until the model
/// covers `target` of the frame, by bisection on the distance between a quarter of the
/// framing distance (the model overfilling the frame) and 64 times it. A target out of
/// that range gets the nearer end.
pub(super) fn camera_at_coverage(
    tracer: &mut ComputeTracer,
    scene: &mut Scene,
    settings: RenderSettings,
    target: f64,
) -> Result<Camera, GpuError> {
    let home = scene.camera;
    let framing = home.framing(MODEL_RADIUS, 1.0);
    let dir = (home.position - home.target).normalize_or(glam::Vec3::Z);
    let framed_distance = (framing.position - framing.target).length();
    let at = |distance: f32| Camera { position: home.target + dir * distance, ..home };
    // Coverage falls as the camera steps back: bisect on the logarithm of the distance.
    let (mut near, mut far) = ((framed_distance * 0.25).ln(), (framed_distance * 64.0).ln());
    let mut best = (at(near.exp()), f64::NEG_INFINITY);
    for _ in 0..SEARCH_STEPS {
        let mid = 0.5 * (near + far);
        scene.camera = at(mid.exp());
        let reached = coverage(tracer, scene, settings)?;
        if (reached - target).abs() < (best.1 - target).abs() {
            best = (scene.camera, reached);
        }
        if (reached - target).abs() < CLOSE_ENOUGH {
            break;
        }
        if reached > target {
            near = mid;
        } else {
            far = mid;
        }
    }
    scene.camera = home;
    Ok(best.0)
}

/// The rows' label for a measured coverage ("60% model").
pub(super) fn coverage_label(share: f64) -> String {
    format!("{:.0}% model", 100.0 * share)
}

/// A row's `features` with its measured coverage after them.
pub(super) fn labelled(features: &str, share: f64) -> String {
    let label = coverage_label(share);
    if features.is_empty() {
        label
    } else {
        format!("{features}, {label}")
    }
}

/// What a run carries from row to row for [`Coverage`]: the last target row's share of the
/// frame and the camera found for it, per mesh, so that our rows and the vendor's trace
/// the same rays.
#[derive(Default)]
pub(super) struct CoverageRuns {
    target: Option<(String, f64)>,
    matched: Option<(String, Camera)>,
}

impl CoverageRuns {
    /// Before `case`'s frames, on `tracer` holding `scene` (of the mesh keyed `mesh`): its
    /// share of the frame measured, or its camera moved to the last target's share. Returns
    /// the share its label gives (the frame's own, measured with the camera set), or None
    /// for a row that does neither.
    pub(super) fn prepare(
        &mut self,
        case: &Case,
        mesh: &str,
        tracer: &mut ComputeTracer,
        scene: &mut Scene,
    ) -> anyhow::Result<Option<f64>> {
        let s = case.spec.settings;
        match case.coverage {
            Coverage::Unmeasured => return Ok(None),
            Coverage::Measured => {}
            Coverage::Target => {
                let share = coverage(tracer, scene, s)?;
                self.target = Some((mesh.to_string(), share));
                return Ok(Some(share));
            }
            Coverage::Matched => {
                let goal = self.target.as_ref().filter(|t| t.0 == mesh).map(|t| t.1);
                let goal = goal.ok_or_else(|| {
                    anyhow::anyhow!("a matched row needs a target row of its mesh before it")
                })?;
                let key = format!("{mesh}:{goal}");
                if self.matched.as_ref().is_none_or(|m| m.0 != key) {
                    self.matched = Some((key, camera_at_coverage(tracer, scene, s, goal)?));
                }
                scene.camera = self.matched.as_ref().unwrap().1;
            }
        }
        Ok(Some(coverage(tracer, scene, s)?))
    }
}

/// After a run with field rows: per knot and tracer, each field's frame over the one
/// copy's at the same coverage (the bar: at most 2).
pub fn summary(rows: &[Row]) -> Vec<String> {
    let per_copy = |r: &Row| r.workload.triangles / u64::from(r.workload.models.max(1));
    let tracer = |r: &Row| (per_copy(r), r.workload.accel, r.workload.bvh, r.vendor_kernel.clone());
    let mut lines = Vec::new();
    for one in rows.iter().filter(|r| r.series == "field" && r.workload.models == 1) {
        let Some(one_ms) = one.gpu_ms.map(|t| t.median) else { continue };
        let fields = rows
            .iter()
            .filter(|r| r.series == "field" && r.workload.models > 1 && tracer(r) == tracer(one));
        for field in fields {
            let Some(ms) = field.gpu_ms.map(|t| t.median) else { continue };
            let who = match (one.workload.accel, &one.vendor_kernel) {
                (Accel::Vendor, Some(kernel)) => format!("vendor ({kernel})"),
                (Accel::Vendor, None) => "vendor".to_string(),
                (accel, _) => format!("{accel} ({})", one.workload.bvh),
            };
            lines.push(format!(
                "{who}, {}: {} copies ({}) {ms:.3} ms = {:.2}x one copy ({}) {one_ms:.3} ms",
                one.workload.model,
                field.workload.models,
                field.features,
                ms / one_ms,
                one.features,
            ));
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A field-series row of `copies` copies of a `per_copy`-triangle knot, traced by `accel`
    /// (and `kernel`) in `ms`.
    fn row(copies: u32, per_copy: u64, accel: &str, kernel: Option<&str>, ms: f64) -> Row {
        let json = serde_json::json!({
            "series": "field", "model": format!("torusknot-{per_copy}"), "models": copies,
            "triangles": per_copy * u64::from(copies), "width": 64, "height": 64, "bounces": 0,
            "accel": accel, "bvh": "wide", "features": format!("{copies} copies"),
            "rays_per_frame": 4096,
            "gpu_ms": {"min": ms, "mean": ms, "max": ms, "median": ms, "p10": ms, "p90": ms},
            "wall_ms": {"min": ms, "mean": ms, "max": ms, "median": ms, "p10": ms, "p90": ms},
            "mrays_per_s": 1.0, "fps": 1.0, "bvh_build_ms": 1.0, "scene_bytes": 1,
            "paper_fps": null, "paper_ms": null, "skipped": null, "vendor_kernel": kernel,
        });
        serde_json::from_value(json).unwrap()
    }

    #[test]
    fn each_field_is_set_against_the_one_copy_of_its_knot_and_tracer() {
        let rows = [
            row(10_000, 1000, "bvh", None, 3.0),
            row(10_000, 1000, "vendor", Some("query"), 8.0),
            row(1, 1000, "bvh", None, 1.5),
            row(1, 1000, "vendor", Some("query"), 2.0),
            row(10_000, 1000, "bvh", None, 4.5),
            // Another knot's one copy is not this field's.
            row(1, 2000, "bvh", None, 100.0),
        ];
        let lines = summary(&rows);
        assert_eq!(lines.len(), 3, "{lines:#?}");
        assert!(lines[0].starts_with("bvh (wide), torusknot-1000:"), "{}", lines[0]);
        assert!(lines[0].contains("3.000 ms = 2.00x one copy"), "{}", lines[0]);
        assert!(lines[1].contains("4.500 ms = 3.00x one copy"), "{}", lines[1]);
        assert!(
            lines[2].starts_with("vendor (query)") && lines[2].contains("= 4.00x"),
            "{}",
            lines[2]
        );
        // Without its one copy, a field has no ratio.
        assert!(summary(&rows[..2]).is_empty());
    }
}
