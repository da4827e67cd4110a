//! The egui side panel: what the viewer shows (rates, timings, time) and the controls it offers. It
//! returns the user's requests as [`Action`]s; the app carries them out (and reports errors back).

use super::legend::Scale;
use super::renderer::{Colouring, DrawMode, RenderSettings};
use super::surface::MAX_THICKNESS_DOWNSAMPLE;
use super::timer::{Pass, PassTimes};
use crate::contract::{LAW_CARREAU_YASUDA, LAW_HERSCHEL_BULKLEY, LAW_POWER_LAW, MAX_MATERIALS};
use crate::sim::scene::MAX_CFL;
use crate::sim::{presets, PhaseTimings};
use egui::{Color32, RichText};
use glam::Vec3;

/// The viscosity slider's top, Pa s: past honey's 10 and the yield-stress liquids' consistencies
/// (the viscous limit on the substep makes the top costly: see docs/physics.md).
const MAX_SLIDER_VISCOSITY: f32 = 1000.0;

/// Values the panel displays, gathered by the app each frame.
pub struct HudInfo<'a> {
    pub scene: &'a str,
    /// The scene's material table: the material colouring's key.
    pub materials: &'a [crate::sim::material::NamedMaterial],
    pub backend: &'a str,
    pub particles: usize,
    pub fps: f64,
    /// Wall milliseconds between draws (smoothed).
    pub frame_ms: f64,
    /// Per-phase GPU (or CPU) milliseconds of the last completed 60 Hz frame, where measured.
    pub timings: Option<PhaseTimings>,
    pub substeps: u32,
    pub dt: f32,
    pub max_cfl: f32,
    /// Substeps since the scene started whose CFL number went above the bound.
    pub substeps_over_cfl: u64,
    /// Particles the colliders' backstop put back on a surface since the start; `None` without colliders.
    pub backstop_pushes: Option<u64>,
    /// A 60 Hz frame is being stepped over several draws.
    pub frame_in_progress: bool,
    pub sim_time: f64,
    pub wall_time: f64,
    /// Simulated / wall seconds (slow-motion factor below 1).
    pub speed: f64,
    pub transfer: &'a str,
    /// GPU milliseconds per render pass (timer queries of a frame a few draws old).
    pub render_passes: Option<PassTimes>,
    /// Whether CUDA summed the surface's thickness (else GL blended it).
    pub thickness_by_cuda: bool,
    pub recording: Option<(String, u64)>,
    /// While the run is exported (`mpm view --export ...`): what so far, "42 frames (ply, usd)".
    pub export: Option<&'a str>,
    pub message: Option<&'a str>,
}

/// What the panel lets the user change, kept between frames.
pub struct Controls {
    pub paused: bool,
    pub render: RenderSettings,
    /// The material row the physics sliders change.
    pub liquid: usize,
    /// Per material row: the viscosity (`Material::viscosity`: mu, K or mu_0 by law) and the
    /// sound speed, as the simulation has them.
    pub viscosity: [f32; MAX_MATERIALS as usize],
    pub sound_speed: [f32; MAX_MATERIALS as usize],
    pub gravity: Vec3,
    /// Step a fixed number of 60 Hz frames per drawn frame instead of following wall time.
    pub fixed_pacing: bool,
    pub frames_per_draw: u32,
    /// The preset chosen in the picker; `None` until one is (e.g. a scene file is running).
    pub preset: Option<usize>,
    pub scene_path: String,
    /// Push: velocity change at the cursor ray per drag pixel, and radius as a fraction of the domain.
    pub push_strength: f32,
    pub push_radius: f32,
    /// The densities a dropped box and ball are given, kg/m^3 (`DropShape::default_density` at the
    /// scene's start: a box that floats, a ball that sinks).
    pub box_density: f64,
    pub ball_density: f64,
    /// Position-based MPM's constraint iterations a substep and substeps a frame, where the scene
    /// runs it (`None` under the explicit scheme).
    pub pbmpm: Option<PbmpmControls>,
}

/// The position-based scheme's live controls.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PbmpmControls {
    pub iterations: u32,
    pub substeps: u32,
}

