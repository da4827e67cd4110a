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

/// A 20 cm tank at dx = 1 cm with `materials` (TOML `[[material]]` entries) and `bodies` after them.
fn liquids(materials: &str, bodies: &str) -> String {
    format!("[domain]\nsize = [0.2, 0.2, 0.2]\nresolution = [20, 20, 20]\n{materials}{bodies}")
}

/// A `[[material]]` entry named `name` of water's density and sound speed, with `extra` keys.
fn entry(name: &str, extra: &str) -> String {
    format!("[[material]]\nname = \"{name}\"\nrest_density = 1000.0\nsound_speed = 20.0\n{extra}")
}

/// A block of `material` (none where empty), the `i`-th of a row of them along x.
fn block_of(i: usize, material: &str) -> String {
    let x = 0.03 + 0.04 * i as f64;
    let name = if material.is_empty() {
        String::new()
    } else {
        format!("material = \"{material}\"\n")
    };
    format!(
        "[[block]]\nmin = [{x}, 0.03, 0.03]\nmax = [{}, 0.08, 0.08]\n{name}",
        x + 0.03
    )
}

/// Water and oil, each in its own block.
fn water_and_oil(water_block: &str) -> String {
    liquids(
        &format!("{}{}", entry("water", ""), entry("oil", "viscosity = 0.05\n")),
        &format!("{}{}", block_of(0, water_block), block_of(1, "oil")),
    )
}

