//! The single-thread CPU reference: docs/physics.md step for step, with the names of the paper
//! (x, v, C, base, fx, w). It is the report's baseline and the oracle of every GPU test, so each
//! phase is a public method that a test can run on its own.

use super::colliders::bodies::{BodiesState, BodyWalls, ContactFeature, HostBodies, RigidBody};
use super::colliders::ColliderFrame;
use super::flow::{FlowCounts, FlowState, Lifecycle, Slots};
use super::params::{gathers_volume, DensityRule, Material, Params, ScatterMode};
use super::phase::{Phase, PhaseClock, PhaseTimings};
use super::push::Push;
use super::scene::{Deformation, Particles};
use super::solid;
use super::solver::{push_step_timing, Solver, StepExtremes};
use super::view::ParticleView;
use crate::contract::VOLUME_UNITS_PER_WEIGHT;
use glam::{IVec3, Mat3, UVec3, Vec3};

/// Quadratic B-spline weights of one particle on its 3x3x3 stencil.
#[derive(Debug, Clone, Copy)]
pub struct Stencil {
    /// Lowest stencil node.
    pub base: IVec3,
    /// Position relative to `base`, in cells; each component in [0.5, 1.5).
    pub fx: Vec3,
    /// Per-axis weights of nodes base+0, base+1, base+2.
    pub w: [Vec3; 3],
}

impl Stencil {
    /// `x` in metres.
    pub fn new(x: Vec3, inv_dx: f32) -> Stencil {
        let xg = x * inv_dx;
        let base = (xg - 0.5).floor();
        let fx = xg - base;
        let w = [
            0.5 * (1.5 - fx) * (1.5 - fx),
            0.75 - (fx - 1.0) * (fx - 1.0),
            0.5 * (fx - 0.5) * (fx - 0.5),
        ];
        Stencil {
            base: base.as_ivec3(),
            fx,
            w,
        }
    }

    /// Calls `f(node index, w, d)` for the 27 stencil nodes, d = node - x in cells.
    #[inline(always)]
    pub fn for_each_node(&self, shape: GridShape, mut f: impl FnMut(usize, f32, Vec3)) {
        let [_, sx, sxy] = shape.strides();
        let base = shape.index(self.base);
        for oz in 0..3 {
            let (wz, dz) = (self.w[oz].z, oz as f32 - self.fx.z);
            for oy in 0..3 {
                let (wyz, dy) = (self.w[oy].y * wz, oy as f32 - self.fx.y);
                let row = base + oy * sx + oz * sxy;
                for ox in 0..3 {
                    let d = Vec3::new(ox as f32 - self.fx.x, dy, dz);
                    f(row + ox, self.w[ox].x * wyz, d);
                }
            }
        }
    }
}

/// The box of the domain's nodes a grid holds (on the GPU, `KernelParams::box_lo`, `box_res`): for one
/// solver the whole grid; on a rank of several, CPU or CUDA, the planes of its slab and ghost planes
/// along the slab axis (`Slabs::held`) and the whole grid along the other two, so that a rank's grid
/// shrinks with its slab. Nodes keep the domain's coordinates everywhere; the box only says where
/// one is stored ([`GridShape::index`], `grid_index` in kernels/common.cuh). It starts on a node
/// block's edge, as the slabs are cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridBox {
    pub lo: [u32; 3],
    pub res: [u32; 3],
}

impl GridBox {
    /// The whole grid of `grid_res` nodes.
    pub const fn whole(grid_res: [u32; 3]) -> GridBox {
        GridBox {
            lo: [0; 3],
            res: grid_res,
        }
    }

    /// The planes `planes` across `axis` of a grid of `grid_res` nodes.
    pub fn planes(grid_res: [u32; 3], axis: usize, planes: std::ops::Range<u32>) -> GridBox {
        let mut held = GridBox::whole(grid_res);
        held.lo[axis] = planes.start;
        held.res[axis] = planes.len() as u32;
        held
    }

    pub fn nodes(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    /// Its planes across `axis`.
    pub fn along(&self, axis: usize) -> std::ops::Range<u32> {
        self.lo[axis]..self.lo[axis] + self.res[axis]
    }

    /// `params` with this box's, for kernels on a grid of this box.
    pub fn set_in(&self, params: &mut Params) {
        params.box_lo = self.lo;
        params.box_res = self.res;
    }
}

/// The domain's nodes and the box of them a grid stores ([`GridBox`]), in the node order shared with
/// the kernels (x fastest).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridShape {
    /// Nodes per axis of the domain: the walls, their band and the clamp stand at its ends.
    pub res: UVec3,
    /// The nodes stored.
    pub held: GridBox,
}

impl GridShape {
    /// The whole domain of `res` nodes, stored whole.
    pub const fn whole(res: UVec3) -> GridShape {
        GridShape {
            res,
            held: GridBox::whole([res.x, res.y, res.z]),
        }
    }

    /// The domain of `res` nodes, of which planes `planes` across `axis` are stored.
    pub fn planes(res: UVec3, axis: usize, planes: std::ops::Range<u32>) -> GridShape {
        GridShape {
            res,
            held: GridBox::planes(res.to_array(), axis, planes),
        }
    }

    /// Where node `node` (inside the box) is stored.
    #[inline]
    pub fn index(&self, node: IVec3) -> usize {
        let (lo, r) = (UVec3::from(self.held.lo), UVec3::from(self.held.res));
        let n = node.as_uvec3() - lo;
        debug_assert!(n.cmplt(r).all(), "node {node} outside the grid's box");
        (n.x + r.x * (n.y + r.y * n.z)) as usize
    }

    /// The node stored at `index`.
    pub fn node(&self, index: usize) -> UVec3 {
        let (i, r) = (index as u32, self.held.res);
        UVec3::from(self.held.lo) + UVec3::new(i % r[0], (i / r[0]) % r[1], i / (r[0] * r[1]))
    }