impl PbmpmControls {
    /// `scene`'s, where it runs position-based MPM.
    pub fn of(scene: &crate::sim::Scene) -> Option<PbmpmControls> {
        (scene.method == crate::sim::Method::Pbmpm).then(|| PbmpmControls {
            iterations: scene.pbmpm.iterations,
            substeps: scene
                .time_step
                .substeps(crate::sim::FRAME_DT, 0.0, scene.dx)
                .map_or(crate::sim::pbmpm::DEFAULT_SUBSTEPS, |(n, _)| n),
        })
    }
}

/// The sliders' tops: the scene keys take more (64 iterations, 1000 substeps), set in the file.
const MAX_SLIDER_ITERATIONS: u32 = 16;
const MAX_SLIDER_SUBSTEPS: u32 = 32;

pub enum Action {
    Step,
    Reset,
    LoadPreset(&'static str),
    LoadFile(String),
    Screenshot,
    ToggleRecording,
    /// Ends the export of the run (`mpm view --export ...`) before the window closes.
    StopExport,
    SaveSnapshot,
    LoadSnapshot,
    FrameCamera,
    /// Row, value.
    SetViscosity(usize, f32),
    SetSoundSpeed(usize, f32),
    SetGravity(Vec3),
    /// Position-based MPM's constraint iterations a substep, and substeps a frame.
    SetIterations(u32),
    SetSubsteps(u32),
    /// Drops a rigid body into the running scene: a ball (`true`) or a box.
    DropBody {
        ball: bool,
    },
    Quit,
}

pub const KEYS: &[(&str, &str)] = &[
    ("Space", "pause / resume"),
    ("N", "single step (one 60 Hz frame)"),
    ("R", "reset the scene"),
    ("M", "draw: points / spheres / surface"),
    ("C", "colour: solid / speed / density"),
    ("F", "frame the domain"),
    ("B", "drop a box (a rigid body) into the scene"),
    ("O", "drop a ball (a rigid body) into the scene"),
    ("P", "screenshot (PNG)"),
    ("V", "start / stop PNG recording"),
    ("E", "stop the export (mpm view --export ...)"),
    ("F5", "save a snapshot (checkpoint)"),
    ("F9", "load the newest snapshot"),
    ("H", "hide / show this panel"),
    ("Esc", "quit"),
    ("left drag", "orbit"),
    ("right drag", "pan"),
    ("wheel", "zoom"),
    ("Shift + left drag", "push the fluid"),
    ("Ctrl + left drag", "move a collider"),
];

pub fn panel(ctx: &egui::Context, controls: &mut Controls, info: &HudInfo) -> Vec<Action> {
    let mut actions = Vec::new();
    egui::SidePanel::left("hud")
        .resizable(false)
        .default_width(290.0)
        .show(ctx, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.heading("MLS-MPM fluid");
                ui.label(format!(
                    "{} — {} particles on {}",
                    info.scene, info.particles, info.backend
                ));
                if let Some(message) = info.message {
                    ui.colored_label(Color32::from_rgb(255, 140, 90), message);
                }
                ui.separator();
                stats(ui, info);
                ui.separator();
                run_controls(ui, controls, info, &mut actions);
                ui.separator();
                view_controls(ui, controls, info.materials, &mut actions);
                ui.separator();
                physics_controls(ui, controls, info.materials, &mut actions);
                ui.separator();
                drop_controls(ui, controls, &mut actions);
                ui.separator();
                scene_controls(ui, controls, &mut actions);
                ui.separator();
                ui.collapsing("Keys and mouse", |ui| {
                    egui::Grid::new("keys").striped(true).show(ui, |ui| {
                        for (key, what) in KEYS {
                            ui.label(RichText::new(*key).monospace());
                            ui.label(*what);
                            ui.end_row();
                        }
                    });
                });
            });
        });
    actions
}

