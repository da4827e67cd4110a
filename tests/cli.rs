//! The command line as a user meets it: help, misplaced options, numbers, and paths checked before
//! the first step. Each case runs the `mpm` binary and reads what it says; none needs a GPU or a
//! display.

use std::process::{Command, Output};
use std::time::{Duration, Instant};

mod common;
use common::mpm;

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn top_level_help_lists_commands_not_viewer_options() {
    let out = mpm(&["--help"]);
    assert!(out.status.success());
    let text = stdout(&out);
    assert!(text.contains("Commands:") && text.contains("run"), "{text}");
    assert!(
        !text.contains("--fixed-frames"),
        "viewer options at the top level:\n{text}"
    );
    assert!(
        text.contains("mpm view"),
        "says where the viewer's options are:\n{text}"
    );
}

#[test]
fn options_before_a_command_say_where_they_go() {
    let out = mpm(&["--scene", "drop", "run"]);
    assert!(!out.status.success());
    let text = stderr(&out);
    assert!(text.contains("mpm run --scene drop"), "{text}");
}

#[test]
fn scenes_show_without_a_name_lists_the_presets() {
    let out = mpm(&["scenes", "--show"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    for preset in mpm::sim::presets::NAMES {
        assert!(text.contains(preset), "{preset} missing from:\n{text}");
    }
}

/// `--show` prints every preset's file byte for byte, and the listing names a scene's materials
/// where it has several.
#[test]
fn scenes_show_prints_each_preset_exactly_and_the_listing_names_materials() {
    for preset in mpm::sim::presets::NAMES {
        let out = mpm(&["scenes", "--show", preset]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert!(
            out.stdout == mpm::sim::presets::get(preset).unwrap().as_bytes(),
            "`mpm scenes --show {preset}` is not the preset's file"
        );
    }
    let one = mpm::sim::Scene::load("drop").unwrap();
    assert!(!mpm::sim::presets::listing("drop", &one).contains("materials"));
    let two = common::scene(
        "[domain]\nsize = [0.2, 0.2, 0.2]\nresolution = [20, 20, 20]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 20.0\n\
         [[material]]\nname = \"oil\"\nrest_density = 900.0\nsound_speed = 20.0\n\
         [[block]]\nmin = [0.03, 0.03, 0.03]\nmax = [0.08, 0.08, 0.08]\nmaterial = \"oil\"\n",
    );
    let line = mpm::sim::presets::listing("two", &two);
    assert!(line.ends_with("(materials: water, oil)"), "{line}");
}

#[test]
fn negative_and_zero_numbers_are_named() {
    for (args, words) in [
        (&["run", "--frames", "-1"][..], "-1 is too small"),
        (&["run", "--export", "x", "--every", "0"][..], "0 is too small"),
        (&["view", "--fixed-frames", "0"][..], "0 is too small"),
        (&["view", "--fixed-frames", "1000"][..], "1 to 60"),
        (&["view", "--max-fps", "0"][..], "0 is too small"),
        (&["view", "--max-fps", "5000"][..], "1 to 1000"),
        (
            &["render", "--frames", "100000", "--no-images"][..],
            "at most 99999",
        ),
        (&["bench", "--steps", "-5"][..], "-5 is too small"),
        // Past u64 and past i128: too large, not "not a whole number" (issue 39, item 7).
        (&["run", "--frames", "99999999999999999999"][..], "is too large"),
        (
            &["run", "--frames", "999999999999999999999999999999999999999999"][..],
            "is too large",
        ),
        (&["bench", "--particles", "-5"][..], "-5 is too small"),
        (&["bench", "--block-size", "7"][..], "from 32"),
        (&["bench", "--block-size", "100"][..], "not a multiple of 32"),
    ] {
        let out = mpm(args);
        assert!(!out.status.success(), "{args:?} accepted");
        let text = stderr(&out);
        assert!(
            text.contains(words) && !text.contains("unexpected argument"),
            "{args:?}: {text}"
        );
    }
}

/// `--processes` outside a launcher names the launchers and their variables, before any work; the
/// window refuses it; and a rank-only variable without the run's size is named.
#[test]
fn processes_outside_a_launcher_are_refused_with_the_launch_commands() {
    let launchers = [
        "OMPI_COMM_WORLD_RANK",
        "OMPI_COMM_WORLD_SIZE",
        "PMI_RANK",
        "PMI_SIZE",
        "SLURM_PROCID",
        "SLURM_NTASKS",
        "RANK",
        "WORLD_SIZE",
    ];
    let run = |args: &[&str], env: &[(&str, &str)]| {
        let mut command = Command::new(common::mpm_binary());
        for name in launchers {
            command.env_remove(name);
        }
        command.args(args).envs(env.iter().copied()).output().unwrap()
    };
    let out = run(&["run", "--processes", "--frames", "1"], &[]);
    assert!(!out.status.success());
    let text = stderr(&out);
    assert!(
        text.contains("mpirun -n N") && text.contains("SLURM_PROCID"),
        "{text}"
    );
    let out = run(&["view", "--processes"], &[]);
    assert!(
        stderr(&out)
            .contains("`mpm view` runs in one process; use --gpus N to step on the GPUs of this host"),
        "{}",
        stderr(&out)
    );
    let out = run(&["run", "--processes", "--frames", "1"], &[("RANK", "1")]);
    assert!(stderr(&out).contains("WORLD_SIZE"), "{}", stderr(&out));
    let out = run(&["run", "--processes", "--gpus", "2"], &[]);
    assert!(stderr(&out).contains("cannot be used with"), "{}", stderr(&out));
    let nowhere = [
        ("RANK", "0"),
        ("WORLD_SIZE", "2"),
        ("MPM_RENDEZVOUS", "/no/such/folder"),
    ];
    let out = run(&["run", "--processes", "--frames", "1"], &nowhere);
    let text = stderr(&out);
    assert!(
        text.contains("MPM_RENDEZVOUS=/no/such/folder: not a folder"),
        "{text}"
    );
    let launched = [("RANK", "0"), ("WORLD_SIZE", "2")];
    for command in ["run", "bench"] {
        let out = run(&[command, "--processes", "--backend", "cpu-parallel"], &launched);
        let text = stderr(&out);
        assert!(!out.status.success());
        assert!(
            text.contains("the cpu-parallel backend steps one rank")
                && text.contains("--backend cpu for the CPU reference's ranks"),
            "mpm {command}: {text}"
        );
        if mpm::cuda::library::device_available().is_err() {
            let out = run(&[command, "--processes", "--backend", "cuda"], &launched);
            let text = stderr(&out);
            assert!(!out.status.success());
            assert!(
                text.contains("no usable CUDA device")
                    && text.contains("as these processes with --backend cpu")
                    && text.contains("--backend cpu --ranks 2"),
                "mpm {command}: {text}"
            );
        }
    }
}

/// `--gpus` is refused, naming the fix, where it cannot run: on the CPU backends, beside `--ranks`,
/// and at zero. The fix for the CPU backends is CUDA where a device works, else dropping `--gpus`
/// (`refusals_give_advice_that_runs_here` runs it).
#[test]
fn gpus_are_refused_where_they_cannot_run() {
    let gpu_fix = if mpm::cuda::library::device_available().is_ok() {
        "use --backend cuda"
    } else {
        "drop --gpus"
    };
    for (args, words) in [
        (
            &["run", "--backend", "cpu", "--gpus", "2", "--frames", "1"][..],
            gpu_fix,
        ),
        (
            &[
                "bench",
                "--backend",
                "cpu-parallel",
                "--gpus",
                "2",
                "--steps",
                "1",
            ][..],
            gpu_fix,
        ),
        (&["run", "--gpus", "2", "--ranks", "2"][..], "cannot be used with"),
        (&["run", "--gpus", "0"][..], "0 is too small"),
    ] {
        let out = mpm(args);
        assert!(!out.status.success(), "{args:?} accepted");
        let text = stderr(&out);
        assert!(text.contains(words), "{args:?}: {text}");
    }
}

/// Every path the viewer writes is checked before the window opens (here there is no display, so a
/// late check would be reported as the missing display instead).
#[test]
fn viewer_paths_are_checked_before_the_window() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing");
    let shot = missing.join("x.png");
    let out = mpm(&["view", "--final-screenshot", shot.to_str().unwrap()]);
    let text = stderr(&out);
    assert!(!out.status.success() && text.contains("does not exist"), "{text}");
    assert!(!text.contains("window"), "checked only after the window: {text}");

    let out = mpm(&["view", "--capture-dir", missing.to_str().unwrap()]);
    let text = stderr(&out);
    assert!(!out.status.success() && text.contains("--capture-dir"), "{text}");
    assert!(!text.contains("window"), "checked only after the window: {text}");
    assert!(!shot.exists() && !missing.exists(), "nothing is created");
}

/// Without a display the viewer says so, without winit's source path.
#[test]
fn viewer_without_a_display_says_so_plainly() {
    let out = mpm(&["view", "--scene", "bench-65k"]);
    let text = stderr(&out);
    assert!(!out.status.success());
    assert!(text.contains("display") && !text.contains(".rs:"), "{text}");
}

/// The error line(s) of a command that failed.
fn error_lines(out: &Output) -> Vec<String> {
    assert!(!out.status.success(), "accepted: {}", stderr(out));
    stderr(out)
        .lines()
        .filter(|l| l.starts_with("error"))
        .map(String::from)
        .collect()
}

/// `mpm view` takes `mpm run`'s export options and checks them as `mpm run` does, with the same
/// messages, before its window opens (here there is no display: a check made only after the window
/// would be reported as the missing display instead): a folder that is a file, an earlier run's
/// frames or stage without --overwrite, a stage in a missing folder, a scene without the bodies
/// --export-bodies asks for, --usd-surface without --export-usd. Accepted options get as far as the
/// window, with --overwrite's note on stderr.
#[test]
fn viewer_exports_are_checked_before_the_window_as_mpm_run_checks_them() {
    let dir = tempfile::tempdir().unwrap();
    let at = |p: &str| dir.path().join(p).display().to_string();
    let file = at("a-file");
    std::fs::write(&file, "x").unwrap();
    let earlier = at("earlier");
    std::fs::create_dir(&earlier).unwrap();
    std::fs::write(dir.path().join("earlier/frame_000000.ply"), "ply").unwrap();
    let stage = at("stage.usda");
    std::fs::write(&stage, "#usda 1.0").unwrap();
    let through_file = format!("{file}/meshes");
    let refusals: [(&[&str], &str); 6] = [
        (&["--export", &file], "is a file, not a directory"),
        (
            &["--export-surface", &through_file],
            "cannot create the export directory",
        ),
        (&["--export", &earlier], "already holds 1 exported frame"),
        (
            &["--export-usd", &stage, "--every", "2"],
            "exists; pass --overwrite to replace it",
        ),
        (
            &["--export-usd", &at("no/such/folder/a.usda")],
            "does not exist; create it",
        ),
        (&["--export-bodies", &at("bodies")], "has no rigid bodies"),
    ];
    for (options, words) in refusals {
        let common = ["--backend", "cpu", "--scene", "dam-break-coarse"];
        let view = mpm(&[&["view"][..], &common, options].concat());
        let run = mpm(&[&["run", "--frames", "0"][..], &common, options].concat());
        let (view_says, run_says) = (error_lines(&view), error_lines(&run));
        assert!(
            view_says.join("\n").contains(words),
            "{options:?}: {}",
            stderr(&view)
        );
        assert!(
            !stderr(&view).contains("window"),
            "{options:?}: checked after the window: {}",
            stderr(&view)
        );
        assert_eq!(
            view_says, run_says,
            "{options:?}: the viewer and mpm run say it differently"
        );
    }
    let usd_surface = mpm(&["view", "--usd-surface"]);
    assert!(
        !usd_surface.status.success() && stderr(&usd_surface).contains("--export-usd <FILE>"),
        "{}",
        stderr(&usd_surface)
    );
    assert_eq!(
        std::fs::read_to_string(&stage).unwrap(),
        "#usda 1.0",
        "the stage is untouched"
    );
    assert!(
        !dir.path().join("bodies").exists(),
        "a refused export made its folder"
    );

    // Accepted, with or without the command name: they get as far as the window, the earlier run's
    // files removed and said so.
    for command in [&["view"][..], &[]] {
        std::fs::write(&stage, "#usda 1.0").unwrap();
        std::fs::write(dir.path().join("earlier/frame_000000.ply"), "ply").unwrap();
        let options = [
            "--export",
            &earlier,
            "--export-usd",
            &stage,
            "--every",
            "3",
            "--overwrite",
        ];
        let out = mpm(&[command, &options].concat());
        let text = stderr(&out);
        assert!(
            !out.status.success() && text.contains("cannot open a window"),
            "{text}"
        );
        assert!(
            text.contains(&format!("--overwrite: removed the earlier {stage}"))
                && text.contains("--overwrite: removed frame_000000.ply of an earlier run"),
            "{command:?}: no note of what --overwrite removed: {text}"
        );
        assert!(
            !std::path::Path::new(&stage).exists(),
            "--overwrite removed the earlier stage"
        );
    }
}

#[test]
fn export_onto_a_file_says_it_is_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("frames");
    std::fs::write(&file, "x").unwrap();
    let out = mpm(&["run", "--frames", "1", "--export", file.to_str().unwrap()]);
    let text = stderr(&out);
    assert!(
        !out.status.success() && text.contains("is a file, not a directory"),
        "{text}"
    );
}

/// A huge --frames is accepted and simply runs (it used to abort reserving memory for every frame).
#[test]
fn a_huge_frame_count_starts_running() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("tiny.toml");
    std::fs::write(
        &scene,
        "[domain]\nsize = [0.1, 0.1, 0.1]\nresolution = [10, 10, 10]\n[material]\nrest_density = 1000.0\n\
         sound_speed = 10.0\n[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.05, 0.05, 0.05]\n",
    )
    .unwrap();
    let mut child = Command::new(common::mpm_binary())
        .args(["run", "--backend", "cpu", "--frames", "99999999999", "--scene"])
        .arg(&scene)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut first = String::new();
    {
        use std::io::BufRead;
        let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
        while start.elapsed() < Duration::from_secs(60) {
            match lines.next() {
                Some(Ok(line)) if line.starts_with("frame") => {
                    first = line;
                    break;
                }
                Some(Ok(_)) => continue,
                _ => break,
            }
        }
    }
    let status = child.try_wait().unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(status.is_none(), "mpm ended: {status:?}");
    assert!(first.starts_with("frame     1"), "no frame line: {first:?}");
}