    /// The nodes stored.
    pub fn num_nodes(&self) -> usize {
        self.held.nodes()
    }

    /// How far apart in storage neighbours along x, y and z lie.
    pub fn strides(&self) -> [usize; 3] {
        let [rx, ry, _] = self.held.res.map(|r| r as usize);
        [1, rx, rx * ry]
    }
}

/// Grid accumulators: mass, and momentum that grid_update turns into velocity in place.
#[derive(Debug, Clone)]
pub struct Grid {
    pub shape: GridShape,
    pub mass: Vec<f32>,
    pub momentum: Vec<Vec3>,
    /// The fixed-point scatter's sums (`ScatterMode::FixedPoint`), made on its first use.
    pub fixed: Option<FixedGrid>,
    /// The grid's volume where the rest densities differ ([`gathers_volume`]): each node's sum of
    /// the particles' stencil weights in fixed-point units ([`volume_units`]), whatever the scatter
    /// mode, so that no sum depends on the order of its terms; empty until the first such scatter.
    pub volume: Vec<i64>,
}

impl Grid {
    /// A zeroed grid of the nodes `shape` stores.
    pub fn new(shape: GridShape) -> Grid {
        Grid {
            shape,
            mass: vec![0.0; shape.num_nodes()],
            momentum: vec![Vec3::ZERO; shape.num_nodes()],
            fixed: None,
            volume: Vec::new(),
        }
    }

    /// What its sums take in memory, bytes.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of_val;
        let fixed = self.fixed.as_ref().map_or(0, |f| {
            size_of_val(f.mass.as_slice()) + size_of_val(f.momentum.as_slice())
        });
        size_of_val(self.mass.as_slice())
            + size_of_val(self.momentum.as_slice())
            + size_of_val(self.volume.as_slice())
            + fixed
    }

    /// The fixed-point sums, zeroed where they were just made.
    pub fn fixed_mut(&mut self) -> &mut FixedGrid {
        let n = self.shape.num_nodes();
        self.fixed.get_or_insert_with(|| FixedGrid {
            mass: vec![0; n],
            momentum: vec![[0; 3]; n],
        })
    }
}

/// The fixed-point scatter's accumulators, like the GPU's (kernels/common.cuh): each contribution
/// rounded to an integer number of units (`Params::fixed_mass_scale`, `fixed_momentum_scale` per kg
/// and per kg m/s) and summed as integers, so a node's sum does not depend on the order of its
/// contributions (nor on how they are split between ranks). The sums become the float mass and
/// momentum before anything reads them (`CpuSolver::settle_mass`, `settle_momentum`).
#[derive(Debug, Clone, Default)]
pub struct FixedGrid {
    pub mass: Vec<i64>,
    pub momentum: Vec<[i64; 3]>,
}

/// A contribution's fixed-point units (`scaled` = value times its scale), rounded to nearest even as
/// CUDA's `__float2ll_rn`; 0 where out of range (beyond 2^52 units, or NaN), as on the GPU.
#[inline(always)]
pub fn fixed_point_units(scaled: f32) -> i64 {
    if scaled.abs() < FIXED_CONTRIBUTION_LIMIT {
        scaled.round_ties_even() as i64
    } else {
        0
    }
}

/// A fixed-point sum as a float: `__ll2float_rn(units) * inv_scale`.
#[inline(always)]
pub fn fixed_point_value(units: i64, inv_scale: f32) -> f32 {
    units as f32 * inv_scale
}

/// A stencil weight's units in the grid's volume ([`Grid::volume`]), rounded to nearest even as
/// kernels/volume.cu rounds `w * VOLUME_UNITS_PER_WEIGHT`, in a tile or not.
#[inline(always)]
pub fn volume_units(w: f32) -> i64 {
    fixed_point_units(w * VOLUME_UNITS_PER_WEIGHT)
}

/// 2^52 units: a contribution beyond it is dropped (kernels/common.cuh's FIXED_CONTRIBUTION_LIMIT).
const FIXED_CONTRIBUTION_LIMIT: f32 = 4_503_599_627_370_496.0;

/// Where a node lies against one wall's mirror plane, of the low wall (`low`) or the high one: what
/// decides the image it receives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WallSide {
    /// On the plane or on the fluid's side of it.
    Fluid { low: bool },
    /// Beyond the plane, inside the wall.
    Beyond { low: bool },
}

/// The image `partner` adds, across the plane of an `axis` wall, to the momentum `own` of a node on
/// `side`: the wall-normal component of the partner's momentum, reflected (a mirror-image fluid
/// moving the other way), or as it is (an image moving with the fluid), so that the image pushes
/// fluid off the wall and never pulls it back, as a collider's boundary does:
/// - on the fluid's side (the plane included) the image's normal momentum points off the wall
///   whatever its sign: fluid pressed on the wall gets the reflected push it always got, and fluid
///   leaving it gets a push along, not the reflected pull that would hold it there;
/// - beyond the plane it is reflected while the fluid there presses on the wall (so the band then
///   stops it), and moves with the fluid where the fluid moves off the wall: where the node's own
///   momentum points off the wall by more than [`OFF_THE_WALL`] of the partner's. (The margin keeps
///   the choice the same on every backend: float and fixed-point sums of a node that holds next to no
///   momentum differ in their last bits, and a choice at exactly zero would follow them.)
pub fn momentum_image(own: Vec3, mut partner: Vec3, axis: usize, side: WallSide) -> Vec3 {
    let (own, p) = (own[axis], partner[axis]);
    partner[axis] = match side {
        WallSide::Fluid { low: true } => p.abs(),
        WallSide::Fluid { low: false } => -p.abs(),
        WallSide::Beyond { low } => {
            let off_the_wall = if low { own } else { -own } > p.abs() * OFF_THE_WALL;
            if off_the_wall {
                p
            } else {
                -p
            }
        }
    };
    partner
}