/// (what, scene text, expected key, words the message must contain)
fn cases() -> Vec<(&'static str, String, &'static str, &'static str)> {
    let water = |extra: &str| common::water_box(20, extra);
    let herschel_bulkley = "law = \"herschel-bulkley\"\nconsistency = 2.0\nmax_viscosity = 50.0\n";
    let solid = |extra: &str| {
        format!("[[material]]\nname = \"jelly\"\nlaw = \"fixed-corotated\"\nrest_density = 500.0\n{extra}")
    };
    let jelly = "youngs_modulus = 4.0e4\npoisson_ratio = 0.3\n";
    vec![
        // Solids (issue "Solids in the tank").
        (
            "a solid given a sound speed",
            liquids(&solid(&format!("{jelly}sound_speed = 10.0\n")), &block_of(0, "jelly")),
            "material[0].sound_speed",
            "not a parameter of law = \"fixed-corotated\"",
        ),
        (
            "a solid without its Young's modulus",
            liquids(&solid("poisson_ratio = 0.3\n"), &block_of(0, "jelly")),
            "material[0].youngs_modulus",
            "is missing",
        ),
        (
            "a Poisson's ratio of a half",
            liquids(&solid("youngs_modulus = 4.0e4\npoisson_ratio = 0.5\n"), &block_of(0, "jelly")),
            "material[0].poisson_ratio",
            "outside [0, 0.49]",
        ),
        (
            "a liquid's viscosity on a solid",
            liquids(&solid(&format!("{jelly}viscosity = 1.0\n")), &block_of(0, "jelly")),
            "material[0].viscosity",
            "choose a law that takes it",
        ),
        (
            "sand without its friction angle",
            liquids(
                "[[material]]\nname = \"sand\"\nlaw = \"sand\"\nrest_density = 1600.0\nyoungs_modulus = 3.5e5\npoisson_ratio = 0.3\n",
                &block_of(0, "sand"),
            ),
            "material[0].friction_angle",
            "is missing",
        ),
        (
            "an emitter of a solid",
            liquids(
                &format!("{}{}", entry("water", ""), solid(jelly)),
                &format!(
                    "{}[particles]\ncapacity = 20000\n[[emitter]]\nmaterial = \"jelly\"\nshape = \"disc\"\nparticles_per_cell = 8\ncenter = [0.1, 0.15, 0.1]\nnormal = [0.0, -1.0, 0.0]\nradius = 0.02\nspeed = 1.0\n",
                    block_of(0, "water")
                ),
            ),
            "emitter[0].material",
            "an emitter pours liquids",
        ),
        // The yield stress's regularisation (docs/physics.md, "Yield stress").
        (
            "herschel-bulkley without a regularisation",
            liquids(
                &entry("mud", "law = \"herschel-bulkley\"\nconsistency = 2.0\nyield_stress = 50.0\n"),
                &block_of(0, ""),
            ),
            "material[0].max_viscosity",
            "or shear_modulus (Pa",
        ),
        (
            "an elastic herschel-bulkley of n != 1 without a ceiling",
            liquids(
                &entry(
                    "paste",
                    "law = \"herschel-bulkley\"\nconsistency = 2.0\nflow_index = 0.5\nyield_stress = 50.0\nshear_modulus = 1.0e4\n",
                ),
                &block_of(0, ""),
            ),
            "material[0].max_viscosity",
            "no bound of its own",
        ),
        (
            "a shear modulus given to a solid",
            liquids(
                &format!("{}{}", entry("water", ""), solid(jelly).replace("poisson_ratio", "shear_modulus = 1.0e4\npoisson_ratio")),
                &block_of(0, "water"),
            ),
            "material[1].shear_modulus",
            "choose a law that takes it (\"herschel-bulkley\")",
        ),
        (
            "a negative shear modulus",
            liquids(
                &entry("mud", "law = \"herschel-bulkley\"\nconsistency = 2.0\nyield_stress = 50.0\nshear_modulus = -5.0\n"),
                &block_of(0, ""),
            ),
            "material[0].shear_modulus",
            "must be positive",
        ),
        // The material table (issue "Liquids beyond water", item 3).
        (
            "a material's absorption past the opaque end",
            liquids(&entry("ink", "absorption = 500.0\n"), &block_of(0, "ink")),
            "material[0].absorption",
            "from 0 (clear) to 100 (opaque)",
        ),
        (
            "a negative absorption",
            liquids(&entry("ink", "absorption = -1.0\n"), &block_of(0, "ink")),
            "material[0].absorption",
            "from 0 (clear)",
        ),
        (
            "a body naming an unknown material",
            water_and_oil("watr"),
            "block[0].material",
            "use one of \"water\", \"oil\"",
        ),
        (
            "a [[material]] without a name",
            liquids(
                &format!(
                    "{}[[material]]\nrest_density = 900.0\nsound_speed = 20.0\n",
                    entry("water", "")
                ),
                &block_of(0, "water"),
            ),
            "material[1].name",
            "is missing",
        ),
        (
            "a law given a parameter it does not take",
            liquids(&entry("water", "yield_stress = 5.0\n"), &block_of(0, "")),
            "material[0].yield_stress",
            "not a parameter of law = \"newtonian\"",
        ),
        (
            "herschel-bulkley without its yield stress",
            liquids(&entry("mud", herschel_bulkley), &block_of(0, "")),
            "material[0].yield_stress",
            "give yield_stress (Pa)",
        ),
        (
            "two materials of one name",
            liquids(
                &format!("{}{}", entry("water", ""), entry("water", "viscosity = 0.01\n")),
                &block_of(0, "water"),
            ),
            "material[1].name",
            "already the name of material[0]",
        ),
        (
            "more than 8 materials",
            liquids(
                &(0..9)
                    .map(|i| entry(&format!("liquid {i}"), ""))
                    .collect::<String>(),
                &block_of(0, "liquid 0"),
            ),
            "material",
            "more than the 8",
        ),
        (
            "several materials and a block naming none",
            water_and_oil(""),
            "block[0].material",
            "is missing: the scene has several materials",
        ),
        (
            "a material name with a line break",
            liquids(&entry("water\\nplus", ""), &block_of(0, "")),
            "material[0].name",
            "line break",
        ),
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

/// Each material-table refusal's fix, done as it says, loads: the name it suggests, the parameter it
/// asks for, the law it names.
#[test]
fn the_material_tables_fixes_load() {
    let loads = |what: &str, toml: &str| {
        Scene::from_toml(toml, "fixed.toml").unwrap_or_else(|e| panic!("{what}: the fix is refused: {e}"))
    };
    // An unknown name: one of those listed.
    let e = refuse(&water_and_oil("watr"));
    assert!(e.fix.contains("\"water\""), "{e}");
    let scene = loads("the unknown name", &water_and_oil("water"));
    assert_eq!(scene.materials.len(), 2);
    assert_eq!(scene.bodies[0].material, 0);
    assert_eq!(scene.bodies[1].material, 1);
    // A block naming none: the example the fix gives.
    let e = refuse(&water_and_oil(""));
    assert!(e.fix.contains("material = \"water\""), "{e}");
    // Herschel-Bulkley without a yield stress: give it.
    let mud = |extra: &str| {
        liquids(
            &entry(
                "mud",
                &format!("law = \"herschel-bulkley\"\nconsistency = 2.0\nmax_viscosity = 50.0\n{extra}"),
            ),
            &block_of(0, ""),
        )
    };
    let e = refuse(&mud(""));
    assert!(e.fix.contains("docs/scenes.md"), "{e}");
    let scene = loads("the missing yield stress", &mud("yield_stress = 20.0\n"));
    assert_eq!(scene.materials[0].law.yield_stress, 20.0);
    // A parameter of another law: the fix names the laws that take it.
    let e = refuse(&liquids(
        &entry("water", "yield_stress = 5.0\n"),
        &block_of(0, ""),
    ));
    assert!(e.fix.contains("\"herschel-bulkley\""), "{e}");
    // More than eight: eight load.
    let eight = liquids(
        &(0..8)
            .map(|i| entry(&format!("liquid {i}"), ""))
            .collect::<String>(),
        &block_of(0, "liquid 0"),
    );
    assert_eq!(loads("eight materials", &eight).materials.len(), 8);
}
