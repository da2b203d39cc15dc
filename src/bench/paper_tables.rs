//! The paper's Table 1 and Table 2 (GTX 1080 Ti, brute force, 2 bounces) and the case
//! lists that re-measure them, plus the scaling series.

use std::sync::Arc;

use super::Case;
use crate::render_settings::{Accel, Aov, RenderSettings};
use crate::scene::paper::ModelSource;
use crate::scene::primitives::{large_torus_knot, PaperModel};
use crate::scene::EnvironmentSource;

/// Table 1: (model, [(fps, ms) at 512x512, (fps, ms) at 1024x1024]).
pub const TABLE1: [(PaperModel, [(f64, f64); 2]); 4] = [
    (PaperModel::Geosphere, [(250.0, 4.52), (72.0, 14.58)]),
    (PaperModel::TorusKnot, [(50.0, 20.91), (14.0, 77.42)]),
    (PaperModel::Sphere, [(27.0, 38.96), (8.0, 143.36)]),
    (PaperModel::Cylinder, [(22.0, 48.12), (6.0, 200.5)]),
];

/// Table 2: geosphere copies -> [(fps, ms) at 512x512, at 1024x1024].
pub const TABLE2: [(u32, [(f64, f64); 2]); 4] = [
    (1, [(250.0, 4.52), (72.0, 14.58)]),
    (2, [(140.0, 7.69), (40.0, 26.14)]),
    (3, [(98.0, 10.81), (27.0, 38.96)]),
    (4, [(76.0, 13.83), (21.0, 50.5)]),
];

pub(super) fn settings(size: u32, bounces: u32, accel: Accel) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        bounces,
        blend: 0.5,
        accel,
        aov: Aov::Color,
        ..RenderSettings::default()
    }
}

/// Both tables at the given resolutions (the paper's: 512, 1024) for each acceleration.
pub fn paper_cases(resolutions: &[u32], accels: &[Accel]) -> Vec<Case> {
    let mut cases = Vec::new();
    for &accel in accels {
        for (model, figures) in TABLE1 {
            for &size in resolutions {
                let paper = match size {
                    512 => Some(figures[0]),
                    1024 => Some(figures[1]),
                    _ => None,
                };
                cases.push(Case {
                    paper,
                    ..Case::new("table1", ModelSource::Paper(model), 1, settings(size, 2, accel))
                });
            }
        }
        for (count, figures) in TABLE2 {
            for &size in resolutions {
                let paper = match size {
                    512 => Some(figures[0]),
                    1024 => Some(figures[1]),
                    _ => None,
                };
                cases.push(Case {
                    paper,
                    ..Case::new(
                        "table2",
                        ModelSource::Paper(PaperModel::Geosphere),
                        count,
                        settings(size, 2, accel),
                    )
                });
            }
        }
    }
    cases
}

/// Frame time against triangle count (generated torus knots), resolution, bounces and
/// model count; `extra` .obj files join the triangle series.
pub fn scaling_cases(
    triangle_counts: &[usize],
    extra: &[ModelSource],
    accels: &[Accel],
    size: u32,
    bounces: u32,
) -> Vec<Case> {
    let mut cases = Vec::new();
    for &n in triangle_counts {
        let mesh = Arc::new(large_torus_knot(n));
        for &accel in accels {
            cases.push(Case {
                generated: Some(mesh.clone()),
                ..Case::new("triangles", ModelSource::default(), 1, settings(size, bounces, accel))
            });
        }
    }
    for source in extra {
        for &accel in accels {
            cases.push(Case::new("triangles", source.clone(), 1, settings(size, bounces, accel)));
        }
    }
    for &accel in accels {
        for res in [256, 512, 1024, 2048] {
            cases.push(Case::new(
                "resolution",
                ModelSource::Paper(PaperModel::Cylinder),
                1,
                settings(res, 2, accel),
            ));
        }
        for b in 0..=8 {
            cases.push(Case::new(
                "bounces",
                ModelSource::Paper(PaperModel::Cylinder),
                1,
                settings(size, b, accel),
            ));
        }
        // The paper's counts inside the box, then the field (not for brute force: 10,000
        // copies are 800,000 tests a ray).
        let field: &[u32] = if accel == Accel::Brute { &[] } else { &[100, 1000, 10_000] };
        for &m in [1, 2, 4, 7, 14, 27].iter().chain(field) {
            cases.push(Case::new(
                "models",
                ModelSource::Paper(PaperModel::Geosphere),
                m,
                settings(size, 2, accel),
            ));
        }
    }
    cases
}

