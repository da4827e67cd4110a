//! Position-based MPM (Lewin, "A Position-Based Material Point Method", SIGGRAPH 2024), in 3D: the
//! single-thread CPU reference of `solver.method = "pbmpm"`, which the GPU port (kernels/pbmpm.cu)
//! is tested against (docs/physics.md, "Position-based MPM").
//!
//! A substep works in displacements, not velocities. Each particle starts it with the displacement
//! it had over the last substep plus gravity's, d = v dt + g dt^2, and the affine part of it,
//! D = C dt (the warm start). Then `iterations` times: every particle projects its material's
//! constraint onto D ([`project`]), the particles scatter mass-weighted displacement to the grid
//! (APIC: w m (d + D (x_i - x_p))) and the walls' mirror images join it as the explicit solver's
//! momentum, the grid turns it into node displacements, applies the colliders and the tank's walls to
//! where each node would move this substep ([`ColliderFrame::hold_displacement`],
//! [`wall_displacement`]) and the liquids' viscosity as a diffusion of the displacements, and the
//! particles gather d and D back. Last, each particle integrates once ([`integrate`]): x += d, its
//! deformation F <- (I + D) F with its law's return mapping, a liquid's volume ratio J <- J (1 +
//! tr D); and v = d / dt, C = D / dt carry the state to the next substep, so that a checkpoint,
//! the export and the statistics see the particles as they see the explicit solver's.
//!
//! Nothing here has a stability limit on the substep: a constraint only moves D towards a target,
//! and the grid only averages; how far a material is from its target after the iterations is how
//! soft it looks. The quadratic B-spline stencil is the explicit solver's ([`Stencil`]), the solids'
//! return mappings and the SVD are src/sim/solid.rs's and src/sim/svd.rs's.

use super::colliders::ColliderFrame;
use super::cpu::{self, GridShape, Stencil};
use super::params::{Material, Params};
use super::phase::{Phase, PhaseClock, PhaseTimings};
use super::push::Push;
use super::scene::Particles;
use super::solid;
use super::solver::{push_step_timing, Solver, StepExtremes};
use super::svd;
use super::view::ParticleView;
use crate::contract::{LAW_HERSCHEL_BULKLEY, LAW_SAND};
use glam::{Mat3, UVec3, Vec3};

/// Constraint iterations a substep when the scene gives none (`solver.iterations`).
pub const DEFAULT_ITERATIONS: u32 = 4;
/// The most `solver.iterations` may ask for.
pub const MAX_ITERATIONS: u32 = 64;
/// Substeps a 60 Hz frame when the scene gives none (`time_step.substeps`).
pub const DEFAULT_SUBSTEPS: u32 = 2;
/// The most `time_step.substeps` may ask for.
pub const MAX_SUBSTEPS: u32 = 1000;
/// The sound speed a pbmpm liquid is given where its scene names none, m/s: it only sets the
/// signal speed the statistics report (no equation of state runs under pbmpm).
pub const PBMPM_NOMINAL_SOUND_SPEED: f32 = 10.0;
pub use crate::contract::{
    FADING_NODE_MASS, FULL_NODE_FILL, FULL_NODE_FILL_RAMP, FULL_NODE_WEIGHT, GRID_VOLUME_RATE,
    LIQUID_RELAXATION, MAX_VOLUME_BIAS, MIN_LIQUID_VOLUME, SOLID_RELAXATION, VOLUME_ERROR_GAIN,
    VOLUME_MEMORY_GAIN,
};
/// The singular values of a solid's F are held within these after each integration (the
/// contract's `PBMPM_MIN_STRETCH`, `PBMPM_MAX_STRETCH`).
pub const SOLID_STRETCH_RANGE: (f32, f32) = (
    crate::contract::PBMPM_MIN_STRETCH,
    crate::contract::PBMPM_MAX_STRETCH,
);

/// Why the cpu-parallel backend refuses a scene of `solver.method = "pbmpm"` (before any work
/// starts).
pub const NOT_CPU_PARALLEL: &str = "solver.method = \"pbmpm\" runs on CUDA (--backend cuda) and on the \
     single-thread CPU reference (--backend cpu), not on cpu-parallel";

/// The position-based solver's settings (`solver.iterations`, `solver.wall_friction`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Constraint iterations a substep.
    pub iterations: u32,
    /// The tank walls' Coulomb coefficient: a node held at a wall keeps a tangential displacement
    /// shortened by this times the normal displacement the wall took from it.
    pub wall_friction: f32,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            iterations: DEFAULT_ITERATIONS,
            wall_friction: 0.0,
        }
    }
}

