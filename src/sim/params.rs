//! What a substep needs: the scatter mode and pipeline choices, and `Params`: the kernels' parameters
//! (`KernelParams`) and the material table. `Material` and `KernelParams` themselves are defined in
//! the host/device contract (src/contract/items.rs), which the kernels' header is written from; the
//! material's law is in `material.rs`.

pub use crate::contract::MAX_VOLUME_CHANGE;
pub use crate::contract::{KernelParams, Material, MAX_MATERIALS};
use crate::contract::{DENSITY_ADVECTED, DENSITY_GATHERED, SCATTER_FIXED_POINT, SCATTER_FLOAT};

/// Everything a substep needs, written by `Scene::params`: the parameters every kernel gets by value
/// ([`KernelParams`], which this derefs to: `params.dt`, `params.dx`, ...) and the scene's material
/// table. The table lives apart from the kernels' parameters, in their constant memory (the CUDA
/// solver writes it where it changes): 512 bytes more in every launch's parameters made the
/// compiler address them through a register, which cost the grid update 6 registers and 11 % of its
/// time on the H100 (BENCHMARKS.md M1).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Params {
    pub kernel: KernelParams,
    /// The scene's materials; each particle names its row (`Particles::material`, the bits of v.w on
    /// the device). Rows past `material_count` are zero.
    pub materials: [Material; MAX_MATERIALS as usize],
}

impl Params {
    /// These parameters with the substep `dt`.
    pub fn with_dt(&self, dt: f32) -> Params {
        let mut params = *self;
        params.dt = dt;
        params
    }
}

impl std::ops::Deref for Params {
    type Target = KernelParams;
    fn deref(&self) -> &KernelParams {
        &self.kernel
    }
}

impl std::ops::DerefMut for Params {
    fn deref_mut(&mut self) -> &mut KernelParams {
        &mut self.kernel
    }
}

/// Simulated seconds per displayed frame: the runner and the viewer advance one 60 Hz frame at a time.
pub const FRAME_DT: f32 = 1.0 / 60.0;

/// How p2g accumulates into the grid on the GPU. The CPU reference is sequential and ignores it.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum ScatterMode {
    /// Float atomics, as in the report: fastest, but the summation order (and so the last bits) varies.
    #[default]
    Float,
    /// Fixed-point integer atomics: order-independent, so runs are byte-identical.
    FixedPoint,
}

impl ScatterMode {
    /// The value of `Params::scatter_mode` that the kernels switch on.
    pub fn code(self) -> u32 {
        match self {
            ScatterMode::Float => SCATTER_FLOAT,
            ScatterMode::FixedPoint => SCATTER_FIXED_POINT,
        }
    }
}

/// Which sequence of GPU kernels takes a substep, and with it the density rule ([`DensityRule`]) that
/// every backend, the CPU ones included, follows for the scene.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Pipeline {
    /// One particle pass per substep (the default): the binned pipeline's bins and tiles, with g2p,
    /// advection and the next substep's whole scatter (mass and momentum) in one kernel, the density
    /// carried by the particle ([`DensityRule::Advected`]).
    #[default]
    #[value(
        help = "One particle pass per substep (the default): the binned pipeline's bins and \
                    tiles, with g2p, advection and the next substep's whole scatter (mass and \
                    momentum) in one kernel, the density carried by the particle (advected)"
    )]
    Fused,
    /// Particles binned by 4x4x4-node block, scatters through shared-memory tiles, g2p fused with the
    /// next substep's mass scatter, then the report's density gather and momentum scatter: two
    /// particle passes per substep, the report's scheme.
    Binned,
    /// The report's four kernels, p2g_init, p2g, grid_update (whole grid), g2p, with global atomics:
    /// the baseline the benchmark tables compare with.
    Report,
}

impl Pipeline {
    pub const ALL: [Pipeline; 3] = [Pipeline::Fused, Pipeline::Binned, Pipeline::Report];

    pub fn name(self) -> &'static str {
        match self {
            Pipeline::Fused => "fused",
            Pipeline::Binned => "binned",
            Pipeline::Report => "report",
        }
    }

    /// Whether the particles are binned by node block and scattered through shared tiles (every
    /// pipeline but the report's).
    pub fn is_binned(self) -> bool {
        self != Pipeline::Report
    }

    pub fn density_rule(self) -> DensityRule {
        match self {
            Pipeline::Fused => DensityRule::Advected,
            Pipeline::Binned | Pipeline::Report => DensityRule::Gathered,
        }
    }
}