/// Primary rays only with the camera moved in until the model fills the frame, as in the
/// vendor's figure (a 4M-triangle mesh filling 1024x1024): every ray meets the mesh's BVH.
pub fn framed_cases(
    triangle_counts: &[usize],
    extra: &[ModelSource],
    accels: &[Accel],
    size: u32,
) -> Vec<Case> {
    let mut cases = Vec::new();
    for &n in triangle_counts {
        let mesh = Arc::new(large_torus_knot(n));
        for &accel in accels {
            cases.push(
                Case {
                    generated: Some(mesh.clone()),
                    ..Case::new("framed", ModelSource::default(), 1, settings(size, 0, accel))
                }
                .framed(),
            );
        }
    }
    for source in extra {
        for &accel in accels {
            cases.push(Case::new("framed", source.clone(), 1, settings(size, 0, accel)).framed());
        }
    }
    cases
}

/// The AO view on the framed series' scenes (`bench --ao`): per pixel one primary ray and
/// `samples` occlusion rays of length `radius`, any-hit queries (ours with early exit, the
/// vendor's terminating on the first hit), so `--compare` times our AO against the
/// vendor's on the rays the issue had not measured: incoherent ones.
pub fn ao_cases(
    triangle_counts: &[usize],
    extra: &[ModelSource],
    accels: &[Accel],
    size: u32,
    samples: u32,
    radius: f32,
) -> Vec<Case> {
    framed_cases(triangle_counts, extra, accels, size)
        .into_iter()
        .map(|mut case| {
            case.series = "ao".into();
            case.features = format!("ao {samples} rays, r {radius}");
            case.spec.settings = RenderSettings {
                aov: Aov::Ao,
                ao_samples: samples,
                ao_radius: radius,
                ..case.spec.settings
            };
            case
        })
        .collect()
}

/// The cost of each shading feature at `size`, on the BVH: the paper's flat shading as the
/// baseline, then smooth shading, the environment map, 4 jittered samples, adaptive 4
/// samples, and textures (on `textured`, e.g. Sponza, when given).
pub fn feature_cases(size: u32, model: ModelSource, textured: Option<ModelSource>) -> Vec<Case> {
    let base = RenderSettings { textures: false, ..settings(size, 2, Accel::Bvh) };
    let variants: [(&str, RenderSettings, bool); 6] = [
        ("flat (paper)", base, false),
        ("smooth", RenderSettings { smooth: true, ..base }, false),
        ("env sky", base, true),
        ("spp 4", RenderSettings { spp: 4, ..base }, false),
        ("adaptive 4", RenderSettings { spp: 4, adaptive: true, ..base }, false),
        ("all", RenderSettings { smooth: true, spp: 4, adaptive: true, ..base }, true),
    ];
    let mut cases: Vec<Case> = variants
        .iter()
        .map(|(label, s, env)| {
            Case { features: label.to_string(), ..Case::new("features", model.clone(), 1, *s) }
                .with_environment(env.then_some(EnvironmentSource::Sky))
        })
        .collect();
    if let Some(t) = textured {
        cases.push(Case {
            features: "untextured".into(),
            ..Case::new("features", t.clone(), 1, base)
        });
        cases.push(Case {
            features: "textures".into(),
            ..Case::new("features", t, 1, RenderSettings { textures: true, ..base })
        });
    }
    cases
}