/// The single-thread position-based solver.
pub struct PbmpmSolver {
    pub particles: Particles,
    pub settings: Settings,
    shape: GridShape,
    /// Per node: the substep's mass (scattered once: particles do not move during the iterations).
    mass: Vec<f32>,
    /// Per node: the mass-weighted displacement scattered, then (in place) the node's displacement.
    displacement: Vec<Vec3>,
    /// Per node, where the walls' mirror joins the scatter and the walls hold with friction: the
    /// particles' own mass and mass-weighted displacement before the images joined them (the
    /// friction reads what the walls take from these); empty otherwise.
    own_mass: Vec<f32>,
    own_displacement: Vec<Vec3>,
    /// Per node: the liquids' kinematic viscosity mu / rho0, mass-weighted (scattered with the
    /// mass), then the node's; empty where no particle has any ([`Self::diffuse`]).
    viscosity: Vec<f32>,
    /// Per node, where the scene has liquids ([`Self::liquid_volumes`]): the particles' rest volume
    /// (then over the cell's: the fill), and the liquids' mass and mass-weighted volume error (then
    /// the node's volume error).
    fill: Vec<f32>,
    liquid_mass: Vec<f32>,
    volume_error: Vec<f32>,
    /// The displacement before a diffusion sweep.
    previous: Vec<Vec3>,
    /// Per particle, within a substep: its stencil, displacement d and affine displacement D, and
    /// F^-1 of a particle that carries a deformation (identity otherwise).
    stencils: Vec<Stencil>,
    d: Vec<Vec3>,
    affine: Vec<Mat3>,
    f_inverse: Vec<Mat3>,
    /// Per particle, within a substep: a liquid's volume target, how far past its rest volume its
    /// constraint aims ([`Self::liquid_volumes`]); 0 for a solid.
    target: Vec<f32>,
    /// The colliders where the substep ends (`Solver::set_colliders`): they hold the grid's nodes
    /// ([`ColliderFrame::hold_displacement`]) and, after the integration, the particles (the backstop).
    colliders: ColliderFrame,
    extremes: StepExtremes,
    timings: Vec<PhaseTimings>,
}

impl PbmpmSolver {
    /// A solver of `particles` on a grid of `grid_res` nodes. A liquid particle's density is its
    /// volume ratio's, rho0 / J: one spawned at rest density starts at J = 1. Particles without a
    /// volume bias (a fresh spawn, a checkpoint written before there was one) start with none.
    pub fn new(mut particles: Particles, grid_res: [u32; 3], settings: Settings) -> PbmpmSolver {
        if particles.volume_bias.is_empty() {
            particles.volume_bias = vec![0.0; particles.len()];
        }
        assert_eq!(
            particles.volume_bias.len(),
            particles.len(),
            "a volume bias per slot"
        );
        let shape = GridShape::whole(UVec3::from(grid_res));
        let n = shape.num_nodes();
        PbmpmSolver {
            particles,
            settings,
            shape,
            mass: vec![0.0; n],
            displacement: vec![Vec3::ZERO; n],
            own_mass: Vec::new(),
            own_displacement: Vec::new(),
            viscosity: Vec::new(),
            fill: Vec::new(),
            liquid_mass: Vec::new(),
            volume_error: Vec::new(),
            previous: Vec::new(),
            stencils: Vec::new(),
            d: Vec::new(),
            affine: Vec::new(),
            f_inverse: Vec::new(),
            target: Vec::new(),
            colliders: ColliderFrame::default(),
            extremes: StepExtremes::default(),
            timings: Vec::new(),
        }
    }

    /// The warm start: stencils, d = v dt + g dt^2, D = C dt, F^-1; the substep's grid mass (the
    /// walls' images joined); and the liquids' volume targets ([`Self::liquid_volumes`]).
    fn begin_substep(&mut self, params: &Params) {
        let p = &self.particles;
        let (dt, gravity) = (params.dt, Vec3::from(params.gravity));
        let n = p.len();
        self.stencils.clear();
        self.stencils
            .extend(p.x.iter().map(|&x| Stencil::new(x, params.inv_dx)));
        self.d.clear();
        self.d.extend(p.v.iter().map(|&v| v * dt + gravity * (dt * dt)));
        self.affine.clear();
        self.affine.extend(p.c.iter().map(|&c| c * dt));
        self.f_inverse.clear();
        self.f_inverse.extend((0..n).map(|i| match p.deformation.get(i) {
            Some(d) if Material::of(params, p.material[i]).carries_deformation() => d.f.inverse(),
            _ => Mat3::IDENTITY,
        }));
        self.mass.fill(0.0);
        self.viscosity.clear();
        let (shape, mass) = (self.shape, &mut self.mass);
        for i in (0..n).filter(|&i| p.live[i]) {
            let mat = Material::of(params, p.material[i]);
            let m_p = mat.particle_mass;
            self.stencils[i].for_each_node(shape, |node, w, _| mass[node] += w * m_p);
            // A liquid's viscosity at its strain rate over the last substep, C.
            let nu = if mat.is_solid() {
                0.0
            } else {
                mat.effective_viscosity(p.c[i]) / mat.rest_density
            };
            if nu > 0.0 {
                if self.viscosity.is_empty() {
                    self.viscosity = vec![0.0; shape.num_nodes()];
                }
                let viscosity = &mut self.viscosity;
                self.stencils[i].for_each_node(shape, |node, w, _| viscosity[node] += w * m_p * nu);
            }
        }
        for (nu, &m) in self.viscosity.iter_mut().zip(&self.mass) {
            if m > 0.0 {
                *nu /= m;
            }
        }
        self.own_mass.clear();
        if mirrors(params) {
            if self.settings.wall_friction > 0.0 {
                self.own_mass.clone_from(&self.mass);
            }
            cpu::mirror_walls(shape, params, &mut self.mass, |_, m, _, _| m);
        }
        self.liquid_volumes(params);
    }

