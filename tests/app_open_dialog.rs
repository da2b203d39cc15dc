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

#[test]
fn an_absolute_path_typed_in_one_burst_after_ctrl_o_loads_its_model() {
    let x = Xvfb::start();
    let dir = TempDir::new("open-typed");
    // In a folder of its own, so the dialog (opened in the current folder) does not list it.
    let models = dir.path().join("models");
    std::fs::create_dir_all(&models).unwrap();
    let cube = models.join("cube.obj");
    std::fs::write(&cube, CUBE).unwrap();
    let mut cmd = meshtracer(&x.display, dir.path());
    cmd.args([
        "--width",
        "512",
        "--height",
        "512",
        "--bounces",
        "2",
        "--window",
        "640x480",
        "--frames",
        "1000000",
    ]);
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);

    press(&x.display, &window, &["ctrl+o"]);
    std::thread::sleep(Duration::from_millis(1500));
    let typed = xdotool(&x.display, &["type", "--delay", "12", &cube.display().to_string()]);
    assert!(typed.status.success(), "xdotool type failed");
    std::thread::sleep(Duration::from_millis(1000));
    press(&x.display, &window, &["Return"]);

    // The screenshot's name says the model traced: the cube, once it has loaded.
    let shot = wait_until(Duration::from_secs(120), "an F12 screenshot of the cube", || {
        app.assert_alive();
        press(&x.display, &window, &["F12"]);
        std::thread::sleep(Duration::from_millis(1500));
        let names: Vec<String> = pngs(dir.path(), "meshtracer_")
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().to_string())
            .collect();
        names
            .into_iter()
            .find(|n| n.contains("_cube_x1_512x512_b2_") && !n.ends_with("_window.png"))
    });
    assert!(!shot.is_empty());
    press(&x.display, &window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));
}
