//! The scene file's `[[collider]]` tables as written, and their validation into [`Collider`]s.

use super::*;

/// One `[[collider]]` table as written.
#[derive(Debug, Clone, Default, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ColliderSpec {
    /// "box", "sphere", "capsule", "cylinder" or "mesh".
    pub shape: String,
    /// m. The shape's centre; for a mesh, where its file's origin goes (default 0).
    pub center: Option<[f64; 3]>,
    /// Box: full edge lengths, m.
    pub size: Option<[f64; 3]>,
    /// Sphere, capsule, cylinder, m.
    pub radius: Option<f64>,
    /// Capsule: length of its axis segment (end caps not counted); cylinder: its height. m, along
    /// the local y axis.
    pub length: Option<f64>,
    /// Orientation as Euler angles in degrees about the world x, then y, then z axes.
    pub rotation: Option<[f64; 3]>,
    /// Or as an axis and an angle in degrees: [ax, ay, az, degrees].
    pub axis_angle: Option<[f64; 4]>,
    /// Mesh: an .obj or .stl file, relative to the scene file.
    pub file: Option<String>,
    /// Mesh: factor applied to the file's coordinates (default 1).
    pub scale: Option<f64>,
    /// "slip" (default), "stick" or "friction" (then `friction` gives the coefficient).
    pub boundary: Option<String>,
    /// Coulomb coefficient; implies boundary = "friction".
    pub friction: Option<f64>,
    /// For a kinematic collider, how it moves; for a rigid body, its velocity at the start.
    pub motion: Option<MotionSpec>,
    /// kg/m^3: makes the collider a rigid body that the liquid moves (or give `mass`).
    pub density: Option<f64>,
    /// kg: a rigid body's mass (instead of `density`).
    pub mass: Option<f64>,
    /// A rigid body's fixed axis: it turns about it and nothing else.
    pub hinge: Option<HingeSpec>,
    /// Coulomb coefficient of a rigid body's contacts with the walls (default 0.4).
    pub contact_friction: Option<f64>,
}

/// `[collider.hinge]`: the axis a rigid body turns about.
#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct HingeSpec {
    /// A point of the axis, m.
    pub point: [f64; 3],
    /// Its direction.
    pub axis: [f64; 3],
}

/// `[collider.motion]`: give `velocity` and/or `angular_velocity`, or `piston`, or `flap`.
#[derive(Debug, Clone, Default, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// m/s.
    pub velocity: Option<[f64; 3]>,
    /// Degrees per second about the collider's centre, as a world-frame axis times rate.
    pub angular_velocity: Option<[f64; 3]>,
    pub piston: Option<PistonSpec>,
    pub flap: Option<FlapSpec>,
}

#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct PistonSpec {
    /// Direction of the stroke (normalised).
    pub direction: [f64; 3],
    /// m.
    pub amplitude: f64,
    /// s.
    pub period: f64,
    /// Degrees; the offset is amplitude sin(360 t / period + phase).
    #[serde(default)]
    pub phase: f64,
}

#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct FlapSpec {
    /// A point of the hinge line, m.
    pub hinge: [f64; 3],
    /// Direction of the hinge line.
    pub axis: [f64; 3],
    /// Degrees.
    pub amplitude: f64,
    /// s.
    pub period: f64,
    /// Degrees.
    #[serde(default)]
    pub phase: f64,
}

/// A refused collider: the key (below `collider[i]`), what is wrong, the fix.
#[derive(Debug)]
pub struct SpecError {
    pub key: String,
    pub problem: String,
    pub fix: String,
}

fn spec_err(key: impl Into<String>, problem: impl Into<String>, fix: impl Into<String>) -> SpecError {
    SpecError {
        key: key.into(),
        problem: problem.into(),
        fix: fix.into(),
    }
}

/// A positive `value` of `key`, or what to give: `what`, and (for a bad value) `why` after it.
fn positive(key: &str, value: Option<f64>, what: &str, why: &str) -> Result<f64, SpecError> {
    match value {
        None => Err(spec_err(key, "is missing", format!("give {what}"))),
        Some(v) if v.is_finite() && v > 0.0 => Ok(v),
        Some(v) => Err(spec_err(
            key,
            format!("= {v} must be a positive number"),
            format!("give {what}{why}"),
        )),
    }
}