    /// The liquids' volume targets for the substep, with their memory and drift correction
    /// (docs/physics.md, "Position-based MPM"). Every particle scatters its rest volume (a solid its
    /// volume, m / rho) and every liquid particle its mass and mass-weighted volume error m (1 - J),
    /// the walls' mirror images joining them. Then each liquid particle gathers:
    /// - the fill phi = sum w V_i / dx^3, whose inverse is the volume ratio the grid measures about
    ///   it. Where every stencil node is full ([`FULL_NODE_FILL`]; not at a free surface, which reads
    ///   as expansion) its J moves [`GRID_VOLUME_RATE`] of the way there, less where its least full
    ///   node is within the ramp ([`FULL_NODE_FILL_RAMP`], [`FULL_NODE_WEIGHT`]): J integrated from
    ///   tr D drifts from the particles' real spacing as they rearrange;
    /// - its smoothed volume error e = sum w (m (1 - J))_i / m_i (the error gathered from the grid is
    ///   the same for neighbours, so no particle-to-particle pattern can grow in the memory): its
    ///   volume bias b gains [`VOLUME_MEMORY_GAIN`] e, held within 0 and [`MAX_VOLUME_BIAS`], and its
    ///   volume target for the substep is b + [`VOLUME_ERROR_GAIN`] max(e, 0) ([`project`]).
    ///
    /// The bias is the pressure memory: a liquid under a load its iterations cannot carry within a
    /// substep stays compressed, and its bias grows until the load is carried at J = 1; then e = 0
    /// and the bias holds.
    fn liquid_volumes(&mut self, params: &Params) {
        let (shape, n) = (self.shape, self.particles.len());
        self.target.clear();
        self.target.resize(n, 0.0);
        let p = &self.particles;
        let is_liquid = |i: usize| p.live[i] && !Material::of(params, p.material[i]).is_solid();
        if !(0..n).any(is_liquid) {
            return;
        }
        let nodes = shape.num_nodes();
        for grid in [&mut self.fill, &mut self.liquid_mass, &mut self.volume_error] {
            grid.clear();
            grid.resize(nodes, 0.0);
        }
        for i in (0..n).filter(|&i| p.live[i]) {
            let mat = Material::of(params, p.material[i]);
            let m_p = mat.particle_mass;
            let (fill, stencil) = (&mut self.fill, &self.stencils[i]);
            if mat.is_solid() {
                let v = m_p / p.rho[i];
                stencil.for_each_node(shape, |node, w, _| fill[node] += w * v);
                continue;
            }
            let (v, error) = (m_p / mat.rest_density, m_p * (1.0 - mat.rest_density / p.rho[i]));
            let (liquid_mass, volume_error) = (&mut self.liquid_mass, &mut self.volume_error);
            stencil.for_each_node(shape, |node, w, _| {
                fill[node] += w * v;
                liquid_mass[node] += w * m_p;
                volume_error[node] += w * error;
            });
        }
        for grid in [&mut self.fill, &mut self.liquid_mass, &mut self.volume_error] {
            cpu::mirror_walls(shape, params, grid, |_, m, _, _| m);
        }
        let cell = params.inv_dx * params.inv_dx * params.inv_dx;
        for ((fill, error), &m) in self
            .fill
            .iter_mut()
            .zip(&mut self.volume_error)
            .zip(&self.liquid_mass)
        {
            *fill *= cell;
            if m > 0.0 {
                *error /= m;
            }
        }
        let p = &mut self.particles;
        for i in (0..n).filter(|&i| p.live[i]) {
            let mat = Material::of(params, p.material[i]);
            if mat.is_solid() {
                continue;
            }
            let (mut phi, mut least, mut e) = (0.0f32, f32::MAX, 0.0f32);
            let (fill, volume_error) = (&self.fill, &self.volume_error);
            self.stencils[i].for_each_node(shape, |node, w, _| {
                phi += w * fill[node];
                e += w * volume_error[node];
                least = least.min(fill[node] + (1.0 - w / FULL_NODE_WEIGHT).max(0.0));
            });
            let full = ((least - FULL_NODE_FILL) / FULL_NODE_FILL_RAMP + 0.5).clamp(0.0, 1.0);
            if full > 0.0 {
                let j = mat.rest_density / p.rho[i];
                let j = j + GRID_VOLUME_RATE * full * (1.0 / phi - j);
                p.rho[i] = mat.rest_density / j.max(MIN_LIQUID_VOLUME);
            }
            let bias = &mut p.volume_bias[i];
            *bias = (*bias + VOLUME_MEMORY_GAIN * e).clamp(0.0, MAX_VOLUME_BIAS);
            self.target[i] = *bias + VOLUME_ERROR_GAIN * e.max(0.0);
        }
    }