/// How far, as a fraction of its partner's, a beyond-the-plane node's own wall-normal momentum must
/// point off the wall for the image to move with it (`momentum_image`): a millionth, far above the
/// rounding of any backend's sums and far below any flow.
pub const OFF_THE_WALL: f32 = 1e-6;

/// The velocity the walls' mirror images gave a node of mass `m` and momentum `mv` (images
/// included) whose particles' own sums were `own_m` and `own_mv`: its velocity less its particles'
/// own (none where they put no mass there). A Coulomb collider counts its push off the collider's
/// surface as normal velocity removed (`ColliderFrame::project_node_exchanging`); the GPU's twin is
/// mirrored_sums' in kernels/grid_update.cu.
#[inline(always)]
pub fn image_push(m: f32, mv: Vec3, own_m: f32, own_mv: Vec3) -> Vec3 {
    let own_v = if own_m > 0.0 { own_mv / own_m } else { Vec3::ZERO };
    mv / m - own_v
}

/// The particles' own sums at each node before the walls' mirror images join them, kept only where
/// something reads them: the mass where the scene has rigid bodies (their exchange counts no image
/// mass) or a Coulomb collider under the mirror, the momentum for the latter ([`image_push`]).
/// Empty otherwise: the nodes' own sums are then their sums.
#[derive(Debug, Clone, Default)]
pub struct OwnSums {
    pub mass: Vec<f32>,
    pub momentum: Vec<Vec3>,
}

impl OwnSums {
    /// Node `i`'s own mass and the images' push, given its sums with the images (`m`, `mv`).
    #[inline(always)]
    pub fn at(&self, i: usize, m: f32, mv: Vec3) -> (f32, Vec3) {
        let own_m = self.mass.get(i).copied().unwrap_or(m);
        let push = self
            .momentum
            .get(i)
            .map_or(Vec3::ZERO, |&own_mv| image_push(m, mv, own_m, own_mv));
        (own_m, push)
    }
}

/// Adds the mirror image of the fluid beyond every wall to a grid quantity, in place.
///
/// A fluid resting against the wall plane at node W has an image beyond it: what the particles put on
/// node W + d, their images put on node W - d, and the reverse. Each pair (W - d, W + d) on the grid
/// therefore ends with the sum of both, and W itself with twice its own: `image(own, partner, axis,
/// side)` is what the partner adds to a node (the mass as it is, momentum by [`momentum_image`]).
/// Axis by axis in turn (x, y, z), which also gives the images at edges and corners.
///
/// Without it the particles next to a wall miss the mass beyond it (their density reads like a free
/// surface's: 0.62, 0.85, 0.97 rho0 in the outer layers), and the first free node layer misses the
/// image's pressure push, so fluid sinks along the walls and circulates.
pub fn mirror_walls<T: Copy + std::ops::Add<Output = T>>(
    shape: GridShape,
    params: &Params,
    values: &mut [T],
    image: impl Fn(T, T, usize, WallSide) -> T,
) {
    if params.wall_mirror_lo == 0 {
        return;
    }
    let (res, lo, held) = (shape.res, shape.held.lo, shape.held.res);
    let stride = shape.strides();
    for a in 0..3 {
        // The two axes across the lines, the smaller stride innermost (x before y before z).
        let (outer, inner) = match a {
            0 => (2, 1),
            1 => (2, 0),
            _ => (1, 0),
        };
        // Where plane i along the axis lies on each line, if the box holds it. A rank's box holds a
        // wall's pairs across its slab axis whole (`Slabs::holds_mirror`) or, in its ghost planes,
        // some of them; a pair it holds one node of is skipped, and the owner's values overwrite
        // those ghosts before anything reads them.
        let along = |i: u32| (i.wrapping_sub(lo[a]) < held[a]).then(|| (i - lo[a]) as usize * stride[a]);
        for (wall, low) in [(params.wall_mirror_lo, true), (params.wall_mirror_hi[a], false)] {
            let reach = wall.min(res[a] - 1 - wall);
            let (fluid, beyond_plane) = (WallSide::Fluid { low }, WallSide::Beyond { low });
            let on_plane = along(wall);
            let pairs: Vec<(usize, usize)> = (1..=reach)
                .filter_map(|d| {
                    let (beyond, inside) = match low {
                        true => (wall - d, wall + d),
                        false => (wall + d, wall - d),
                    };
                    Some((along(beyond)?, along(inside)?))
                })
                .collect();
            for u in 0..held[outer] as usize {
                for v in 0..held[inner] as usize {
                    let line = u * stride[outer] + v * stride[inner];
                    if let Some(on_plane) = on_plane {
                        let own = values[line + on_plane];
                        values[line + on_plane] = own + image(own, own, a, fluid);
                    }
                    for &(beyond, inside) in &pairs {
                        let (beyond, inside) = (line + beyond, line + inside);
                        let (x, y) = (values[beyond], values[inside]);
                        values[beyond] = x + image(x, y, a, beyond_plane);
                        values[inside] = y + image(y, x, a, fluid);
                    }
                }
            }
        }
    }
}

