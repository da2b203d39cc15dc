//! `meshtracer render` as a user runs it: the preset every PNG carries, `--preset` (a PNG
//! or a TOML file, also for `view` and `bench`) with flags over it, its errors and
//! warnings, and the output formats (PNG, JPEG, EXR with depth as channel Z).

mod common;

use std::path::Path;
use std::process::Command;

use common::Scratch;

use meshtracer::cli::{Cli, Command as Cmd};
use meshtracer::files::image_files::png_settings;
use meshtracer::scene::preset;
use meshtracer::scene::spec::SceneSpec;

/// `meshtracer render ARGS` in `dir` under the validation layer; panics unless it succeeds.
fn render(dir: &Path, args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_meshtracer"))
        .current_dir(dir)
        .env("MESHTRACER_VALIDATION", "1")
        .arg("render")
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "render {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn settings_of(path: &Path) -> String {
    png_settings(&std::fs::read(path).unwrap())
        .unwrap()
        .unwrap_or_else(|| panic!("{} has no settings chunk", path.display()))
}

const SCENE: [&str; 16] = [
    "--width",
    "96",
    "--height",
    "64",
    "--bounces",
    "3",
    "--smooth",
    "--light-angle",
    "150",
    "--models",
    "2",
    "--eye",
    "1,2,5",
    "--fov",
    "50",
    "--adaptive",
];

#[test]
fn a_png_carries_its_preset_and_preset_renders_it_again() {
    let dir = Scratch::new("preset");
    render(&dir.0, &[&SCENE[..], &["--spp", "4", "-o", "first.png"]].concat());
    let text = settings_of(&dir.join("first.png"));
    let (spec, unknown) = preset::from_text(&text).unwrap();
    assert!(unknown.is_empty());
    assert_eq!(
        (spec.settings.width, spec.settings.height, spec.settings.bounces, spec.models),
        (96, 64, 3, 2)
    );
    assert!(spec.settings.smooth && spec.settings.adaptive && spec.settings.spp == 4);
    assert_eq!(spec.light.angle_deg, 150.0);
    assert_eq!(spec.camera.eye, Some(glam::Vec3::new(1.0, 2.0, 5.0)));
    assert_eq!(spec.camera.fov, Some(50.0));
    // Exactly the preset text: a PNG is a preset.
    assert_eq!(text, spec.to_preset_text());
    for table in
        ["version = 1", "[model]", "[image]", "[tracing]", "[shading]", "[light]", "[camera]"]
    {
        assert!(text.lines().any(|l| l == table), "no {table} in:\n{text}");
    }

    // The same image again from the PNG alone, preset chunk included.
    render(&dir.0, &["--preset", "first.png", "-o", "again.png"]);
    let (a, b) = (
        image::open(dir.join("first.png")).unwrap().to_rgba8(),
        image::open(dir.join("again.png")).unwrap().to_rgba8(),
    );
    assert_eq!(a.dimensions(), (96, 64));
    assert!(a == b, "`render --preset first.png` made another image");
    assert_eq!(settings_of(&dir.join("again.png")), text);

    // Flags beside the preset override it; the rest stays.
    render(&dir.0, &["--preset", "first.png", "--bounces", "0", "-o", "flat.png"]);
    let (changed, _) = preset::from_text(&settings_of(&dir.join("flat.png"))).unwrap();
    assert_eq!(changed.settings.bounces, 0);
    assert_eq!(
        SceneSpec {
            settings: meshtracer::render_settings::RenderSettings {
                bounces: 3,
                ..changed.settings
            },
            ..changed
        },
        spec
    );
    assert!(
        image::open(dir.join("flat.png")).unwrap().to_rgba8() != a,
        "--bounces 0 over the preset changed nothing"
    );

    // The text as a preset file is the same preset.
    std::fs::write(dir.join("look.toml"), &text).unwrap();
    render(&dir.0, &["--preset", "look.toml", "-o", "from_file.png"]);
    assert!(
        image::open(dir.join("from_file.png")).unwrap().to_rgba8() == a,
        "the preset file made another image"
    );
}

/// `meshtracer ARGS` in `dir` (no validation layer: these runs fail before any GPU work).
fn run_in(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_meshtracer")).current_dir(dir).args(args).output().unwrap()
}