    /// Every particle's constraint on D ([`project`]).
    fn project_all(&mut self, params: &Params) {
        let p = &self.particles;
        let relaxation = liquid_relaxation(self.settings.iterations);
        for i in (0..p.len()).filter(|&i| p.live[i]) {
            let volume = VolumeTarget {
                target: self.target[i],
                relaxation,
            };
            let deformation = p.deformation.get(i).map(|d| (d.f, d.plastic));
            self.affine[i] = project(
                params,
                Material::of(params, p.material[i]),
                self.affine[i],
                p.rho[i],
                deformation,
                self.f_inverse[i],
                volume,
            );
        }
    }

    /// w m_p (d + D (x_i - x_p)) to every stencil node, then the walls' mirror images (as the
    /// explicit solver's momentum: [`cpu::mirror_walls`], [`cpu::momentum_image`]).
    fn scatter(&mut self, params: &Params) {
        self.displacement.fill(Vec3::ZERO);
        let (shape, dx, grid) = (self.shape, params.dx, &mut self.displacement);
        let p = &self.particles;
        for i in (0..p.len()).filter(|&i| p.live[i]) {
            let m_p = Material::of(params, p.material[i]).particle_mass;
            let (d, affine) = (self.d[i], self.affine[i] * dx);
            self.stencils[i].for_each_node(shape, |node, w, offset| {
                grid[node] += (w * m_p) * (d + affine * offset)
            });
        }
        if mirrors(params) {
            if !self.own_mass.is_empty() {
                self.own_displacement.clone_from(grid);
            }
            cpu::mirror_walls(shape, params, grid, cpu::momentum_image);
        }
    }

    /// Node displacements, held by the colliders ([`ColliderFrame::hold_displacement`]), then by the
    /// walls ([`wall_displacement`]; where the mirror joined the scatter and the walls grip,
    /// [`wall_displacement_with_images`]), which have the last word.
    fn grid_update(&mut self, params: &Params) {
        let (lo, hi) = fluid_region(params, self.shape);
        let friction = self.settings.wall_friction;
        for (i, (&m, d)) in self.mass.iter().zip(self.displacement.iter_mut()).enumerate() {
            *d = if m > 0.0 {
                let x = self.shape.node(i).as_vec3() * params.dx;
                let held = self.colliders.hold_displacement(x, *d / m, params.dt);
                match self.own_mass.get(i) {
                    Some(&own) if own > 0.0 => {
                        let own = self.own_displacement[i] / own;
                        wall_displacement_with_images(held, own, x, lo, hi, friction)
                    }
                    // A node that only images reach has no fluid of its own to grip.
                    Some(_) => wall_displacement(held, x, lo, hi, 0.0),
                    None => wall_displacement(held, x, lo, hi, friction),
                }
            } else {
                Vec3::ZERO
            };
        }
        if !self.viscosity.is_empty() {
            self.diffuse(params, lo, hi);
        }
    }

    /// The liquids' viscosity on the grid: one Jacobi sweep of the implicit diffusion of the node
    /// displacements, d_i <- (d_i + a sum_j t_j d_j) / (1 + a sum_j t_j), over the face neighbours j,
    /// each counted by its mass m_j as t_j = m_j / (m_j + [`FADING_NODE_MASS`] of a cell's), a =
    /// nu_i dt / (dx^2 iterations): a substep's iterations together take about one implicit step of
    /// nu dt / dx^2, and each sweep is a weighted average, stable at any viscosity. Then the colliders
    /// and the walls again, which the average may have crossed.
    fn diffuse(&mut self, params: &Params, lo: Vec3, hi: Vec3) {
        let scale = params.dt * params.inv_dx * params.inv_dx / self.settings.iterations as f32;
        let res = self.shape.res;
        let stride = [1usize, res.x as usize, (res.x * res.y) as usize];
        // A cell's mass of the densest material is 2^40 units of the fixed-point mass scale.
        let fading = FADING_NODE_MASS * (1u64 << 40) as f32 / params.fixed_mass_scale;
        self.previous.clone_from(&self.displacement);
        for i in 0..self.mass.len() {
            let a = self.viscosity[i] * scale;
            if self.mass[i] <= 0.0 || a <= 0.0 {
                continue;
            }
            let node = self.shape.node(i);
            let (mut sum, mut n) = (Vec3::ZERO, 0.0f32);
            for axis in 0..3 {
                for j in [
                    (node[axis] > 0).then(|| i - stride[axis]),
                    (node[axis] + 1 < res[axis]).then(|| i + stride[axis]),
                ]
                .into_iter()
                .flatten()
                {
                    let t = self.mass[j] / (self.mass[j] + fading);
                    sum += self.previous[j] * t;
                    n += t;
                }
            }
            let d = (self.previous[i] + sum * a) / (1.0 + a * n);
            let x = node.as_vec3() * params.dx;
            let held = self.colliders.hold_displacement(x, d, params.dt);
            self.displacement[i] = wall_displacement(held, x, lo, hi, self.settings.wall_friction);
        }
    }