/// p2g for one particle with stencil `st`: its density, and what it adds to the grid momentum,
/// `w (mv + affine d)` on each stencil node. Returns `(rho, mv, affine)`. The density is gathered
/// (`DensityRule::Gathered`) from the grid's mass, or from its volume where the rest densities
/// differ ([`gathered_density`]), or it is the particle's own `rho_p`, which its last g2p advected
/// (`DensityRule::Advected`, [`density_after_g2p`]). Shared by the reference and the parallel
/// backend, so both compute the same expressions.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn p2g_particle(
    params: &Params,
    st: &Stencil,
    shape: GridShape,
    grid: DensitySource,
    rho_p: f32,
    v: Vec3,
    c: Mat3,
    material: u8,
    deformation: Option<&Deformation>,
) -> (f32, Vec3, Mat3) {
    let mat = Material::of(params, material);
    let (dx, dt, m_p) = (params.dx, params.dt, mat.particle_mass);
    let rho = match DensityRule::of(params) {
        DensityRule::Gathered => gathered_density(params, st, shape, grid, m_p),
        DensityRule::Advected => rho_p,
    };
    if let Some(d) = deformation.filter(|_| mat.is_solid()) {
        // A solid's Kirchhoff stress tau = J sigma over its rest volume: V sigma = V0 tau.
        let tau = solid::kirchhoff_stress(mat, d.f, d.plastic);
        let affine = c * (m_p * dx) - tau * (4.0 * dt * (m_p / mat.rest_density) / dx);
        return (rho, v * m_p, affine);
    }
    let volume = m_p / rho;
    let pressure = mat.pressure(rho);
    let stress = mat.stress(pressure, c, rho);
    // (mv)_i += w [m_p v + (m_p dx C - 4 dt V / dx sigma) d]
    let affine = c * (m_p * dx) - stress * (4.0 * dt * volume / dx);
    if let Some(d) = deformation.filter(|_| mat.is_elastoviscoplastic()) {
        // The yield stress's elastic part, deviatoric, over the rest volume as a solid's.
        let elastic = solid::kirchhoff_stress(mat, d.f, d.plastic);
        let affine = affine - elastic * (4.0 * dt * (m_p / mat.rest_density) / dx);
        return (rho, v * m_p, affine);
    }
    (rho, v * m_p, affine)
}

/// What a particle's density is gathered from: the grid's mass, settled and mirrored, and its
/// volume (empty unless the rest densities differ, [`gathers_volume`]).
#[derive(Clone, Copy)]
pub struct DensitySource<'a> {
    pub mass: &'a [f32],
    pub volume: &'a [i64],
}

impl<'a> DensitySource<'a> {
    pub fn of(grid: &'a Grid) -> DensitySource<'a> {
        DensitySource {
            mass: &grid.mass,
            volume: &grid.volume,
        }
    }
}

/// A particle's density gathered over its stencil `st`: from the grid's mass ([`grid_density`]), or,
/// where the rest densities differ, from the grid's volume times its own particle mass `m_p`
/// ([`volume_density`]).
#[inline(always)]
pub fn gathered_density(
    params: &Params,
    st: &Stencil,
    shape: GridShape,
    grid: DensitySource,
    m_p: f32,
) -> f32 {
    if gathers_volume(params) {
        volume_density(params, st, shape, grid.volume, m_p)
    } else {
        grid_density(params, st, shape, grid.mass)
    }
}

/// rho = m_p sum w V_i / dx^3 over the stencil `st`, V_i the node's weights ([`Grid::volume`]): the
/// number of particles about the particle times its own mass, so each liquid reads its own rest
/// density wherever it is packed as at rest, beside another liquid or not. In a scene of one
/// material it is `grid_density`, the mass being m_p V_i. kernels/common.cuh `gather_volume_density`
/// is the twin.
#[inline(always)]
pub fn volume_density(params: &Params, st: &Stencil, shape: GridShape, volume: &[i64], m_p: f32) -> f32 {
    let inv_units = 1.0 / VOLUME_UNITS_PER_WEIGHT;
    let mut weights = 0.0;
    st.for_each_node(shape, |i, w, _| {
        weights += w * fixed_point_value(volume[i], inv_units)
    });
    weights * m_p * (params.inv_dx * params.inv_dx * params.inv_dx)
}

/// rho = sum w m_i / dx^3 over the stencil `st`.
#[inline(always)]
pub fn grid_density(params: &Params, st: &Stencil, shape: GridShape, mass: &[f32]) -> f32 {
    let mut grid_mass = 0.0;
    st.for_each_node(shape, |i, w, _| grid_mass += w * mass[i]);
    grid_mass * (params.inv_dx * params.inv_dx * params.inv_dx)
}

/// The density a particle of `material` leaves g2p with. Under `DensityRule::Advected`: gathered
/// from the grid (its mass, or its volume where the rest densities differ: [`gathered_density`], as
/// the substep scattered and mirrored them) at the particle's position before the advection,
/// `x_before`, and carried over the substep by the fluid's velocity divergence gathered there from
/// the node velocities `velocity` (`DensityRule::advect`, `DensityRule::fluid_divergence`).
/// Otherwise the density its p2g gathered, `rho`, unchanged.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn density_after_g2p(
    params: &Params,
    shape: GridShape,
    grid: DensitySource,
    velocity: &[Vec3],
    x_before: Vec3,
    rho: f32,
    material: u8,
) -> f32 {
    if DensityRule::of(params) == DensityRule::Gathered {
        return rho;
    }
    let mass = grid.mass;
    let (mut grid_mass, mut v_p, mut sum_v_dot_d, mut filled_w_d) = (0.0, Vec3::ZERO, 0.0, Vec3::ZERO);
    let st = Stencil::new(x_before, params.inv_dx);
    st.for_each_node(shape, |i, w, d| {
        grid_mass += w * mass[i];
        v_p += w * velocity[i];
        sum_v_dot_d += w * velocity[i].dot(d);
        if mass[i] > 0.0 {
            filled_w_d += w * d;
        }
    });
    let inv_dx = params.inv_dx;
    let divergence =
        DensityRule::fluid_divergence(sum_v_dot_d, filled_w_d.to_array(), v_p.to_array(), inv_dx);
    let before = if gathers_volume(params) {
        let m_p = Material::of(params, material).particle_mass;
        volume_density(params, &st, shape, grid.volume, m_p)
    } else {
        grid_mass * (inv_dx * inv_dx * inv_dx)
    };
    DensityRule::advect(before, divergence, params.dt)
}

