//! The vendor's ray tracing in the window, run as the window tests are (a private Xvfb, the
//! validation layer on, real X input): the A key reaches it live, a split view sets it
//! against our BVH, and a device without it falls back with a note.

mod app_support;

use app_support::*;
use std::time::Duration;

/// The `acceleration` column of every frame row of a `--stats-csv` log.
fn accelerations(csv: &str) -> Vec<String> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let col = header.iter().position(|h| *h == "acceleration").expect("an acceleration column");
    lines
        .map(|l| l.split(',').nth(col).unwrap_or("").to_string())
        .filter(|a| !a.is_empty())
        .collect()
}

#[test]
fn the_a_key_reaches_the_vendors_tracing_live_and_it_traces_as_render_does() {
    let x = Xvfb::start();
    let dir = TempDir::new("vendor-key");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(view_args(&["--frames", "1000000", "--stats-csv", "frames.csv"]));
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    let _ = f12(&x, &window, dir.path(), &mut app);
    // BVH, brute force, vendor: each press takes effect on the next frame. The second press
    // waits for a brute-force frame in the log: two presses within one frame both apply
    // before it is traced, and brute force would then never be seen (it failed so once in
    // CI on a loaded machine).
    press(&x.display, &window, &["a"]);
    let log_path = dir.path().join("frames.csv");
    let deadline = std::time::Instant::now() + Duration::from_secs(120);
    while std::time::Instant::now() < deadline
        && !std::fs::read_to_string(&log_path)
            .is_ok_and(|log| accelerations(&log).iter().any(|a| a == "brute"))
    {
        std::thread::sleep(Duration::from_millis(100));
    }
    press(&x.display, &window, &["a"]);
    std::thread::sleep(Duration::from_secs(2));
    let vendor = f12(&x, &window, dir.path(), &mut app);
    press(&x.display, &window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));

    let log = std::fs::read_to_string(dir.path().join("frames.csv")).unwrap();
    let accels = accelerations(&log);
    // Our BVH in its default layout (the wide tree), then brute force, then the vendor's.
    for a in ["wide", "brute", "vendor"] {
        assert!(accels.iter().any(|x| x == a), "no {a} frame in the log: {accels:?}");
    }
    assert_eq!(
        accels.last().map(String::as_str),
        Some("vendor"),
        "the last frames are the vendor's"
    );
    let flags = with_accel("vendor");
    let render = headless_render(dir.path(), &flags, "vendor.png");
    assert!(
        max_diff(&vendor, &render) <= 1,
        "the window's vendor frame differs from `render --accel vendor` by {}",
        max_diff(&vendor, &render)
    );
}

#[test]
fn a_split_view_sets_the_vendors_tracing_against_ours() {
    // A: our BVH, 2 bounces; B: the vendor's, no bounces (so the halves differ visibly).
    let x = Xvfb::start();
    let dir = TempDir::new("vendor-split");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(view_args(&[
        "--frames",
        "1000000",
        "--split",
        "0.5",
        "--split-b",
        "accel=vendor,bounces=0",
    ]));
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    let shot = f12(&x, &window, dir.path(), &mut app);
    press(&x.display, &window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));

    let a = headless_render(dir.path(), &SCENE, "a.png");
    let b_flags = ["--width", "128", "--height", "128", "--bounces", "0", "--accel", "vendor"];
    let b = headless_render(dir.path(), &b_flags, "b.png");
    let crop = |img: &image::RgbaImage, x: u32, w: u32| {
        image::imageops::crop_imm(img, x, 0, w, 128).to_image()
    };
    assert!(
        max_diff(&crop(&shot, 0, 64), &crop(&a, 0, 64)) <= 1,
        "the left half is not our BVH's frame"
    );
    assert!(
        max_diff(&crop(&shot, 64, 64), &crop(&b, 64, 64)) <= 1,
        "the right half is not the vendor's frame"
    );
    assert!(
        max_diff(&crop(&a, 64, 64), &crop(&b, 64, 64)) > 30,
        "A and B look alike: the test proves nothing"
    );
}

#[test]
fn without_the_extensions_the_window_falls_back_to_the_bvh() {
    let x = Xvfb::start();
    let dir = TempDir::new("vendor-none");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.env("MESHTRACER_NO_VENDOR_RT", "1").args(view_args(&[
        "--accel",
        "vendor",
        "--frames",
        "3",
        "--stats-csv",
        "frames.csv",
    ]));
    let out = spawn(cmd).wait(Duration::from_secs(120));
    assert_clean_exit(&out);
    let log = std::fs::read_to_string(dir.path().join("frames.csv")).unwrap();
    let accels = accelerations(&log);
    assert!(
        !accels.is_empty() && accels.iter().all(|a| a == "wide"),
        "frames were traced with {accels:?}"
    );
}