    /// d = sum w d_i, D = (4 / dx^2) sum w d_i (x_i - x_p)^T.
    fn gather(&mut self, params: &Params) {
        let (shape, grid) = (self.shape, &self.displacement);
        let p = &self.particles;
        for i in (0..p.len()).filter(|&i| p.live[i]) {
            let (mut d, mut b) = (Vec3::ZERO, Mat3::ZERO);
            self.stencils[i].for_each_node(shape, |node, w, offset| {
                let wd = w * grid[node];
                d += wd;
                b += Mat3::from_cols(wd * offset.x, wd * offset.y, wd * offset.z);
            });
            self.d[i] = d;
            self.affine[i] = b * (4.0 * params.inv_dx);
        }
    }

    /// Every particle's [`integrate`], then the colliders' backstop (a particle that ended inside a
    /// collider goes back to its surface and loses its velocity into it, as under the explicit
    /// solver), and the substep's extremes.
    fn integrate_all(&mut self, params: &Params) {
        let (lo, hi) = fluid_region(params, self.shape);
        let p = &mut self.particles;
        for i in (0..p.len()).filter(|&i| p.live[i]) {
            let mat = Material::of(params, p.material[i]);
            let state = Integrated {
                x: p.x[i],
                d: self.d[i],
                affine: self.affine[i],
                rho: p.rho[i],
                deformation: p.deformation.get(i).map(|d| (d.f, d.plastic)),
            };
            let out = integrate(mat, state, lo, hi);
            (p.x[i], p.v[i]) = (out.x, out.d / params.dt);
            if let Some((x, v)) = self.colliders.backstop(p.x[i], p.v[i]) {
                (p.x[i], p.v[i]) = (x.clamp(lo, hi), v);
                self.extremes.backstop_pushes += 1;
            }
            p.c[i] = out.affine / params.dt;
            p.rho[i] = out.rho;
            if let (Some(d), Some((f, plastic))) = (p.deformation.get_mut(i), out.deformation) {
                (d.f, d.plastic) = (f, plastic);
            }
            let speed = p.v[i].length();
            self.extremes.max_speed = self.extremes.max_speed.max(speed);
            let reported = super::cpu::reported_density(params, p.material[i], p.rho[i]);
            self.extremes.max_density = self.extremes.max_density.max(reported);
        }
    }

    /// One substep: the warm start, `iterations` times constraints, scatter, grid and gather, then
    /// the integration. Timed as the explicit solver's phases: the mass scatter as p2g_init, the
    /// constraints with the displacement scatter as p2g, the grid as grid_update, the gathers and the
    /// integration as g2p.
    pub fn substep(&mut self, params: &Params) {
        let mut clock = PhaseClock::start();
        self.begin_substep(params);
        clock.lap(Phase::P2gInit);
        for _ in 0..self.settings.iterations {
            self.project_all(params);
            self.scatter(params);
            clock.lap(Phase::P2g);
            self.grid_update(params);
            clock.lap(Phase::GridUpdate);
            self.gather(params);
            clock.lap(Phase::G2p);
        }
        self.integrate_all(params);
        clock.lap(Phase::G2p);
        push_step_timing(&mut self.timings, clock.finish());
    }
}

/// Whether the walls' mirror joins the scatter: the scene's `solver.mirror_wall_mass` (on by
/// default), as in the explicit solver (docs/physics.md, "Walls: the mirror boundary").
fn mirrors(params: &Params) -> bool {
    params.wall_mirror_lo != 0
}

/// The nodes' fluid region in metres, `[lo, hi]` per axis: where the explicit solver's walls hold
/// the fluid (`scene::fluid_region_nodes`, without the soft wall, which pbmpm refuses).
pub fn fluid_region(params: &Params, shape: GridShape) -> (Vec3, Vec3) {
    let (lo, hi) = super::scene::fluid_region_nodes(shape.res.to_array(), params.boundary_band, false);
    (
        Vec3::splat(lo as f32 * params.dx),
        UVec3::from(hi).as_vec3() * params.dx,
    )
}

/// A node's displacement `d` for the substep, the node at `x`, after the tank's walls: on each axis
/// the node may not end beyond a wall's plane (`lo`, `hi`), and a node already beyond one may not
/// move further into the wall; motion off a wall is free. Where a wall takes normal displacement
/// from the node, Coulomb friction `friction` shortens its tangential displacement by that much
/// times the coefficient (to zero at most).
#[inline]
pub fn wall_displacement(mut d: Vec3, x: Vec3, lo: Vec3, hi: Vec3, friction: f32) -> Vec3 {
    for a in 0..3 {
        let (least, most) = ((lo[a] - x[a]).min(0.0), (hi[a] - x[a]).max(0.0));
        let held = d[a].clamp(least, most);
        let taken = (held - d[a]).abs();
        d[a] = held;
        grip(&mut d, a, friction * taken);
    }
    d
}

/// [`wall_displacement`] of a node whose displacement `d` the walls' mirror images joined, `own` the
/// displacement of its particles alone: the images cancel what the fluid presses into a wall before
/// the walls see it, so the friction reads the normal displacement the walls take from `own`, the
/// push the images gave in their place.
#[inline]
pub fn wall_displacement_with_images(
    mut d: Vec3,
    own: Vec3,
    x: Vec3,
    lo: Vec3,
    hi: Vec3,
    friction: f32,
) -> Vec3 {
    for a in 0..3 {
        let (least, most) = ((lo[a] - x[a]).min(0.0), (hi[a] - x[a]).max(0.0));
        d[a] = d[a].clamp(least, most);
        grip(&mut d, a, friction * (own[a].clamp(least, most) - own[a]).abs());
    }
    d
}