/// grid_update for node `index` with mass `m > 0` (`own_m` of it the particles', the rest the walls'
/// images; `image_push` the velocity the images gave it, [`image_push`]) and momentum `mv`:
/// velocity, gravity, the colliders' boundary conditions (adding what rigid bodies' boundaries took
/// to `body_impulses`), and free slip in the walls' boundary band (last, so the walls hold whatever
/// a moving collider near them does).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn node_velocity(
    params: &Params,
    shape: GridShape,
    index: usize,
    m: f32,
    own_m: f32,
    image_push: Vec3,
    mv: Vec3,
    colliders: &ColliderFrame,
    body_impulses: &mut [[i64; 6]],
) -> Vec3 {
    let mut v = mv / m + Vec3::from(params.gravity) * params.dt;
    let node = shape.node(index);
    if !colliders.is_empty() {
        v = colliders.project_node_exchanging(
            node.as_vec3() * params.dx,
            v,
            own_m,
            image_push,
            body_impulses,
        );
    }
    // The band removes only motion into the wall (as a collider's boundary does), so fluid leaves a
    // wall freely.
    let (band, res) = (params.boundary_band, shape.res);
    for a in 0..3 {
        if node[a] < band {
            v[a] = v[a].max(0.0);
        } else if node[a] >= res[a] - band {
            v[a] = v[a].min(0.0);
        }
    }
    v
}

/// g2p for one particle at `x`: velocity and C gathered from the grid velocities, the soft wall, then
/// advection and the clamp. Returns the new `(x, v, C)`.
#[inline(always)]
pub fn g2p_particle(params: &Params, shape: GridShape, velocity: &[Vec3], x: Vec3) -> (Vec3, Vec3, Mat3) {
    let (dx, dt, inv_dx) = (params.dx, params.dt, params.inv_dx);
    let res = shape.res.as_vec3();
    let mut v = Vec3::ZERO;
    let mut b = Mat3::ZERO;
    Stencil::new(x, inv_dx).for_each_node(shape, |i, w, d| {
        let wv = w * velocity[i];
        v += wv;
        b += Mat3::from_cols(wv * d.x, wv * d.y, wv * d.z); // w v_i d^T
    });
    let tau = params.soft_wall_tau;
    if tau > 0.0 {
        let wall_lo = Vec3::splat((params.boundary_band + 1) as f32 * dx);
        let wall_hi = (res - (params.boundary_band + 2) as f32) * dx;
        let predicted = x + v * tau;
        v += (wall_lo - predicted).max(Vec3::ZERO) / tau;
        v -= (predicted - wall_hi).max(Vec3::ZERO) / tau;
    }
    let (lo, hi) = (Vec3::splat(dx), (res - 2.0) * dx);
    (((x + v * dt).clamp(lo, hi)), v, b * (4.0 * inv_dx))
}

/// `g2p_particle`, then the colliders' particle backstop (`ColliderFrame::backstop_exchanging`, for a
/// particle of mass `m`: a rigid body's push is taken from `body_impulses`) and g2p's clamp again:
/// the particle's new x, v and C, and whether the backstop moved it. Both CPU backends' g2p.
#[inline(always)]
pub fn g2p_with_backstop(
    params: &Params,
    shape: GridShape,
    velocity: &[Vec3],
    colliders: &ColliderFrame,
    x: Vec3,
    m: f32,
    body_impulses: &mut [[i64; 6]],
) -> (Vec3, Vec3, Mat3, bool) {
    let (x, v, c) = g2p_particle(params, shape, velocity, x);
    if colliders.is_empty() {
        return (x, v, c, false);
    }
    match colliders.backstop_exchanging(x, v, m, body_impulses) {
        Some((x, v)) => {
            let dx = params.dx;
            (
                x.clamp(Vec3::splat(dx), (shape.res.as_vec3() - 2.0) * dx),
                v,
                c,
                true,
            )
        }
        None => (x, v, c, false),
    }
}

/// A particle's deformation after g2p gave it velocity gradient `c`: F_E carried over the substep,
/// F <- (I + dt C) F, then its law's return mapping ([`solid::plastic_return`]); nothing for a row
/// that carries none or where no row does (`deformation` `None`). Returns what it advanced.
#[inline(always)]
pub fn advance_deformation<'d>(
    params: &Params,
    material: u8,
    c: Mat3,
    deformation: Option<&'d mut Deformation>,
) -> Option<&'d Deformation> {
    let d = deformation?;
    let mat = Material::of(params, material);
    if mat.carries_deformation() {
        let trial = (Mat3::IDENTITY + c * params.dt) * d.f;
        (d.f, d.plastic) = solid::plastic_return(mat, trial, d.plastic);
    }
    Some(d)
}

pub struct CpuSolver {
    pub particles: Particles,
    pub grid: Grid,
    /// Emitters and sinks, where the scene has them (`sim::flow`).
    pub lifecycle: Option<Lifecycle>,
    /// The colliders as of the next substep (`Solver::set_colliders`), the rigid bodies' slots
    /// holding where `bodies` are.
    pub colliders: ColliderFrame,
    /// The rigid bodies (`Solver::set_bodies`), stepped after each grid update.
    pub bodies: HostBodies,
    /// The nodes' sums before the walls' images, where something reads them.
    pub own: OwnSums,
    extremes: StepExtremes,
    /// One record per substep, until taken.
    timings: Vec<PhaseTimings>,
    /// `DensityRule::Advected`: the step the next p2g's stress impulse takes, the last substep's (see
    /// `Solver::step`); `None` before the first substep.
    pub scatter_dt: Option<f32>,
}

impl CpuSolver {
    pub fn new(particles: Particles, grid_res: [u32; 3]) -> CpuSolver {
        CpuSolver {
            particles,
            grid: Grid::new(GridShape::whole(UVec3::from(grid_res))),
            lifecycle: None,
            colliders: ColliderFrame::default(),
            bodies: HostBodies::default(),
            own: OwnSums::default(),
            extremes: StepExtremes::default(),
            timings: Vec::new(),
            scatter_dt: None,
        }
    }