#[test]
fn a_saved_preset_renders_like_the_same_flags() {
    let dir = Scratch::new("saved");
    let flags: Vec<&str> =
        [&SCENE[..], &["--env", "sky", "--no-box", "--blend", "0.25", "--accel", "brute"]].concat();
    // The spec these flags make, saved the way the panel saves it.
    let cli = Cli::try_parse_from_noting_flags(
        [&["meshtracer", "render"][..], &flags, &["-o", "x.png"]].concat(),
    )
    .unwrap();
    let Some(Cmd::Render(args)) = cli.command else { panic!("not a render command") };
    let (spec, _) = args.spec().unwrap();
    preset::save(&spec, &dir.join("look.toml"), false).unwrap();
    render(&dir.0, &[&flags[..], &["-o", "flags.png"]].concat());
    render(&dir.0, &["--preset", "look.toml", "-o", "preset.png"]);
    let (a, b) = (
        image::open(dir.join("flags.png")).unwrap().to_rgba8(),
        image::open(dir.join("preset.png")).unwrap().to_rgba8(),
    );
    assert!(a == b, "the saved preset renders another image than its flags");
}

#[test]
fn a_bad_preset_is_one_line_naming_file_key_and_line() {
    let dir = Scratch::new("bad");
    std::fs::write(dir.join("bad.toml"), "version = 1\n\n[tracing]\nbounces = 12\n").unwrap();
    for command in ["render", "view", "bench"] {
        let mut args = vec![command, "--preset", "bad.toml"];
        if command == "render" {
            args.extend(["-o", "x.png"]);
        }
        let out = run_in(&dir.0, &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.code().is_some_and(|c| c != 0 && c != 101),
            "{command}: {:?}: {stderr}",
            out.status
        );
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(
            lines,
            ["error: preset bad.toml: line 4, key 'tracing.bounces': 12 is out of range (0..=8)"],
            "{command}"
        );
    }
    // A preset that is not TOML at all, and one that is missing.
    std::fs::write(dir.join("broken.toml"), "[image\nwidth = 5\n").unwrap();
    let out = run_in(&dir.0, &["render", "--preset", "broken.toml", "-o", "x.png"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: preset broken.toml: line 1"), "{stderr}");
    let out = run_in(&dir.0, &["render", "--preset", "missing.toml", "-o", "x.png"]);
    assert!(String::from_utf8_lossy(&out.stderr)
        .starts_with("error: cannot read the preset missing.toml: "));
}

#[test]
fn unknown_preset_keys_are_warned_about_and_ignored() {
    let dir = Scratch::new("unknown");
    std::fs::write(
        dir.join("typo.toml"),
        "version = 1\n[image]\nwidth = 32\nheight = 24\n[shading]\nsmoth = true\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_meshtracer"))
        .current_dir(&dir.0)
        .env("MESHTRACER_VALIDATION", "1")
        .args(["render", "--preset", "typo.toml", "-o", "x.png"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains(
            "warning: preset typo.toml: unknown key 'shading.smoth' on line 6 is ignored"
        ),
        "{stderr}"
    );
    let (spec, _) = preset::from_text(&settings_of(&dir.join("x.png"))).unwrap();
    assert_eq!((spec.settings.width, spec.settings.height, spec.settings.smooth), (32, 24, false));
}

/// `bench --preset <preset> <args> --json out.json` in `dir` under the validation layer:
/// the JSON report.
fn bench_preset(dir: &Scratch, preset: &str, args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_meshtracer"))
        .current_dir(&dir.0)
        .env("MESHTRACER_VALIDATION", "1")
        .args(["bench", "--preset", preset])
        .args(args)
        .args(["--json", "out.json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&std::fs::read(dir.join("out.json")).unwrap()).unwrap()
}

#[test]
fn bench_runs_a_preset_with_flags_over_it() {
    let dir = Scratch::new("bench");
    std::fs::write(dir.join("look.toml"), "version = 1\n[image]\nwidth = 48\nheight = 32\n[tracing]\nbounces = 1\n[shading]\nsmooth = true\n").unwrap();
    let args = ["--frames", "2", "--warmup", "1", "--accel", "bvh,brute", "--size", "40"];
    let json = bench_preset(&dir, "look.toml", &args);
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "one row per --accel given");
    for (row, accel) in rows.iter().zip(["bvh", "brute"]) {
        assert_eq!(row["series"], "preset");
        assert_eq!(row["accel"], accel);
        assert_eq!(
            (row["width"].as_u64(), row["height"].as_u64(), row["bounces"].as_u64()),
            (Some(40), Some(40), Some(1)),
            "{row}"
        );
    }
}

#[test]
fn bench_times_a_preset_in_the_ao_view_as_ao_and_other_views_as_colour() {
    let dir = Scratch::new("bench-ao");
    let image = |aov: &str| format!("version = 1\n[image]\naov = \"{aov}\"\nao_samples = 3\n");
    std::fs::write(dir.join("ao.toml"), image("ao")).unwrap();
    std::fs::write(dir.join("depth.toml"), image("depth")).unwrap();
    let features = |preset: &str| {
        let json = bench_preset(&dir, preset, &["--frames", "1", "--warmup", "1", "--size", "32"]);
        json["rows"][0]["features"].as_str().unwrap().to_string()
    };
    let ao = features("ao.toml");
    assert!(ao.starts_with("ao 3 rays, r 0.25"), "{ao}");
    let depth = features("depth.toml");
    assert!(!depth.contains("ao"), "a depth preset is timed as colour: {depth}");
}

#[test]
fn jpeg_output_is_rgb_and_close_to_the_png() {
    let dir = Scratch::new("jpeg");
    render(&dir.0, &["--width", "64", "--height", "48", "-o", "out.png"]);
    render(&dir.0, &["--width", "64", "--height", "48", "-o", "out.jpg"]);
    render(&dir.0, &["--width", "64", "--height", "48", "-o", "out.JPEG"]);
    let jpeg = image::open(dir.join("out.jpg")).unwrap();
    assert_eq!(
        image::ImageFormat::from_path(dir.join("out.jpg")).unwrap(),
        image::ImageFormat::Jpeg
    );
    assert_eq!(jpeg.color(), image::ColorType::Rgb8, "JPEG has no alpha");
    assert_eq!((jpeg.width(), jpeg.height()), (64, 48));
    let png = image::open(dir.join("out.png")).unwrap().to_rgb8();
    let jpeg = jpeg.to_rgb8();
    let mean =
        png.as_raw().iter().zip(jpeg.as_raw()).map(|(a, b)| a.abs_diff(*b) as f64).sum::<f64>()
            / png.as_raw().len() as f64;
    assert!(mean < 6.0, "the JPEG differs from the PNG by {mean:.1} on average");
    assert!(image::open(dir.join("out.JPEG")).is_ok());
}

#[test]
fn depth_exr_is_one_channel_z_and_normals_stay_rgb() {
    use exr::prelude::*;
    let dir = Scratch::new("exr");
    render(&dir.0, &["--width", "40", "--height", "30", "--aov", "depth", "-o", "depth.exr"]);
    render(&dir.0, &["--width", "40", "--height", "30", "--aov", "normal", "-o", "normal.exr"]);
    let depth = read_all_flat_layers_from_file(dir.join("depth.exr")).unwrap();
    assert_eq!(depth.layer_data.len(), 1);
    let layer = &depth.layer_data[0];
    assert_eq!(layer.size, Vec2(40, 30));
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    assert_eq!(names, ["Z"], "the depth EXR's channels");
    let z: Vec<f32> = layer.channel_data.list[0].sample_data.values_as_f32().collect();
    assert_eq!(z.len(), 40 * 30);
    // The paper's scene from inside the mirror box: every primary ray hits, at a distance
    // between the model (about 3 away) and the far corners of the box.
    assert!(
        z.iter().all(|&d| d > 1.0 && d < 14.0),
        "depth out of the box: {:?}",
        z.iter().copied().fold((f32::MAX, f32::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)))
    );

    let normal = read_all_flat_layers_from_file(dir.join("normal.exr")).unwrap();
    let mut names: Vec<String> =
        normal.layer_data[0].channel_data.list.iter().map(|c| c.name.to_string()).collect();
    names.sort();
    assert_eq!(names, ["A", "B", "G", "R"], "the normal EXR's channels");
}

#[test]
fn other_extensions_get_one_line_listing_the_formats() {
    let dir = Scratch::new("bmp");
    for name in ["x.bmp", "x.tif", "noext"] {
        let out = Command::new(env!("CARGO_BIN_EXE_meshtracer"))
            .current_dir(&dir.0)
            .args(["render", "--width", "8", "--height", "8", "-o", name])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.code().is_some_and(|c| c != 0 && c != 101),
            "{name}: {:?}: {stderr}",
            out.status
        );
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{name}: expected one line, got:\n{stderr}");
        for needle in [name, ".png", ".jpg", ".exr"] {
            assert!(
                lines[0].contains(needle),
                "{name}: the line does not mention {needle}: {}",
                lines[0]
            );
        }
        assert!(!dir.join(name).exists(), "{name} was written anyway");
    }
}

#[test]
fn an_accumulated_image_carries_its_frame_count_and_renders_again() {
    let dir = Scratch::new("accumulate");
    render(&dir.0, &["--width", "48", "--height", "32", "--accumulate", "6", "-o", "acc.png"]);
    let text = settings_of(&dir.join("acc.png"));
    assert!(text.contains("accumulate = 6"), "{text}");
    assert_eq!(preset::from_text(&text).unwrap().0.accumulate, 6);
    // The preset alone traces the same six frames; the CPU reference averages the same jitter.
    render(&dir.0, &["--preset", "acc.png", "-o", "again.png"]);
    render(&dir.0, &["--preset", "acc.png", "--cpu", "-o", "cpu.png"]);
    render(&dir.0, &["--width", "48", "--height", "32", "-o", "one.png"]);
    let load = |n: &str| image::open(dir.join(n)).unwrap().to_rgba8();
    let (acc, again, cpu, one) =
        (load("acc.png"), load("again.png"), load("cpu.png"), load("one.png"));
    assert!(acc == again, "render --preset of an accumulated image traces another image");
    let off = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels()
            .zip(b.pixels())
            .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 2))
            .count()
    };
    assert!(
        off(&acc, &cpu) <= acc.len() / 4 / 100,
        "GPU vs CPU accumulation: {} pixels off",
        off(&acc, &cpu)
    );
    assert!(
        off(&acc, &one) > 0,
        "six jittered frames average to the one centred frame: the test proves nothing"
    );
}