/// `mpm render` that fails after checking its --out folder (here: the CUDA backend without a GPU,
/// or no EGL) leaves no folder behind. On a machine where it succeeds there is nothing to check.
#[test]
fn a_failed_render_leaves_no_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("new").join("frames");
    let out = mpm(&[
        "render",
        "--backend",
        "cuda",
        "--frames",
        "1",
        "--size",
        "64x64",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    if !out.status.success() {
        assert!(
            !dir.path().join("new").exists(),
            "left {}: {}",
            out_dir.display(),
            stderr(&out)
        );
    }
}

/// The folder of a frame sequence that never got a frame is removed with it (the unit behind the
/// test above, which needs a failing machine).
#[test]
fn an_unused_frame_sequence_removes_its_folders() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("a").join("b");
    let sequence = mpm::render::capture::FrameSequence::create(&out_dir, 3).unwrap();
    assert!(out_dir.is_dir());
    drop(sequence);
    assert!(!dir.path().join("a").exists(), "left the folders behind");
    // A folder that existed before is left alone.
    let sequence = mpm::render::capture::FrameSequence::create(dir.path(), 3).unwrap();
    drop(sequence);
    assert!(dir.path().is_dir());
}

/// A run that cannot start (here the CUDA backend refuses a collider scene in the report pipeline,
/// or has no GPU) creates none of its outputs, so the same command on another backend is not refused
/// for files a failed start left (issue 17, item 3).
#[test]
fn a_run_that_cannot_start_leaves_no_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let at = |p: &str| dir.path().join(p).display().to_string();
    let (export, checkpoint, stats) = (at("p"), at("c"), at("s.jsonl"));
    let run = |backend: &str, pipeline: &str| {
        mpm(&[
            "run",
            "--backend",
            backend,
            "--pipeline",
            pipeline,
            "--scene",
            "dam-break-obstacle",
            "--frames",
            "0",
            "--export",
            &export,
            "--checkpoint",
            &checkpoint,
            "--stats",
            &stats,
        ])
    };
    let failed = run("cuda", "report");
    assert!(!failed.status.success(), "{}", stdout(&failed));
    for path in [&export, &checkpoint, &stats] {
        assert!(
            !std::path::Path::new(path).exists(),
            "{path} was left behind: {}",
            stderr(&failed)
        );
    }
    let retry = run("cpu", "binned");
    assert!(retry.status.success(), "{}", stderr(&retry));
}

