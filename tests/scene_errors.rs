//! Bad scenes are refused with a message that names the file, the key and the fix.

mod common;

use mpm::sim::{Pipeline, Scene, SceneError};

const BLOCK: &str = "[[block]]\nmin = [0.05, 0.05, 0.05]\nmax = [0.1, 0.1, 0.1]\n";

fn refuse(toml: &str) -> SceneError {
    match Scene::from_toml(toml, "bad.toml") {
        Ok(_) => panic!("accepted a bad scene:\n{toml}"),
        Err(e) => e,
    }
}

/// (what, scene text, expected key, words the message must contain)
fn cases() -> Vec<(&'static str, String, &'static str, &'static str)> {
    let water = |extra: &str| common::water_box(20, extra);
    vec![
        (
            "unknown key",
            water(&format!("[solver]\ngravty = [0.0, -9.8, 0.0]\n{BLOCK}")),
            "",
            "gravty",
        ),
        (
            "negative density",
            water(BLOCK).replace("rest_density = 1000.0", "rest_density = -1000.0"),
            "material.rest_density",
            "positive",
        ),
        (
            "body outside the domain",
            water("[[block]]\nmin = [0.05, 0.05, 0.05]\nmax = [0.1, 0.1, 0.5]"),
            "block[0].max",
            "outside the domain",
        ),
        (
            "sphere outside the domain",
            water("[[sphere]]\ncenter = [0.1, 0.1, 0.1]\nradius = 0.2"),
            "sphere[0]",
            "outside",
        ),
        ("zero particles: no bodies", water(""), "block", "zero particles"),
        (
            "zero particles: a body smaller than the lattice",
            water("[[block]]\nmin = [0.050, 0.050, 0.050]\nmax = [0.051, 0.051, 0.051]"),
            "block[0]",
            "zero particles",
        ),
        (
            "grid under 8 cells",
            water(BLOCK).replace("resolution = [20, 20, 20]", "resolution = [20, 20, 6]"),
            "domain.resolution",
            "under 8",
        ),
        (
            "cells that are not cubes",
            water(BLOCK).replace("resolution = [20, 20, 20]", "resolution = [20, 20, 30]"),
            "domain.resolution",
            "cells must be cubes",
        ),
        (
            "fixed dt above the stability limit",
            water(&format!("[time_step]\ndt = 1.0e-3\n{BLOCK}")),
            "time_step.dt",
            "stability limit",
        ),
        (
            "cfl above the bound",
            water(&format!("[time_step]\ncfl = 0.9\n{BLOCK}")),
            "time_step.cfl",
            "outside (0, 0.5]",
        ),
        (
            "both sound speed and stiffness",
            water(BLOCK).replace("sound_speed = 20.0", "sound_speed = 20.0\neos_stiffness = 5.0e4"),
            "material.sound_speed",
            "both given",
        ),
        (
            "particles per cell not a cube",
            water("[[block]]\nmin = [0.05, 0.05, 0.05]\nmax = [0.1, 0.1, 0.1]\nparticles_per_cell = 6"),
            "block[0].particles_per_cell",
            "1, 8, 27 or 64",
        ),
        (
            "particles per cell differing between bodies",
            water(&format!(
                "{BLOCK}[[sphere]]\ncenter = [0.15, 0.15, 0.15]\nradius = 0.02\nparticles_per_cell = 27"
            )),
            "sphere[0].particles_per_cell",
            "same particles_per_cell",
        ),
        (
            "a particle count that cannot fit in memory",
            common::water_box(
                1000,
                "[[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [9.9, 9.9, 9.9]\nparticles_per_cell = 64",
            ),
            "",
            "available",
        ),
        (
            "unknown GPU pipeline",
            water(&format!("[solver]\npipeline = \"tiled\"\n{BLOCK}")),
            "",
            "binned",
        ),
        // Values that load but could never run are refused at load, naming a range (issue 39,
        // item 5), not left to fail in frame 1 as a "blow-up".
        (
            "a sound speed past the substep cap",
            water(BLOCK).replace("sound_speed = 20.0", "sound_speed = 1.0e12"),
            "material.sound_speed",
            "give a sound speed from 1 to",
        ),
        (
            "a stiffness whose sound speed is past the substep cap",
            water(BLOCK).replace("sound_speed = 20.0", "eos_stiffness = 1.0e20"),
            "material.eos_stiffness",
            "max_substeps",
        ),
        (
            "a gravity under which water falls faster than sound",
            water(&format!("[solver]\ngravity = [0.0, -1.0e9, 0.0]\n{BLOCK}")),
            "solver.gravity",
            "give |g| from 0 to",
        ),
        (
            "not TOML at all",
            "this is not = = toml".to_string(),
            "",
            "not a valid scene file",
        ),
    ]
}

#[test]
fn bad_scenes_name_the_file_the_key_and_the_fix() {
    for (what, toml, key, words) in cases() {
        let e = refuse(&toml);
        let message = e.to_string();
        assert_eq!(e.source, "bad.toml", "{what}");
        assert_eq!(e.key, key, "{what}: {message}");
        assert!(message.contains(words), "{what}: `{words}` not in: {message}");
        assert!(
            !e.fix.is_empty() && message.contains("fix:"),
            "{what}: no fix in: {message}"
        );
        assert!(
            message.contains("bad.toml"),
            "{what}: the file is not named in: {message}"
        );
    }
}