#[test]
fn devices_name_their_driver_and_its_version() {
    // Two lavapipes (Mesa 22 and 25) have one device name: the driver tells them apart (#30).
    let out = Command::new(env!("CARGO_BIN_EXE_meshtracer")).arg("devices").output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && !stdout.trim().is_empty(), "{stdout}");
    for line in stdout.lines() {
        let driver = line.rsplit_once("; ").map(|(_, d)| d.trim_end_matches(')')).unwrap_or("");
        assert!(driver.chars().any(|c| c.is_ascii_digit()), "no driver version in {line:?}");
    }
}

/// Under a file-size limit (`ulimit -f 1`: 1 KiB), a write that outgrows it is one error
/// line and leaves neither the file nor its temporary: the system's SIGXFSZ, which used to
/// stop the program mid-write, is ignored.
#[test]
fn a_write_past_the_file_size_limit_is_one_line_and_leaves_nothing() {
    let dir = Scratch::new("fsize");
    for (name, aov) in
        [("x.png", "color"), ("x.jpg", "color"), ("x.exr", "color"), ("d.exr", "depth")]
    {
        let out = Command::new("bash")
            .current_dir(&dir.0)
            .args(["-c", "ulimit -f 1; exec \"$0\" \"$@\"", env!("CARGO_BIN_EXE_meshtracer")])
            .args(["render", "--cpu", "--width", "64", "--height", "64", "--aov", aov, "-o", name])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{name}: {:?}: {stderr}", out.status);
        assert_eq!(stderr.trim(), format!("error: cannot write {name}: file too large"), "{name}");
        assert!(dir.names().is_empty(), "{name}: left {:?}", dir.names());
    }
}

