//! The frame-time log and the remembered settings, run for real: the built binary in a
//! private Xvfb with the validation layer on, driven by real X input (xdotool).

mod app_support;

use std::path::Path;
use std::time::Duration;

use app_support::*;

const FLAGS: [&str; 8] =
    ["--width", "128", "--height", "128", "--bounces", "2", "--window", "640x480"];

fn rows(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    text.lines().map(|l| l.split(',').map(str::to_string).collect()).collect()
}

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

#[test]
fn stats_csv_has_a_row_per_frame() {
    let x = Xvfb::start();
    let dir = TempDir::new("stats-csv");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(FLAGS).args(["--frames", "5", "--stats-csv", "frames.csv"]);
    let out = spawn(cmd).wait(Duration::from_secs(180));
    assert_clean_exit(&out);
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("wrote 5 frames to frames.csv"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );

    let rows = rows(&dir.path().join("frames.csv"));
    let header = &rows[0];
    assert_eq!(header[0], "row");
    let frames: Vec<&Vec<String>> = rows[1..].iter().filter(|r| r[0] == "frame").collect();
    assert_eq!(frames.len(), 5, "{rows:?}");
    assert_eq!(rows.len(), 6, "no change rows in a run where nothing changes: {rows:?}");
    for (i, r) in frames.iter().enumerate() {
        assert_eq!(r.len(), header.len(), "{r:?}");
        assert_eq!(r[column(header, "frame")], i.to_string());
        assert_eq!(r[column(header, "resolution")], "128x128");
        assert_eq!(r[column(header, "bounces")], "2");
        // A scripted run traces the default layout (no timing of each): the wide tree.
        assert_eq!(r[column(header, "acceleration")], "wide");
        assert!(r[column(header, "triangles")].parse::<u64>().unwrap() > 0, "{r:?}");
        assert_eq!(r[column(header, "rays")], (128 * 128 * 3).to_string());
    }
    // A scripted run leaves no remembered settings.
    assert!(!dir.path().join("config").exists(), "a scripted run wrote the settings");
}

#[test]
fn the_window_times_each_bvh_layout_and_keeps_one() {
    // `--bvh auto`: binary frames until the wide tree is loaded, then each layout in turn
    // until every one has frames timed, then the fastest for the rest of the run.
    let x = Xvfb::start();
    let dir = TempDir::new("stats-auto");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(["--width", "48", "--height", "48", "--bounces", "1", "--window", "640x480"]);
    // How many binary frames come before the wide tree is loaded depends on how busy the
    // machine is (the tree is built beside the frames), so the run is long enough for a late
    // tree and the checks look at the order of the layouts, not at fixed frame numbers.
    let frames = 150;
    cmd.args(["--bvh", "auto", "--frames", &frames.to_string(), "--stats-csv", "frames.csv"]);
    let out = spawn(cmd).wait(Duration::from_secs(300));
    assert_clean_exit(&out);
    let rows = rows(&dir.path().join("frames.csv"));
    let at = column(&rows[0], "acceleration");
    let traced: Vec<&str> =
        rows[1..].iter().filter(|r| r[0] == "frame").map(|r| r[at].as_str()).collect();
    assert_eq!(traced.len(), frames, "{rows:?}");
    assert_eq!(traced[0], "bvh", "the first frame is the binary tree's: {traced:?}");
    // The layout kept to the end, and where it began to be kept.
    let last = traced[frames - 1];
    let kept_from = traced.iter().rposition(|&l| l != last).map_or(0, |i| i + 1);
    for layout in ["bvh", "wide", "wide-runs"] {
        let timed = traced[..kept_from].iter().filter(|&&l| l == layout).count();
        assert!(timed >= 3, "{layout} timed before one was kept: {traced:?}");
    }
    assert!(frames - kept_from >= 20, "one layout kept at the end: {traced:?}");
}