    /// `params` as p2g scatters with them: under `DensityRule::Advected`, with the step of the last
    /// substep where there was one (`Solver::step`).
    pub fn scatter_params(&self, params: &Params) -> Params {
        match (DensityRule::of(params), self.scatter_dt) {
            (DensityRule::Advected, Some(dt)) => params.with_dt(dt),
            _ => *params,
        }
    }

    /// The solver with emitters and sinks.
    pub fn with_lifecycle(mut self, lifecycle: Option<Lifecycle>) -> CpuSolver {
        self.lifecycle = lifecycle;
        self
    }

    /// Drains (`Lifecycle::drains`) every live particle inside a sink: after g2p.
    pub fn drain(&mut self) {
        let Some(lifecycle) = &mut self.lifecycle else {
            return;
        };
        if lifecycle.flow.sinks.is_empty() {
            return;
        }
        let p = &mut self.particles;
        for (i, (x, live)) in p.x.iter().zip(p.live.iter_mut()).enumerate() {
            if *live && lifecycle.drains(i, *x) {
                *live = false;
            }
        }
        lifecycle.state.settle();
    }

    pub fn clear_grid(&mut self) {
        self.grid.mass.fill(0.0);
        self.grid.momentum.fill(Vec3::ZERO);
        self.grid.volume.fill(0);
        if let Some(fixed) = &mut self.grid.fixed {
            fixed.mass.fill(0);
            fixed.momentum.fill([0; 3]);
        }
    }

    /// m_i += w m_p, as floats or (fixed-point scatter) integer units, which `settle_mass` turns into
    /// the float mass.
    pub fn p2g_init(&mut self, params: &Params) {
        self.scatter_mass(params);
        self.settle_mass(params);
    }

    /// The mass scatter alone: [`Self::p2g_init`] without `settle_mass`; and the volume's, where
    /// the rest densities differ.
    pub fn scatter_mass(&mut self, params: &Params) {
        if gathers_volume(params) {
            self.scatter_volume(params);
        }
        let shape = self.grid.shape;
        let p = &self.particles;
        let live = (0..p.len())
            .filter(|&n| p.live[n])
            .map(|n| (p.x[n], Material::of(params, p.material[n]).particle_mass));
        if is_fixed_point(params) {
            let (scale, mass) = (params.fixed_mass_scale, &mut self.grid.fixed_mut().mass);
            for (x, m_p) in live {
                Stencil::new(x, params.inv_dx)
                    .for_each_node(shape, |i, w, _| mass[i] += fixed_point_units(w * m_p * scale));
            }
        } else {
            let mass = &mut self.grid.mass;
            for (x, m_p) in live {
                Stencil::new(x, params.inv_dx).for_each_node(shape, |i, w, _| mass[i] += w * m_p);
            }
        }
    }

    /// The grid's volume ([`Grid::volume`]): every live particle's stencil weights in fixed-point
    /// units, at the positions the mass is scattered from.
    pub fn scatter_volume(&mut self, params: &Params) {
        let shape = self.grid.shape;
        let volume = &mut self.grid.volume;
        volume.resize(shape.num_nodes(), 0);
        let p = &self.particles;
        for n in (0..p.len()).filter(|&n| p.live[n]) {
            Stencil::new(p.x[n], params.inv_dx).for_each_node(shape, |i, w, _| volume[i] += volume_units(w));
        }
    }

    /// The fixed-point scatter's mass sums as the float mass (nothing under the float scatter).
    pub fn settle_mass(&mut self, params: &Params) {
        if let (true, Some(fixed)) = (is_fixed_point(params), &self.grid.fixed) {
            let inv_scale = 1.0 / params.fixed_mass_scale;
            for (m, &q) in self.grid.mass.iter_mut().zip(&fixed.mass) {
                *m = fixed_point_value(q, inv_scale);
            }
        }
    }

    /// The fixed-point scatter's momentum sums as the float momentum (nothing under the float
    /// scatter).
    pub fn settle_momentum(&mut self, params: &Params) {
        if let (true, Some(fixed)) = (is_fixed_point(params), &self.grid.fixed) {
            let inv_scale = 1.0 / params.fixed_momentum_scale;
            for (mv, q) in self.grid.momentum.iter_mut().zip(&fixed.momentum) {
                *mv = Vec3::from(q.map(|q| fixed_point_value(q, inv_scale)));
            }
        }
    }

    /// The walls' image mass (see [`mirror_walls`]), between p2g_init and p2g; and the image volume.
    pub fn mirror_mass(&mut self, params: &Params) {
        self.keep_own_mass(params);
        mirror_walls(self.grid.shape, params, &mut self.grid.mass, |_, m, _, _| m);
        if gathers_volume(params) {
            mirror_walls(self.grid.shape, params, &mut self.grid.volume, |_, v, _, _| v);
        }
    }

    /// The walls' image momentum ([`momentum_image`]), between p2g and grid_update.
    pub fn mirror_momentum(&mut self, params: &Params) {
        self.keep_own_momentum(params);
        mirror_walls(self.grid.shape, params, &mut self.grid.momentum, momentum_image);
    }

    /// Whether a Coulomb collider meets the walls' mirror: then its friction reads the images' push.
    fn friction_under_mirror(&self, params: &Params) -> bool {
        params.wall_mirror_lo != 0 && self.colliders.has_friction()
    }

    /// The grid's mass as the particles left it, before the walls' images join it, where the
    /// rigid bodies' exchange or a Coulomb collider under the mirror reads it ([`OwnSums`]).
    pub fn keep_own_mass(&mut self, params: &Params) {
        if !self.bodies.states.is_empty() || self.friction_under_mirror(params) {
            self.own.mass.clone_from(&self.grid.mass);
        } else {
            self.own.mass.clear();
        }
    }