fn stats(ui: &mut egui::Ui, info: &HudInfo) {
    egui::Grid::new("stats").num_columns(2).show(ui, |ui| {
        let mut row = |name: &str, value: String| {
            ui.label(name);
            ui.label(RichText::new(value).monospace());
            ui.end_row();
        };
        row("FPS", format!("{:.1}", info.fps));
        row("draw interval", format!("{:.1} ms", info.frame_ms));
        row("substeps", format!("{} x dt {:.3e} s", info.substeps, info.dt));
        if info.substeps_over_cfl > 0 {
            let over = crate::text::count(info.substeps_over_cfl, "substep", "substeps");
            row("CFL", format!("{:.2} (> {MAX_CFL} in {over})", info.max_cfl));
        } else {
            row("CFL", format!("{:.2}", info.max_cfl));
        }
        if let Some(pushes) = info.backstop_pushes {
            row(
                "collider backstop",
                crate::text::count(pushes, "particle", "particles"),
            );
        }
        row("sim time", format!("{:.3} s", info.sim_time));
        row("wall time", format!("{:.3} s", info.wall_time));
        row("sim / wall", speed_text(info.speed));
        if info.frame_in_progress {
            row("", "each 60 Hz frame spans several draws".to_string());
        }
        row("transfer", info.transfer.to_string());
        if let Some(t) = &info.timings {
            // One completed 60 Hz frame; a phase this backend does not run (0 ms) has no row. Where
            // the backend timed the phases of some substeps only (CUDA: one in 7), their times are
            // scaled to the frame's substeps.
            row("last 60 Hz frame", format!("{} substeps", t.steps));
            let phased = t.phased();
            if phased > 0 && phased < t.steps {
                row("phases of", format!("{phased} substeps, scaled to {}", t.steps));
            }
            let scale = if phased > 0 {
                f64::from(t.steps) / f64::from(phased)
            } else {
                0.0
            };
            for (phase, ms) in t.iter() {
                if ms > 0.0 {
                    row(phase.name(), format!("{:.3} ms", ms * scale));
                }
            }
            row("step total", format!("{:.3} ms", t.total()));
        }
        if let Some(passes) = info.render_passes.filter(|p| !p.is_empty()) {
            row("render (GPU)", String::new());
            for (pass, ms) in passes.iter() {
                let name = match pass {
                    Pass::Thickness if info.thickness_by_cuda => "thickness (CUDA)",
                    _ => pass.name(),
                };
                row(name, format!("{ms:.3} ms"));
            }
            row("render total", format!("{:.3} ms", passes.total()));
        }
        if let Some((dir, frames)) = &info.recording {
            row(
                "recording",
                format!("{} -> {dir}", crate::text::count(*frames, "frame", "frames")),
            );
        }
        if let Some(export) = info.export {
            row("exporting", export.to_string());
        }
    });
}

/// Simulated seconds per wall second, with enough digits to read when it is small, and what it means.
pub fn speed_text(speed: f64) -> String {
    if speed.is_nan() || speed <= 0.0 {
        return "-".to_string();
    }
    if speed >= 0.98 {
        return format!("{speed:.2}x");
    }
    // Two significant digits: 0.50x, 0.050x, 0.0040x.
    let digits = if speed >= 0.1 {
        2
    } else {
        (-speed.log10().floor()) as usize + 1
    };
    format!(
        "{speed:.digits$}x: slower than real time, 1 s takes {:.0} s",
        1.0 / speed
    )
}

fn run_controls(ui: &mut egui::Ui, c: &mut Controls, info: &HudInfo, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        if ui
            .button(if c.paused {
                "Resume (Space)"
            } else {
                "Pause (Space)"
            })
            .clicked()
        {
            c.paused = !c.paused;
        }
        if ui.button("Step (N)").clicked() {
            actions.push(Action::Step);
        }
        if ui.button("Reset (R)").clicked() {
            actions.push(Action::Reset);
        }
    });
    ui.horizontal(|ui| {
        if ui.button("Screenshot (P)").clicked() {
            actions.push(Action::Screenshot);
        }
        let record = if info.recording.is_some() {
            "Stop recording (V)"
        } else {
            "Record (V)"
        };
        if ui.button(record).clicked() {
            actions.push(Action::ToggleRecording);
        }
        if info.export.is_some() && ui.button("Stop export (E)").clicked() {
            actions.push(Action::StopExport);
        }
    });
    snapshot_buttons(ui, actions);
    ui.checkbox(
        &mut c.fixed_pacing,
        "fixed frames per draw (else follow wall time)",
    );
    if c.fixed_pacing {
        ui.add(egui::Slider::new(&mut c.frames_per_draw, 1..=8).text("60 Hz frames per draw"));
    }
}

fn snapshot_buttons(ui: &mut egui::Ui, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        if ui.button("Save snapshot (F5)").clicked() {
            actions.push(Action::SaveSnapshot);
        }
        if ui.button("Load snapshot (F9)").clicked() {
            actions.push(Action::LoadSnapshot);
        }
    });
}