/// What `positive` adds for a size: why it cannot be zero.
const NO_ZERO_SIZE: &str = "; a collider of zero size is nothing";

fn finite(key: &str, v: &[f64]) -> Result<(), SpecError> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(spec_err(
            key,
            format!("must be finite, got {v:?}"),
            "give finite numbers",
        ))
    }
}

fn unit(key: &str, v: [f64; 3]) -> Result<DVec3, SpecError> {
    finite(key, &v)?;
    DVec3::from(v).try_normalize().ok_or_else(|| {
        spec_err(
            key,
            format!("= {v:?} has no direction"),
            "give a non-zero direction vector, e.g. [1.0, 0.0, 0.0]",
        )
    })
}

fn oscillation(key: &str, amplitude: f64, period: f64, phase_deg: f64) -> Result<Oscillation, SpecError> {
    finite(&format!("{key}.amplitude"), &[amplitude])?;
    finite(&format!("{key}.phase"), &[phase_deg])?;
    if !(period.is_finite() && period > 0.0) {
        return Err(spec_err(
            format!("{key}.period"),
            format!("= {period} must be a positive number of seconds"),
            "give the period of one stroke in seconds, e.g. 1.0",
        ));
    }
    Ok(Oscillation {
        amplitude,
        period,
        phase: phase_deg.to_radians(),
    })
}

/// A mesh file's welded vertices and triangles, or why they could not be read.
pub type ReadMesh<'a> = &'a dyn Fn(&str, f64) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), String>;