#[test]
fn a_key_that_changes_a_parameter_gives_a_change_row() {
    let x = Xvfb::start();
    let dir = TempDir::new("stats-change");
    let log = dir.path().join("frames.csv");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(FLAGS).args(["--frames", "1000000", "--stats-csv", "frames.csv"]);
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    // Traced frames before the key (the model may still be loading).
    wait_until(Duration::from_secs(90), "frames in the log", || {
        app.assert_alive();
        (std::fs::read_to_string(&log)
            .unwrap_or_default()
            .lines()
            .filter(|l| l.starts_with("frame,"))
            .count()
            >= 3)
            .then_some(())
    });
    press(&x.display, &window, &["Prior"]);
    wait_until(Duration::from_secs(60), "the change row", || {
        app.assert_alive();
        std::fs::read_to_string(&log).unwrap_or_default().contains("change,").then_some(())
    });
    press(&x.display, &window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));

    let rows = rows(&log);
    let header = &rows[0];
    let changes: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == "change").collect();
    assert_eq!(changes.len(), 1, "{changes:?}");
    let change = changes[0];
    assert_eq!(
        (change[column(header, "parameter")].as_str(), change[column(header, "change")].as_str()),
        ("bounces", "2->3")
    );
    // The change row comes just before the first frame traced with three bounces.
    let at = rows.iter().position(|r| r[0] == "change").unwrap();
    let bounces = column(header, "bounces");
    assert_eq!(rows[at - 1][bounces], "2");
    assert_eq!(rows[at + 1][0], "frame");
    assert_eq!(rows[at + 1][bounces], "3");
    assert_eq!(rows[at + 1][column(header, "frame")], change[column(header, "frame")]);
    assert!(
        rows[at + 1..].iter().all(|r| r[bounces] == "3"),
        "every later frame has three bounces"
    );
}

#[test]
fn the_window_size_is_remembered_unless_no_persist() {
    let x = Xvfb::start();
    let dir = TempDir::new("persist");
    let size = |args: &[&str]| {
        let mut cmd = meshtracer(&x.display, dir.path());
        cmd.args(["--width", "64", "--height", "64"]).args(args);
        let mut app = spawn(cmd);
        let window = wait_for_window(&x.display, &mut app);
        let out = xdotool(&x.display, &["getwindowgeometry", &window]);
        let geometry = String::from_utf8_lossy(&out.stdout)
            .lines()
            .find_map(|l| l.trim().strip_prefix("Geometry: ").map(str::to_string))
            .unwrap();
        press(&x.display, &window, &["ctrl+q"]);
        assert_clean_exit(&app.wait(Duration::from_secs(120)));
        geometry
    };
    assert_eq!(size(&["--window", "500x400", "--no-persist"]), "500x400");
    assert!(!dir.path().join("config").exists(), "--no-persist wrote the settings");
    assert_eq!(size(&["--window", "520x410"]), "520x410");
    let text = std::fs::read_to_string(dir.path().join("config/settings.toml")).unwrap();
    assert!(text.contains("window = [520, 410]"), "{text}");
    // Without --window, the size it had; --no-persist does not read it.
    assert_eq!(size(&[]), "520x410");
    assert_ne!(size(&["--no-persist"]), "520x410", "--no-persist read the remembered size");
    // A corrupt file: one warning line, the defaults, and the run goes on.
    std::fs::write(dir.path().join("config/settings.toml"), "window = [oops").unwrap();
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(["--width", "64", "--height", "64"]);
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    press(&x.display, &window, &["ctrl+q"]);
    let out = app.wait(Duration::from_secs(120));
    assert_clean_exit(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("settings.toml")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].starts_with("warning: ignoring the remembered settings")
            && warnings[0].ends_with("using the defaults"),
        "{stderr}"
    );
    // The file is written afresh at exit.
    assert!(std::fs::read_to_string(dir.path().join("config/settings.toml"))
        .unwrap()
        .contains("window = ["));
}