/// `--frames 0` writes the checkpoint after the last frame, which is the start, and leaves no empty
/// stats file (issue 17, item 5).
#[test]
fn zero_frames_write_the_start_as_the_last_checkpoint_and_no_empty_stats() {
    let dir = tempfile::tempdir().unwrap();
    let checkpoints = dir.path().join("c");
    let stats = dir.path().join("s.jsonl");
    let out = common::cpu_run(
        "dam-break-coarse",
        "0",
        &[
            "--checkpoint",
            checkpoints.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        checkpoints.join("checkpoint_000000.mpmck").is_file(),
        "{}",
        stdout(&out)
    );
    assert!(!stats.exists(), "an empty stats file");
}

/// A file a killed run was still writing (`*.partial`) is not an exported frame: the next run into
/// the folder neither counts it nor refuses for it, and removes it, saying so (issue 17, item 6).
#[test]
fn a_killed_runs_unfinished_file_is_removed_not_counted() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    std::fs::write(frames.join("frame_000000.ply.partial"), b"cut short").unwrap();
    let out = common::cpu_run("dam-break-coarse", "0", &["--export", frames.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("removed 1 file that a killed run left unfinished"),
        "{}",
        stdout(&out)
    );
    assert!(!frames.join("frame_000000.ply.partial").exists());
    assert!(frames.join("frame_000000.ply").is_file());
}

/// Help and defaults a newcomer meets (issue 17, item 9): `mpm bench` runs on a machine without a
/// GPU (its backend is auto), a run's option given to the viewer says where it goes, and `--export`
/// ends with a line saying what it wrote.
#[test]
fn bench_defaults_to_auto_run_options_point_to_run_and_export_says_what_it_wrote() {
    let bench = mpm(&[
        "bench",
        "--scene",
        "dam-break-coarse",
        "--steps",
        "2",
        "--warmup",
        "0",
    ]);
    assert!(bench.status.success(), "{}", stderr(&bench));
    if mpm::cuda::library::device_available().is_err() {
        assert!(stdout(&bench).contains("cpu-parallel"), "{}", stdout(&bench));
    }
    let misplaced = mpm(&["--frames", "10"]);
    assert!(!misplaced.status.success());
    assert!(
        stderr(&misplaced).contains("`mpm run --frames 10`"),
        "{}",
        stderr(&misplaced)
    );

    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("f");
    let run = common::cpu_run("dam-break-coarse", "2", &["--export", frames.to_str().unwrap()]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stdout(&run).contains("exported 3 particle frames into"),
        "{}",
        stdout(&run)
    );
}

/// Messages that point the right way (issue 17, item 8): a missing mesh file names the path it was
/// looked for at and how to get a preset's; a missing `--resume` file is named as missing; a scene
/// file without `.toml` loads.
#[test]
fn messages_point_the_right_way() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("tap.toml");
    let shown = mpm(&["scenes", "--show", "tap"]);
    std::fs::write(&scene, &shown.stdout).unwrap();
    assert!(
        stderr(&shown).contains("mpm scenes --mesh glass.obj > glass.obj"),
        "{}",
        stderr(&shown)
    );
    let out = common::cpu_run(scene.to_str().unwrap(), "0", &[]);
    let text = stderr(&out);
    assert!(!out.status.success());
    assert!(
        text.contains(&dir.path().join("glass.obj").display().to_string()),
        "{text}"
    );
    assert!(text.contains("mpm scenes --mesh glass.obj > glass.obj"), "{text}");
    let mesh = mpm(&["scenes", "--mesh", "glass.obj"]);
    std::fs::write(dir.path().join("glass.obj"), &mesh.stdout).unwrap();
    let out = common::cpu_run(scene.to_str().unwrap(), "0", &[]);
    assert!(out.status.success(), "{}", stderr(&out));

    let missing = dir.path().join("checkpoint_000007.mpmck");
    let out = mpm(&["run", "--resume", missing.to_str().unwrap()]);
    assert!(
        stderr(&out).contains("there is no checkpoint"),
        "{}",
        stderr(&out)
    );

    let bare = dir.path().join("coarse");
    std::fs::write(&bare, mpm::sim::presets::get("dam-break-coarse").unwrap()).unwrap();
    let out = common::cpu_run(bare.to_str().unwrap(), "0", &[]);
    assert!(out.status.success(), "{}", stderr(&out));

    // A path that is not UTF-8 is refused as a --scene path, saying why and what to do.
    use std::os::unix::ffi::OsStrExt;
    let latin1 = dir.path().join(std::ffi::OsStr::from_bytes(b"d\xe9mo.toml"));
    let out = Command::new(common::mpm_binary())
        .args(["run", "--backend", "cpu", "--frames", "0", "--scene"])
        .arg(&latin1)
        .output()
        .expect("running mpm");
    let text = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{text}");
    assert!(
        text.contains("--scene") && text.contains("not valid UTF-8") && text.contains("ln -s"),
        "{text}"
    );
    assert!(!text.contains("Error:"), "{text}");
}

