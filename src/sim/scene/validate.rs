//! A scene file's specification checked into a [`Scene`]: every value in range, every body inside the
//! domain, the memory a run needs available. Every refusal names the file, the key and the fix.

use super::spec::*;
use super::{
    default_name, fluid_region, Body, Scene, Shape, TimeStepPolicy, CPU_BYTES_PER_NODE,
    CPU_BYTES_PER_PARTICLE, MAX_CFL,
};
use crate::contract::{
    LAW_CARREAU_YASUDA, LAW_FIXED_COROTATED, LAW_HERSCHEL_BULKLEY, LAW_NEO_HOOKEAN, LAW_NEWTONIAN,
    LAW_POWER_LAW, LAW_SAND, LAW_SNOW, MAX_MATERIALS,
};
use crate::sim::colliders::{self, Colliders, MAX_COLLIDERS};
use crate::sim::flow::{self, Emitter, Flow, Nozzle, Sink, MAX_EMITTERS};
use crate::sim::material::{default_colour, densest_liquid, MaterialTable, NamedMaterial, MAX_ABSORPTION};
use crate::sim::params::{Material, Method, FRAME_DT};
use crate::sim::pbmpm::{self, PBMPM_NOMINAL_SOUND_SPEED};
use crate::sim::{mesh, presets, solid};
use glam::{DVec3, Vec3};
use std::fmt;
use std::path::Path;

/// A scene that could not be loaded: where, which key, what is wrong, and how to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The file path or `preset NAME`.
    pub source: String,
    /// The offending key, in TOML path form (`material.rest_density`, `block[1].max`); empty for the file.
    pub key: String,
    pub problem: String,
    pub fix: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "scene {}: {}", self.source, self.problem)?;
        } else {
            write!(f, "scene {}: `{}` {}", self.source, self.key, self.problem)?;
        }
        if !self.fix.is_empty() {
            write!(f, "\n  fix: {}", self.fix)?;
        }
        Ok(())
    }
}

impl std::error::Error for SceneError {}

pub(super) struct Validator<'a> {
    pub(super) source: &'a str,
}