fn view_controls(
    ui: &mut egui::Ui,
    c: &mut Controls,
    materials: &[crate::sim::material::NamedMaterial],
    actions: &mut Vec<Action>,
) {
    let r = &mut c.render;
    ui.horizontal(|ui| {
        ui.label("draw");
        ui.selectable_value(&mut r.mode, DrawMode::Points, "points");
        ui.selectable_value(&mut r.mode, DrawMode::Spheres, "spheres");
        ui.selectable_value(&mut r.mode, DrawMode::Surface, "surface");
    });
    ui.horizontal(|ui| {
        ui.label("colour");
        let before = r.colouring;
        ui.selectable_value(&mut r.colouring, Colouring::Solid, "solid");
        ui.selectable_value(&mut r.colouring, Colouring::Speed, "speed");
        ui.selectable_value(&mut r.colouring, Colouring::Density, "density");
        ui.selectable_value(&mut r.colouring, Colouring::Material, "material");
        if r.colouring != before {
            r.scale_range = RenderSettings::default_range(r.colouring);
        }
    });
    match r.mode {
        DrawMode::Points => {
            ui.add(egui::Slider::new(&mut r.point_size, 1.0..=8.0).text("point size (px)"));
        }
        DrawMode::Spheres => {
            ui.add(
                egui::Slider::new(&mut r.sphere_radius, 0.0005..=0.02)
                    .logarithmic(true)
                    .text("sphere radius (m)"),
            );
        }
        DrawMode::Surface => {
            let s = &mut r.surface;
            // From a quarter to three particle spacings: below, the spheres part; above, the water swells.
            ui.add(
                egui::Slider::new(&mut s.radius, 0.25 * r.spacing..=3.0 * r.spacing)
                    .logarithmic(true)
                    .text("particle radius (m)"),
            );
            ui.add(egui::Slider::new(&mut s.smoothing, 0.0..=12.0).text("smoothing (radii)"));
            ui.add(egui::Slider::new(&mut s.iterations, 0..=4).text("smoothing passes"));
            ui.add(egui::Slider::new(&mut s.absorption, 0.0..=5.0).text("absorption (colour depth)"));
            ui.add(egui::Slider::new(&mut s.refraction, 0.0..=2.0).text("refraction"));
            // Speed against quality: each cuts the surface's GPU time (docs/viewer.md, "Surface speed").
            ui.checkbox(&mut s.half_res_smoothing, "smooth at half resolution");
            ui.add(egui::Slider::new(&mut s.max_filter_px, 1..=48).text("smoothing reach (px, at most)"));
            ui.add(
                egui::Slider::new(&mut s.thickness_downsample, 1..=MAX_THICKNESS_DOWNSAMPLE)
                    .text("thickness resolution (1/n)"),
            );
            ui.add(
                egui::Slider::new(&mut s.thickness_min_splat_px, 0.5..=3.0)
                    .text("thickness splat (px, at least)"),
            );
            if r.colouring == Colouring::Speed {
                ui.label("speed: whitewater from the low to the high end of the scale");
            }
        }
    }
    if r.colouring == Colouring::Material {
        material_key(ui, materials, |_| true);
    } else if r.mode == DrawMode::Surface && materials.iter().any(|m| m.law.is_solid()) {
        // The surface draws the solids in their own colours whatever the colouring.
        material_key(ui, materials, |m| m.law.is_solid());
    }
    if r.colouring != Colouring::Solid && r.colouring != Colouring::Material {
        let unit = if r.colouring == Colouring::Speed {
            "m/s"
        } else {
            "rho/rho0"
        };
        ui.horizontal(|ui| {
            ui.label(format!("scale ({unit})"));
            ui.add(egui::DragValue::new(&mut r.scale_range[0]).speed(0.01));
            ui.add(egui::DragValue::new(&mut r.scale_range[1]).speed(0.01));
        });
        if let Some(scale) = r.legend() {
            legend(ui, &scale);
        }
    }
    ui.horizontal(|ui| {
        ui.checkbox(&mut r.show_box, "domain box");
        if ui.button("Frame (F)").clicked() {
            actions.push(Action::FrameCamera);
        }
    });
}