/// `mpm devices` answers on any machine: a CUDA line and an NCCL line, each either what is there or
/// what is missing with the fix; a bad MPM_NCCL_LIB is named.
#[test]
fn devices_says_what_is_here_and_what_is_missing() {
    let out = mpm(&["devices"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    let line = |prefix: &str| {
        text.lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("no {prefix} line:\n{text}"))
            .to_string()
    };
    let cuda = line("CUDA: ");
    assert!(cuda.contains("device") || cuda.contains("driver"), "{cuda}");
    let nccl = line("NCCL: ");
    assert!(
        nccl.starts_with("NCCL: 2.") || nccl.contains("pip install nvidia-nccl-cu13"),
        "neither a version nor the fix: {nccl}"
    );
    let out = Command::new(common::mpm_binary())
        .arg("devices")
        .env("MPM_NCCL_LIB", "/nonexistent/libnccl.so.2")
        .output()
        .unwrap();
    let text = stdout(&out);
    assert!(
        text.contains("MPM_NCCL_LIB=/nonexistent/libnccl.so.2 is not a file"),
        "{text}"
    );
}

/// `args` with the flags in `drop` (each with its value) taken out and `add` put in.
fn with(args: &[String], drop: &[&str], add: &[&str]) -> Vec<String> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < args.len() {
        if drop.contains(&args[i].as_str()) {
            i += 2;
            continue;
        }
        out.push(args[i].clone());
        i += 1;
    }
    out.extend(add.iter().map(|a| a.to_string()));
    out
}