impl Validator<'_> {
    fn err(&self, key: impl Into<String>, problem: impl Into<String>, fix: impl Into<String>) -> SceneError {
        SceneError {
            source: self.source.to_string(),
            key: key.into(),
            problem: problem.into(),
            fix: fix.into(),
        }
    }

    /// Refuses the first of `keys` the scene gives (each with whether it is given), as `err` would
    /// name it: keys that do not belong where they stand.
    fn refuse_given<K: Into<String>>(
        &self,
        keys: impl IntoIterator<Item = (K, bool)>,
        problem: impl Into<String>,
        fix: impl Into<String>,
    ) -> Result<(), SceneError> {
        match keys.into_iter().find(|(_, given)| *given) {
            Some((key, _)) => Err(self.err(key, problem, fix)),
            None => Ok(()),
        }
    }

    fn positive(&self, key: &str, value: f32, fix: &str) -> Result<f32, SceneError> {
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(self.err(key, format!("must be a positive number, got {value}"), fix))
        }
    }

    fn finite3(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        if v.iter().all(|c| c.is_finite()) {
            Ok(Vec3::from(v))
        } else {
            Err(self.err(
                key,
                format!("must be finite, got {v:?}"),
                "give three finite numbers",
            ))
        }
    }

    pub(super) fn scene(&self, spec: &SceneSpec) -> Result<Scene, SceneError> {
        let (grid_res, dx) = self.domain(&spec.domain)?;
        let band = spec.solver.boundary_band;
        if band < 1 || 2 * band + 4 > grid_res.iter().copied().min().unwrap_or(0) {
            return Err(self.err(
                "solver.boundary_band",
                format!("= {band} leaves no room for fluid in a grid of {grid_res:?} nodes"),
                "use 2 (the default); it must be at least 1 and leave 4 free nodes on every axis",
            ));
        }
        let particles_per_axis = self.particles_per_axis(spec)?;
        let method = spec.solver.method;
        let materials = self.materials(&spec.material, dx, particles_per_axis, method)?;
        let gravity = self.finite3("solver.gravity", spec.solver.gravity)?;
        let bodies = self.bodies(spec, &materials, grid_res, dx, band, spec.solver.soft_wall)?;
        let emitter_speeds = spec
            .emitters
            .iter()
            .map(|e| if e.speed.is_finite() { e.speed } else { 0.0 });
        let max_body_speed = bodies
            .iter()
            .map(|b| b.velocity.length())
            .chain(emitter_speeds)
            .fold(0.0, f32::max);
        let colliders = self.colliders(spec, grid_res, dx, &materials)?;
        let max_speed = max_body_speed.max(colliders.max_speed());
        let fastest = materials
            .iter()
            .map(|m| &m.law)
            .max_by(|a, b| a.sound_speed().total_cmp(&b.sound_speed()))
            .expect("a scene has at least one material");
        let pbmpm = self.pbmpm_settings(spec)?;
        let time_step = match method {
            Method::Explicit => self.time_step(&spec.time_step, fastest, &materials, dx, max_speed)?,
            Method::Pbmpm => self.pbmpm_time_step(&spec.time_step)?,
        };
        // pbmpm has no equation of state whose sound speed the flow must stay under.
        let explicit_entries = match method {
            Method::Explicit => spec.material.entries(),
            Method::Pbmpm => Vec::new(),
        };
        for ((key, m), material) in explicit_entries.into_iter().zip(&materials) {
            self.plausible_speeds(
                &key,
                m,
                &material.law,
                gravity,
                &spec.domain,
                dx,
                max_speed,
                &time_step,
            )?;
        }

        let mut scene = Scene {
            name: spec.name.clone().unwrap_or_else(|| default_name(self.source)),
            description: spec.description.clone().unwrap_or_default(),
            source: self.source.to_string(),
            grid_res,
            dx: dx as f32,
            materials,
            gravity,
            boundary_band: band,
            soft_wall: spec.solver.soft_wall,
            mirror_wall_mass: spec.solver.mirror_wall_mass,
            scatter: spec.solver.scatter,
            pipeline: spec.solver.pipeline,
            method,
            pbmpm,
            ranks: 1,
            gpus: 1,
            process: None,
            time_step,
            particles_per_axis,
            bodies,
            colliders,
            num_particles: 0,
            flow: Flow::default(),
            // A spec always serialises (plain numbers, strings and arrays).
            toml: toml::to_string(spec).unwrap_or_default(),
        };
        // The exact count walks every lattice point: refuse absurd sizes from the volume estimate first.
        self.fits_in_memory(&scene, self.estimate_particles(&scene))?;
        scene.num_particles = self.count_particles(&scene, !spec.emitters.is_empty())?;
        scene.flow = self.flow(spec, &scene)?;
        scene.colliders.set_pipes(&scene.flow.emitters);
        self.fits_in_memory(&scene, scene.slots())?;
        scene.check_method()?;
        Ok(scene)
    }

    fn domain(&self, d: &DomainSpec) -> Result<([u32; 3], f64), SceneError> {
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            if !(d.size[a].is_finite() && d.size[a] > 0.0) {
                return Err(self.err(
                    "domain.size",
                    format!("{axis} = {} must be a positive length in metres", d.size[a]),
                    "give the tank size per axis, e.g. size = [1.0, 0.5, 0.5]",
                ));
            }
            if d.resolution[a] < 8 {
                return Err(self.err(
                    "domain.resolution",
                    format!("{axis} = {} is under 8 grid nodes", d.resolution[a]),
                    "use at least 8 nodes per axis (the boundary band and stencil need room)",
                ));
            }
        }
        let dxs: Vec<f64> = (0..3).map(|a| d.size[a] / f64::from(d.resolution[a])).collect();
        let dx = dxs[0];
        if dxs.iter().any(|&h| ((h - dx) / dx).abs() > 1e-4) {
            return Err(self.err(
                "domain.resolution",
                format!(
                    "gives different cell sizes per axis (size / resolution = {:.6}, {:.6}, {:.6} m)",
                    dxs[0], dxs[1], dxs[2]
                ),
                cube_cells_fix(d, dx),
            ));
        }
        Ok((d.resolution, dx))
    }

    fn particles_per_axis(&self, spec: &SceneSpec) -> Result<u32, SceneError> {
        let ppcs = spec
            .blocks
            .iter()
            .enumerate()
            .map(|(i, b)| (format!("block[{i}].particles_per_cell"), b.particles_per_cell))
            .chain(
                spec.spheres
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (format!("sphere[{i}].particles_per_cell"), s.particles_per_cell)),
            )
            .chain(
                spec.emitters
                    .iter()
                    .enumerate()
                    .map(|(i, e)| (format!("emitter[{i}].particles_per_cell"), e.particles_per_cell)),
            );
        let mut chosen: Option<(String, u32)> = None;
        for (key, ppc) in ppcs {
            let n = (1..=4).find(|n| n * n * n == ppc).ok_or_else(|| {
                self.err(
                    &key,
                    format!("= {ppc} is not a cube lattice"),
                    "use 1, 8, 27 or 64 particles per cell (1 to 4 per axis); 8 is the usual choice",
                )
            })?;
            match &chosen {
                Some((first, m)) if *m != n => {
                    return Err(self.err(
                        &key,
                        format!("= {ppc} differs from `{first}` = {}", m * m * m),
                        "give every body the same particles_per_cell: the particle mass \
                         m_p = rho0 dx^3 / ppc is one material constant",
                    ))
                }
                Some(_) => {}
                None => chosen = Some((key, n)),
            }
        }
        chosen.map(|(_, n)| n).ok_or_else(|| {
            self.err(
                "block",
                "the scene has no fluid bodies and no emitters, so it has zero particles",
                "add at least one [[block]] (min, max), [[sphere]] (center, radius) or [[emitter]]",
            )
        })
    }

    /// The material table: `[material]` as its one row, or each `[[material]]` in order.
    fn materials(
        &self,
        spec: &MaterialsSpec,
        dx: f64,
        n: u32,
        method: Method,
    ) -> Result<Vec<NamedMaterial>, SceneError> {
        let entries = spec.entries();
        if entries.is_empty() {
            return Err(self.err(
                "material",
                "is an empty list",
                "give at least one [[material]] with a name and a rest_density",
            ));
        }
        if entries.len() > MAX_MATERIALS as usize {
            return Err(self.err(
                "material",
                format!(
                    "lists {} materials, more than the {MAX_MATERIALS} a scene may have",
                    entries.len()
                ),
                format!(
                    "keep at most {MAX_MATERIALS} [[material]] entries; bodies and emitters of the same \
                     liquid can name one entry"
                ),
            ));
        }
        let table = matches!(spec, MaterialsSpec::Table(_));
        let mut rows: Vec<NamedMaterial> = Vec::with_capacity(entries.len());
        for (row, (key, m)) in entries.into_iter().enumerate() {
            let name = match (&m.name, table) {
                (Some(name), _) if name.trim().is_empty() => {
                    return Err(self.err(
                        format!("{key}.name"),
                        "is empty",
                        "give the material a name, e.g. name = \"honey\"",
                    ))
                }
                // PLY headers and the panel show the name on one line.
                (Some(name), _) if name.chars().any(char::is_control) => {
                    return Err(self.err(
                        format!("{key}.name"),
                        format!("= {name:?} holds a line break or another control character"),
                        "give a name of letters, digits, spaces and punctuation, e.g. name = \"olive oil\"",
                    ))
                }
                (Some(name), _) => name.clone(),
                (None, true) => return Err(self.err(
                    format!("{key}.name"),
                    "is missing",
                    "give every [[material]] a name that bodies and emitters can use, e.g. name = \"oil\"",
                )),
                (None, false) => "liquid".to_string(),
            };
            if let Some(first) = rows.iter().position(|r| r.name == name) {
                return Err(self.err(
                    format!("{key}.name"),
                    format!("= \"{name}\" is already the name of material[{first}]"),
                    "give each material a name of its own",
                ));
            }
            let colour = match m.colour {
                Some(c) if c.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)) => c,
                Some(c) => {
                    return Err(self.err(
                        format!("{key}.colour"),
                        format!("= {c:?} is not a colour"),
                        "give linear RGB, three numbers from 0 to 1, e.g. colour = [0.9, 0.6, 0.1]",
                    ))
                }
                None => default_colour(row),
            };
            let absorption = match m.absorption {
                None => 1.0,
                Some(a) if a.is_finite() && (0.0..=MAX_ABSORPTION).contains(&a) => a,
                Some(a) => {
                    return Err(self.err(
                        format!("{key}.absorption"),
                        format!("= {a} is not an absorption"),
                        format!(
                        "give a number from 0 (clear) to {MAX_ABSORPTION} (opaque), 1 being the colour's own"
                    ),
                    ))
                }
            };
            rows.push(NamedMaterial {
                name,
                colour,
                absorption,
                law: self.material(&key, m, dx, n, method)?,
            });
        }
        Ok(rows)
    }

    fn material(
        &self,
        key: &str,
        m: &MaterialSpec,
        dx: f64,
        n: u32,
        method: Method,
    ) -> Result<Material, SceneError> {
        let k = |field: &str| format!("{key}.{field}");
        let rho0 = self.positive(
            &k("rest_density"),
            m.rest_density,
            "give the rest density in kg/m^3, e.g. 1000 for water",
        )?;
        if m.law.is_solid() {
            return self.solid(key, m, rho0, dx, n);
        }
        let gamma = self.positive(&k("eos_power"), m.eos_power, "use 7 (Tait, water)")?;
        let stiffness = match (m.sound_speed, m.eos_stiffness) {
            (Some(c0), None) => {
                let c0 = self.positive(
                    &k("sound_speed"),
                    c0,
                    "give the sound speed in m/s; 10-20 for real-time water",
                )?;
                rho0 * c0 * c0 / gamma
            }
            (None, Some(stiffness)) => self.positive(&k("eos_stiffness"), stiffness, "give k in Pa")?,
            (Some(_), Some(_)) => {
                return Err(self.err(
                    k("sound_speed"),
                    format!("and `{}` are both given", k("eos_stiffness")),
                    "give one: the sound speed fixes the stiffness (k = rho0 c0^2 / gamma) and back",
                ))
            }
            // pbmpm's liquids hold their volume by a constraint, not an equation of state: the
            // sound speed only sets the signal speed the frame statistics report.
            (None, None) if method == Method::Pbmpm => {
                rho0 * PBMPM_NOMINAL_SOUND_SPEED * PBMPM_NOMINAL_SOUND_SPEED / gamma
            }
            (None, None) => {
                return Err(self.err(
                    k("sound_speed"),
                    "is missing",
                    "give sound_speed (m/s) or eos_stiffness (Pa), e.g. sound_speed = 20.0",
                ))
            }
        };
        if !(m.pressure_floor.is_finite() && m.pressure_floor <= 0.0) {
            return Err(self.err(
                k("pressure_floor"),
                format!("= {} must be zero or negative", m.pressure_floor),
                "use 0 (no tension) or a small negative pressure in Pa for surface cohesion",
            ));
        }
        let ppc = f64::from(n * n * n);
        let mut material = Material {
            rest_density: rho0,
            eos_stiffness: stiffness,
            eos_power: gamma,
            particle_mass: (f64::from(rho0) * dx * dx * dx / ppc) as f32,
            pressure_floor: m.pressure_floor,
            flow_index: 1.0,
            max_viscosity: f32::INFINITY,
            ..Material::default()
        };
        self.law(key, m, &mut material)?;
        Ok(material)
    }

    /// A solid's row: no equation of state (its stress comes from its deformation), its law's
    /// parameters.
    fn solid(&self, key: &str, m: &MaterialSpec, rho0: f32, dx: f64, n: u32) -> Result<Material, SceneError> {
        let k = |field: &str| format!("{key}.{field}");
        let law_name = m.law.name();
        self.refuse_given(
            [
                (k("sound_speed"), m.sound_speed.is_some()),
                (k("eos_stiffness"), m.eos_stiffness.is_some()),
                (k("pressure_floor"), m.pressure_floor != 0.0),
            ],
            format!(
                "is not a parameter of law = \"{law_name}\": a solid's stress comes from its deformation"
            ),
            "remove it; a solid's stiffness is youngs_modulus (Pa) and poisson_ratio",
        )?;
        let ppc = f64::from(n * n * n);
        let mut material = Material {
            rest_density: rho0,
            particle_mass: (f64::from(rho0) * dx * dx * dx / ppc) as f32,
            flow_index: 1.0,
            ..Material::default()
        };
        self.law(key, m, &mut material)?;
        Ok(material)
    }

    /// The law's parameters into `material`: those the law needs present and in range, those it
    /// does not use refused (a yield stress given to a Newtonian liquid is a mistake, not a no-op).
    fn law(&self, key: &str, m: &MaterialSpec, material: &mut Material) -> Result<(), SceneError> {
        let k = |field: &str| format!("{key}.{field}");
        let law_name = m.law.name();
        let given: [(&str, Option<f32>); 16] = [
            ("viscosity", m.viscosity),
            ("consistency", m.consistency),
            ("flow_index", m.flow_index),
            ("yield_stress", m.yield_stress),
            ("max_viscosity", m.max_viscosity),
            ("shear_modulus", m.shear_modulus),
            ("min_viscosity", m.min_viscosity),
            ("relaxation_time", m.relaxation_time),
            ("transition_exponent", m.transition_exponent),
            ("youngs_modulus", m.youngs_modulus),
            ("poisson_ratio", m.poisson_ratio),
            ("critical_compression", m.critical_compression),
            ("critical_stretch", m.critical_stretch),
            ("hardening", m.hardening),
            ("friction_angle", m.friction_angle),
            ("cohesion", m.cohesion),
        ];
        let (needs, allows) = law_parameters(m.law);
        let takes = || {
            let optional = if allows.is_empty() {
                String::new()
            } else {
                format!(", and optionally {}", allows.join(", "))
            };
            format!("\"{law_name}\" takes {}{optional}", needs.join(", "))
        };
        for (field, value) in given {
            let Some(value) = value else {
                if needs.contains(&field) {
                    return Err(self.err(
                        k(field),
                        format!("is missing: law = \"{law_name}\" needs {}", needs.join(", ")),
                        format!(
                            "give {field} ({}) in this material; {} (docs/scenes.md lists each law's \
                             parameters and their units)",
                            law_parameter_unit(field),
                            takes()
                        ),
                    ));
                }
                continue;
            };
            if !needs.contains(&field) && !allows.contains(&field) {
                let laws_with_it: Vec<String> = LawSpec::ALL
                    .into_iter()
                    .filter(|law| {
                        let (needs, allows) = law_parameters(*law);
                        needs.contains(&field) || allows.contains(&field)
                    })
                    .map(|law| format!("\"{}\"", law.name()))
                    .collect();
                return Err(self.err(
                    k(field),
                    format!("is not a parameter of law = \"{law_name}\""),
                    format!(
                        "remove it, or choose a law that takes it ({}); {} (docs/scenes.md lists each \
                         law's parameters)",
                        laws_with_it.join(", "),
                        takes()
                    ),
                ));
            }
            let may_be_zero = ["min_viscosity", "poisson_ratio", "cohesion"].contains(&field)
                || (field == "viscosity" && m.law == LawSpec::Newtonian);
            let positive = !may_be_zero;
            if !value.is_finite() || value < 0.0 || (positive && value == 0.0) {
                return Err(self.err(
                    k(field),
                    format!(
                        "= {value} must be {}",
                        if positive { "positive" } else { "zero or positive" }
                    ),
                    "give it in SI units: Pa s for viscosities, Pa s^n for the consistency, Pa, s",
                ));
            }
            let bounds = match field {
                "poisson_ratio" => Some((0.0, 0.49, "0.2 to 0.45 for jelly and snow, 0.3 for sand")),
                "critical_compression" | "critical_stretch" => Some((
                    0.0,
                    0.5,
                    "snow: 2.5e-2 for the compression, 7.5e-3 for the stretch",
                )),
                "friction_angle" => Some((1.0, 60.0, "degrees: 30 to 35 for dry sand")),
                "cohesion" => Some((0.0, 0.1, "a Hencky strain: 0 for dry sand, up to 1e-2 for damp")),
                "hardening" => Some((0.0, 50.0, "10 for snow (Stomakhin et al. 2013)")),
                _ => None,
            };
            if let Some((lo, hi, typical)) = bounds {
                if value < lo || value > hi {
                    return Err(self.err(
                        k(field),
                        format!("= {value} is outside [{lo}, {hi}]"),
                        format!("give it inside: {typical}"),
                    ));
                }
            }
        }
        let get = |field: &str, default: f32| {
            given
                .iter()
                .find(|(f, _)| *f == field)
                .and_then(|g| g.1)
                .unwrap_or(default)
        };
        material.law = match m.law {
            LawSpec::Newtonian => LAW_NEWTONIAN,
            LawSpec::PowerLaw => LAW_POWER_LAW,
            LawSpec::CarreauYasuda => LAW_CARREAU_YASUDA,
            LawSpec::HerschelBulkley => LAW_HERSCHEL_BULKLEY,
            LawSpec::FixedCorotated => LAW_FIXED_COROTATED,
            LawSpec::NeoHookean => LAW_NEO_HOOKEAN,
            LawSpec::Snow => LAW_SNOW,
            LawSpec::Sand => LAW_SAND,
        };
        if m.law.is_solid() {
            (material.shear_modulus, material.lame_lambda) =
                solid::lame_parameters(get("youngs_modulus", 0.0), get("poisson_ratio", 0.0));
            material.critical_compression = get("critical_compression", 2.5e-2);
            material.critical_stretch = get("critical_stretch", 7.5e-3);
            material.hardening = get("hardening", 10.0);
            material.friction_alpha = solid::drucker_prager_alpha(get("friction_angle", 0.0));
            material.cohesion = get("cohesion", 0.0);
            return Ok(());
        }
        material.viscosity = match m.law {
            LawSpec::Newtonian => get("viscosity", 1.0e-3),
            LawSpec::CarreauYasuda => get("viscosity", 0.0),
            _ => get("consistency", 0.0),
        };
        material.flow_index = get("flow_index", 1.0);
        material.yield_stress = get("yield_stress", 0.0);
        material.shear_modulus = get("shear_modulus", 0.0);
        material.min_viscosity = get("min_viscosity", 0.0);
        material.relaxation_time = get("relaxation_time", 0.0);
        material.transition_exponent = get("transition_exponent", 2.0);
        material.max_viscosity = match m.law {
            LawSpec::Newtonian => material.viscosity,
            // Shear-thinning Carreau-Yasuda is bounded by its zero-shear viscosity.
            LawSpec::CarreauYasuda if material.flow_index <= 1.0 => get("max_viscosity", material.viscosity),
            LawSpec::CarreauYasuda => m.max_viscosity.ok_or_else(|| {
                self.err(
                    k("max_viscosity"),
                    "is missing: a shear-thickening Carreau-Yasuda liquid (flow_index > 1) needs a ceiling",
                    "give the largest viscosity the liquid may reach, in Pa s",
                )
            })?,
            LawSpec::HerschelBulkley => self.yield_regularisation(key, m, material)?,
            _ => get("max_viscosity", f32::INFINITY),
        };
        if material.min_viscosity > material.max_viscosity {
            return Err(self.err(
                k("min_viscosity"),
                format!(
                    "= {} is above max_viscosity = {}",
                    material.min_viscosity, material.max_viscosity
                ),
                "the floor must lie below the ceiling",
            ));
        }
        if material.flow_index > 4.0 || material.flow_index < 0.1 {
            return Err(self.err(
                k("flow_index"),
                format!("= {} is outside [0.1, 4]", material.flow_index),
                "n is 0.2 to 0.8 for shear-thinning liquids, 1 for Newtonian or Bingham, 1.2 to 2 for thickening ones",
            ));
        }
        Ok(())
    }

    /// A Herschel-Bulkley liquid's ceiling on its viscosity, given its regularisation: bi-viscous
    /// (`max_viscosity`, the ceiling of K gammadot^(n - 1) + tau_y / gammadot) or elastic
    /// (`shear_modulus`; the viscosity K gammadot^(n - 1) alone, constant at n = 1, where it needs
    /// no ceiling (`Material::viscosity_ceiling` is then K, and follows the viewer's control of K),
    /// and one given otherwise, as a power law's).
    fn yield_regularisation(
        &self,
        key: &str,
        m: &MaterialSpec,
        material: &Material,
    ) -> Result<f32, SceneError> {
        let k = |field: &str| format!("{key}.{field}");
        match (m.max_viscosity, m.shear_modulus) {
            (Some(ceiling), _) => Ok(ceiling),
            (None, Some(_)) if material.flow_index == 1.0 => Ok(f32::INFINITY),
            (None, Some(_)) => Err(self.err(
                k("max_viscosity"),
                format!(
                    "is missing: with flow_index = {} the viscosity K gammadot^(n - 1) beside the \
                     elastic part has no bound of its own",
                    material.flow_index
                ),
                "give the largest viscosity the liquid may reach, in Pa s (it sets the viscous limit on the substep)",
            )),
            (None, None) => Err(self.err(
                k("max_viscosity"),
                "is missing: law = \"herschel-bulkley\" needs a regularisation of its yield stress",
                "give max_viscosity (Pa s: bi-viscous, a Newtonian liquid of that viscosity below the yield \
                 stress, which creeps) or shear_modulus (Pa: elastic below the yield stress, which comes to \
                 rest; docs/physics.md, \"Yield stress\")",
            )),
        }
    }

    /// The row of the material a body or emitter names (`key`): the only one where the scene has one
    /// and the body names none.
    pub(super) fn material_row(
        &self,
        key: &str,
        name: &Option<String>,
        materials: &[NamedMaterial],
    ) -> Result<u8, SceneError> {
        let names = || {
            materials
                .iter()
                .map(|m| format!("\"{}\"", m.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        match name {
            None if materials.len() == 1 => Ok(0),
            None => Err(self.err(
                key,
                "is missing: the scene has several materials",
                format!(
                    "name the material it is made of, e.g. material = \"{}\"; the scene's materials are {}",
                    materials[0].name,
                    names()
                ),
            )),
            Some(name) => materials
                .iter()
                .position(|m| &m.name == name)
                .map(|row| row as u8)
                .ok_or_else(|| {
                    self.err(
                        key,
                        format!("= \"{name}\" names no material of this scene"),
                        format!(
                            "use one of {} (names are matched exactly, case included), or add a \
                             [[material]] named \"{name}\"",
                            names()
                        ),
                    )
                }),
        }
    }

    fn bodies(
        &self,
        spec: &SceneSpec,
        materials: &[NamedMaterial],
        res: [u32; 3],
        dx: f64,
        band: u32,
        soft_wall: bool,
    ) -> Result<Vec<Body>, SceneError> {
        let (lo, hi) = fluid_region(res, dx, band, soft_wall);
        let region = format!(
            "[{:.4}, {:.4}] x [{:.4}, {:.4}] x [{:.4}, {:.4}] m",
            lo.x, hi.x, lo.y, hi.y, lo.z, hi.z
        );
        let fix = format!(
            "keep bodies inside the fluid region {region} (the domain less the {band}-node boundary band{})",
            if soft_wall { " and the soft wall" } else { "" }
        );
        let mut bodies = Vec::new();
        for (i, b) in spec.blocks.iter().enumerate() {
            let (min, max) = (DVec3::from(b.min), DVec3::from(b.max));
            if !(min.is_finite() && max.is_finite()) || min.cmpge(max).any() {
                return Err(self.err(
                    format!("block[{i}]"),
                    format!("has min {:?} not below max {:?} on every axis", b.min, b.max),
                    "give min < max on x, y and z",
                ));
            }
            let eps = 1e-9 * dx;
            if min.cmplt(lo - eps).any() || max.cmpgt(hi + eps).any() {
                let key = if min.cmplt(lo - eps).any() { "min" } else { "max" };
                return Err(self.err(
                    format!("block[{i}].{key}"),
                    "lies outside the domain's fluid region",
                    fix.clone(),
                ));
            }
            bodies.push(Body {
                shape: Shape::Block { min, max },
                velocity: self.finite3(&format!("block[{i}].velocity"), b.velocity)?,
                material: self.material_row(&format!("block[{i}].material"), &b.material, materials)?,
            });
        }
        for (i, s) in spec.spheres.iter().enumerate() {
            let center = DVec3::from(s.center);
            if !(s.radius.is_finite() && s.radius > 0.0) {
                return Err(self.err(
                    format!("sphere[{i}].radius"),
                    format!("= {} must be positive", s.radius),
                    "give the radius in metres",
                ));
            }
            if !center.is_finite()
                || (center - s.radius).cmplt(lo).any()
                || (center + s.radius).cmpgt(hi).any()
            {
                return Err(self.err(
                    format!("sphere[{i}]"),
                    "reaches outside the domain's fluid region",
                    fix.clone(),
                ));
            }
            bodies.push(Body {
                shape: Shape::Sphere {
                    center,
                    radius: s.radius,
                },
                velocity: self.finite3(&format!("sphere[{i}].velocity"), s.velocity)?,
                material: self.material_row(&format!("sphere[{i}].material"), &s.material, materials)?,
            });
        }
        Ok(bodies)
    }

    /// Emitters and sinks, validated against the domain, and the particle capacity.
    fn flow(&self, spec: &SceneSpec, scene: &Scene) -> Result<Flow, SceneError> {
        let (lo, hi) = scene.fluid_region();
        let spacing = scene.lattice().spacing;
        let region = format!(
            "[{:.4}, {:.4}] x [{:.4}, {:.4}] x [{:.4}, {:.4}] m",
            lo.x, hi.x, lo.y, hi.y, lo.z, hi.z
        );
        if spec.emitters.len() > MAX_EMITTERS {
            return Err(self.err(
                "emitter",
                format!(
                    "{} emitters are more than the {MAX_EMITTERS} a scene may have",
                    spec.emitters.len()
                ),
                "merge nozzles that share a speed and direction into one rectangle",
            ));
        }
        let mut emitters = Vec::new();
        for (i, e) in spec.emitters.iter().enumerate() {
            emitters.push(self.emitter(i, e, spacing, (lo, hi), &region, &scene.materials)?);
        }
        let domain = DVec3::from(scene.grid_res.map(f64::from)) * f64::from(scene.dx);
        // dx is single precision: a sink out to the domain's size as the scene wrote it (0.4 m of 80
        // cells of 5 mm) may lie a rounding past the cells' product.
        let domain_edge = domain * (1.0 + 1e-6);
        let mut sinks = Vec::new();
        for (i, k) in spec.sinks.iter().enumerate() {
            let (min, max) = (DVec3::from(k.min), DVec3::from(k.max));
            if !(min.is_finite() && max.is_finite()) || min.cmpge(max).any() {
                return Err(self.err(
                    format!("sink[{i}]"),
                    format!("has min {:?} not below max {:?} on every axis", k.min, k.max),
                    "give min < max on x, y and z",
                ));
            }
            if min.cmplt(DVec3::ZERO).any() || max.cmpgt(domain_edge).any() {
                return Err(self.err(
                    format!("sink[{i}]"),
                    format!(
                        "reaches outside the domain [0, {:.4}] x [0, {:.4}] x [0, {:.4}] m",
                        domain.x, domain.y, domain.z
                    ),
                    "keep the sink box inside the domain; a drain at the floor reaches down to 0",
                ));
            }
            if min.cmpge(hi).any() || max.cmple(lo).any() {
                return Err(self.err(
                    format!("sink[{i}]"),
                    format!("lies wholly in the boundary band, where no particle goes (the fluid region is {region})"),
                    "let the box reach into the fluid region",
                ));
            }
            sinks.push(Sink {
                min: min.as_vec3(),
                max: max.as_vec3(),
            });
        }
        let initial = scene.num_particles;
        let capacity = match &spec.particles {
            Some(p) => {
                let capacity = p.capacity;
                if capacity == 0 || capacity < initial as u64 {
                    return Err(self.err(
                        "particles.capacity",
                        format!("= {capacity} is below the {initial} particles the bodies spawn"),
                        format!("give at least {initial}, plus room for what the emitters add"),
                    ));
                }
                if capacity > u64::from(u32::MAX) {
                    return Err(self.err(
                        "particles.capacity",
                        format!("= {capacity} is above the 2^32 limit of particle indices"),
                        "give a smaller capacity",
                    ));
                }
                capacity as usize
            }
            None if !emitters.is_empty() => {
                return Err(self.err(
                    "particles.capacity",
                    "is missing: a scene with emitters allocates its particles up front",
                    format!(
                        "add [particles] capacity = N, N at least {initial} (the bodies' particles) plus what the emitters may add"
                    ),
                ))
            }
            None => initial,
        };
        Ok(Flow {
            emitters,
            sinks,
            capacity,
        })
    }

    fn emitter(
        &self,
        i: usize,
        e: &EmitterSpec,
        spacing: f64,
        (lo, hi): (DVec3, DVec3),
        region: &str,
        materials: &[NamedMaterial],
    ) -> Result<Emitter, SceneError> {
        let key = |k: &str| format!("emitter[{i}].{k}");
        let normal = Vec3::from(e.normal);
        if !(normal.is_finite() && normal.length() > 1e-6) {
            return Err(self.err(
                key("normal"),
                format!("= {:?} is not a direction", e.normal),
                "give the direction the fluid leaves in, e.g. [0.0, -1.0, 0.0] for a tap",
            ));
        }
        let normal = normal.normalize();
        let nozzle = match (e.shape, e.radius, e.size) {
            (NozzleShape::Disc, Some(radius), None) if radius.is_finite() && radius > 0.0 => {
                Nozzle::Disc { radius }
            }
            (NozzleShape::Rectangle, None, Some(size)) if size.iter().all(|s| s.is_finite() && *s > 0.0) => {
                Nozzle::Rectangle { size }
            }
            (NozzleShape::Disc, ..) => {
                return Err(self.err(
                    key("radius"),
                    "must be given, positive, for a disc nozzle (and `size` left out)",
                    "give radius = R in metres",
                ))
            }
            (NozzleShape::Rectangle, ..) => {
                return Err(self.err(
                    key("size"),
                    "must be given, two positive lengths, for a rectangle nozzle (and `radius` left out)",
                    "give size = [A, B] in metres, the sides across the normal",
                ))
            }
        };
        if !(e.speed.is_finite() && e.speed > 0.0) {
            return Err(self.err(
                key("speed"),
                format!("= {} must be a positive speed", e.speed),
                "give the speed the fluid leaves the nozzle at, m/s",
            ));
        }
        let center = DVec3::from(e.center);
        let points = flow::nozzle_points(nozzle, center, normal, spacing);
        if points.is_empty() {
            return Err(self.err(
                format!("emitter[{i}]"),
                format!("has a nozzle smaller than the particle spacing {spacing:.4} m"),
                "make the nozzle wider than one particle spacing",
            ));
        }
        let (lo32, hi32) = (lo.as_vec3(), hi.as_vec3());
        if !center.is_finite() || points.iter().any(|p| p.cmplt(lo32).any() || p.cmpgt(hi32).any()) {
            return Err(self.err(
                format!("emitter[{i}]"),
                format!("reaches outside the domain's fluid region {region}"),
                "move the nozzle inside the region, or make it smaller",
            ));
        }
        let full = points.len() as f64 * spacing * spacing * f64::from(e.speed);
        let rate = match e.rate {
            None => full,
            Some(rate) if rate.is_finite() && rate > 0.0 && rate <= full * (1.0 + 1e-9) => rate,
            Some(rate) if rate.is_finite() && rate > full => {
                return Err(self.err(
                    key("rate"),
                    format!(
                        "= {rate:.3e} m^3/s is more than the nozzle passes at {} m/s ({full:.3e} m^3/s: its {} particle columns times the speed); particles would land on each other",
                        e.speed,
                        points.len()
                    ),
                    "raise the speed, widen the nozzle, or lower the rate",
                ))
            }
            Some(rate) => {
                return Err(self.err(
                    key("rate"),
                    format!("= {rate} must be a positive flow in m^3/s"),
                    format!("give a rate up to {full:.3e} m^3/s, or leave it out for that full flow"),
                ))
            }
        };
        let pipe_length = e.pipe_length.unwrap_or(0.0);
        if !(pipe_length.is_finite() && pipe_length >= 0.0) {
            return Err(self.err(
                key("pipe_length"),
                format!("= {pipe_length} must be a length of 0 or more, m"),
                "give the pipe's length past the nozzle in metres (0, the default, for none)",
            ));
        }
        let pipe_end = (center + normal.as_dvec3() * pipe_length).as_vec3();
        if pipe_end.cmplt(lo32).any() || pipe_end.cmpgt(hi32).any() {
            return Err(self.err(
                key("pipe_length"),
                format!("= {pipe_length} m takes the pipe's end outside the domain's fluid region {region}"),
                "shorten the pipe, or move the nozzle back from the wall it points at",
            ));
        }
        let material = self.material_row(&key("material"), &e.material, materials)?;
        let row = &materials[usize::from(material)];
        if row.law.is_solid() {
            return Err(self.err(
                key("material"),
                format!(
                    "names \"{}\", a solid: an emitter pours liquids (solid grains raining onto a pile \
                     would embed in it without stress)",
                    row.name
                ),
                "name a liquid, or place the solid as a [[block]] or [[sphere]] with a velocity",
            ));
        }
        Ok(Emitter {
            nozzle,
            center,
            normal,
            speed: e.speed,
            rate,
            points,
            material,
            pipe_length,
        })
    }

    fn colliders(
        &self,
        spec: &SceneSpec,
        res: [u32; 3],
        dx: f64,
        materials: &[NamedMaterial],
    ) -> Result<Colliders, SceneError> {
        if spec.colliders.len() > MAX_COLLIDERS {
            return Err(self.err(
                format!("collider[{MAX_COLLIDERS}]"),
                format!(
                    "is one of {} colliders, more than the {MAX_COLLIDERS} a scene may have",
                    spec.colliders.len()
                ),
                "merge obstacles into one mesh collider, or drop some",
            ));
        }
        // Mesh files are found beside the scene file; a preset's among the files embedded with it.
        let dir = Path::new(self.source)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let preset = self
            .source
            .strip_prefix("preset ")
            .is_some_and(|name| presets::get(name).is_some());
        let read_mesh = |file: &str, scale: f64| match presets::mesh(file).filter(|_| preset) {
            Some(text) => mesh::parse_triangles(Path::new(file), text.as_bytes(), scale)
                .map_err(|e| format!("{file} (embedded with the presets): {e}")),
            None => {
                let path = dir.join(file);
                mesh::read_triangles(&path, scale).map_err(|e| format!("{}: {e}", path.display()))
            }
        };
        let domain = DVec3::from(res.map(f64::from)) * dx;
        let list = spec
            .colliders
            .iter()
            .enumerate()
            .map(|(i, c)| {
                colliders::validate(c, &read_mesh, domain, dx)
                    .map_err(|e| self.err(format!("collider[{i}].{}", e.key), e.problem, e.fix))
            })
            .collect::<Result<Vec<_>, _>>()?;
        // The explicit coupling's limit (bodies.rs, Dynamics::check_band_mass), against the densest
        // liquid.
        let liquid_density = densest_liquid(materials);
        for (i, c) in list.iter().enumerate() {
            let Some(body) = &c.body else { continue };
            if let Err((problem, fix)) = body.check_band_mass(&c.shape, liquid_density, dx) {
                return Err(self.err(format!("collider[{i}].density"), problem, fix));
            }
        }
        Ok(Colliders::new(list, dx as f32))
    }

    /// pbmpm's settings: `solver.iterations` and `solver.wall_friction`, refused under the explicit
    /// method, which has neither.
    fn pbmpm_settings(&self, spec: &SceneSpec) -> Result<pbmpm::Settings, SceneError> {
        let s = &spec.solver;
        if s.method == Method::Explicit {
            self.refuse_given(
                [
                    ("solver.iterations", s.iterations.is_some()),
                    ("solver.wall_friction", s.wall_friction.is_some()),
                ],
                "is a setting of the position-based solver, and this scene runs the explicit one",
                "drop it, or set solver.method = \"pbmpm\"",
            )?;
            return Ok(pbmpm::Settings::default());
        }
        let iterations = s.iterations.unwrap_or(pbmpm::DEFAULT_ITERATIONS);
        if !(1..=pbmpm::MAX_ITERATIONS).contains(&iterations) {
            return Err(self.err(
                "solver.iterations",
                format!("= {iterations} is outside 1 to {}", pbmpm::MAX_ITERATIONS),
                format!(
                    "give the constraint iterations a substep from 1 to {} ({} by default)",
                    pbmpm::MAX_ITERATIONS,
                    pbmpm::DEFAULT_ITERATIONS
                ),
            ));
        }
        let wall_friction = s.wall_friction.unwrap_or(0.0);
        if !(wall_friction.is_finite() && wall_friction >= 0.0) {
            return Err(self.err(
                "solver.wall_friction",
                format!("= {wall_friction} is not a friction coefficient"),
                "give a Coulomb coefficient >= 0 (0, the default, is free slip; 0.5 grips like wet wood)",
            ));
        }
        Ok(pbmpm::Settings {
            iterations,
            wall_friction,
        })
    }

    /// pbmpm's time step: `time_step.substeps` a 60 Hz frame, each 1 / (60 substeps) s, with no
    /// stability limit. The explicit method's keys (`cfl`, `dt`, `max_substeps`) are refused: the
    /// CFL policy does not apply to a scheme that is stable at any substep.
    fn pbmpm_time_step(&self, t: &TimeStepSpec) -> Result<TimeStepPolicy, SceneError> {
        self.refuse_given(
            [
                ("time_step.cfl", t.cfl.is_some()),
                ("time_step.dt", t.dt.is_some()),
                ("time_step.max_substeps", t.max_substeps.is_some()),
            ],
            "belongs to the explicit method's CFL policy; solver.method = \"pbmpm\" is stable at any \
             substep and runs a fixed number a frame",
            format!(
                "drop it and give time_step.substeps (substeps a 60 Hz frame, {} by default)",
                pbmpm::DEFAULT_SUBSTEPS
            ),
        )?;
        let substeps = t.substeps.unwrap_or(pbmpm::DEFAULT_SUBSTEPS);
        if !(1..=pbmpm::MAX_SUBSTEPS).contains(&substeps) {
            return Err(self.err(
                "time_step.substeps",
                format!("= {substeps} is outside 1 to {}", pbmpm::MAX_SUBSTEPS),
                format!(
                    "give the substeps a 60 Hz frame from 1 to {} ({} by default)",
                    pbmpm::MAX_SUBSTEPS,
                    pbmpm::DEFAULT_SUBSTEPS
                ),
            ));
        }
        Ok(TimeStepPolicy::pbmpm(substeps))
    }

    fn time_step(
        &self,
        t: &TimeStepSpec,
        material: &Material,
        materials: &[NamedMaterial],
        dx: f64,
        max_body_speed: f32,
    ) -> Result<TimeStepPolicy, SceneError> {
        let signal = material.sound_speed() + max_body_speed;
        let rows: Vec<Material> = materials.iter().map(|m| m.law).collect();
        let viscous_dt = rows.as_slice().viscous_dt(dx as f32);
        let dt_limit = (MAX_CFL * dx as f32 / signal).min(viscous_dt);
        if t.substeps.is_some() {
            return Err(self.err(
                "time_step.substeps",
                "is the position-based solver's fixed substep count; the explicit method chooses its \
                 substeps from cfl or a fixed dt",
                "drop it (and give cfl or dt), or set solver.method = \"pbmpm\"",
            ));
        }
        match (t.cfl, t.dt) {
            (Some(_), Some(_)) => Err(self.err(
                "time_step.dt",
                "and `time_step.cfl` are both given",
                "give cfl (substeps chosen from the stability limits) or a fixed dt, not both",
            )),
            (_, Some(dt)) => {
                let dt = self.positive("time_step.dt", dt, "give the substep in seconds")?;
                if dt > dt_limit {
                    return Err(self.err(
                        "time_step.dt",
                        format!(
                            "= {dt:.3e} s is above the stability limit {dt_limit:.3e} s \
                             ({MAX_CFL} dx / (c0 + |v|max) with c0 = {:.2} m/s, and the viscous limit \
                             {viscous_dt:.3e} s)",
                            material.sound_speed()
                        ),
                        format!(
                            "use dt <= {dt_limit:.3e}, or drop dt and set cfl = 0.4 to let the solver choose"
                        ),
                    ));
                }
                Ok(TimeStepPolicy::Fixed { dt })
            }
            (cfl, None) => {
                let cfl = cfl.unwrap_or(DEFAULT_CFL);
                if !(cfl.is_finite() && cfl > 0.0 && cfl <= MAX_CFL) {
                    return Err(self.err(
                        "time_step.cfl",
                        format!("= {cfl} is outside (0, {MAX_CFL}]"),
                        "use 0.3 to 0.5; 0.4 is the default",
                    ));
                }
                let max_substeps = t.max_substeps.unwrap_or(DEFAULT_MAX_SUBSTEPS);
                if max_substeps == 0 {
                    return Err(self.err(
                        "time_step.max_substeps",
                        "must be at least 1",
                        format!("drop it (default {DEFAULT_MAX_SUBSTEPS})"),
                    ));
                }
                let viscous_substeps = (FRAME_DT / viscous_dt).ceil();
                if viscous_substeps > max_substeps as f32 {
                    let stiffest = materials
                        .iter()
                        .min_by(|a, b| {
                            let limit =
                                |m: &NamedMaterial| std::slice::from_ref(&m.law).viscous_dt(dx as f32);
                            limit(a).total_cmp(&limit(b))
                        })
                        .expect("a scene has at least one material");
                    return Err(self.err(
                        "time_step.max_substeps",
                        format!(
                            "= {max_substeps} is under the {viscous_substeps:.0} substeps per frame that the \
                             viscous limit of material \"{}\" needs (dt <= rho0 dx^2 / (6 mu) = {viscous_dt:.3e} s \
                             with mu up to {} Pa s)",
                            stiffest.name,
                            stiffest.law.viscosity_ceiling()
                        ),
                        "raise time_step.max_substeps, lower that material's viscosity (or max_viscosity), \
                         or use a coarser grid (the limit grows with dx^2)",
                    ));
                }
                Ok(TimeStepPolicy::Cfl { cfl, max_substeps })
            }
        }
    }

    /// A sound speed or a gravity that loads but could never run, refused here rather than as a
    /// "blow-up" in frame 1: a sound speed whose first frame needs more substeps than the cap, and a
    /// gravity under which water falling across the domain outruns its own sound speed (the weakly
    /// compressible model holds only well below it).
    #[allow(clippy::too_many_arguments)]
    fn plausible_speeds(
        &self,
        key: &str,
        m: &MaterialSpec,
        material: &Material,
        gravity: Vec3,
        domain: &DomainSpec,
        dx: f64,
        max_body_speed: f32,
        policy: &TimeStepPolicy,
    ) -> Result<(), SceneError> {
        let c0 = material.sound_speed();
        if let TimeStepPolicy::Cfl { cfl, max_substeps } = *policy {
            let allowed = max_substeps as f32 * cfl * dx as f32 / FRAME_DT;
            if c0 + max_body_speed > allowed {
                let needs = (FRAME_DT * (c0 + max_body_speed) / (cfl * dx as f32)).ceil();
                let (key, given) = match (m.sound_speed, m.eos_stiffness) {
                    (Some(c), _) => (format!("{key}.sound_speed"), format!("= {c} m/s")),
                    (None, k) => (
                        format!("{key}.eos_stiffness"),
                        format!(
                            "= {} Pa gives a sound speed of {c0:.3e} m/s, which",
                            k.unwrap_or_default()
                        ),
                    ),
                };
                return Err(self.err(
                    key,
                    format!(
                        "{given} needs {needs:.3e} substeps per 60 Hz frame at dx = {dx} m and cfl = {cfl}, \
                         more than time_step.max_substeps = {max_substeps}"
                    ),
                    format!(
                        "give a sound speed from 1 to {:.0} m/s for this grid (10 to 20 m/s is real-time \
                         water; the substeps per frame grow with it)",
                        (allowed - max_body_speed).max(1.0)
                    ),
                ));
            }
        }
        let g = gravity.length();
        // The domain's extent along gravity: the farthest the water can fall.
        let drop = if g > 0.0 {
            let down = gravity / g;
            (0..3)
                .map(|a| (down[a] * domain.size[a] as f32).abs())
                .sum::<f32>()
        } else {
            0.0
        };
        let fall_speed = (2.0 * g * drop).sqrt();
        if fall_speed > c0 {
            return Err(self.err(
                "solver.gravity",
                format!(
                    "= {:?} m/s^2 lets water falling {drop:.3} m across the domain reach {fall_speed:.3e} m/s, \
                     faster than its sound speed c0 = {c0:.3} m/s, where the weakly compressible model \
                     no longer holds",
                    gravity.to_array()
                ),
                format!(
                    "give |g| from 0 to {:.1} m/s^2 for this sound speed and domain (c0^2 / (2 x {drop:.3} \
                     m); 9.81 on Earth), or raise {key}.sound_speed",
                    c0 * c0 / (2.0 * drop)
                ),
            ));
        }
        Ok(())
    }

    /// The live particles the bodies spawn; zero only where emitters will bring fluid.
    fn count_particles(&self, scene: &Scene, has_emitters: bool) -> Result<usize, SceneError> {
        let lattice = scene.lattice();
        let colliders = scene.colliders_at_start();
        let mut total = 0usize;
        for (k, body) in scene.bodies.iter().enumerate() {
            let own = scene.own_points(&lattice, k, &colliders).count();
            if own == 0 {
                let blocks = scene.bodies[..k]
                    .iter()
                    .filter(|b| matches!(b.shape, Shape::Block { .. }))
                    .count();
                let key = match body.shape {
                    Shape::Block { .. } => format!("block[{blocks}]"),
                    Shape::Sphere { .. } => format!("sphere[{}]", k - blocks),
                };
                return Err(self.err(
                    key,
                    format!(
                        "holds zero particles (smaller than the particle spacing {:.4} m, or inside an earlier body or a collider)",
                        lattice.spacing
                    ),
                    "make it larger than one cell, or move it out of the bodies listed before it and the colliders",
                ));
            }
            total += own;
        }
        if total == 0 && !has_emitters {
            return Err(self.err(
                "block",
                "the scene spawns zero particles",
                "add a [[block]] or [[sphere]] of fluid, or an [[emitter]]",
            ));
        }
        if total > u32::MAX as usize {
            return Err(self.err(
                "block",
                format!("the scene spawns {total} particles, above the 2^32 limit of particle indices"),
                "use fewer particles per cell or smaller bodies",
            ));
        }
        Ok(total)
    }

    /// Body volumes over the lattice cell volume, overlaps counted twice: cheap, and close enough to
    /// refuse a scene that could never fit before counting its points one by one.
    fn estimate_particles(&self, scene: &Scene) -> usize {
        let cell = scene.lattice().spacing.powi(3);
        let volume: f64 = scene
            .bodies
            .iter()
            .map(|b| match b.shape {
                Shape::Block { min, max } => (max - min).element_product(),
                Shape::Sphere { radius, .. } => 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
            })
            .sum();
        (volume / cell) as usize
    }

    fn fits_in_memory(&self, scene: &Scene, particles: usize) -> Result<(), SceneError> {
        let nodes: usize = scene.grid_res.iter().map(|&r| r as usize).product();
        let needed = particles.saturating_mul(CPU_BYTES_PER_PARTICLE) + nodes * CPU_BYTES_PER_NODE;
        if nodes > u32::MAX as usize {
            return Err(self.err(
                "domain.resolution",
                format!("gives {nodes} grid nodes, above the 2^32 limit of node indices"),
                "use a coarser grid",
            ));
        }
        if let Some(available) = available_host_memory() {
            if needed as u64 > available {
                return Err(self.err(
                    "",
                    format!(
                        "needs {:.1} GiB ({} particles, {} grid nodes) but this machine has {:.1} GiB available",
                        gib(needed as u64),
                        particles,
                        nodes,
                        gib(available)
                    ),
                    "use a coarser domain.resolution, fewer particles_per_cell or smaller bodies",
                ));
            }
        }
        Ok(())
    }
}

/// The parameters a law needs and those it may take besides.
fn law_parameters(law: LawSpec) -> (&'static [&'static str], &'static [&'static str]) {
    match law {
        LawSpec::Newtonian => (&[], &["viscosity"]),
        LawSpec::PowerLaw => (
            &["consistency", "flow_index", "max_viscosity"],
            &["min_viscosity"],
        ),
        LawSpec::CarreauYasuda => (
            &["viscosity", "flow_index", "relaxation_time"],
            &["min_viscosity", "max_viscosity", "transition_exponent"],
        ),
        LawSpec::HerschelBulkley => (
            &["consistency", "yield_stress"],
            &["flow_index", "min_viscosity", "max_viscosity", "shear_modulus"],
        ),
        LawSpec::FixedCorotated | LawSpec::NeoHookean => (&["youngs_modulus", "poisson_ratio"], &[]),
        LawSpec::Snow => (
            &["youngs_modulus", "poisson_ratio"],
            &["critical_compression", "critical_stretch", "hardening"],
        ),
        LawSpec::Sand => (
            &["youngs_modulus", "poisson_ratio", "friction_angle"],
            &["cohesion"],
        ),
    }
}

