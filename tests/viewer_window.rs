//! The windowed viewer, end to end: `mpm view` on the CPU backend under an X server (Xvfb with
//! Mesa's software OpenGL in CI) for a few frames, then its last frame must show particles, and
//! what it exports must be what `mpm run` exports.
//! Reported as ignored, with the reason, where neither a display nor Xvfb is available
//! (tests/harness: `harness = false`). An Xvfb it starts is stopped with SIGTERM, so that it removes
//! its lock file and socket; the test checks that it did.

use mpm::render::capture::Image;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod common;

mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "viewer",
        display_or_xvfb,
        harness::tests![
            viewer_window_shows_particles,
            viewer_splits_slow_frames_across_draws,
            viewer_window_draws_colliders,
            viewer_exports_the_frames_mpm_run_exports
        ],
    )
}

/// What the test needs: a `DISPLAY`, or an `Xvfb` on `PATH` to start one.
fn display_or_xvfb() -> Result<(), String> {
    if std::env::var("DISPLAY").is_ok_and(|d| !d.is_empty()) {
        return Ok(());
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    if std::env::split_paths(&path).any(|dir| dir.join("Xvfb").is_file()) {
        return Ok(());
    }
    Err("no DISPLAY and no Xvfb on PATH (.ci/run installs xvfb)".into())
}

/// Stops the Xvfb this test started, however the test ends: SIGTERM, so that it removes its
/// `/tmp/.X<n>-lock` and socket (SIGKILL leaves both behind), and SIGKILL only if it has not gone
/// within 5 s.
struct Xvfb {
    child: Child,
    number: u32,
}

impl Xvfb {
    fn lock_file(&self) -> String {
        format!("/tmp/.X{}-lock", self.number)
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
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

/// The tests take turns: two Xvfb servers started at once would pick the same free display number.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// A display to draw on: `$DISPLAY` if the caller has one, else a fresh Xvfb.
fn display() -> Result<(String, Option<Xvfb>), String> {
    if let Ok(display) = std::env::var("DISPLAY") {
        if !display.is_empty() {
            return Ok((display, None));
        }
    }
    let number = (90..200)
        .find(|n| !Path::new(&format!("/tmp/.X{n}-lock")).exists())
        .ok_or("no free X display number")?;
    let display = format!(":{number}");
    let child = Command::new("Xvfb")
        .args([
            display.as_str(),
            "-screen",
            "0",
            "1024x768x24",
            "-nolisten",
            "tcp",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("no DISPLAY and no Xvfb ({e}); .ci/run installs xvfb"))?;
    let xvfb = Xvfb { child, number };
    let socket = format!("/tmp/.X11-unix/X{number}");
    let start = Instant::now();
    while !Path::new(&socket).exists() {
        if start.elapsed() > Duration::from_secs(10) {
            return Err("Xvfb did not come up within 10 s".into());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok((display, Some(xvfb)))
}

/// One test's turn at a display, and a folder for its files. Dropped in this order: the folder,
/// the Xvfb the test started, then the turn, so the next test finds the display number free.
struct Session {
    dir: tempfile::TempDir,
    xvfb: Option<Xvfb>,
    display: String,
    _turn: std::sync::MutexGuard<'static, ()>,
}

fn session() -> Session {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let (display, xvfb) = display().unwrap_or_else(|why| panic!("{why}"));
    let dir = tempfile::tempdir().expect("temp dir");
    Session {
        dir,
        xvfb,
        display,
        _turn,
    }
}

impl Session {
    /// `mpm view --backend cpu ARGS --capture-dir DIR` on the session's display; must succeed.
    /// Returns its stderr (printed).
    fn view(&self, args: &[&str]) -> String {
        let output = Command::new(common::mpm_binary())
            .args(["view", "--backend", "cpu"])
            .args(args)
            .arg("--capture-dir")
            .arg(self.dir.path())
            .env("DISPLAY", &self.display)
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .expect("running mpm view");
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        println!("mpm view stderr:\n{stderr}");
        assert!(output.status.success(), "mpm view failed: {}", output.status);
        stderr
    }

    /// `scene` (TOML) written to the session's folder as `name`.toml, and the last frame of
    /// `mpm view` on it at 800 x 500 after `frames` frames.
    fn last_frame(&self, name: &str, scene: &str, frames: u32) -> (String, Image) {
        let file = self.dir.path().join(format!("{name}.toml"));
        std::fs::write(&file, scene).expect("writing the scene");
        let shot = self.dir.path().join("last-frame.png");
        let stderr = self.view(&[
            "--size",
            "800x500",
            "--no-vsync",
            "--scene",
            file.to_str().expect("a UTF-8 temp path"),
            "--quit-after",
            &frames.to_string(),
            "--final-screenshot",
            shot.to_str().expect("a UTF-8 temp path"),
        ]);
        let bytes = std::fs::read(&shot).expect("the viewer wrote its last frame");
        (stderr, Image::read_png(&bytes).expect("a PNG"))
    }
}

/// A small tank (about 5,600 particles), so the CPU backend steps it quickly under software GL.
const SMALL: &str = common::tank!(
    "small",
    [0.4, 0.4, 0.4],
    [20, 20, 20],
    r#"
[[block]]
min = [0.05, 0.05, 0.05]
max = [0.2, 0.3, 0.2]
"#
);

fn viewer_window_shows_particles() {
    let mut session = session();
    let (stderr, image) = session.last_frame("small", SMALL, 6);
    // Scripts on a display-less GPU server (scripts/view-on-gpu.sh) read the particles' path and
    // the window system's API from the log.
    assert!(
        stderr.contains("drawn, particles by host copy + glBufferSubData;"),
        "the viewer's last line names how the particles reached OpenGL"
    );
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with("OpenGL: ") && (l.contains("(GLX ") || l.contains("(EGL "))),
        "the viewer names its window system's API"
    );
    // The final screenshot is the scene's part of the window: its height, and the width right of
    // the panel.
    assert_eq!(image.height, 500);
    assert!((300..800).contains(&image.width), "scene width {}", image.width);
    let stats = image.stats();
    // Particles at rest are drawn in the low (blue) end of the speed scale, lit.
    let blue = common::pixel_fraction(&image, |p| p[2] > 60 && i32::from(p[2]) > i32::from(p[0]) + 30);
    println!("stats {stats:?}, blue particle pixels {:.1}%", 100.0 * blue);
    assert!(
        blue > 0.01,
        "no particles visible: {:.3}% blue pixels",
        100.0 * blue
    );
    assert!(
        stats.covered_fraction < 0.9,
        "the frame is filled, not drawn: {stats:?}"
    );
    if let Some(xvfb) = session.xvfb.take() {
        let lock = xvfb.lock_file();
        drop(xvfb);
        assert!(!Path::new(&lock).exists(), "Xvfb left {lock} behind");
    }
}

/// bench-65k on the single-thread CPU takes most of a second per 60 Hz frame; the viewer splits it
/// over draws, so no draw spends much more than its 50 ms stepping budget (plus one substep) on it.
fn viewer_splits_slow_frames_across_draws() {
    let stderr = session().view(&[
        "--scene",
        "bench-65k",
        "--size",
        "400x300",
        "--draw",
        "points",
        "--no-vsync",
        "--quit-after",
        "10",
    ]);
    let longest: f64 = stderr
        .lines()
        .find_map(|l| l.split("the longest stepping in one draw took ").nth(1))
        .and_then(|rest| rest.trim_end_matches(" ms").parse().ok())
        .expect("the viewer reports its longest step");
    assert!(longest < 300.0, "one draw spent {longest} ms stepping");
}

/// Colliders beside the water: a sphere, and a tilted box moving as a piston.
const OBSTACLES: &str = common::tank!(
    "obstacles",
    [0.4, 0.4, 0.4],
    [20, 20, 20],
    r#"
[[block]]
min = [0.05, 0.05, 0.05]
max = [0.15, 0.2, 0.2]
[[collider]]
shape = "sphere"
center = [0.28, 0.12, 0.2]
radius = 0.07
[[collider]]
shape = "box"
center = [0.25, 0.3, 0.2]
size = [0.1, 0.04, 0.2]
rotation = [0.0, 0.0, 30.0]
[collider.motion]
piston = { direction = [0.0, 1.0, 0.0], amplitude = 0.02, period = 0.5 }
"#
);

/// A scene with colliders beside the water: the last frame shows them, solid and shaded in their warm
/// grey (src/render/colliders.rs), and the panel's backstop row does not stop the viewer.
fn viewer_window_draws_colliders() {
    let (_, image) = session().last_frame("obstacles", OBSTACLES, 4);
    // The colliders' shade (0.62, 0.58, 0.52) times a light factor: red above blue, green between.
    let grey = common::pixel_fraction(&image, |p| {
        p[0] > 60 && p[0] >= p[1] && p[1] >= p[2] && i32::from(p[0]) - i32::from(p[2]) > 8
    });
    println!("collider pixels {:.1}%", 100.0 * grey);
    assert!(
        grey > 0.01,
        "no colliders visible: {:.3}% of the pixels",
        100.0 * grey
    );
}

/// The names of the files in `dir` (not its folders), sorted.
fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `mpm view --export DIR --export-usd FILE` writes frame 0 and every frame it steps, until it
/// quits, and they are the files `mpm run` writes for the same frames, byte for byte: the PLY
/// frames, the stage's layers and its root layer. The scene is the coarse dam break with a fixed
/// substep (`time_step.dt` for its `cfl`): under the CFL policy the viewer's run is its own (it
/// splits a slow frame over draws, and chooses a frame's first substeps while the last frame's
/// are still in flight), so its frames differ from `mpm run`'s in the last bits. On the single-
/// thread CPU a frame of it takes about 60 ms, so the viewer's frames are split over draws here.
fn viewer_exports_the_frames_mpm_run_exports() {
    let session = session();
    let dir = session.dir.path();
    let preset = common::mpm(&["scenes", "--show", "dam-break-coarse"]);
    let preset = String::from_utf8(preset.stdout).expect("the preset as text");
    let scene = preset.replacen("\ncfl = 0.35 ", "\ndt = 8.0e-4 ", 1);
    assert_ne!(scene, preset, "the preset's time step line moved");
    let scene_file = dir.join("dam-break-coarse-fixed-step.toml");
    std::fs::write(&scene_file, scene).expect("writing the scene");
    let (view, run) = (dir.join("view"), dir.join("run"));
    for side in [&view, &run] {
        std::fs::create_dir(side).unwrap();
    }
    let path = |p: std::path::PathBuf| p.to_str().expect("a UTF-8 temp path").to_string();
    let stderr = session.view(&[
        "--scene",
        &path(scene_file.clone()),
        "--size",
        "400x300",
        "--draw",
        "points",
        "--no-vsync",
        "--fixed-frames",
        "1",
        "--quit-after",
        "40",
        "--export",
        &path(view.join("ply")),
        "--export-usd",
        &path(view.join("stage.usda")),
    ]);
    let frames = files_in(&view.join("ply"));
    let count = frames.len();
    // 40 draws of 50 ms of stepping at most; a frame takes about two here, more on a busy machine.
    assert!(count >= 3, "only {count} frames exported: {frames:?}");
    let expected: Vec<String> = (0..count).map(|f| format!("frame_{f:06}.ply")).collect();
    assert_eq!(frames, expected, "frame 0 and every frame after it");
    assert!(
        stderr.contains(&format!(
            "export finished as the viewer closed: {count} frames in "
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!("exported {count} particle frames into")),
        "the export's closing lines: {stderr}"
    );

    let last = (count - 1).to_string();
    let out = common::cpu_run(
        &path(scene_file),
        &last,
        &[
            "--export",
            &path(run.join("ply")),
            "--export-usd",
            &path(run.join("stage.usda")),
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for folder in ["ply", "stage_clips", "."] {
        let (view, run) = (view.join(folder), run.join(folder));
        let files = files_in(&view);
        assert_eq!(files, files_in(&run), "{folder}: other files than mpm run's");
        for name in files {
            let read = |side: &Path| std::fs::read(side.join(&name)).unwrap();
            assert!(
                read(&view) == read(&run),
                "{folder}/{name}: the viewer's file differs from mpm run's"
            );
        }
    }
}