/// Every refusal of `--gpus` and `--ranks` on a machine without CUDA gives advice that runs on it:
/// the test follows each piece of advice and runs it (issue 39, item 2: `--gpus 2` advised
/// cpu-parallel, which refused `--gpus`; `--ranks 2` advised cpu-parallel, which refused `--ranks`;
/// `bench --gpus 2` announced timing the CPU, then advised CUDA).
#[test]
fn refusals_give_advice_that_runs_here() {
    if mpm::cuda::library::device_available().is_ok() {
        return; // Where CUDA works these commands run, or are refused for the GPUs' count.
    }
    let run: &[&str] = &["run", "--scene", "dam-break-coarse", "--frames", "1"];
    let bench: &[&str] = &[
        "bench",
        "--scene",
        "dam-break-coarse",
        "--steps",
        "2",
        "--warmup",
        "0",
    ];
    let command = |base: &[&str], backend: Option<&str>, flag: &str| -> Vec<String> {
        let mut a: Vec<String> = base.iter().map(|s| s.to_string()).collect();
        if let Some(b) = backend {
            a.extend(["--backend".to_string(), b.to_string()]);
        }
        a.extend([flag.to_string(), "2".to_string()]);
        a
    };
    // (command, advice the message must hold, the command that advice makes)
    let mut cases: Vec<(Vec<String>, &str, Vec<String>)> = Vec::new();
    for base in [run, bench] {
        for backend in [None, Some("cpu"), Some("cpu-parallel"), Some("cuda")] {
            let a = command(base, backend, "--gpus");
            let (advice, dropped) = match backend {
                Some("cuda") => (
                    "--backend cpu-parallel and no --gpus",
                    with(&a, &["--gpus", "--backend"], &["--backend", "cpu-parallel"]),
                ),
                _ => ("drop --gpus", with(&a, &["--gpus"], &[])),
            };
            cases.push((a.clone(), advice, dropped));
            let split = with(
                &a,
                &["--gpus", "--backend"],
                &["--backend", "cpu", "--ranks", "2"],
            );
            cases.push((a, "--backend cpu --ranks 2 in place of --gpus", split));
        }
        for backend in [None, Some("cpu-parallel"), Some("cuda")] {
            let a = command(base, backend, "--ranks");
            let split = with(&a, &["--backend"], &["--backend", "cpu"]);
            cases.push((a.clone(), "--backend cpu --ranks 2", split));
            let advice = match backend {
                Some("cuda") => "drop --ranks and --backend cuda",
                _ => "drop --ranks",
            };
            let dropped = with(&a, &["--ranks", "--backend"], &[]);
            cases.push((a, advice, dropped));
        }
    }
    for (args, advice, fixed) in cases {
        let args_ref: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = mpm(&args_ref);
        let text = stderr(&out);
        assert!(!out.status.success(), "{args:?} ran without CUDA");
        assert!(text.contains(advice), "{args:?}: `{advice}` not in: {text}");
        assert!(
            !text.contains("use --backend cuda") && !text.contains("timing the CPU"),
            "{args:?}: advice that cannot run here, or work announced before the refusal: {text}"
        );
        let fixed_ref: Vec<&str> = fixed.iter().map(String::as_str).collect();
        let retry = mpm(&fixed_ref);
        assert!(
            retry.status.success(),
            "{args:?} advised `{advice}`; {fixed:?} failed: {}",
            stderr(&retry)
        );
    }
}