/// Shortens the part of `d` tangential to an `axis` wall by `cut` (to zero at most): Coulomb
/// friction.
#[inline]
fn grip(d: &mut Vec3, axis: usize, cut: f32) {
    if cut <= 0.0 {
        return;
    }
    let mut tangent = *d;
    tangent[axis] = 0.0;
    let length = tangent.length();
    if length > 0.0 {
        let kept = (length - cut).max(0.0) / length;
        for b in (0..3).filter(|&b| b != axis) {
            d[b] *= kept;
        }
    }
}

/// The elasticity ratio of a solid's shape target: the weight of the rotation (its shear) against
/// the volume-preserving stretch (its volume) in the blend r R + (1 - r) Q, from its fixed-corotated
/// energy mu |F - R|^2 + lambda / 2 (J - 1)^2 as 2 mu / (2 mu + lambda): 0.57 at a Poisson's ratio
/// of 0.3, towards 0 as the solid becomes incompressible, 1 at a ratio of 0.
pub fn elasticity_ratio(mat: &Material) -> f32 {
    let (mu, lambda) = (mat.shear_modulus, mat.lame_lambda.max(0.0));
    if mu + lambda <= 0.0 {
        return 1.0;
    }
    2.0 * mu / (2.0 * mu + lambda)
}

/// How much of its relaxed correction a solid takes an iteration: k / (1 + k), k = (c dt / dx)^2
/// with c its wave speed (`solid::solid_wave_speed`, snow's hardening included): the compliance of
/// an XPBD constraint of stiffness rho c^2 on a particle of a cell's mass. A solid whose wave
/// crosses a cell within the substep is held to its shape as stiffly as the iterations can; a softer
/// one yields over several substeps.
pub fn stiffness_weight(params: &Params, speed: f32) -> f32 {
    let k = (speed * params.dt * params.inv_dx).powi(2);
    k / (1.0 + k)
}

/// The rotation of F's polar decomposition F = R S by Newton's iteration R <- (R + R^-T) / 2, which
/// converges quadratically from F where det F > 0; an inverted or near-singular F (det F at most
/// 1e-6 of |F|^3) takes the SVD's rotation (`svd::polar`), which is a rotation even there.
pub fn polar_rotation(f: Mat3) -> Mat3 {
    let scale = f.to_cols_array().iter().fold(0.0f32, |m, v| m.max(v.abs()));
    if scale.is_nan() || scale <= 0.0 || f.determinant() <= 1e-6 * scale * scale * scale {
        return svd::polar(f);
    }
    let mut r = f;
    for _ in 0..20 {
        let next = (r + r.inverse().transpose()) * 0.5;
        let change = (next - r)
            .to_cols_array()
            .iter()
            .fold(0.0f32, |m, v| m.max(v.abs()));
        r = next;
        if change <= 1e-6 {
            break;
        }
    }
    r
}

fn trace(a: Mat3) -> f32 {
    a.x_axis.x + a.y_axis.y + a.z_axis.z
}

/// The deviatoric part of a matrix (its trace removed).
fn deviator(a: Mat3) -> Mat3 {
    a - Mat3::from_diagonal(Vec3::splat(trace(a) / 3.0))
}

/// The liquids' over-relaxation `w` in a substep of `iterations` iterations: [`LIQUID_RELAXATION`]
/// where a later iteration's gather and projection take part of each overshoot back, none at one
/// iteration, whose only projection is integrated as it is. Over-relaxed there, a particle expanded
/// past J (1 + tr D) = 3 (1 + t) was projected past no volume, held at [`MIN_LIQUID_VOLUME`], and
/// pushed out of it at tens of m/s the next substep: one iteration diverged on every dam break of 1 cm
/// and finer (BENCHMARKS.md M24).
pub fn liquid_relaxation(iterations: u32) -> f32 {
    if iterations > 1 {
        LIQUID_RELAXATION
    } else {
        1.0
    }
}

/// A liquid particle's volume constraint in one iteration: its target t ([`PbmpmSolver`]'s
/// `liquid_volumes`) and how far past it the iteration moves it ([`liquid_relaxation`]).
#[derive(Clone, Copy, Debug)]
pub struct VolumeTarget {
    pub target: f32,
    pub relaxation: f32,
}

