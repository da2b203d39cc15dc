//! `meshtracer bench` end to end: the real binary runs the paper's tables at a tiny size on
//! the Vulkan device (lavapipe in CI) with the validation layer on, and its JSON, CSV and
//! PNG charts are checked. No timing is asserted beyond "positive".
//! Also: `--charts-from` redraws the charts of the committed H100 reports without a GPU.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

const CHARTS: [&str; 3] = ["chart_triangles.png", "chart_resolution.png", "chart_models.png"];

/// A fresh, empty scratch folder for this test.
fn scratch(tag: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("meshtracer-bench-cli-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn meshtracer(args: &[&str], validation: bool) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshtracer"));
    cmd.args(args).env("RUST_BACKTRACE", "1");
    if validation {
        cmd.env("MESHTRACER_VALIDATION", "1");
    } else {
        cmd.env_remove("MESHTRACER_VALIDATION");
    }
    cmd.output().expect("the binary runs")
}

fn assert_success(out: &Output, what: &str) {
    assert!(
        out.status.success(),
        "{what}: exit status {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The chart decodes as a PNG of a sensible size with real content: many non-white pixels
/// and many colours (axes, text, coloured series), not a blank or a flat image.
fn check_chart(path: &Path) {
    assert!(path.is_file(), "{} was not written", path.display());
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{} does not decode: {e}", path.display()))
        .to_rgb8();
    let (w, h) = img.dimensions();
    assert!(w >= 800 && h >= 500, "{}: {w}x{h}", path.display());
    let pixels = img.pixels().count();
    let inked = img.pixels().filter(|p| p.0.iter().any(|&c| c < 200)).count();
    assert!(
        inked * 100 > pixels,
        "{}: only {inked} of {pixels} pixels are not white",
        path.display()
    );
    assert!(
        inked * 2 < pixels,
        "{}: {inked} of {pixels} pixels are inked, not a chart",
        path.display()
    );
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 50, "{}: only {} colours", path.display(), colours.len());
    // Coloured series are drawn (saturated pixels: the blues and reds of the lines).
    let saturated = img.pixels().filter(|p| {
        let (max, min) = (*p.0.iter().max().unwrap() as i32, *p.0.iter().min().unwrap() as i32);
        max - min > 100
    });
    assert!(saturated.count() > 200, "{}: no coloured series", path.display());
}

#[test]
fn paper_tables_tiny_with_json_csv_and_charts() {
    let dir = scratch("paper");
    let json = dir.join("bench.json");
    let csv = dir.join("bench.csv");
    let charts = dir.join("charts");
    let args = [
        "bench",
        "--paper",
        "--resolutions",
        "32",
        "--frames",
        "2",
        "--warmup",
        "1",
        "--accel",
        "brute,bvh",
        "--json",
        json.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
        "--charts",
        charts.to_str().unwrap(),
    ];
    let out = meshtracer(&args, true);
    assert_success(&out, "bench --paper");

    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("JSON written"))
            .expect("valid JSON");
    assert_eq!(report["frames"], 2);
    assert_eq!(report["warmup"], 1);
    let env = &report["environment"];
    for key in ["device", "driver", "vulkan", "date"] {
        assert!(
            env[key].as_str().is_some_and(|s| !s.is_empty()),
            "environment.{key} missing: {env}"
        );
    }
    let rows = report["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), 16, "4 models + 4 copy counts, for each of 2 accelerations");

    let mut seen = Vec::new();
    for r in rows {
        let series = r["series"].as_str().unwrap();
        let model = r["model"].as_str().unwrap().to_string();
        let models = r["models"].as_u64().unwrap();
        let accel = r["accel"].as_str().unwrap().to_string();
        assert!(r["skipped"].is_null(), "row skipped: {r}");
        assert_eq!(r["width"], 32, "{r}");
        assert_eq!(r["height"], 32, "{r}");
        assert_eq!(r["bounces"], 2, "{r}");
        assert!(accel == "brute" || accel == "bvh", "{r}");
        assert!(r["triangles"].as_u64().unwrap() > 12, "{r}");
        assert_eq!(r["rays_per_frame"], 32 * 32 * 3, "{r}");
        // The paper's figures belong to 512² and 1024² rows only.
        assert!(
            r["paper_fps"].is_null() && r["paper_ms"].is_null(),
            "paper figures on a 32x32 row: {r}"
        );
        let wall = r["wall_ms"]["median"].as_f64().unwrap();
        assert!(wall > 0.0, "{r}");
        let gpu = &r["gpu_ms"];
        assert!(!gpu.is_null(), "no GPU timestamps: {r}");
        for q in ["median", "p10", "p90"] {
            assert!(gpu[q].as_f64().unwrap() > 0.0, "{r}");
        }
        assert!(gpu["p10"].as_f64() <= gpu["p90"].as_f64(), "{r}");
        assert!(
            r["mrays_per_s"].as_f64().unwrap() > 0.0 && r["fps"].as_f64().unwrap() > 0.0,
            "{r}"
        );
        // lavapipe, like NVIDIA's driver, has the shader clock the clock guard reads.
        assert!(
            r["gpu_clock_mhz"].as_f64().is_some_and(|mhz| mhz > 0.0),
            "no shader clock reading: {r}"
        );
        match series {
            "table1" => assert_eq!(models, 1, "{r}"),
            "table2" => assert_eq!(model, "geosphere", "{r}"),
            other => panic!("unexpected series {other}"),
        }
        seen.push((series.to_string(), model, models, accel));
    }
    for accel in ["brute", "bvh"] {
        for model in ["geosphere", "torusknot", "sphere", "cylinder"] {
            assert!(
                seen.contains(&("table1".into(), model.into(), 1, accel.into())),
                "table1 {model} {accel} missing"
            );
        }
        for n in 1..=4 {
            assert!(
                seen.contains(&("table2".into(), "geosphere".into(), n, accel.into())),
                "table2 x{n} {accel} missing"
            );
        }
    }

    let csv_text = std::fs::read_to_string(&csv).expect("CSV written");
    let lines: Vec<&str> = csv_text.lines().collect();
    assert_eq!(lines.len(), 17, "header + 16 rows");
    assert!(lines[0].starts_with("series,model,models,triangles,width,height,bounces,accel"));
    for l in &lines[1..] {
        assert!(l.starts_with("table1,") || l.starts_with("table2,"), "{l}");
        assert!(l.contains(",32,32,2,"), "{l}");
    }

    for name in CHARTS {
        check_chart(&charts.join(name));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn charts_from_the_committed_h100_reports() {
    let results = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/results");
    let dir = scratch("from");
    let files: Vec<String> =
        ["scaling.json", "scaling_brute.json", "paper.json", "primary.json", "features.json"]
            .iter()
            .map(|f| results.join(f).to_str().unwrap().to_string())
            .collect();
    let mut args = vec!["bench", "--charts-from"];
    args.extend(files.iter().map(String::as_str));
    args.extend(["--charts", dir.to_str().unwrap()]);
    let out = meshtracer(&args, false);
    assert_success(&out, "bench --charts-from");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("NVIDIA H100"), "{stdout}");
    for name in CHARTS {
        check_chart(&dir.join(name));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn charts_from_needs_a_folder_and_a_report() {
    let out = meshtracer(&["bench", "--charts-from", "nothing.json"], false);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--charts"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let dir = scratch("bad");
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "{\"rows\": 3}").unwrap();
    let out = meshtracer(
        &["bench", "--charts-from", bad.to_str().unwrap(), "--charts", dir.to_str().unwrap()],
        false,
    );
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("bad.json") && !stderr.contains("panicked"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn framed_series_fills_the_frame_with_the_model() {
    // The default camera sees the knot in a small part of the frame; the framed series moves
    // in until the model covers most of it, and says how much.
    let dir = scratch("framed");
    let json = dir.join("framed.json");
    let out = meshtracer(
        &[
            "bench",
            "--framed",
            "--triangles",
            "2000",
            "--size",
            "32",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--json",
            json.to_str().unwrap(),
        ],
        true,
    );
    assert_success(&out, "bench --framed");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = report["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1);
    let row = &rows[0];
    assert_eq!(row["series"], "framed");
    assert_eq!(row["bounces"], 0);
    let label = row["features"].as_str().unwrap();
    let percent: f64 = label
        .trim_start_matches("framed, ")
        .trim_end_matches("% model")
        .parse()
        .unwrap_or_else(|_| panic!("label {label:?}"));
    assert!((40.0..=100.0).contains(&percent), "the model should cover most of the frame: {label}");
    assert!(
        row["gpu_ms"]["median"].as_f64().is_some_and(|ms| ms > 0.0)
            || row["wall_ms"]["median"].as_f64().is_some_and(|ms| ms > 0.0)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The share of the frame in a row's label ("..., 61% model"), in percent.
fn coverage_percent(row: &Value) -> f64 {
    let label = row["features"].as_str().unwrap();
    let tail = label.rsplit(", ").next().unwrap();
    tail.trim_end_matches("% model").parse().unwrap_or_else(|_| panic!("label {label:?}"))
}

#[test]
fn fields_trace_one_copy_at_the_fields_coverage() {
    // `bench --fields`: 10,000 copies as the window frames them, one copy with its camera
    // moved until it covers the same share of the frame, the turned field; and the ratios.
    let dir = scratch("fields");
    let json = dir.join("fields.json");
    let args = ["bench", "--fields", "--triangles", "600", "--size", "48", "--frames", "1"];
    let out = meshtracer(
        &[&args[..], &["--warmup", "0", "--json", json.to_str().unwrap()]].concat(),
        true,
    );
    assert_success(&out, "bench --fields");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = report["rows"].as_array().unwrap();
    let copies: Vec<u64> = rows.iter().map(|r| r["models"].as_u64().unwrap()).collect();
    assert_eq!(copies, [10_000, 1, 10_000]);
    assert!(rows.iter().all(|r| r["series"] == "field" && r["bounces"] == 0), "{rows:?}");
    let (field, one, turned) =
        (coverage_percent(&rows[0]), coverage_percent(&rows[1]), coverage_percent(&rows[2]));
    // The window's view of the field leaves a margin around it; the one copy's camera is
    // found to within a percent or two of the field's share (a pixel is 0.04% here).
    assert!((20.0..=95.0).contains(&field), "the field framed with a margin: {field}%");
    assert!((field - one).abs() <= 2.0, "one copy at {one}% against the field's {field}%");
    assert!(turned > 0.0);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let ratios: Vec<&str> = stdout.lines().filter(|l| l.contains("x one copy")).collect();
    assert_eq!(ratios.len(), 2, "a ratio for each field:\n{stdout}");
    for line in ratios {
        let ratio: f64 = line
            .split(" = ")
            .nth(1)
            .and_then(|r| r.split('x').next())
            .and_then(|r| r.parse().ok())
            .unwrap_or_else(|| panic!("{line}"));
        assert!(ratio > 0.0, "{line}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn load_measures_every_phase_of_a_file_and_a_generated_model() {
    // `bench --load`: a file (read, parse, build, pack, upload) and a generated knot (no
    // read), each to its first frame, as a table, JSON and CSV.
    let dir = scratch("load");
    let obj = dir.join("quad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    let ply = dir.join("tri.ply");
    std::fs::write(&ply, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
    let (json, csv) = (dir.join("load.json"), dir.join("load.csv"));
    let out = meshtracer(
        &[
            "bench",
            "--load",
            obj.to_str().unwrap(),
            "torusknot:2000",
            ply.to_str().unwrap(),
            "--size",
            "32",
            "--json",
            json.to_str().unwrap(),
            "--csv",
            csv.to_str().unwrap(),
        ],
        true,
    );
    assert_success(&out, "bench --load");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("read s") && stdout.contains("to frame s"), "{stdout}");
    let report: Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let rows = report["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0]["triangles"], 2, "a quad is two triangles");
    assert_eq!(rows[2]["triangles"], 1);
    assert!(
        rows[2]["phase_s"][0].as_f64().unwrap() > 0.0,
        "a PLY is read, then parsed: {}",
        rows[2]
    );
    assert_eq!(rows[0]["file_bytes"], std::fs::metadata(&obj).unwrap().len());
    for row in rows {
        let phases: Vec<f64> =
            row["phase_s"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert_eq!(phases.len(), 5);
        assert!(phases.iter().all(|&s| s >= 0.0));
        let total = row["to_first_frame_s"].as_f64().unwrap();
        assert!(total >= phases.iter().sum::<f64>(), "the wait includes every phase: {row}");
    }
    // The tree's quality as tinybvh measures it: the quad's two triangles are one leaf
    // under the root, whose box is the leaf's: 1 for the root, 2 triangles over all its area.
    assert_eq!((rows[0]["sah_cost"].as_f64(), rows[0]["bvh_nodes"].as_u64()), (Some(3.0), Some(2)));
    for row in rows {
        assert!(row["sah_cost"].as_f64().is_some_and(|c| c >= 1.0), "{row}");
        assert!(row["bvh_nodes"].as_u64().is_some_and(|n| n >= 2), "{row}");
    }
    assert!(stdout.contains("SAH") && stdout.contains("nodes"), "{stdout}");
    assert_eq!(rows[1]["phase_s"][0], 0.0, "a generated model reads no file");
    assert!(rows[1]["triangles"].as_u64().unwrap() >= 2000);
    let csv_text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(csv_text.lines().count(), 4, "{csv_text}");

    let missing = meshtracer(&["bench", "--load", "/nonexistent/model.ply", "--size", "32"], false);
    assert!(!missing.status.success());
    let stderr = String::from_utf8_lossy(&missing.stderr);
    assert!(stderr.contains("model.ply") && !stderr.contains("panicked"), "{stderr}");
}

#[test]
fn a_knot_too_big_for_the_device_is_refused_before_its_build() {
    let (limit, triangles) = common::storage_limit_and_a_knot_past_it();
    let triangles = triangles.to_string();
    let args = ["bench", "--framed", "--triangles", &triangles, "--size", "8", "--frames", "1"];
    common::assert_refused_before_build(&meshtracer(&args, false), limit);
}
