//! The Open dialog's path field, typed into as a person types: Ctrl+O, then an absolute
//! path in one burst (12 ms a key, its leading `/` opening the field) and Enter, while the
//! window traces 512² on lavapipe at a few frames a second, so many keys share a frame.
//! Every key must reach the field and the path must replace the folder the field opens
//! with; the model must then load. Xvfb, xdotool and Vulkan are required, as for `app_window`.

mod app_support;

use std::time::Duration;

use app_support::*;

/// A cube of 12 triangles.
const CUBE: &str = "\
v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6
";

/// Start the window at 512², `bounces` bounces (slow frames on lavapipe) with `cube.obj` in a
/// folder of its own (the dialog, opened in the current folder, does not list it); returns
/// the app, its window and the cube's path.
fn start(x: &Xvfb, dir: &TempDir, bounces: &str) -> (Running, String, std::path::PathBuf) {
    let models = dir.path().join("models");
    std::fs::create_dir_all(&models).unwrap();
    let cube = models.join("cube.obj");
    std::fs::write(&cube, CUBE).unwrap();
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args(["--width", "512", "--height", "512", "--bounces", bounces]);
    cmd.args(["--window", "640x480", "--frames", "1000000"]);
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    (app, window, cube)
}

/// Press F12 until the screenshot's name says the cube is traced, then quit cleanly.
fn expect_the_cube(x: &Xvfb, dir: &TempDir, window: &str, mut app: Running, bounces: &str) {
    let infix = format!("_cube_x1_512x512_b{bounces}_");
    let shot = wait_until(Duration::from_secs(120), "an F12 screenshot of the cube", || {
        app.assert_alive();
        press(&x.display, window, &["F12"]);
        std::thread::sleep(Duration::from_millis(1500));
        let names: Vec<String> = pngs(dir.path(), "meshtracer_")
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().to_string())
            .collect();
        names.into_iter().find(|n| n.contains(&infix) && !n.ends_with("_window.png"))
    });
    assert!(!shot.is_empty());
    press(&x.display, window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));
}

#[test]
fn an_absolute_path_typed_in_one_burst_after_ctrl_o_loads_its_model() {
    let x = Xvfb::start();
    let dir = TempDir::new("open-typed");
    let (app, window, cube) = start(&x, &dir, "2");
    press(&x.display, &window, &["ctrl+o"]);
    std::thread::sleep(Duration::from_millis(1500));
    let typed = xdotool(&x.display, &["type", "--delay", "12", &cube.display().to_string()]);
    assert!(typed.status.success(), "xdotool type failed");
    std::thread::sleep(Duration::from_millis(1000));
    press(&x.display, &window, &["Return"]);
    expect_the_cube(&x, &dir, &window, app, "2");
}

#[test]
fn ctrl_o_a_path_and_its_line_end_in_one_burst_load_the_model() {
    // #43: Ctrl+O, the path and "\n" typed at once at 512² and 8 bounces left the path in the
    // field: xdotool types the line end as the Linefeed keysym, which winit names no key.
    let x = Xvfb::start();
    let dir = TempDir::new("open-burst");
    let (app, window, cube) = start(&x, &dir, "8");
    let focus = xdotool(&x.display, &["windowfocus", &window]);
    assert!(focus.status.success(), "xdotool windowfocus failed");
    let line = format!("{}\n", cube.display());
    let typed = xdotool(&x.display, &["key", "ctrl+o", "type", "--delay", "12", &line]);
    assert!(typed.status.success(), "xdotool failed");
    expect_the_cube(&x, &dir, &window, app, "8");
}
