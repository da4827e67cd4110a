//! Built-in scenes. Each is an ordinary scene file under `scenes/`, embedded in the binary, so
//! `mpm scenes --show NAME` prints a complete, valid starting point for a scene of one's own. The
//! mesh files the presets' colliders name are embedded beside them (a preset has no folder on disk
//! to find them in); a scene saved from one finds them beside itself, as any scene does.

/// Preset names, the default first.
pub const NAMES: [&str; 23] = [
    "dam-break",
    "dam-break-1m",
    "dam-break-coarse",
    "dam-break-obstacle",
    "wave-tank",
    "double-dam-break",
    "drop",
    "fountain",
    "tap",
    "honey",
    "mud-dam-break",
    "oil-on-water",
    "jelly-drop",
    "sand-column",
    "snowball",
    "boats",
    "ball-drop",
    "water-wheel",
    "pbmpm-dam-break",
    "pbmpm-jelly-drop",
    "pbmpm-1m",
    "bench-65k",
    "bench-655k",
];

const FILES: [&str; 23] = [
    include_str!("../../scenes/dam-break.toml"),
    include_str!("../../scenes/dam-break-1m.toml"),
    include_str!("../../scenes/dam-break-coarse.toml"),
    include_str!("../../scenes/dam-break-obstacle.toml"),
    include_str!("../../scenes/wave-tank.toml"),
    include_str!("../../scenes/double-dam-break.toml"),
    include_str!("../../scenes/drop.toml"),
    include_str!("../../scenes/fountain.toml"),
    include_str!("../../scenes/tap.toml"),
    include_str!("../../scenes/honey.toml"),
    include_str!("../../scenes/mud-dam-break.toml"),
    include_str!("../../scenes/oil-on-water.toml"),
    include_str!("../../scenes/jelly-drop.toml"),
    include_str!("../../scenes/sand-column.toml"),
    include_str!("../../scenes/snowball.toml"),
    include_str!("../../scenes/boats.toml"),
    include_str!("../../scenes/ball-drop.toml"),
    include_str!("../../scenes/water-wheel.toml"),
    include_str!("../../scenes/pbmpm-dam-break.toml"),
    include_str!("../../scenes/pbmpm-jelly-drop.toml"),
    include_str!("../../scenes/pbmpm-1m.toml"),
    include_str!("../../scenes/bench-65k.toml"),
    include_str!("../../scenes/bench-655k.toml"),
];

/// The line `mpm scenes` lists a loaded scene with: its name, particles and description, and where
/// it has several materials, their names.
pub fn listing(name: &str, scene: &super::Scene) -> String {
    let mut line = format!(
        "{name:<18} {:>9} particles  {}",
        scene.num_particles, scene.description
    );
    if scene.materials.len() > 1 {
        let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        line.push_str(&format!(" (materials: {})", names.join(", ")));
    }
    line
}

/// The default scene of the runner and the viewer.
pub const DEFAULT: &str = NAMES[0];

/// The TOML text of a preset.
pub fn get(name: &str) -> Option<&'static str> {
    NAMES.iter().position(|&n| n == name).map(|i| FILES[i])
}

/// The mesh files the presets name, by the name they give (`file = "glass.obj"`).
const MESHES: [(&str, &str); 2] = [
    ("glass.obj", include_str!("../../scenes/glass.obj")),
    ("water-wheel.obj", include_str!("../../scenes/water-wheel.obj")),
];

/// The names of the mesh files the presets use.
pub const MESH_NAMES: [&str; MESHES.len()] = {
    let mut names = [""; MESHES.len()];
    let mut i = 0;
    while i < MESHES.len() {
        names[i] = MESHES[i].0;
        i += 1;
    }
    names
};

/// The text of a mesh file a preset names.
pub fn mesh(file: &str) -> Option<&'static str> {
    MESHES
        .iter()
        .find(|(name, _)| *name == file)
        .map(|(_, text)| *text)
}