#[test]
fn the_gpu_pipeline_is_fused_unless_the_scene_says_otherwise() {
    let parse =
        |solver: &str| Scene::from_toml(&common::water_box(20, &format!("{solver}{BLOCK}")), "ok.toml");
    assert_eq!(parse("").unwrap().pipeline, Pipeline::Fused);
    assert_eq!(
        parse("[solver]\npipeline = \"fused\"\n").unwrap().pipeline,
        Pipeline::Fused
    );
    assert_eq!(
        parse("[solver]\npipeline = \"report\"\n").unwrap().pipeline,
        Pipeline::Report
    );
    assert_eq!(
        parse("[solver]\npipeline = \"binned\"\n").unwrap().pipeline,
        Pipeline::Binned
    );
}

#[test]
fn a_missing_file_and_an_unknown_preset_say_what_exists() {
    let e = Scene::load("/nonexistent/scene.toml").unwrap_err();
    assert!(e.to_string().contains("does not exist"), "{e}");
    let e = Scene::load("dambreak").unwrap_err();
    assert!(e.to_string().contains("dam-break"), "the presets are listed: {e}");
}

/// A binary file given as a scene is called what it is, not a wrong path.
#[test]
fn a_binary_file_is_not_a_scene_and_not_a_bad_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("noise.toml");
    std::fs::write(&path, [0xffu8, 0xfe, 0x00, 0x9c, 0x80, 0x01]).unwrap();
    let e = Scene::load(path.to_str().unwrap()).unwrap_err().to_string();
    assert!(
        e.contains("not a text file") && !e.contains("check the path"),
        "{e}"
    );
    let e = Scene::load(dir.path().to_str().unwrap()).unwrap_err().to_string();
    assert!(e.contains("is a directory"), "{e}");
}

#[test]
fn a_good_scene_reports_the_exact_particle_count_it_spawns() {
    let scene = common::scene(&common::water_box(
        20,
        "[[block]]\nmin = [0.05, 0.05, 0.05]\nmax = [0.1, 0.1, 0.1]\n\
         [[sphere]]\ncenter = [0.1, 0.1, 0.1]\nradius = 0.03\n",
    ));
    // The block is 5^3 cells at 8 per cell; the sphere overlaps it and adds only its own points.
    let p = scene.spawn();
    assert_eq!(p.len(), scene.num_particles);
    assert!(scene.num_particles > 1000 && scene.num_particles < 1000 + 8 * 113 + 1);
    let mut seen = std::collections::HashSet::new();
    for x in &p.x {
        assert!(
            seen.insert((x * 1e5).round().as_ivec3().to_array()),
            "duplicate particle at {x}"
        );
    }
}

/// A scene whose `max_substeps` is merely lower than it needs is told to raise it; "blowing up" is
/// kept for speeds past what the default allows.
#[test]
fn a_low_max_substeps_is_not_called_a_blow_up() {
    use mpm::sim::scene::{TimeStepPolicy, DEFAULT_MAX_SUBSTEPS};
    use mpm::sim::FRAME_DT;
    let low = TimeStepPolicy::Cfl {
        cfl: 0.4,
        max_substeps: 10,
    };
    // 20 m/s at dx = 1 cm: about 84 substeps per frame.
    let e = low.substeps(FRAME_DT, 20.0, 0.01).unwrap_err();
    assert!(
        e.contains("raise max_substeps") && !e.contains("blowing up"),
        "{e}"
    );
    let default = TimeStepPolicy::Cfl {
        cfl: 0.4,
        max_substeps: DEFAULT_MAX_SUBSTEPS,
    };
    let e = default.substeps(FRAME_DT, 1.0e5, 0.01).unwrap_err();
    assert!(e.contains("blowing up"), "{e}");
}

/// The fix a refusal suggests loads: cells that are not cubes get sizes (and, where one exists, a
/// resolution) the checks accept, never `resolution = [40, 0, 0]` (issue 39, item 7).
#[test]
fn the_cube_cells_fix_loads() {
    let scene = |size: &str, res: &str| {
        format!(
            "[domain]\nsize = {size}\nresolution = {res}\n[material]\nrest_density = 1000.0\n\
             sound_speed = 10.0\n[[block]]\nmin = [0.05, 0.05, 0.05]\nmax = [0.1, 0.1, 0.1]\n"
        )
    };
    // A domain too thin for its resolution: rounding the sizes gives 2 nodes, under the 8 allowed.
    for (size, res) in [
        ("[1.0, 0.05, 0.05]", "[40, 20, 20]"),
        ("[1.0, 0.5, 0.4]", "[40, 20, 20]"),
    ] {
        let e = refuse(&scene(size, res));
        assert_eq!(e.key, "domain.resolution", "{e}");
        let fix = &e.fix;
        let value = |key: &str| {
            fix.split(&format!("{key} = "))
                .nth(1)
                .map(|rest| rest[..=rest.find(']').unwrap()].to_string())
        };
        let new_size = value("size").unwrap_or_else(|| panic!("no size in the fix: {fix}"));
        Scene::from_toml(&scene(&new_size, res), "fixed.toml")
            .unwrap_or_else(|e| panic!("the fix {new_size} is refused: {e}"));
        if let Some(new_res) = value("resolution") {
            Scene::from_toml(&scene(size, &new_res), "fixed.toml")
                .unwrap_or_else(|e| panic!("the fix {new_res} is refused: {e}"));
        }
    }
}

/// The preset scenes all pass the load checks of sound speed and gravity.
#[test]
fn every_preset_passes_the_speed_checks() {
    for name in mpm::sim::presets::NAMES {
        Scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}