/// A swatch and the name of each material `listed` picks, in the colours the particles are drawn
/// in; a solid's marked as one (the surface draws it as spheres, not as a liquid).
fn material_key(
    ui: &mut egui::Ui,
    materials: &[crate::sim::material::NamedMaterial],
    listed: impl Fn(&crate::sim::material::NamedMaterial) -> bool,
) {
    for (row, m) in materials.iter().enumerate().filter(|(_, m)| listed(m)) {
        ui.horizontal(|ui| {
            let (rect, _) = ui.allocate_exact_size(egui::vec2(14.0, 14.0), egui::Sense::hover());
            let [r, g, b] = m.colour.map(|c| (c.clamp(0.0, 1.0) * 255.0) as u8);
            ui.painter().rect_filled(rect, 2.0, Color32::from_rgb(r, g, b));
            let solid = if m.law.is_solid() { " (solid)" } else { "" };
            ui.label(format!("{row}: {}{solid}", m.name));
        });
    }
}

/// The colour scale with its end values, as the particles use it.
fn legend(ui: &mut egui::Ui, scale: &Scale) {
    let range = scale.range;
    let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width(), 14.0), egui::Sense::hover());
    let steps = 48;
    for i in 0..steps {
        let t = (i as f32 + 0.5) / steps as f32;
        let [r, g, b] = scale.colour(t).map(|c| (c * 255.0) as u8);
        let x0 = rect.left() + rect.width() * i as f32 / steps as f32;
        let x1 = rect.left() + rect.width() * (i + 1) as f32 / steps as f32;
        ui.painter().rect_filled(
            egui::Rect::from_min_max(egui::pos2(x0, rect.top()), egui::pos2(x1 + 0.5, rect.bottom())),
            0.0,
            Color32::from_rgb(r, g, b),
        );
    }
    ui.horizontal(|ui| {
        ui.label(format!("{:.2}", range[0]));
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            ui.label(format!("{:.2} {}", range[1], scale.unit));
        });
    });
}

/// The viscosity and sound speed sliders of material row `row`, a liquid.
fn liquid_sliders(
    ui: &mut egui::Ui,
    c: &mut Controls,
    material: &crate::sim::material::NamedMaterial,
    row: usize,
    actions: &mut Vec<Action>,
) {
    let what = match material.law.law {
        LAW_POWER_LAW | LAW_HERSCHEL_BULKLEY => "consistency K (Pa s^n)",
        LAW_CARREAU_YASUDA => "zero-shear viscosity (Pa s)",
        _ => "viscosity (Pa s)",
    };
    if ui
        .add(
            egui::Slider::new(&mut c.viscosity[row], 0.0..=MAX_SLIDER_VISCOSITY)
                .logarithmic(true)
                .text(what),
        )
        .changed()
    {
        actions.push(Action::SetViscosity(row, c.viscosity[row]));
    }
    if ui
        .add(
            egui::Slider::new(&mut c.sound_speed[row], 1.0..=200.0)
                .logarithmic(true)
                .text("sound speed (m/s)"),
        )
        .changed()
    {
        actions.push(Action::SetSoundSpeed(row, c.sound_speed[row]));
    }
}

/// Position-based MPM's iterations and substeps: more of either holds a liquid's volume and a
/// solid's shape more stiffly, at their cost (each iteration is a particle pass, each substep a
/// start and a last pass more).
fn pbmpm_sliders(ui: &mut egui::Ui, p: &mut PbmpmControls, actions: &mut Vec<Action>) {
    // The tops reach a file's larger count, so that the slider shows it rather than clamping it.
    let (most_iterations, most_substeps) = (
        MAX_SLIDER_ITERATIONS.max(p.iterations),
        MAX_SLIDER_SUBSTEPS.max(p.substeps),
    );
    if ui
        .add(
            egui::Slider::new(&mut p.iterations, 1..=most_iterations).text("constraint iterations a substep"),
        )
        .on_hover_text(
            "position-based MPM: the file's solver.iterations takes up to 64; a snapshot keeps the file's",
        )
        .changed()
    {
        actions.push(Action::SetIterations(p.iterations));
    }
    if ui
        .add(egui::Slider::new(&mut p.substeps, 1..=most_substeps).text("substeps a frame"))
        .on_hover_text(
            "position-based MPM: a deep liquid on a fine grid needs more to hold its volume; the file's \
             time_step.substeps takes up to 1000; a snapshot keeps the file's",
        )
        .changed()
    {
        actions.push(Action::SetSubsteps(p.substeps));
    }
}

