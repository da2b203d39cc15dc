//! Loading a model file into the running tool, for real: an .obj dropped on the window by
//! an XDND drag source (X events, as a file manager sends them) and one picked in the Open
//! dialog by keys (xdotool). Each time the traced image must become what `render --model`
//! makes of the same file. Xvfb, xdotool and Vulkan are required, as for `app_window`.

mod app_support;

use std::path::{Path, PathBuf};
use std::time::Duration;

use app_support::*;

const SCENE: [&str; 6] = ["--width", "96", "--height", "96", "--bounces", "2"];

/// A cube of 12 triangles: nothing like the default geosphere.
const CUBE: &str = "\
v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6
";

/// Start `view` on the default model in `dir`, with `cube.obj` written there; returns the
/// app, its window and the cube's path.
fn start(x: &Xvfb, dir: &Path) -> (Running, String, PathBuf) {
    let cube = dir.join("cube.obj");
    std::fs::write(&cube, CUBE).unwrap();
    let mut cmd = meshtracer(&x.display, dir);
    cmd.args(SCENE).args(["--window", "640x480", "--frames", "1000000"]);
    let mut app = spawn(cmd);
    let window = wait_for_window(&x.display, &mut app);
    (app, window, cube)
}

/// Press F12 until a trace screenshot of the model `label` appears; returns it. The name
/// must also say two bounces: a tool key that fired while the dialog showed would not.
fn f12_of(x: &Xvfb, window: &str, dir: &Path, app: &mut Running, label: &str) -> image::RgbaImage {
    let infix = format!("_{label}_x1_96x96_b2_");
    let shot =
        wait_until(Duration::from_secs(120), &format!("an F12 screenshot of {label}"), || {
            app.assert_alive();
            press(&x.display, window, &["F12"]);
            std::thread::sleep(Duration::from_millis(700));
            pngs(dir, "meshtracer_").into_iter().find(|p| {
                let name = p.file_name().unwrap().to_string_lossy().to_string();
                name.contains(&infix) && !name.ends_with("_window.png")
            })
        });
    load(&shot)
}

/// The cube as `render --model` traces it with the same settings.
fn cube_reference(dir: &Path) -> image::RgbaImage {
    let mut flags = SCENE.to_vec();
    flags.extend(["--model", "cube.obj"]);
    headless_render(dir, &flags, "cube_ref.png")
}

/// Quit with Ctrl+Q and check the exit was clean (no validation messages).
fn quit(x: &Xvfb, window: &str, mut app: Running) {
    press(&x.display, window, &["ctrl+q"]);
    assert_clean_exit(&app.wait(Duration::from_secs(120)));
}

#[test]
fn an_obj_dropped_on_the_window_is_traced_as_render_traces_it() {
    let x = Xvfb::start();
    let dir = TempDir::new("drop");
    let (mut app, window, cube) = start(&x, dir.path());
    let before = f12_of(&x, &window, dir.path(), &mut app, "geosphere");

    let outcome = xdnd::drop_files(&x.display, &window, &[&cube], Duration::from_secs(60)).unwrap();
    assert_eq!(
        outcome,
        xdnd::DropOutcome { accepted: true, finished_ok: true, data_requested: true }
    );
    let after = f12_of(&x, &window, dir.path(), &mut app, "cube");

    let reference = cube_reference(dir.path());
    assert!(
        max_diff(&before, &reference) > 1,
        "the cube looks like the geosphere: the test proves nothing"
    );
    assert!(
        max_diff(&after, &reference) <= 1,
        "the dropped cube differs from `render --model cube.obj` by {}",
        max_diff(&after, &reference)
    );
    quit(&x, &window, app);
}

#[test]
fn an_obj_picked_in_the_open_dialog_by_keys_is_traced_as_render_traces_it() {
    let x = Xvfb::start();
    let dir = TempDir::new("open");
    let (mut app, window, cube) = start(&x, dir.path());
    let before = f12_of(&x, &window, dir.path(), &mut app, "geosphere");

    press(&x.display, &window, &["ctrl+o"]);
    std::thread::sleep(Duration::from_millis(1500));
    // The tool's keys wait while the dialog shows: PgUp would trace a third bounce.
    press(&x.display, &window, &["Prior"]);
    // "/" opens the dialog's path field; the typed path replaces what it holds; Enter picks.
    press(&x.display, &window, &["slash"]);
    std::thread::sleep(Duration::from_millis(1000));
    press(&x.display, &window, &["ctrl+a"]);
    let typed = xdotool(&x.display, &["type", "--delay", "30", &cube.display().to_string()]);
    assert!(typed.status.success(), "xdotool type failed");
    std::thread::sleep(Duration::from_millis(500));
    press(&x.display, &window, &["Return"]);
    let after = f12_of(&x, &window, dir.path(), &mut app, "cube");

    let reference = cube_reference(dir.path());
    assert!(
        max_diff(&before, &reference) > 1,
        "the cube looks like the geosphere: the test proves nothing"
    );
    assert!(
        max_diff(&after, &reference) <= 1,
        "the cube picked in the dialog differs from `render --model cube.obj` by {}",
        max_diff(&after, &reference)
    );
    quit(&x, &window, app);
}
