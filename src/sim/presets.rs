//! Built-in scenes. Each is an ordinary scene file under `scenes/`, embedded in the binary, so
//! `mpm scenes --show NAME` prints a complete, valid starting point for a scene of one's own.

/// Preset names, the default first.
pub const NAMES: [&str; 9] = [
    "dam-break",
    "dam-break-coarse",
    "dam-break-obstacle",
    "wave-tank",
    "double-dam-break",
    "drop",
    "fountain",
    "bench-65k",
    "bench-655k",
];

const FILES: [&str; 9] = [
    include_str!("../../scenes/dam-break.toml"),
    include_str!("../../scenes/dam-break-coarse.toml"),
    include_str!("../../scenes/dam-break-obstacle.toml"),
    include_str!("../../scenes/wave-tank.toml"),
    include_str!("../../scenes/double-dam-break.toml"),
    include_str!("../../scenes/drop.toml"),
    include_str!("../../scenes/fountain.toml"),
    include_str!("../../scenes/bench-65k.toml"),
    include_str!("../../scenes/bench-655k.toml"),
];

/// The default scene of the runner and the viewer.
pub const DEFAULT: &str = NAMES[0];

/// The TOML text of a preset.
pub fn get(name: &str) -> Option<&'static str> {
    NAMES.iter().position(|&n| n == name).map(|i| FILES[i])
}
