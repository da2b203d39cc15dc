//! The A/B split view, run for real as the window tests are (a private Xvfb, the
//! validation layer on, real X input): each half of the split frame is traced as set.

mod app_support;

use std::time::Duration;

use app_support::*;

/// Largest per-channel difference between `a` and `b` over the pixel columns `columns`.
fn columns_diff(a: &image::RgbaImage, b: &image::RgbaImage, columns: std::ops::Range<u32>) -> u8 {
    assert_eq!(a.dimensions(), b.dimensions(), "image sizes differ");
    let mut most = 0;
    for y in 0..a.height() {
        for x in columns.clone() {
            let (p, q) = (a.get_pixel(x, y), b.get_pixel(x, y));
            most = (0..4).map(|c| p[c].abs_diff(q[c])).fold(most, u8::max);
        }
    }
    most
}

#[test]
fn the_split_views_halves_differ_as_set() {
    // A (the flags: 2 bounces, flat) left of the line, B (no bounces, smooth) right of it.
    // F12 saves the split frame as traced: each side equals `render` with its half's settings.
    let x = Xvfb::start();
    let dir = TempDir::new("split");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(view_args(&[
        "--frames",
        "1000000",
        "--split",
        "0.5",
        "--split-b",
        "bounces=0,smooth=on",
    ]));
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    let half = f12(&x, &window, dir.path(), &mut app);

    // With the panel hidden the 128² image fills the window's height: 480² from x = 80, the
    // line (column 64) at x = 320. A left drag from the line moves it to x = 140: column 16,
    // which the split snaps to the nearest multiple of the work group's width.
    press(&x.display, &window, &["h"]);
    std::thread::sleep(Duration::from_millis(500));
    let drag = [
        "mousemove",
        "--window",
        &window,
        "320",
        "240",
        "mousedown",
        "1",
        "mousemove",
        "--window",
        &window,
        "250",
        "240",
        "mousemove",
        "--window",
        &window,
        "140",
        "240",
        "mouseup",
        "1",
    ];
    assert!(xdotool(&x.display, &drag).status.success());
    let moved = f12(&x, &window, dir.path(), &mut app);

    // S turns the split off: the whole frame is A's again.
    press(&x.display, &window, &["s"]);
    let whole = f12(&x, &window, dir.path(), &mut app);
    press(&x.display, &window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));

    let a = headless_render(dir.path(), &SCENE, "a.png");
    let b_flags: Vec<&str> = with_bounces("0").into_iter().chain(["--smooth"]).collect();
    let b = headless_render(dir.path(), &b_flags, "b.png");
    let group = meshtracer::gpu::GROUP.width;
    let dragged = (16.0 / group as f64).round() as u32 * group;
    assert!(dragged < 64, "the drag must move the line");
    for (name, img, line) in [("at 0.5", &half, 64), ("dragged", &moved, dragged)] {
        assert!(
            columns_diff(img, &a, 0..line) <= 1,
            "split {name}: left of column {line} differs from `render` (A) by {}",
            columns_diff(img, &a, 0..line)
        );
        assert!(
            columns_diff(img, &b, line..128) <= 1,
            "split {name}: right of column {line} differs from `render` (B) by {}",
            columns_diff(img, &b, line..128)
        );
    }
    // The columns between the two lines changed sides with the drag: they must tell A from B.
    for columns in [dragged..64, 64..128] {
        assert!(
            columns_diff(&a, &b, columns.clone()) > 30,
            "A and B look alike in columns {columns:?}: the test proves nothing"
        );
    }
    assert!(
        max_diff(&whole, &a) <= 1,
        "with the split off the frame differs from `render` (A) by {}",
        max_diff(&whole, &a)
    );
}

#[test]
fn a_split_frame_traced_in_bands_has_each_half_as_set() {
    // Brute force with a tiny submission budget: the split frame comes in many bands, each
    // traced on both sides of the line (B: one bounce, 4 adaptive samples, so each half keys
    // its own edges). Away from the line each half equals `render` with its settings.
    let x = Xvfb::start();
    let dir = TempDir::new("split-bands");
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.env("MESHTRACER_TESTS_PER_SUBMISSION", "20000");
    cmd.args(view_args(&[
        "--accel",
        "brute",
        "--split",
        "0.3",
        "--split-b",
        "bounces=1,spp=4,adaptive=on",
        "--frames",
        "2",
        "--screenshot",
        "split.png",
    ]));
    assert_clean_exit(&spawn(cmd).wait(Duration::from_secs(300)));
    let split = load(&dir.path().join("split.png"));
    let a_flags = with_accel("brute");
    let a = headless_render(dir.path(), &a_flags, "a.png");
    let b_flags: Vec<&str> = with_bounces("1")
        .into_iter()
        .chain(["--accel", "brute", "--spp", "4", "--adaptive"])
        .collect();
    let b = headless_render(dir.path(), &b_flags, "b.png");
    // 0.3 of 128 is column 38.4: the halves meet at the nearest multiple of the group's width
    // (dispatches start at a group's edge).
    let group = meshtracer::gpu::GROUP.width;
    let line = (38.4 / group as f64).round() as u32 * group;
    assert!(
        columns_diff(&split, &a, 0..line) <= 1,
        "left of column {line} differs from `render` (A) by {}",
        columns_diff(&split, &a, 0..line)
    );
    // The line's own column compares its key with the column left of it, traced as A: it may differ.
    assert!(
        columns_diff(&split, &b, line + 1..128) <= 1,
        "right of column {line} differs from `render` (B) by {}",
        columns_diff(&split, &b, line + 1..128)
    );
    assert!(
        columns_diff(&a, &b, line + 1..128) > 30,
        "A and B look alike: the test proves nothing"
    );
}
