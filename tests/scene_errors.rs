//! Bad scenes are refused with a message that names the file, the key and the fix.

mod common;

use mpm::sim::{Scene, SceneError};

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
fn a_missing_file_and_an_unknown_preset_say_what_exists() {
    let e = Scene::load("/nonexistent/scene.toml").unwrap_err();
    assert!(e.to_string().contains("cannot be read"), "{e}");
    let e = Scene::load("dambreak").unwrap_err();
    assert!(e.to_string().contains("dam-break"), "the presets are listed: {e}");
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