/// `mpm bench --json PATH` checks the path before the first table, as `mpm run` checks its outputs:
/// a file on the path, a missing folder and a read-only folder fail at once, naming the problem
/// (issue 39, item 3). As root the read-only case runs as `nobody` (through setpriv).
#[test]
fn bench_json_is_checked_before_the_work() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let bench = |json: &std::path::Path| -> Vec<String> {
        [
            "bench",
            "--backend",
            "cpu",
            "--scene",
            "dam-break-coarse",
            "--steps",
            "2",
            "--warmup",
            "0",
            "--json",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([json.display().to_string()])
        .collect()
    };
    let as_root = std::fs::metadata("/proc/self")
        .map(|m| m.uid() == 0)
        .unwrap_or(false);
    for (json, words) in [
        (file.join("out.json"), "is a file, not a folder"),
        (dir.path().join("missing").join("out.json"), "does not exist"),
        (locked.join("out.json"), "not writable"),
    ] {
        let args = bench(&json);
        let out = if as_root {
            Command::new("setpriv")
                .args(["--reuid=65534", "--regid=65534", "--clear-groups", "--"])
                .arg(common::mpm_binary())
                .args(&args)
                .output()
                .expect("as root, this test runs mpm as nobody through setpriv (util-linux)")
        } else {
            Command::new(common::mpm_binary()).args(&args).output().unwrap()
        };
        let text = stderr(&out);
        assert!(!out.status.success(), "{json:?} accepted");
        assert!(
            text.contains(words) && text.contains("--json"),
            "{json:?}: {text}"
        );
        assert!(
            !stdout(&out).contains("| total"),
            "{json:?}: refused only after the tables"
        );
    }
    // A good path still takes the report.
    let good = dir.path().join("report.json");
    let args = bench(&good);
    let out = Command::new(common::mpm_binary()).args(&args).output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(good.is_file());
    assert!(
        !dir.path().join(".mpm-write-check").exists(),
        "the probe file was left"
    );
}