/// One particle's constraint on its affine displacement `affine` (D), in one iteration: the
/// particle of material `mat`, density `rho` (a liquid's volume ratio is rho0 / rho), deformation
/// `deformation` (F and the plastic scalar, where it carries one) with F^-1 `f_inverse`, and (a
/// liquid's) `volume` target. Returns the projected D.
/// (A liquid's viscosity acts on the grid: [`PbmpmSolver`]'s `diffuse`.)
///
/// - A liquid's volume: D += w a I with a = ((1 + t) / J - 1 - tr D) / 3, which makes the volume
///   it integrates to J (1 + tr D) = 1 + t, t the target (its volume bias, the memory of the load
///   it carries, and its smoothed volume error; w its relaxation). The target holds both ways, as
///   Lewin's: an expanded particle is pulled back as a compressed one is pushed out (a unilateral
///   target, with J held at 1 at most, let the integrated J drift from the particles' real spacing:
///   a pool lost about 19 % of its height within 5 s against about 9 % both ways). Its
///   `pressure_floor` is not read.
/// - An elastic solid (fixed-corotated, Neo-Hookean, snow): its shape target T = r R + (1 - r) Q,
///   R the rotation of F_trial = (I + D) F ([`polar_rotation`]), Q = F_trial / |det F_trial|^(1/3)
///   its shape at rest volume, r the elasticity ratio ([`elasticity_ratio`]); D moves towards
///   T F^-1 - I by the relaxation times the stiffness weight ([`stiffness_weight`]).
/// - Sand: the same, except that Q restores only a lost volume (|det F_trial| held at 1 at most);
///   Drucker-Prager comes at integration, and forgets what the cone does not hold. (Lewin's target, U Sigma' V^T
///   with F_trial's singular values held at 1 or more, resists compression alone: here a 10 cm
///   column of it ran to the far wall at 4, 16 and 64 iterations alike.)
/// - An elastoviscoplastic liquid (Herschel-Bulkley with a shear modulus): the liquid's volume,
///   then the deviatoric part of the move towards R F^-1 - I (its elastic part is isochoric).
pub fn project(
    params: &Params,
    mat: &Material,
    mut affine: Mat3,
    rho: f32,
    deformation: Option<(Mat3, f32)>,
    f_inverse: Mat3,
    volume: VolumeTarget,
) -> Mat3 {
    if !mat.is_solid() {
        let j = (mat.rest_density / rho).max(MIN_LIQUID_VOLUME);
        let a = ((1.0 + volume.target) / j - 1.0 - trace(affine)) / 3.0;
        affine += Mat3::from_diagonal(Vec3::splat(volume.relaxation * a));
        if let Some((f, _)) = deformation.filter(|_| mat.is_elastoviscoplastic()) {
            let f_trial = (Mat3::IDENTITY + affine) * f;
            let target = polar_rotation(f_trial) * f_inverse - Mat3::IDENTITY;
            let speed = (mat.shear_modulus / mat.rest_density).sqrt();
            let weight = SOLID_RELAXATION * stiffness_weight(params, speed);
            affine += deviator(target - affine) * weight;
        }
        return affine;
    }
    let Some((f, plastic)) = deformation else {
        return affine;
    };
    let f_trial = (Mat3::IDENTITY + affine) * f;
    let ratio = elasticity_ratio(mat);
    let det = f_trial.determinant();
    let sand = mat.law == LAW_SAND;
    // Sand restores a lost volume only; an elastic solid its volume either way.
    let volume = if sand {
        det.abs().clamp(0.1, 1.0)
    } else {
        det.abs().clamp(0.1, 1000.0)
    };
    let sign = if det < 0.0 { -1.0 } else { 1.0 };
    let q = f_trial * (sign / volume.cbrt());
    let target = (polar_rotation(f_trial) * ratio + q * (1.0 - ratio)) * f_inverse - Mat3::IDENTITY;
    let speed = solid::solid_wave_speed(mat, plastic);
    let weight = SOLID_RELAXATION * stiffness_weight(params, speed);
    affine += (target - affine) * weight;
    affine
}

/// What a particle integrates from, and what it integrates to: position, displacement d, affine
/// displacement D, density and deformation (F, plastic scalar).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Integrated {
    pub x: Vec3,
    pub d: Vec3,
    pub affine: Mat3,
    pub rho: f32,
    pub deformation: Option<(Mat3, f32)>,
}

/// The substep's integration of one particle of `mat` from `state` (its gathered d and D): x += d,
/// held inside the fluid region `[lo, hi]` (a guard: the walls held its nodes already); a liquid's
/// J <- J (1 + tr D) (det (I + D) to first order, which conserves volume better than the full
/// determinant under the constraint that targets it), held at [`MIN_LIQUID_VOLUME`] or more, its
/// density rho0 / J; a deformation F <- (I + D) F, then its law's return mapping
/// (`solid::plastic_return`: Drucker-Prager for sand, snow's clamp, the yield stress's) and the
/// safety clamp of its singular values ([`SOLID_STRETCH_RANGE`]), a solid's density rho0 / det F.
pub fn integrate(mat: &Material, state: Integrated, lo: Vec3, hi: Vec3) -> Integrated {
    let mut out = state;
    out.x = (state.x + state.d).clamp(lo, hi);
    if let Some((f, plastic)) = state.deformation {
        let trial = (Mat3::IDENTITY + state.affine) * f;
        let (f, plastic) = solid::plastic_return(mat, trial, plastic);
        let f = if mat.law == LAW_HERSCHEL_BULKLEY && !mat.is_solid() {
            f
        } else {
            clamp_stretch(f)
        };
        out.deformation = Some((f, plastic));
        if mat.is_solid() {
            out.rho = mat.rest_density / f.determinant().abs().max(1e-6);
        }
    }
    if !mat.is_solid() {
        let j = mat.rest_density / state.rho * (1.0 + trace(state.affine));
        out.rho = mat.rest_density / j.max(MIN_LIQUID_VOLUME);
    }
    out
}