/// Validates one `[[collider]]` table. `read_mesh` reads a mesh file named in the scene (with its
/// scale), its errors naming where it looked; `domain` is the tank's size, m; `dx` the grid spacing.
pub fn validate(
    spec: &ColliderSpec,
    read_mesh: ReadMesh,
    domain: DVec3,
    dx: f64,
) -> Result<Collider, SpecError> {
    const SHAPES: &str = "box, sphere, capsule, cylinder or mesh";
    let center = DVec3::from(spec.center.unwrap_or([0.0; 3]));
    finite("center", &center.to_array())?;
    if spec.center.is_none() && spec.shape != "mesh" {
        return Err(spec_err(
            "center",
            "is missing",
            "give the collider's centre in metres, e.g. center = [0.5, 0.1, 0.25]",
        ));
    }
    let rotation = match (spec.rotation, spec.axis_angle) {
        (Some(_), Some(_)) => {
            return Err(spec_err(
                "rotation",
                "and `axis_angle` are both given",
                "give one orientation: Euler degrees (rotation = [x, y, z]) or axis_angle = [ax, ay, az, degrees]",
            ))
        }
        (Some(e), None) => {
            finite("rotation", &e)?;
            let [x, y, z] = e.map(f64::to_radians);
            DQuat::from_rotation_z(z) * DQuat::from_rotation_y(y) * DQuat::from_rotation_x(x)
        }
        (None, Some(a)) => {
            let axis = unit("axis_angle", [a[0], a[1], a[2]])?;
            finite("axis_angle", &a)?;
            DQuat::from_axis_angle(axis, a[3].to_radians())
        }
        (None, None) => DQuat::IDENTITY,
    };
    let mesh_keys_given = spec.file.is_some() || spec.scale.is_some();
    let shape = match spec.shape.as_str() {
        "box" => {
            let size = spec.size.ok_or_else(|| {
                spec_err(
                    "size",
                    "is missing",
                    "give the box's edge lengths in metres, e.g. size = [0.2, 0.1, 0.3]",
                )
            })?;
            for (a, s) in size.iter().enumerate() {
                positive(
                    &format!("size[{a}]"),
                    Some(*s),
                    "every edge length in metres",
                    NO_ZERO_SIZE,
                )?;
            }
            Shape::Box {
                half_extents: DVec3::from(size) * 0.5,
            }
        }
        "sphere" => Shape::Sphere {
            radius: positive("radius", spec.radius, "the radius in metres", NO_ZERO_SIZE)?,
        },
        "capsule" | "cylinder" => {
            let radius = positive("radius", spec.radius, "the radius in metres", NO_ZERO_SIZE)?;
            let half_length = 0.5
                * positive(
                    "length",
                    spec.length,
                    "the length along its axis in metres",
                    NO_ZERO_SIZE,
                )?;
            if spec.shape == "capsule" {
                Shape::Capsule { radius, half_length }
            } else {
                Shape::Cylinder { radius, half_length }
            }
        }
        "mesh" => {
            let file = spec.file.as_deref().ok_or_else(|| {
                spec_err(
                    "file",
                    "is missing",
                    "give the mesh file, e.g. file = \"obstacle.obj\" (.obj or .stl)",
                )
            })?;
            let scale = match spec.scale {
                None => 1.0,
                Some(s) => positive("scale", Some(s), "a positive scale factor", NO_ZERO_SIZE)?,
            };
            let fail = |problem: String| {
                let fix = if problem.contains("cannot be opened") {
                    format!(
                        "a mesh file is read from the scene file's folder: put {file} there or give its \
                         path relative to it (a preset's mesh: `mpm scenes --mesh {file} > {file}`)"
                    )
                } else {
                    "give a closed (watertight) triangle mesh in an .obj or .stl file".to_string()
                };
                spec_err("file", problem, fix)
            };
            let (vertices, triangles) = read_mesh(file, scale).map_err(fail)?;
            crate::sim::mesh::check_closed(&triangles).map_err(|e| fail(format!("{file}: {e}")))?;
            let margin = f64::from(BAND_CELLS) * dx + 2.0 * dx;
            // A collider that stays put can only ever touch the tank: its field is sampled there
            // alone (the tank, plus the margin, in the mesh's own frame). A moving one may bring any
            // of itself into the tank.
            let moving = spec.density.is_some()
                || spec.mass.is_some()
                || spec.motion.as_ref().is_some_and(|m| {
                    m.velocity.is_some()
                        || m.angular_velocity.is_some()
                        || m.piston.is_some()
                        || m.flap.is_some()
                });
            let clip = (!moving).then(|| {
                let local = |p: DVec3| rotation.inverse() * (p - center);
                let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
                for corner in 0..8 {
                    let pick = |bit: u32, a: f64| {
                        if corner & (1 << bit) == 0 {
                            -margin
                        } else {
                            a + margin
                        }
                    };
                    let p = local(DVec3::new(
                        pick(0, domain.x),
                        pick(1, domain.y),
                        pick(2, domain.z),
                    ));
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
                (lo, hi)
            });
            let memory = crate::sim::scene::available_host_memory().unwrap_or(u64::MAX) / 2;
            let sdf = crate::sim::mesh::build_sdf(file, vertices, triangles, dx, margin, clip, memory)
                .map_err(|e| {
                    spec_err(
                    "scale",
                    format!("= {scale}: {e}"),
                    "use a smaller scale, or a mesh closer to the tank's size (a static mesh's field covers \
                     only the part of it in the tank)",
                )
                })?;
            Shape::Mesh(Arc::new(sdf))
        }
        other => {
            return Err(spec_err(
                "shape",
                format!("= {other:?} is not a collider shape"),
                format!("use one of {SHAPES}"),
            ))
        }
    };
    if mesh_keys_given && !matches!(shape, Shape::Mesh(_)) {
        return Err(spec_err(
            "file",
            "is only for shape = \"mesh\"",
            "drop `file` and `scale`, or set shape = \"mesh\"",
        ));
    }
    for (key, given, used) in [
        ("size", spec.size.is_some(), matches!(shape, Shape::Box { .. })),
        (
            "radius",
            spec.radius.is_some(),
            matches!(
                shape,
                Shape::Sphere { .. } | Shape::Capsule { .. } | Shape::Cylinder { .. }
            ),
        ),
        (
            "length",
            spec.length.is_some(),
            matches!(shape, Shape::Capsule { .. } | Shape::Cylinder { .. }),
        ),
    ] {
        if given && !used {
            return Err(spec_err(
                key,
                format!("is not a key of a {} collider", shape.kind_name()),
                "box: size; sphere: radius; capsule and cylinder: radius and length; mesh: file and scale",
            ));
        }
    }
    let boundary = match (spec.boundary.as_deref(), spec.friction) {
        (None | Some("slip"), None) => Boundary::Slip,
        (Some("stick"), None) => Boundary::Stick,
        (None | Some("friction"), Some(mu)) => {
            if !(mu.is_finite() && mu >= 0.0) {
                return Err(spec_err(
                    "friction",
                    format!("= {mu} must be zero or positive"),
                    "give the Coulomb coefficient, e.g. friction = 0.3 (0 is free slip)",
                ));
            }
            Boundary::Friction(mu as f32)
        }
        (Some("friction"), None) => {
            return Err(spec_err(
                "friction",
                "is missing",
                "give the Coulomb coefficient, e.g. friction = 0.3",
            ))
        }
        (Some(kind @ ("slip" | "stick")), Some(_)) => {
            return Err(spec_err(
                "friction",
                format!("is given with boundary = {kind:?}"),
                "drop `friction`, or set boundary = \"friction\"",
            ))
        }
        (Some(other), _) => return Err(spec_err(
            "boundary",
            format!("= {other:?} is not a boundary kind"),
            "use \"slip\" (free slip, the default), \"stick\" (no slip) or \"friction\" with friction = mu",
        )),
    };
    let motion = match &spec.motion {
        None => Motion::Static,
        Some(m) => match (m.velocity, m.angular_velocity, &m.piston, &m.flap) {
            (None, None, None, None) => Motion::Static,
            (v, w, None, None) => {
                let v = v.unwrap_or([0.0; 3]);
                let w = w.unwrap_or([0.0; 3]);
                finite("motion.velocity", &v)?;
                finite("motion.angular_velocity", &w)?;
                Motion::Steady {
                    velocity: DVec3::from(v),
                    angular_velocity: DVec3::from(w.map(f64::to_radians)),
                    since: 0.0,
                }
            }
            (None, None, Some(p), None) => Motion::Piston {
                direction: unit("motion.piston.direction", p.direction)?,
                oscillation: oscillation("motion.piston", p.amplitude, p.period, p.phase)?,
            },
            (None, None, None, Some(f)) => {
                finite("motion.flap.hinge", &f.hinge)?;
                Motion::Flap {
                    hinge: DVec3::from(f.hinge),
                    axis: unit("motion.flap.axis", f.axis)?,
                    oscillation: Oscillation {
                        amplitude: f.amplitude.to_radians(),
                        ..oscillation("motion.flap", f.amplitude, f.period, f.phase)?
                    },
                }
            }
            _ => {
                return Err(spec_err(
                    "motion",
                    "mixes kinds of motion",
                    "give velocity and/or angular_velocity, or piston, or flap: one kind per collider",
                ))
            }
        },
    };
    let body = dynamics(spec, &shape, &motion)?;
    let motion = if body.is_some() { Motion::Static } else { motion };
    let collider = Collider {
        shape,
        boundary,
        center,
        rotation,
        motion,
        body,
    };
    // Some of the collider must be inside the domain (a paddle or a slope may well run through a
    // wall or the floor, its centre outside), or the fluid would never meet it.
    let (lo, hi) = collider_bounds(&collider);
    if hi.cmple(DVec3::ZERO).any() || lo.cmpge(domain).any() {
        return Err(spec_err(
            "center",
            format!(
                "puts the collider (centre {:?}, reaching [{:.3}, {:.3}, {:.3}] to [{:.3}, {:.3}, {:.3}] m) outside \
                 the domain [0, {:.4}] x [0, {:.4}] x [0, {:.4}] m",
                center.to_array(),
                lo.x, lo.y, lo.z, hi.x, hi.y, hi.z,
                domain.x, domain.y, domain.z
            ),
            "move the collider so that at least part of it is inside the tank",
        ));
    }
    if collider.body.is_some() {
        let (lo, hi) = collider_bounds(&collider);
        if lo.cmplt(DVec3::ZERO).any() || hi.cmpgt(domain).any() {
            return Err(spec_err(
                "center",
                format!(
                    "puts the rigid body (reaching [{:.3}, {:.3}, {:.3}] to [{:.3}, {:.3}, {:.3}] m) through a wall",
                    lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
                ),
                "a rigid body starts wholly inside the tank: move it in, or make it smaller",
            ));
        }
    }
    Ok(collider)
}

/// A rigid body's dynamics where the table gives a density or a mass; `None` for a collider that
/// moves as it is told. `motion` as validated: a body's velocities are its start.
fn dynamics(spec: &ColliderSpec, shape: &Shape, motion: &Motion) -> Result<Option<Dynamics>, SpecError> {
    let properties = shape.mass_properties();
    let mass = match (spec.density, spec.mass) {
        (None, None) => {
            for (key, given) in [
                ("hinge", spec.hinge.is_some()),
                ("contact_friction", spec.contact_friction.is_some()),
            ] {
                if given {
                    return Err(spec_err(
                        key,
                        "is only for a rigid body",
                        "give the collider a density (kg/m^3) or a mass (kg) to make it a body the water moves",
                    ));
                }
            }
            return Ok(None);
        }
        (Some(_), Some(_)) => {
            return Err(spec_err(
                "mass",
                "and `density` are both given",
                "give one: density (kg/m^3) or mass (kg)",
            ))
        }
        (Some(rho), None) => {
            positive("density", Some(rho), "the body's density in kg/m^3", "")? * properties.volume
        }
        (None, Some(m)) => positive("mass", Some(m), "the body's mass in kg", "")?,
    };
    let (velocity, angular_velocity) = match *motion {
        Motion::Static => (DVec3::ZERO, DVec3::ZERO),
        Motion::Steady {
            velocity,
            angular_velocity,
            ..
        } => (velocity, angular_velocity),
        Motion::Piston { .. } | Motion::Flap { .. } => {
            return Err(spec_err(
                "motion",
                "gives a rigid body a piston or flap motion",
                "a body moves by the forces on it: give only motion.velocity and motion.angular_velocity                  (its start), or drop density/mass to drive it as a collider",
            ))
        }
    };
    let hinge = match &spec.hinge {
        None => None,
        Some(h) => {
            finite("hinge.point", &h.point)?;
            Some(Hinge {
                point: DVec3::from(h.point),
                axis: unit("hinge.axis", h.axis)?,
            })
        }
    };
    let contact_friction = spec.contact_friction.unwrap_or(0.4);
    if !(contact_friction.is_finite() && contact_friction >= 0.0) {
        return Err(spec_err(
            "contact_friction",
            format!("= {contact_friction} must be zero or positive"),
            "give the Coulomb coefficient of the body's contacts, e.g. contact_friction = 0.4",
        ));
    }
    let density = mass / properties.volume;
    Ok(Some(Dynamics {
        mass,
        centroid: properties.centroid,
        inertia: properties.inertia * density,
        velocity,
        angular_velocity,
        hinge,
        contact_friction,
    }))
}

/// A box that holds the collider at rest, world frame.
fn collider_bounds(c: &Collider) -> (DVec3, DVec3) {
    let m = DMat3::from_quat(c.rotation);
    let half = match &c.shape {
        Shape::Box { half_extents } => DVec3::new(
            m.row(0).abs().dot(*half_extents),
            m.row(1).abs().dot(*half_extents),
            m.row(2).abs().dot(*half_extents),
        ),
        Shape::Mesh(mesh) => {
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for v in &mesh.vertices {
                let w = m * v.as_dvec3();
                lo = lo.min(w);
                hi = hi.max(w);
            }
            return (c.center + lo, c.center + hi);
        }
        other => DVec3::splat(other.bounding_radius()),
    };
    (c.center - half, c.center + half)
}
