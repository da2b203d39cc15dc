//! Helpers for the window tests: a private Xvfb per test, the built binary with the test's
//! environment, xdotool, an XDND drag source (`xdnd`), temporary folders and image
//! comparison.
#![allow(dead_code)]

pub mod xdnd;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

static NEXT: AtomicU32 = AtomicU32::new(0);

/// An Xvfb server on its own display number, killed on drop.
pub struct Xvfb {
    child: Child,
    pub display: String,
}

impl Xvfb {
    /// Start `Xvfb -screen 0 1024x768x24` on a display number of the server's own choosing.
    ///
    /// `-displayfd 1` makes the server pick a free number itself (no races between test
    /// processes for display numbers) and print it only once it accepts connections, so the
    /// app never connects to a server that is still starting. `-noreset` keeps the server
    /// from resetting when xdotool, its first client, disconnects before the app connects.
    pub fn start() -> Self {
        let mut last_error = String::new();
        for _ in 0..3 {
            let mut child = Command::new("Xvfb")
                // -r: no key auto-repeat. Under load the server may see a key's release more
                // than its repeat delay after the press and repeat it (one PgUp, two bounces).
                .args([
                    "-displayfd",
                    "1",
                    "-screen",
                    "0",
                    "1024x768x24",
                    "-nolisten",
                    "tcp",
                    "-noreset",
                    "-r",
                ])
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::null())
                .spawn()
                .expect("Xvfb must be installed for the window tests (CI installs xvfb)");
            let stdout = child.stdout.take().unwrap();
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                use std::io::BufRead;
                let mut line = String::new();
                let _ = std::io::BufReader::new(stdout).read_line(&mut line);
                let _ = tx.send(line);
            });
            match rx.recv_timeout(Duration::from_secs(30)) {
                Ok(line) if line.trim().parse::<u32>().is_ok() => {
                    let display = format!(":{}", line.trim());
                    if xdotool(&display, &["getdisplaygeometry"]).status.success() {
                        return Self { child, display };
                    }
                    last_error = format!("Xvfb said {display} but xdotool cannot connect to it");
                }
                Ok(line) => {
                    last_error = format!("Xvfb exited without a display number ({:?})", line.trim())
                }
                Err(_) => last_error = "Xvfb did not become ready within 30 s".to_string(),
            }
            let _ = child.kill();
            let _ = child.wait();
        }
        panic!("could not start Xvfb: {last_error}");
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM lets the server remove its lock file and socket; SIGKILL only if it hangs.
        let _ = Command::new("kill").args(["-TERM", &self.child.id().to_string()]).status();
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(5) {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A temporary folder, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!(
            "meshtracer-{name}-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::SeqCst)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::env::var_os("MESHTRACER_KEEP_TEST_FILES").is_none() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// The scene most window tests trace: 128², 2 bounces (small enough for lavapipe).
pub const SCENE: [&str; 6] = ["--width", "128", "--height", "128", "--bounces", "2"];
/// The window size most window tests open.
pub const WINDOW: [&str; 2] = ["--window", "640x480"];

/// `view` flags: [`SCENE`] in a [`WINDOW`], then `extra`.
pub fn view_args(extra: &[&str]) -> Vec<String> {
    SCENE.iter().chain(WINDOW.iter()).chain(extra.iter()).map(|s| s.to_string()).collect()
}

/// [`SCENE`] with `b` bounces.
pub fn with_bounces(b: &str) -> Vec<&str> {
    let mut flags = SCENE.to_vec();
    flags[5] = b;
    flags
}

/// [`SCENE`] traced with acceleration `accel`.
pub fn with_accel(accel: &str) -> Vec<&str> {
    SCENE.iter().copied().chain(["--accel", accel]).collect()
}

/// The binary, run in `dir` on `display` with validation on.
pub fn meshtracer(display: &str, dir: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshtracer"));
    cmd.current_dir(dir)
        .env("DISPLAY", display)
        .env("MESHTRACER_VALIDATION", "1")
        // The app's own switch for the layer's synchronization validation.
        .env("MESHTRACER_SYNC_VALIDATION", "1")
        .env("MESHTRACER_SCREENSHOT_DIR", dir)
        // Remembered settings in the test's folder: never the user's, never another test's.
        .env("MESHTRACER_CONFIG_DIR", dir.join("config"))
        // Xvfb's DPI is arbitrary: pin the scale so window sizes are exact.
        .env("WINIT_X11_SCALE_FACTOR", "1")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("MESHTRACER_KEEP_TEST_FILES");
    cmd
}

/// Run xdotool on `display`.
pub fn xdotool(display: &str, args: &[&str]) -> Output {
    Command::new("xdotool")
        .args(args)
        .env("DISPLAY", display)
        .output()
        .expect("xdotool must be installed for the window tests (CI installs it)")
}

/// A running child process, killed on drop if still running.
pub struct Running(pub Option<Child>);

impl Running {
    /// Wait up to `timeout` for the exit; kill it and fail otherwise.
    pub fn wait(&mut self, timeout: Duration) -> Output {
        let start = Instant::now();
        loop {
            let child = self.0.as_mut().unwrap();
            if child.try_wait().unwrap().is_some() {
                return self.0.take().unwrap().wait_with_output().unwrap();
            }
            if start.elapsed() > timeout {
                let mut child = self.0.take().unwrap();
                let _ = child.kill();
                let out = child.wait_with_output().unwrap();
                panic!(
                    "meshtracer did not exit within {timeout:?}; stderr: {}",
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Fail (with its stderr) if the process has exited already.
    pub fn assert_alive(&mut self) {
        let child = self.0.as_mut().unwrap();
        if child.try_wait().unwrap().is_some() {
            let out = self.0.take().unwrap().wait_with_output().unwrap();
            panic!(
                "meshtracer exited early ({}): {}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Spawn with piped output.
pub fn spawn(mut cmd: Command) -> Running {
    Running(Some(cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap()))
}

/// Wait until the app's window is mapped; returns its id.
pub fn wait_for_window(display: &str, app: &mut Running) -> String {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(60) {
        app.assert_alive();
        let out = xdotool(display, &["search", "--onlyvisible", "--name", "^meshtracer"]);
        if let Some(id) = String::from_utf8_lossy(&out.stdout).lines().next() {
            return id.trim().to_string();
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    panic!("the meshtracer window did not appear");
}

/// Focus `window` and press `keys` (xdotool key names) through XTEST, like a user.
pub fn press(display: &str, window: &str, keys: &[&str]) {
    let out = xdotool(display, &["windowfocus", window]);
    assert!(
        out.status.success(),
        "xdotool windowfocus failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut args = vec!["key", "--delay", "50"];
    args.extend_from_slice(keys);
    let out = xdotool(display, &args);
    assert!(out.status.success(), "xdotool key failed: {}", String::from_utf8_lossy(&out.stderr));
}

/// Poll until `f` returns Some, or fail after `timeout` with `what`.
pub fn wait_until<T>(timeout: Duration, what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(start.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// PNG files in `dir` whose names start with `prefix`.
pub fn pngs(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|e| e == "png")
                && p.file_name().unwrap().to_string_lossy().starts_with(prefix)
        })
        .collect();
    v.sort();
    v
}

/// Load a PNG as RGBA.
pub fn load(path: &Path) -> image::RgbaImage {
    image::open(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display())).to_rgba8()
}

/// Largest per-channel difference (images must have the same size).
pub fn max_diff(a: &image::RgbaImage, b: &image::RgbaImage) -> u8 {
    assert_eq!(a.dimensions(), b.dimensions(), "image sizes differ");
    a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0)
}

/// `meshtracer render` of the same scene flags into `out`.
pub fn headless_render(dir: &Path, flags: &[&str], out: &str) -> image::RgbaImage {
    let output = Command::new(env!("CARGO_BIN_EXE_meshtracer"))
        .current_dir(dir)
        .env("MESHTRACER_VALIDATION", "1")
        .arg("render")
        .args(flags)
        .args(["-o", out])
        .output()
        .unwrap();
    assert!(output.status.success(), "render failed: {}", String::from_utf8_lossy(&output.stderr));
    load(&dir.join(out))
}

/// Fail unless the run exited 0 without validation messages.
pub fn assert_clean_exit(out: &Output) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "meshtracer failed ({}): {stderr}", out.status);
    assert!(!stderr.to_lowercase().contains("validation"), "validation messages: {stderr}");
}

/// The newest F12 screenshot after pressing F12 (the light is still in scripted runs, so
/// two shots of an unchanged view are equal).
pub fn f12(x: &Xvfb, window: &str, dir: &Path, app: &mut Running) -> image::RgbaImage {
    let shot = f12_file(x, window, dir, app);
    let img = load(&shot);
    std::fs::remove_file(&shot).unwrap();
    img
}

/// The file of the newest F12 screenshot after pressing F12 (it carries its preset), left
/// in `dir`.
///
/// F12 is pressed once, and again only if no shot came for a while (a frame on a loaded
/// lavapipe can take that long). A press while a shot waits for the frame's end is that
/// shot, but one after it is saved asks for another: so after a second press the shots
/// are let land before the newest is taken and the older new ones removed. Pressing every
/// 0.7 s left such late shots behind, which a test's next F12 then took for its own.
pub fn f12_file(x: &Xvfb, window: &str, dir: &Path, app: &mut Running) -> PathBuf {
    const AGAIN_AFTER: Duration = Duration::from_secs(20);
    const QUIET: Duration = Duration::from_secs(5);
    let trace_shots = || -> Vec<PathBuf> {
        pngs(dir, "meshtracer_")
            .into_iter()
            .filter(|p| !p.to_string_lossy().ends_with("_window.png"))
            .collect()
    };
    let before = trace_shots();
    let new_shots =
        || -> Vec<PathBuf> { trace_shots().into_iter().filter(|p| !before.contains(p)).collect() };
    let start = Instant::now();
    let mut presses = 0;
    let mut pressed_at = start;
    while new_shots().is_empty() {
        app.assert_alive();
        if presses == 0 || pressed_at.elapsed() >= AGAIN_AFTER {
            press(&x.display, window, &["F12"]);
            presses += 1;
            pressed_at = Instant::now();
        }
        // Long: the first frame after a shader reload waits for lavapipe to compile the
        // whole kernel, 60-100 s on a 2-core machine with a cold shader cache, and over
        // 240 s while the other window tests run beside it (a clean-clone CI run).
        assert!(
            start.elapsed() < Duration::from_secs(480),
            "timed out waiting for an F12 screenshot"
        );
        std::thread::sleep(Duration::from_millis(300));
    }
    if presses > 1 {
        let (mut count, mut since) = (new_shots().len(), Instant::now());
        while since.elapsed() < QUIET && start.elapsed() < Duration::from_secs(540) {
            app.assert_alive();
            std::thread::sleep(Duration::from_millis(300));
            let now = new_shots().len();
            if now != count {
                (count, since) = (now, Instant::now());
            }
        }
    }
    let mut shots = new_shots();
    let newest = shots.pop().expect("a new shot");
    for older in shots {
        std::fs::remove_file(older).unwrap();
    }
    newest
}