/// F with its singular values held within [`SOLID_STRETCH_RANGE`]; F itself where they are.
fn clamp_stretch(f: Mat3) -> Mat3 {
    let (lowest, highest) = SOLID_STRETCH_RANGE;
    let (u, sigma, v) = svd::svd3(f);
    // sigma_2 carries det F's sign: an inverted F is held at the smallest stretch, the right way round.
    let held = sigma.abs().clamp(Vec3::splat(lowest), Vec3::splat(highest));
    if held == sigma {
        return f;
    }
    u * Mat3::from_diagonal(held) * v.transpose()
}

impl Solver for PbmpmSolver {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn step(&mut self, params: &Params) -> anyhow::Result<()> {
        self.substep(params);
        Ok(())
    }

    /// The state a substep starts from is all in the particles (v, C, density, deformation, volume
    /// bias).
    fn resume_after(&mut self, _last: &Params) {}

    fn take_extremes(&mut self) -> anyhow::Result<StepExtremes> {
        Ok(std::mem::take(&mut self.extremes))
    }

    fn take_step_timings(&mut self) -> anyhow::Result<Option<Vec<PhaseTimings>>> {
        Ok(Some(std::mem::take(&mut self.timings)))
    }

    fn particles(&self) -> ParticleView<'_> {
        ParticleView::Host(&self.particles)
    }

    fn read_particles(&mut self) -> anyhow::Result<Particles> {
        Ok(self.particles.clone())
    }

    fn apply_push(&mut self, push: &Push) -> anyhow::Result<()> {
        push.apply_to(&mut self.particles);
        Ok(())
    }

    fn set_iterations(&mut self, iterations: u32) -> anyhow::Result<()> {
        self.settings.iterations = iterations;
        Ok(())
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> anyhow::Result<()> {
        anyhow::ensure!(
            frame.states.iter().all(|s| s.body == 0),
            "solver.method = \"pbmpm\" moves no rigid bodies"
        );
        self.colliders.clone_from(frame);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newton_polar_matches_the_svd_rotation() {
        let f = Mat3::from_cols(
            Vec3::new(1.1, 0.2, -0.1),
            Vec3::new(-0.3, 0.9, 0.05),
            Vec3::new(0.0, 0.15, 1.2),
        );
        let (newton, svd) = (polar_rotation(f), svd::polar(f));
        let gap = (newton - svd)
            .to_cols_array()
            .iter()
            .fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(gap < 1e-5, "{newton:?} against {svd:?}");
        let identity = newton * newton.transpose() - Mat3::IDENTITY;
        assert!(identity.to_cols_array().iter().all(|v| v.abs() < 1e-5));
    }

    #[test]
    fn a_wall_stops_a_node_at_its_plane_and_lets_it_leave() {
        let (lo, hi) = (Vec3::splat(0.1), Vec3::splat(0.9));
        // Falling 0.3 m onto the floor from 0.2 m: stopped at the plane, sliding on.
        let d = wall_displacement(Vec3::new(0.05, -0.3, 0.0), Vec3::splat(0.2), lo, hi, 0.0);
        assert_eq!(d, Vec3::new(0.05, -0.1, 0.0));
        // With friction 0.2 the 0.2 m taken shortens the slide by 0.04 m.
        let d = wall_displacement(Vec3::new(0.05, -0.3, 0.0), Vec3::splat(0.2), lo, hi, 0.2);
        assert!((d.x - 0.01).abs() < 1e-6 && d.y == -0.1, "{d:?}");
        // A node beyond the plane may leave the wall, not go further in.
        let beyond = Vec3::new(0.5, 0.05, 0.5);
        assert_eq!(
            wall_displacement(Vec3::new(0.0, 0.02, 0.0), beyond, lo, hi, 0.0).y,
            0.02
        );
        assert_eq!(
            wall_displacement(Vec3::new(0.0, -0.02, 0.0), beyond, lo, hi, 0.0).y,
            0.0
        );
    }

    #[test]
    fn under_the_mirror_the_friction_reads_what_the_wall_takes_from_the_fluids_own_displacement() {
        let (lo, hi) = (Vec3::splat(0.1), Vec3::splat(0.9));
        let on_floor = Vec3::new(0.5, 0.1, 0.5);
        // The fluid's own displacement presses 0.05 m into the floor; the images cancelled it.
        let own = Vec3::new(0.05, -0.05, 0.0);
        let d = wall_displacement_with_images(Vec3::new(0.05, 0.0, 0.0), own, on_floor, lo, hi, 0.2);
        assert!((d.x - 0.04).abs() < 1e-6 && d.y == 0.0, "{d:?}");
        // Leaving the floor, it grips nothing.
        let own = Vec3::new(0.05, 0.01, 0.0);
        let d = wall_displacement_with_images(Vec3::new(0.05, 0.01, 0.0), own, on_floor, lo, hi, 0.2);
        assert_eq!(d, own);
    }
}