/// `mpm bench` says what it times (issue 39, item 7): a particle count rounded to whole cells says
/// the count it runs, the reference split into ranks is not labelled a single thread, and a CUDA
/// block size with a CPU backend is refused rather than ignored.
#[test]
fn bench_says_what_it_times() {
    let out = mpm(&[
        "bench",
        "--backend",
        "cpu",
        "--particles",
        "10",
        "--steps",
        "1",
        "--warmup",
        "0",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--particles 10") && stderr(&out).contains("holds 16 particles"),
        "{}",
        stderr(&out)
    );
    let out = mpm(&[
        "bench",
        "--backend",
        "cpu",
        "--ranks",
        "2",
        "--scene",
        "dam-break-coarse",
        "--steps",
        "2",
        "--warmup",
        "0",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.contains("2 ranks of one thread each") && !text.contains("single thread"),
        "{text}"
    );
    let out = mpm(&[
        "bench",
        "--backend",
        "cpu-parallel",
        "--block-size",
        "64",
        "--steps",
        "1",
    ]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("drop --block-size"), "{}", stderr(&out));
}

/// No help text shows a Rust doc link (the `--pipeline` values showed [`DensityRule::Advected`]).
#[test]
fn help_has_no_rust_doc_links() {
    for command in ["view", "render", "run", "bench", "scenes", "devices"] {
        let out = mpm(&[command, "--help"]);
        let text = stdout(&out);
        assert!(out.status.success() && !text.contains("[`"), "{command}: {text}");
    }
}

/// Without CUDA the fallback note says why and what runs, not "use --backend cpu-parallel" while
/// already using it; without a display the viewer's error does not ask whether DISPLAY is set after
/// saying it is not, and gives a whole `mpm render` command, with the coarse scene on a CPU (issue
/// 39, items 1 and 7).
#[test]
fn notes_and_errors_do_not_advise_what_is_done_or_asked() {
    if mpm::cuda::library::device_available().is_err() {
        let out = mpm(&["run", "--scene", "dam-break-coarse", "--frames", "0"]);
        let text = stderr(&out);
        assert!(out.status.success(), "{text}");
        assert!(
            text.contains("(cpu-parallel)") && !text.contains("use --backend cpu-parallel"),
            "{text}"
        );
        let out = mpm(&["view"]);
        let text = stderr(&out);
        assert!(
            text.contains("`mpm render --scene dam-break-coarse --frames 120 --out frames`"),
            "{text}"
        );
    }
    let out = mpm(&["view", "--scene", "fountain"]);
    let text = stderr(&out);
    assert!(!out.status.success());
    assert!(!text.contains("is DISPLAY") && !text.contains("set?"), "{text}");
    assert!(text.contains("--out frames"), "{text}");
}

/// `--resume DIR` (the folder `--checkpoint DIR` wrote) resumes from its latest checkpoint, saying
/// which; a folder without checkpoints says what to give (issue 39, item 7).
#[test]
fn resume_from_a_folder_takes_its_latest_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let checkpoints = dir.path().join("c");
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "--backend", "cpu", "--frames", "2"];
        args.extend(extra);
        mpm(&args)
    };
    let c = checkpoints.to_str().unwrap();
    let first = run(&[
        "--scene",
        "dam-break-coarse",
        "--checkpoint",
        c,
        "--checkpoint-every",
        "1",
    ]);
    assert!(first.status.success(), "{}", stderr(&first));
    let out = run(&["--resume", c]);
    let text = stdout(&out);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        text.contains("checkpoint_000002.mpmck")
            && text.contains("at frame 2")
            && text.contains("frame     4"),
        "{text}"
    );
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let out = run(&["--resume", empty.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("a folder without checkpoints"),
        "{}",
        stderr(&out)
    );
}