#[test]
fn a_model_too_big_for_the_device_is_refused_before_its_build() {
    // Issue #43: `torusknot:4M` on lavapipe (128 MiB of storage buffer) failed only after a
    // 10 s build and 1 GB.
    let (limit, triangles) = common::storage_limit_and_a_knot_past_it();
    let dir = Scratch::new("too-big");
    let model = format!("torusknot:{triangles}");
    let args = ["render", "--model", &model, "--width", "8", "--height", "8", "-o", "x.png"];
    let out = run_in(&dir.0, &args);
    common::assert_refused_before_build(&out, limit);
    assert!(!dir.0.join("x.png").exists(), "nothing written");
}

/// Scenes of several different models: a preset lists them with their transforms.
const SEVERAL_MODELS: &str = r#"
[image]
width = 96
height = 64

[model]
source = "geosphere"
copies = 2

[[object]]
model = "tetra.obj"
translate = [-2.0, -1.0, 0.5]
rotate = [0, 30, 10]
scale = [1.5, 0.6, -1.0]

[[object]]
model = "torusknot:2k"
translate = [0.5, 1.8, -1.5]
rotate = [90, 0, 0]
scale = 0.7

[[object]]
model = "tetra.obj"
translate = [1.0, -2.0, 2.0]
"#;