    /// The grid's momentum before the walls' images join it, where a Coulomb collider under the
    /// mirror reads it ([`OwnSums`]).
    pub fn keep_own_momentum(&mut self, params: &Params) {
        if self.friction_under_mirror(params) {
            self.own.momentum.clone_from(&self.grid.momentum);
        } else {
            self.own.momentum.clear();
        }
    }

    /// Density (from grid mass, or the particle's advected one), Tait pressure, viscous stress; then
    /// momentum and stress to the grid (as floats, or fixed-point units made floats by
    /// `settle_momentum`).
    pub fn p2g(&mut self, params: &Params) {
        self.scatter_momentum(params);
        self.settle_momentum(params);
    }

    /// [`Self::p2g`] without `settle_momentum`.
    pub fn scatter_momentum(&mut self, params: &Params) {
        let params = &self.scatter_params(params);
        let fixed = is_fixed_point(params);
        if fixed {
            self.grid.fixed_mut();
        }
        let Grid {
            shape,
            mass,
            momentum,
            fixed: fixed_grid,
            volume,
        } = &mut self.grid;
        let source = DensitySource { mass, volume };
        let p = &mut self.particles;
        let scale = params.fixed_momentum_scale;
        let mut max_rho = 0.0f32;
        for n in (0..p.x.len()).filter(|&n| p.live[n]) {
            let st = Stencil::new(p.x[n], params.inv_dx);
            let material = p.material[n];
            let (rho, mv, affine) = p2g_particle(
                params,
                &st,
                *shape,
                source,
                p.rho[n],
                p.v[n],
                p.c[n],
                material,
                p.deformation.get(n),
            );
            p.rho[n] = rho;
            max_rho = max_rho.max(reported_density(params, material, rho));
            match fixed_grid.as_mut().filter(|_| fixed) {
                Some(f) => st.for_each_node(*shape, |i, w, d| {
                    let q = &mut f.momentum[i];
                    let c = w * (mv + affine * d);
                    for a in 0..3 {
                        q[a] += fixed_point_units(c[a] * scale);
                    }
                }),
                None => st.for_each_node(*shape, |i, w, d| momentum[i] += w * (mv + affine * d)),
            }
        }
        if DensityRule::of(params) == DensityRule::Gathered {
            self.extremes.max_density = self.extremes.max_density.max(max_rho);
        }
    }

    /// Momentum to velocity, gravity, colliders, free-slip walls in the boundary band; then the rigid
    /// bodies take what their boundaries gave the nodes, and move.
    pub fn grid_update(&mut self, params: &Params) {
        let Grid {
            shape,
            mass,
            momentum,
            ..
        } = &mut self.grid;
        let bodies = &mut self.bodies;
        for (i, (&m, mv)) in mass.iter().zip(momentum.iter_mut()).enumerate() {
            if m > 0.0 {
                let (own_m, push) = self.own.at(i, m, *mv);
                *mv = node_velocity(
                    params,
                    *shape,
                    i,
                    m,
                    own_m,
                    push,
                    *mv,
                    &self.colliders,
                    &mut bodies.impulses,
                );
            }
        }
        self.bodies.step(params.dt, params.gravity, &mut self.colliders);
    }

    /// Velocity and C from the grid, then advection, soft wall and clamp, and the density the particle
    /// carries on ([`density_after_g2p`]); and the extremes the next substep is chosen from (each
    /// particle's own signal speed c(rho_p) + |v_p|).
    pub fn g2p(&mut self, params: &Params) {
        let grid = &self.grid;
        let (shape, velocity, source) = (grid.shape, &grid.momentum, DensitySource::of(grid));
        let p = &mut self.particles;
        let mut extremes = GatherExtremes::default();
        for n in (0..p.x.len()).filter(|&n| p.live[n]) {
            // The particle's mass only where a body may take its backstop push.
            let impulses = &mut self.bodies.impulses;
            let m_p = match impulses.is_empty() {
                true => 0.0,
                false => Material::of(params, p.material[n]).particle_mass,
            };
            let (x, v, c, moved) =
                g2p_with_backstop(params, shape, velocity, &self.colliders, p.x[n], m_p, impulses);
            p.rho[n] = density_after_g2p(params, shape, source, velocity, p.x[n], p.rho[n], p.material[n]);
            (p.x[n], p.v[n], p.c[n]) = (x, v, c);
            let deformation = p.deformation.get_mut(n);
            let deformation = advance_deformation(params, p.material[n], c, deformation);
            extremes = extremes.max(GatherExtremes::of(
                params,
                v,
                p.rho[n],
                p.material[n],
                moved,
                deformation,
            ));
        }
        extremes.add_to(&mut self.extremes);
        self.scatter_dt = Some(params.dt);
    }
}

/// A particle's density `rho` as the solvers report it to the time step: in row 0's terms
/// ([`Material::reported_density`]; `rho` itself in a scene of one material, as the kernels take it).
#[inline(always)]
pub fn reported_density(params: &Params, material: u8, rho: f32) -> f32 {
    if params.material_count == 1 {
        return rho;
    }
    Material::of(params, material).reported_density(rho, params.materials[0].rest_density)
}

/// Whether `params` ask for the fixed-point scatter.
#[inline]
pub fn is_fixed_point(params: &Params) -> bool {
    params.scatter_mode == ScatterMode::FixedPoint.code()
}

/// What g2p adds to a substep's extremes: the largest speed and signal speed c(rho_p) + |v_p|, the
/// particles the colliders' backstop moved, and (`DensityRule::Advected`, where g2p sets the density)
/// the largest density. Both CPU backends fold their particles' into one.
#[derive(Clone, Copy, Default)]
pub struct GatherExtremes {
    max_speed: f32,
    max_signal: f32,
    max_density: f32,
    pushed: u64,
}