/// `mpm render` of a long run says what it will cost after its second frame, as `mpm run` does
/// (issue 39, item 1): 99999 coarse frames drawn take hours on any machine this runs on. Needs a
/// headless OpenGL (EGL); without one there is nothing to time.
#[test]
fn a_long_render_says_its_cost_early() {
    let mut child = Command::new(common::mpm_binary())
        .args([
            "render",
            "--scene",
            "dam-break-coarse",
            "--frames",
            "99999",
            "--no-images",
            "--size",
            "320x180",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut note = None;
    let mut seen = Vec::new();
    {
        use std::io::BufRead;
        let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
        while start.elapsed() < Duration::from_secs(120) {
            match lines.next() {
                Some(Ok(line)) if line.starts_with("note:") => {
                    note = Some(line);
                    break;
                }
                Some(Ok(line)) => seen.push(line),
                _ => break,
            }
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    if !seen.iter().any(|l| l.starts_with("OpenGL:")) {
        return; // No headless OpenGL here: render stopped before its first frame.
    }
    let note = note.unwrap_or_else(|| panic!("no cost note within 2 minutes: {seen:?}"));
    assert!(
        note.contains("these 99999 frames take about") && note.contains("drawing a frame"),
        "{note}"
    );
}

/// The progress bar's ETA (issue 39, item 6): unknown before the first frame, not "0s"; through a
/// slow frame it counts down, and when the frame ends it goes on from where it was instead of jumping
/// with that one frame's cost.
#[test]
fn the_eta_holds_steady() {
    use mpm::runner::eta;
    let s = Duration::from_secs;
    assert_eq!(eta(0, 100, s(0), s(5)), None);
    // 10 s a frame: after 3 frames, 97 are left.
    assert_eq!(eta(3, 100, s(30), s(30)), Some(s(970)));
    assert_eq!(
        eta(3, 100, s(30), s(34)),
        Some(s(966)),
        "counts down within a frame"
    );
    assert_eq!(eta(4, 100, s(40), s(40)), Some(s(960)), "and goes on from there");
    // One frame of twice the cost moves the estimate by a frame's worth, not by half of it all.
    let after_slow = eta(11, 100, s(120), s(120)).unwrap().as_secs_f64();
    assert!((after_slow - 890.0).abs() < 90.0, "{after_slow}");
    assert_eq!(eta(100, 100, s(1000), s(1000)), Some(s(0)));
}

/// docs/command-line.md's synopsis holds every option each command's `--help` lists (issue 39, item
/// 9: `view` and `render` had none, and `--gpus` was missing from `run` and `bench`).
#[test]
fn the_command_line_page_lists_every_option() {
    let page = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/command-line.md")).unwrap();
    let synopsis = page.split("```").nth(1).expect("the synopsis block");
    for command in ["view", "render", "run", "bench", "scenes"] {
        let lines: String = synopsis
            .split("\nmpm ")
            .filter(|block| {
                let name = block.split_whitespace().next().unwrap_or("");
                name == command || (command == "view" && name == "[view]")
            })
            .collect();
        assert!(!lines.is_empty(), "no synopsis of `mpm {command}`");
        let help = stdout(&mpm(&[command, "--help"]));
        for option in help
            .lines()
            .filter(|l| l.trim_start().starts_with('-'))
            .filter_map(|l| l.split_whitespace().find(|w| w.starts_with("--")))
            .map(|w| w.trim_end_matches(','))
            .filter(|o| *o != "--help" && *o != "--version")
        {
            // The whole option, not a longer one it begins (`--surface-format` for `--surface`).
            let whole = lines.match_indices(option).any(|(at, _)| {
                !lines[at + option.len()..].starts_with(|c: char| c.is_ascii_alphanumeric() || c == '-')
            });
            assert!(
                whole,
                "`mpm {command} {option}` is not in docs/command-line.md's synopsis"
            );
        }
    }
}

/// `mpm run` closes with where its wall time went, the parts adding up to the whole.
#[test]
fn a_run_says_where_its_wall_time_went() {
    let out = common::cpu_run("dam-break-coarse", "3", &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    let line = text.lines().last().unwrap_or_default();
    assert!(
        line.starts_with("time: "),
        "the last line is not the time line: {line:?}"
    );
    let seconds: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter(|w| w.contains('.'))
        .map(|w| w.parse().unwrap())
        .collect();
    // wall, start-up, the frames' stepping, finishing, then the substeps' own timing and the ratio.
    let [wall, start_up, stepping, finishing, substeps, ratio] = seconds[..] else {
        panic!("six figures expected in {line:?}");
    };
    assert!(line.contains(" 3 frames "), "{line}");
    // Each figure is rounded to the millisecond on its own: four roundings of half a millisecond.
    assert!((start_up + stepping + finishing - wall).abs() <= 0.0021, "{line}");
    assert!(substeps > 0.0 && substeps <= stepping + 0.001, "{line}");
    assert!((wall / substeps - ratio).abs() <= 0.01 * ratio + 0.01, "{line}");
}
