//! A screenshot taken while the window accumulates frames reproduces (#30): F12 saves the
//! averaged image with its frame count in the preset, and `render --preset shot.png`
//! traces the same frames. Before, the preset said nothing of accumulation and `render`
//! traced one centred sample (thousands of edge pixels off by up to 150).

mod app_support;

use std::time::Duration;

use app_support::*;

#[test]
fn an_f12_screenshot_after_accumulation_renders_again_from_its_preset() {
    let x = Xvfb::start();
    let dir = TempDir::new("accumulation");
    let mut cmd = meshtracer(&x.display, dir.path());
    // Interactive (accumulation on), the light paused with Space so frames average.
    cmd.args(view_args(&["--no-persist", "--spp", "1"]));
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    press(&x.display, &window, &["space"]);
    std::thread::sleep(Duration::from_secs(4));
    let accumulated = |shot: &std::path::Path| {
        let text = meshtracer::files::image_files::png_settings(&std::fs::read(shot).unwrap())
            .unwrap()
            .expect("the screenshot carries its preset");
        meshtracer::scene::preset::from_text(&text).unwrap().0.accumulate
    };
    // A shot taken before the window's second frame (a slow first frame on a loaded
    // machine) carries 1: it is dropped and F12 pressed again until the window has
    // accumulated, which it must do within the wait.
    let shot =
        wait_until(Duration::from_secs(90), "an F12 screenshot of accumulated frames", || {
            app.assert_alive();
            press(&x.display, &window, &["F12"]);
            std::thread::sleep(Duration::from_millis(700));
            let shot = pngs(dir.path(), "meshtracer_")
                .into_iter()
                .find(|p| !p.to_string_lossy().ends_with("_window.png"))?;
            if accumulated(&shot) > 1 {
                return Some(shot);
            }
            std::fs::remove_file(&shot).unwrap();
            None
        });
    press(&x.display, &window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));
    assert!(accumulated(&shot) > 1, "the window accumulated frames");
    let shot_path = shot.to_string_lossy().into_owned();
    let again = headless_render(dir.path(), &["--preset", &shot_path], "again.png");
    let single =
        headless_render(dir.path(), &["--preset", &shot_path, "--accumulate", "1"], "single.png");
    let shot = load(&shot);
    // Within a frame of the count the window had (the capture may hold one more or less):
    // at most 0.5% of the pixels off by more than 8.
    let off = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels()
            .zip(b.pixels())
            .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 8))
            .count()
    };
    let limit = (shot.width() * shot.height()) as usize / 200;
    assert!(
        off(&shot, &again) <= limit,
        "render --preset differs from the screenshot on {} pixels",
        off(&shot, &again)
    );
    assert!(
        off(&shot, &single) > limit,
        "one frame looks like the average ({} pixels off): the test proves nothing",
        off(&shot, &single)
    );
}