/// What a law parameter is given in, for a refusal's fix.
fn law_parameter_unit(field: &str) -> &'static str {
    match field {
        "viscosity" | "max_viscosity" | "min_viscosity" => "Pa s",
        "consistency" => "Pa s^n",
        "yield_stress" => "Pa",
        "relaxation_time" => "s",
        "youngs_modulus" | "shear_modulus" => "Pa",
        "friction_angle" => "degrees",
        _ => "a plain number",
    }
}

/// How to make the cells of `d` cubes of edge `dx` (x's): the sizes that fit the resolution as
/// given, always; and the resolution that fits the sizes, where rounding gives one the checks accept
/// (at least 8 nodes per axis, the same cell edge on every axis).
fn cube_cells_fix(d: &DomainSpec, dx: f64) -> String {
    // Rounded to a micrometre: 40 x 0.025 reads 1, not 1.0000000000000002.
    let metres = |x: f64| {
        let text = format!("{x:.6}");
        let text = text.trim_end_matches('0');
        format!("{text}{}", if text.ends_with('.') { "0" } else { "" })
    };
    let size = d.resolution.map(|r| metres(f64::from(r) * dx));
    let size_fix = format!(
        "size = [{}, {}, {}] for this resolution (dx = {} m)",
        size[0],
        size[1],
        size[2],
        metres(dx)
    );
    let res = [0, 1, 2].map(|a| (d.size[a] / dx).round());
    let fits = res
        .iter()
        .enumerate()
        .all(|(a, &r)| r >= 8.0 && r <= f64::from(u32::MAX) && ((d.size[a] / r - dx) / dx).abs() <= 1e-4);
    if fits {
        format!(
            "cells must be cubes: keep size / resolution equal, e.g. resolution = [{}, {}, {}] for this \
             size, or {size_fix}",
            res[0], res[1], res[2]
        )
    } else {
        format!("cells must be cubes: keep size / resolution equal, e.g. {size_fix}")
    }
}

fn gib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}

/// `MemAvailable` from /proc/meminfo; `None` where that is not there (the check is then skipped).
pub(crate) fn available_host_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}