const TETRAHEDRON: &str =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

#[test]
fn a_preset_of_several_models_round_trips_through_toml_and_png() {
    let dir = Scratch::new("several");
    std::fs::write(dir.join("tetra.obj"), TETRAHEDRON).unwrap();
    std::fs::write(dir.join("scene.toml"), SEVERAL_MODELS).unwrap();
    render(&dir.0, &["--preset", "scene.toml", "-o", "first.png"]);
    // The PNG carries the objects, and reads back as the preset file's scene.
    let (carried, _) = preset::from_text(&settings_of(&dir.join("first.png"))).unwrap();
    let (written, _) = preset::from_text(SEVERAL_MODELS).unwrap();
    assert_eq!(carried.objects.len(), 3);
    for (c, w) in carried.objects.iter().zip(&written.objects) {
        assert_eq!(c.placement, w.placement);
        assert_eq!(c.model.label(), w.model.label());
    }
    // The same image from the PNG alone, and from the CPU reference within its tolerance.
    render(&dir.0, &["--preset", "first.png", "-o", "again.png"]);
    render(&dir.0, &["--preset", "first.png", "--cpu", "-o", "cpu.png"]);
    let load = |n: &str| image::open(dir.join(n)).unwrap().to_rgba8();
    let (first, again, cpu) = (load("first.png"), load("again.png"), load("cpu.png"));
    assert!(first == again, "render --preset of the PNG traced another scene");
    let off = first
        .pixels()
        .zip(cpu.pixels())
        .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 2))
        .count();
    assert!(off <= first.len() / 4 / 100, "GPU vs CPU: {off} pixels off");
    // The objects are in the picture: without them it is another image.
    render(&dir.0, &["--width", "96", "--height", "64", "--models", "2", "-o", "alone.png"]);
    let alone = load("alone.png");
    let changed = first.pixels().zip(alone.pixels()).filter(|(p, q)| p != q).count();
    assert!(changed > first.len() / 4 / 20, "the objects changed only {changed} pixels");
}

/// The device opens beside the model's load (`render` overlaps the driver's start-up with
/// the parse): a device that cannot be opened is still the one error reported, in one
/// line, whether the model loads or not, and nothing is written.
#[test]
fn a_device_that_cannot_open_is_the_one_error_whatever_the_model() {
    let dir = Scratch::new("nodevice");
    for model in ["torusknot:2k", "missing.obj"] {
        let out = Command::new(env!("CARGO_BIN_EXE_meshtracer"))
            .current_dir(&dir.0)
            .args(["render", "--device", "99", "--model", model])
            .args(["--width", "8", "--height", "8", "-o", "x.png"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{model}: {stderr}");
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{model}: expected one line, got:\n{stderr}");
        assert!(lines[0].contains("device 99"), "{model}: {}", lines[0]);
        assert!(!dir.join("x.png").exists(), "{model}: x.png was written anyway");
    }
}