fn physics_controls(
    ui: &mut egui::Ui,
    c: &mut Controls,
    materials: &[crate::sim::material::NamedMaterial],
    actions: &mut Vec<Action>,
) {
    ui.label("physics (applies at once)");
    // The sliders set a liquid's viscosity and sound speed; a solid's stiffness is its Young's
    // modulus and Poisson's ratio, which the scene file gives.
    let liquids: Vec<usize> = (0..materials.len())
        .filter(|&k| !materials[k].law.is_solid())
        .collect();
    if liquids.is_empty() {
        ui.label("no liquid here: a solid's stiffness is the scene file's youngs_modulus and poisson_ratio");
    } else {
        if !liquids.contains(&c.liquid) {
            c.liquid = liquids[0];
        }
        let row = c.liquid;
        if liquids.len() > 1 {
            egui::ComboBox::from_label("liquid the sliders change")
                .selected_text(&materials[row].name)
                .show_ui(ui, |ui| {
                    for &k in &liquids {
                        ui.selectable_value(&mut c.liquid, k, &materials[k].name);
                    }
                });
        }
        liquid_sliders(ui, c, &materials[c.liquid], c.liquid, actions);
    }
    if let Some(pbmpm) = &mut c.pbmpm {
        pbmpm_sliders(ui, pbmpm, actions);
    }
    let mut changed = false;
    ui.horizontal(|ui| {
        ui.label("gravity (m/s²)");
        for k in 0..3 {
            changed |= ui
                .add(
                    egui::DragValue::new(&mut c.gravity[k])
                        .speed(0.1)
                        .range(-100.0..=100.0),
                )
                .changed();
        }
    });
    if changed {
        actions.push(Action::SetGravity(c.gravity));
    }
    ui.add(egui::Slider::new(&mut c.push_strength, 0.0..=0.2).text("push (m/s per pixel)"));
    ui.add(egui::Slider::new(&mut c.push_radius, 0.02..=0.3).text("push radius (domain)"));
}

/// Buttons that drop a box or a ball into the running scene, and the density each is given.
fn drop_controls(ui: &mut egui::Ui, c: &mut Controls, actions: &mut Vec<Action>) {
    ui.label("drop a rigid body (over the camera's target, above the liquid; R clears them)");
    let density = |ui: &mut egui::Ui, value: &mut f64| {
        ui.add(
            egui::DragValue::new(value)
                .speed(10.0)
                .range(1.0..=20_000.0)
                .suffix(" kg/m³"),
        );
    };
    ui.horizontal(|ui| {
        if ui.button("Drop box (B)").clicked() {
            actions.push(Action::DropBody { ball: false });
        }
        density(ui, &mut c.box_density);
    });
    ui.horizontal(|ui| {
        if ui.button("Drop ball (O)").clicked() {
            actions.push(Action::DropBody { ball: true });
        }
        density(ui, &mut c.ball_density);
    });
}

fn scene_controls(ui: &mut egui::Ui, c: &mut Controls, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        let chosen = c.preset.and_then(|i| presets::NAMES.get(i).copied());
        egui::ComboBox::from_label("")
            .selected_text(chosen.unwrap_or("preset..."))
            .show_ui(ui, |ui| {
                for (i, name) in presets::NAMES.iter().enumerate() {
                    ui.selectable_value(&mut c.preset, Some(i), *name);
                }
            });
        let load = ui.add_enabled(chosen.is_some(), egui::Button::new("Load preset"));
        if let (true, Some(name)) = (load.clicked(), chosen) {
            actions.push(Action::LoadPreset(name));
        }
    });
    ui.horizontal(|ui| {
        ui.add(
            egui::TextEdit::singleline(&mut c.scene_path)
                .hint_text("scene.toml")
                .desired_width(170.0),
        );
        if ui.button("Load file").clicked() {
            actions.push(Action::LoadFile(c.scene_path.clone()));
        }
    });
    if ui.button("Quit (Esc)").clicked() {
        actions.push(Action::Quit);
    }
}

#[cfg(test)]
mod tests {
    use super::speed_text;

    #[test]
    fn a_small_speed_keeps_its_digits() {
        assert_eq!(speed_text(1.0), "1.00x");
        assert_eq!(speed_text(0.5), "0.50x: slower than real time, 1 s takes 2 s");
        assert_eq!(
            speed_text(0.004),
            "0.0040x: slower than real time, 1 s takes 250 s"
        );
        assert!(!speed_text(0.0004).starts_with("0.00x"));
    }
}