impl GatherExtremes {
    /// One particle's, of `material`, after g2p gave it velocity `v`, density `rho`
    /// ([`density_after_g2p`]) and, a solid's, its `deformation` ([`advance_deformation`]): a
    /// solid's signal is its own wave speed, hardening included.
    pub fn of(
        params: &Params,
        v: Vec3,
        rho: f32,
        material: u8,
        pushed: bool,
        deformation: Option<&Deformation>,
    ) -> GatherExtremes {
        let speed = v.length();
        let advected = DensityRule::of(params) == DensityRule::Advected;
        let mat = Material::of(params, material);
        GatherExtremes {
            max_speed: speed,
            max_signal: match deformation {
                Some(d) if mat.is_solid() => solid::solid_wave_speed(mat, d.plastic) + speed,
                _ => mat.signal_speed(rho, speed),
            },
            max_density: if advected {
                reported_density(params, material, rho)
            } else {
                0.0
            },
            pushed: u64::from(pushed),
        }
    }

    pub fn max(self, other: GatherExtremes) -> GatherExtremes {
        GatherExtremes {
            max_speed: self.max_speed.max(other.max_speed),
            max_signal: self.max_signal.max(other.max_signal),
            max_density: self.max_density.max(other.max_density),
            pushed: self.pushed + other.pushed,
        }
    }

    pub fn add_to(self, extremes: &mut StepExtremes) {
        extremes.max_speed = extremes.max_speed.max(self.max_speed);
        extremes.max_signal_speed = extremes.max_signal_speed.max(self.max_signal);
        extremes.max_density = extremes.max_density.max(self.max_density);
        extremes.backstop_pushes += self.pushed;
    }
}

/// A CPU backend's substep as its phases: the reference and cpu-parallel differ only in how each
/// phase runs, and share the loop that runs and times them ([`step_phases`]).
pub trait CpuPhases {
    fn run_phase(&mut self, phase: Phase, params: &Params);
    /// The per-substep timing records not yet taken.
    fn pending_timings(&mut self) -> &mut Vec<PhaseTimings>;
}

/// One substep: every phase in step order (`Phase::ALL`), each timed with the host clock; one rank has
/// no exchanges (`dist::CpuRanks` runs them), so they stay at 0.
pub fn step_phases(backend: &mut impl CpuPhases, params: &Params) {
    let mut clock = PhaseClock::start();
    for phase in Phase::ALL.into_iter().filter(|p| !p.is_exchange()) {
        backend.run_phase(phase, params);
        clock.lap(phase);
    }
    push_step_timing(backend.pending_timings(), clock.finish());
}

impl CpuPhases for CpuSolver {
    fn run_phase(&mut self, phase: Phase, params: &Params) {
        match phase {
            Phase::GridClear => self.clear_grid(),
            Phase::Sort => {} // the reference walks the particles in index order
            Phase::HaloSum | Phase::HaloFill => {} // one rank: `step_phases` skips them
            Phase::P2gInit => {
                self.p2g_init(params);
                self.mirror_mass(params);
            }
            Phase::P2g => self.p2g(params),
            Phase::GridUpdate => {
                self.mirror_momentum(params);
                self.grid_update(params);
            }
            Phase::G2p => {
                self.g2p(params);
                self.drain();
            }
        }
    }

    fn pending_timings(&mut self) -> &mut Vec<PhaseTimings> {
        &mut self.timings
    }
}

impl Solver for CpuSolver {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn step(&mut self, params: &Params) -> anyhow::Result<()> {
        step_phases(self, params);
        Ok(())
    }

    fn resume_after(&mut self, last: &Params) {
        self.scatter_dt = Some(last.dt);
    }

    fn take_extremes(&mut self) -> anyhow::Result<StepExtremes> {
        Ok(std::mem::take(&mut self.extremes))
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> anyhow::Result<()> {
        self.colliders.clone_from(frame);
        self.colliders.place_bodies(&self.bodies.states);
        Ok(())
    }

    fn set_bodies(
        &mut self,
        bodies: &BodiesState,
        features: &[ContactFeature],
        walls: BodyWalls,
    ) -> anyhow::Result<()> {
        bodies.check()?;
        self.bodies = HostBodies::new(bodies, features, walls);
        self.colliders.place_bodies(&self.bodies.states);
        Ok(())
    }

    fn bodies(&mut self) -> anyhow::Result<Vec<RigidBody>> {
        Ok(self.bodies.states.clone())
    }

    fn body_impulses(&mut self) -> anyhow::Result<Vec<[i64; 6]>> {
        Ok(self.bodies.impulses.clone())
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

    fn emit(&mut self, _params: &Params, mask: u32) -> anyhow::Result<()> {
        let Some(lifecycle) = &mut self.lifecycle else {
            anyhow::bail!("this solver has no emitters");
        };
        lifecycle.emit(Slots::of(&mut self.particles), mask);
        Ok(())
    }

    fn flow_counts(&mut self) -> anyhow::Result<Option<FlowCounts>> {
        Ok(self.lifecycle.as_ref().map(|l| l.state.counts))
    }

    fn flow_state(&mut self) -> anyhow::Result<Option<FlowState>> {
        Ok(self.lifecycle.as_ref().map(|l| l.state.clone()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_point_units_round_as_cuda_does() {
        // __float2ll_rn: to nearest, ties to even; out of range and NaN give 0.
        assert_eq!(
            [2.5f32, 3.5, -2.5, 0.49, -0.51].map(fixed_point_units),
            [2, 4, -2, 0, -1]
        );
        assert_eq!(fixed_point_units(f32::NAN), 0);
        assert_eq!(fixed_point_units(5.0e15), 0);
        assert_eq!(fixed_point_units(2_251_799_813_685_248.0), 1 << 51);
        assert_eq!(fixed_point_value(3, 0.5), 1.5);
    }
}