/// Which scheme advances a scene (`solver.method`): the explicit MLS-MPM of every backend, or
/// Position-Based MPM (Lewin 2024), a CPU reference for now (`sim::pbmpm`, docs/physics.md,
/// "Position-based MPM").
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Explicit MLS-MPM under the CFL time-step policy (the default; every backend).
    #[default]
    Explicit,
    /// Position-based MPM: constraint iterations on each particle's affine displacement, a fixed
    /// number of substeps a frame, stable at any substep (CUDA and the single-thread CPU reference).
    Pbmpm,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Explicit => "explicit",
            Method::Pbmpm => "pbmpm",
        }
    }
}

/// How a particle's density rho_p, which sets its pressure, is estimated each substep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DensityRule {
    /// The report's scheme: rho_p = sum w m_i / dx^3 from the grid mass scattered at the particle's
    /// current position. The mass must be on the grid before the momentum scatter reads it: two
    /// particle passes a substep.
    Gathered,
    /// rho_p gathered the same way, but from the grid mass at the particle's previous position (the
    /// mass the last substep scattered, read in the same gather as the node velocities), then carried
    /// over the substep by the continuity equation, rho_p = rho_grid / (1 + dt div v), with the
    /// velocity divergence of the fluid around the particle gathered there too
    /// ([`DensityRule::fluid_divergence`]). It differs from the gathered density by O(dt^2) per
    /// substep and never drifts (each substep starts again from the grid), and the substep needs one
    /// particle pass: gather, advect, then scatter mass and momentum together.
    Advected,
}

impl DensityRule {
    /// The value of `Params::density_rule` that the kernels switch on.
    pub fn code(self) -> u32 {
        match self {
            DensityRule::Gathered => DENSITY_GATHERED,
            DensityRule::Advected => DENSITY_ADVECTED,
        }
    }

    /// The rule `params` carry (`Scene::params` writes it from the pipeline).
    pub fn of(params: &Params) -> DensityRule {
        if params.density_rule == DENSITY_ADVECTED {
            DensityRule::Advected
        } else {
            DensityRule::Gathered
        }
    }

    /// The advected density from the grid's `rho_grid` at the particle's previous position and the
    /// fluid's velocity divergence `divergence` there. The volume factor 1 + dt div v is held within
    /// [`MAX_VOLUME_CHANGE`] of 1: a resolved flow within the CFL bound changes a particle's volume by
    /// far less in one substep, and a shock past it (an impact at several times the sound speed) must
    /// not be amplified by a first-order prediction; the next substep's gather corrects what the bound
    /// held back. kernels/common.cuh `advected_density` is the twin.
    #[inline(always)]
    pub fn advect(rho_grid: f32, divergence: f32, dt: f32) -> f32 {
        rho_grid / (1.0 + dt * divergence).clamp(1.0 - MAX_VOLUME_CHANGE, 1.0 + MAX_VOLUME_CHANGE)
    }

    /// The velocity divergence of the fluid around a particle, from its stencil's gather:
    /// `(4/dx) sum_{m_i > 0} w (v_i - v_p) . d`, where `sum_v_dot_d` is `sum w v_i . d` over the
    /// stencil (tr of the gathered `C` dx/4), `filled_w_d` is `sum w d` over the nodes that hold mass,
    /// and `v_p` the gathered velocity. Nodes without mass hold no velocity (0): counting them as fluid
    /// at rest would read a particle moving into empty space as compressed (at the surge front of a
    /// dam break, by 10 % a substep), so they count as moving with the particle. Where every node
    /// holds mass, `sum w d = 0` and this is tr C.
    #[inline(always)]
    pub fn fluid_divergence(sum_v_dot_d: f32, filled_w_d: [f32; 3], v_p: [f32; 3], inv_dx: f32) -> f32 {
        let drift = v_p[0] * filled_w_d[0] + v_p[1] * filled_w_d[1] + v_p[2] * filled_w_d[2];
        4.0 * inv_dx * (sum_v_dot_d - drift)
    }
}

/// Whether `params` gather each particle's density from the grid's volume rather than its mass
/// (`Params::volume_density`): the materials' rest densities differ. The grid's mass mixes two
/// liquids' masses where they meet: gathered from it, an oil particle beside water reads up to 25 %
/// over its rest density and is pushed off the interface, and a water particle reads under its own
/// and loses its support. The volume, V_i = sum w_ip over the particles whatever their liquid, read
/// with the particle's own mass, rho_p = m_p sum w_ip V_i / dx^3, gives each liquid its own density
/// on both sides of the interface (docs/physics.md, "Several liquids").
#[inline(always)]
pub fn gathers_volume(params: &Params) -> bool {
    params.volume_density != 0
}

impl KernelParams {
    pub fn num_nodes(&self) -> usize {
        self.grid_res.iter().map(|&r| r as usize).product()
    }
}
