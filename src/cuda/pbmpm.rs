//! kernels/pbmpm.cu: the position-based substep's launches (`solver.method = "pbmpm"`) and the
//! buffers it keeps beside the explicit solver's ([`PbmpmBuffers`]). Its grid sums are the fixed-point
//! mass and momentum accumulators of [`DeviceGrid`](super::grid::DeviceGrid) (the momentum's holding
//! mass-weighted displacements), so that mirror_walls.cu adds the walls' images to them as it does
//! for the explicit solver; the substep's order is `CudaSolver::enqueue_pbmpm_substep`.

use super::gpu::Gpu;
use super::launch::{host_kernel, Launcher, OptionalArg};
use super::particles::DeviceParticles;
use super::state::{DeviceState, StateArgs};
use crate::contract::PBMPM_CELL_VOLUME_UNITS;
use crate::sim::params::Material;
use crate::sim::pbmpm::{fluid_region, liquid_relaxation, Settings};
use crate::sim::{Params, Particles, Phase, ScatterMode, Scene};
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaSlice, CudaStream, PushKernelArg};
use std::sync::Arc;

host_kernel!(Begin = "pbmpm" / "pbmpm_begin");
host_kernel!(VolumeTargets = "pbmpm" / "pbmpm_volume_targets");
host_kernel!(Scatter = "pbmpm" / "pbmpm_scatter");
host_kernel!(Integrate = "pbmpm" / "pbmpm_integrate");
host_kernel!(GridPass = "pbmpm" / "pbmpm_grid");
host_kernel!(Diffuse = "pbmpm" / "pbmpm_diffuse");

/// Which of the iteration loop's particle passes a scatter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScatterPass {
    /// The first iteration: the warm start's d and D, projected and scattered.
    First,
    /// The node displacements gathered, projected and scattered again.
    Gathered,
}

/// Channels per tile node of pbmpm_scatter: the displacement's xyz, a high and a low word each
/// (`PB_TILE_CHANNELS` in kernels/pbmpm.cu).
const SCATTER_CHANNELS: u32 = 6;
/// Channels per tile node of pbmpm_begin: its five sums, two words each (`PB_BEGIN_SUMS`).
const BEGIN_CHANNELS: u32 = 10;

/// The position-based kernels of one GPU.
pub struct PbmpmKernels {
    begin: Begin,
    volume_targets: VolumeTargets,
    scatter: Scatter,
    integrate: Integrate,
    grid: GridPass,
    diffuse: Diffuse,
}

impl PbmpmKernels {
    pub fn load(modules: &crate::cuda::modules::LoadedModules) -> Result<PbmpmKernels> {
        Ok(PbmpmKernels {
            begin: Begin::load(modules)?,
            volume_targets: VolumeTargets::load(modules)?,
            scatter: Scatter::load(modules)?,
            integrate: Integrate::load(modules)?,
            grid: GridPass::load(modules)?,
            diffuse: Diffuse::load(modules)?,
        })
    }
}

/// A scene's walls and grid in the terms the kernels take: the fluid region's low plane (the same on
/// every axis) and high planes, m.
struct Region {
    lo: f32,
    hi: [f32; 3],
}

/// Pushes a [`Region`] as the kernels take it: lo, then the three hi planes.
trait RegionArg<'a> {
    fn region(&mut self, region: &'a Region) -> &mut Self;
}

impl<'a> RegionArg<'a> for cudarc::driver::LaunchArgs<'a> {
    fn region(&mut self, region: &'a Region) -> &mut Self {
        self.arg(&region.lo)
            .arg(&region.hi[0])
            .arg(&region.hi[1])
            .arg(&region.hi[2])
    }
}

impl Region {
    fn of(params: &Params) -> Region {
        let shape = crate::sim::cpu::GridShape::whole(glam::UVec3::from(params.grid_res));
        let (lo, hi) = fluid_region(params, shape);
        Region {
            lo: lo.x,
            hi: hi.to_array(),
        }
    }
}

/// The position-based substep's own buffers: per node the scalar sums (the liquids' viscosity, the
/// fill, liquid mass and volume error), the particles' own sums before the walls' images joined them
/// (where needed), the node displacements; per particle the pass state (d and the volume target, D,
/// F^-1) and the volume bias, which persists from substep to substep (checkpoints carry it).
pub struct PbmpmBuffers {
    pub settings: Settings,
    /// Whether the grid diffuses the displacements by the liquids' viscosity (any liquid).
    viscous: bool,
    /// Whether the scene has liquids, whose volume targets need the fill and volume error.
    liquids: bool,
    viscosity: Option<CudaSlice<u64>>,
    /// fill, liquid mass, volume error: `nodes` each, where the scene has liquids.
    volume_sums: Option<[CudaSlice<u64>; 3]>,
    /// The mass before the walls' images (viscosity or wall friction under the mirror).
    own_mass: Option<CudaSlice<u64>>,
    /// The displacement sums before the images (wall friction under the mirror).
    own_displacement: Option<CudaSlice<u64>>,
    /// float4 per node: d, and the node's vote in the viscosity's sweep (0 at a node without mass).
    node_d: CudaSlice<f32>,
    /// The same after the viscosity's sweep, where viscous.
    diffused: Option<CudaSlice<f32>>,
    pass_d: CudaSlice<f32>,
    pass_affine: CudaSlice<f32>,
    f_inverse: Option<CudaSlice<f32>>,
    /// Per particle, in the order the particles are stored in (`DeviceParticles::slot` maps it).
    pub volume_bias: CudaSlice<f32>,
    /// Where the particles are kept in bin order: the biases' second buffer, which each binning
    /// gathers into (bin_order.rs) before the two swap with the particles' buffers.
    spare_bias: Option<CudaSlice<f32>>,
}

/// What an overflow of the position-based grid's fixed-point sums advises: under pbmpm it is the
/// liquid collapsing (a deep liquid on a fine grid, too few substeps or one iteration: docs/physics.md,
/// "What it costs and what it gives").
pub const OVERFLOW_FIX: &str = "under solver.method = \"pbmpm\" this is the liquid collapsing (particles \
     compressed to the volume ratio's floor): give the scene solver.iterations = 2 or more (one compresses a \
     falling liquid on a fine grid) and more time_step.substeps a frame (the dam break holds at 8 substeps of 2 \
     iterations on a 1 cm grid, 24 on a 0.5 cm grid)";

/// Bytes a particle and a node of the position-based buffers take at most.
pub const BYTES_PER_PARTICLE: usize = 4 * (4 + 12 + 12 + 2);
pub const BYTES_PER_NODE: usize = 8 * (1 + 3 + 1 + 3) + 4 * (4 + 4);

impl PbmpmBuffers {
    /// Zeroed buffers for `scene` (its particles and grid), after checking they fit; `bin_order`:
    /// the particles are kept in bin order (their biases then gathered with them).
    pub fn allocate(gpu: &Gpu, scene: &Scene, bin_order: bool) -> Result<PbmpmBuffers> {
        let (n, stream) = (scene.slots(), gpu.stream());
        let nodes: usize = scene.grid_res.iter().map(|&r| r as usize).product();
        gpu.ensure_fits(
            n * BYTES_PER_PARTICLE + nodes * BYTES_PER_NODE,
            &format!(
                "the position-based solver's buffers for scene {} ({n} particles, {nodes} grid nodes)",
                scene.source
            ),
            "use a coarser domain.resolution or fewer particles",
        )?;
        let rows: Vec<Material> = scene.materials.iter().map(|m| m.law).collect();
        let liquids = rows.iter().any(|m| !m.is_solid());
        // Every liquid, an inviscid one too: the viewer's slider may give it a viscosity mid-run.
        let viscous = liquids;
        let mirror = scene.params().wall_mirror_lo != 0;
        let gripping = scene.pbmpm.wall_friction > 0.0;
        let f32s = |len: usize, what: &str| {
            stream
                .alloc_zeros::<f32>(len.max(1))
                .with_context(|| format!("allocating the position-based {what} ({len} floats)"))
        };
        let u64s = |len: usize, what: &str| {
            stream
                .alloc_zeros::<u64>(len.max(1))
                .with_context(|| format!("allocating the position-based {what} ({len} sums)"))
        };
        Ok(PbmpmBuffers {
            settings: scene.pbmpm,
            viscous,
            liquids,
            viscosity: viscous.then(|| u64s(nodes, "viscosity")).transpose()?,
            volume_sums: match liquids {
                true => Some([
                    u64s(nodes, "fill")?,
                    u64s(nodes, "liquid mass")?,
                    u64s(nodes, "volume error")?,
                ]),
                false => None,
            },
            own_mass: (mirror && (viscous || gripping))
                .then(|| u64s(nodes, "own mass"))
                .transpose()?,
            own_displacement: (mirror && gripping)
                .then(|| u64s(3 * nodes, "own displacement"))
                .transpose()?,
            node_d: f32s(4 * nodes, "node displacements")?,
            diffused: viscous
                .then(|| f32s(4 * nodes, "diffused displacements"))
                .transpose()?,
            pass_d: f32s(4 * n, "particle displacements")?,
            pass_affine: f32s(12 * n, "affine displacements")?,
            f_inverse: scene
                .has_deformation()
                .then(|| f32s(12 * n, "inverse deformations"))
                .transpose()?,
            volume_bias: f32s(n, "volume biases")?,
            spare_bias: bin_order.then(|| f32s(n, "volume biases' spare")).transpose()?,
        })
    }

    /// The biases and their spare, for a binning that gathers the particles into bin order.
    pub fn bias_and_spare(&self) -> Option<(&CudaSlice<f32>, &CudaSlice<f32>)> {
        self.spare_bias.as_ref().map(|spare| (&self.volume_bias, spare))
    }

    /// Swaps the spare biases in, as the particles' buffers are (`CudaSolver::swap_particle_buffers`).
    pub fn swap_bias(&mut self) {
        if let Some(spare) = &mut self.spare_bias {
            std::mem::swap(&mut self.volume_bias, spare);
        }
    }

    /// Takes the particles' volume biases (none: a fresh spawn, or a state saved before they were
    /// kept, starts with none).
    pub fn upload_bias(&mut self, stream: &Arc<CudaStream>, particles: &Particles) -> Result<()> {
        if particles.volume_bias.is_empty() {
            return stream
                .memset_zeros(&mut self.volume_bias)
                .context("zeroing the volume biases");
        }
        ensure!(
            particles.volume_bias.len() == particles.len(),
            "{} volume biases for {} particles",
            particles.volume_bias.len(),
            particles.len()
        );
        stream
            .memcpy_htod(&particles.volume_bias, &mut self.volume_bias)
            .context("uploading the volume biases")
    }

    /// The volume biases in slot order, `particles` the buffers they are stored beside (their
    /// slots say whose each is). Waits.
    pub fn download_bias(&self, gpu: &Gpu, particles: &DeviceParticles) -> Result<Vec<f32>> {
        let (stored, slots) = (gpu.download(&self.volume_bias)?, gpu.download(&particles.slot)?);
        let mut bias = vec![0.0; particles.count];
        for (&b, &slot) in stored.iter().zip(&slots).take(particles.count) {
            bias[slot as usize] = b;
        }
        Ok(bias)
    }

    /// The substep's start, in stream order: the grid's sums zeroed, the warm start and the scalar
    /// scatters (pbmpm_begin), the particles' own mass kept where it is needed later; the walls'
    /// images are the caller's to add next ([`Self::own_displacement_before_images`] likewise).
    pub fn begin(
        &mut self,
        k: &PbmpmKernels,
        l: &Launcher,
        params: &Params,
        d: &mut DeviceState,
    ) -> Result<()> {
        let stream = &l.stream;
        d.grid.clear_fixed(stream)?;
        for sums in self.scalar_sums_mut() {
            stream
                .memset_zeros(sums)
                .context("zeroing the position-based grid")?;
        }
        let (p, g) = (&d.particles, &d.grid);
        let volume_scale = PBMPM_CELL_VOLUME_UNITS * params.inv_dx.powi(3);
        let (viscous, liquids) = (u32::from(self.viscous), u32::from(self.liquids));
        let [fill, mass, error] = self
            .volume_sums
            .as_ref()
            .map_or([None; 3], |[f, m, e]| [Some(f), Some(m), Some(e)]);
        let (list, config) = (d.bins.list()?, d.bins.tiled_pass(l, &k.begin.0, BEGIN_CHANNELS)?);
        // SAFETY: the arguments match pbmpm_begin; the bin list and order are the substep's binning's,
        // every other buffer is sized for the scene's particles and nodes, and a null pointer stands
        // where its flag (or the scene) leaves it unread.
        unsafe {
            k.begin.0.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(&volume_scale)
                    .arg(&viscous)
                    .arg(&liquids)
                    .arg(list)
                    .arg(&g.work_counts)
                    .arg(&d.bins.order)
                    .particle_state(p)
                    .deformation(p)
                    .arg(g.fixed_mass())
                    .arg_or_null(self.viscosity.as_ref())
                    .arg_or_null(fill)
                    .arg_or_null(mass)
                    .arg_or_null(error)
                    .arg(&self.pass_d)
                    .arg(&self.pass_affine)
                    .arg_or_null(self.f_inverse.as_ref())
                    .arg(&d.counters.device);
            })?;
        }
        if let Some(own) = &mut self.own_mass {
            stream
                .memcpy_dtod(d.grid.fixed_mass(), own)
                .context("keeping the particles' own mass")?;
        }
        Ok(())
    }

    /// The liquids' sums that the walls' images join before the volume targets are gathered.
    pub fn volume_sums(&self) -> impl Iterator<Item = &CudaSlice<u64>> {
        self.volume_sums.iter().flatten()
    }

    fn scalar_sums_mut(&mut self) -> impl Iterator<Item = &mut CudaSlice<u64>> {
        self.viscosity
            .iter_mut()
            .chain(self.volume_sums.iter_mut().flatten())
    }

    /// Each liquid particle's volume target, after the images joined the sums, walked in the
    /// substep's bin order; nothing in a scene without liquids (their targets stay 0).
    pub fn volume_targets(
        &mut self,
        k: &PbmpmKernels,
        l: &Launcher,
        params: &Params,
        d: &DeviceState,
    ) -> Result<()> {
        let Some([fill, mass, error]) = &self.volume_sums else {
            return Ok(());
        };
        let p = &d.particles;
        // SAFETY: the arguments match pbmpm_volume_targets; buffers sized for the scene, `order` a
        // permutation of its particles (the substep's binning wrote it).
        unsafe {
            k.volume_targets.0.launch(l, l.cover(p.count), |a| {
                a.arg(&params.kernel)
                    .arg(&d.bins.order)
                    .arg(&p.x)
                    .arg(&p.v)
                    .arg(&p.rho)
                    .arg(fill)
                    .arg(mass)
                    .arg(error)
                    .arg(&self.volume_bias)
                    .arg(&self.pass_d);
            })
        }
    }

    /// The fixed-point units of the displacement sums, per kg m: the momentum's units per kg m/s
    /// over the substep, so that a displacement of v dt takes the units v would.
    fn displacement_scale(params: &Params) -> f32 {
        params.fixed_momentum_scale / params.dt
    }

    /// One particle pass of the iteration loop (pbmpm_scatter): a block per listed bin chunk,
    /// its tile of `SCATTER_CHANNELS`.
    pub fn scatter(
        &self,
        k: &PbmpmKernels,
        l: &Launcher,
        pass: ScatterPass,
        params: &Params,
        d: &DeviceState,
    ) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        let scale = Self::displacement_scale(params);
        let gather = u32::from(pass == ScatterPass::Gathered);
        let relaxation = liquid_relaxation(self.settings.iterations);
        let (list, config) = (
            d.bins.list()?,
            d.bins.tiled_pass(l, &k.scatter.0, SCATTER_CHANNELS)?,
        );
        let node_d = self.node_displacements();
        // SAFETY: the arguments match pbmpm_scatter; the bin list and order are those of the
        // substep's binning, the other buffers sized for the scene (F^-1 null where no material
        // carries a deformation, and then unread).
        unsafe {
            k.scatter.0.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(&gather)
                    .arg(&scale)
                    .arg(&relaxation)
                    .arg(list)
                    .arg(&g.work_counts)
                    .arg(&d.bins.order)
                    .arg(&p.x)
                    .arg(&p.v)
                    .arg(&p.rho)
                    .deformation(p)
                    .arg(node_d)
                    .arg(g.fixed_mass())
                    .arg(g.fixed_momentum())
                    .arg(&self.pass_d)
                    .arg(&self.pass_affine)
                    .arg_or_null(self.f_inverse.as_ref())
                    .arg(&d.counters.device);
            })
        }
    }

    /// The substep's last particle pass (pbmpm_integrate): the last gather and the integration.
    pub fn integrate(&self, k: &PbmpmKernels, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let p = &d.particles;
        let region = Region::of(params);
        let node_d = self.node_displacements();
        // SAFETY: the arguments match pbmpm_integrate; buffers sized for the scene.
        unsafe {
            k.integrate.0.launch(l, l.cover(p.count), |a| {
                a.arg(&params.kernel)
                    .region(&region)
                    .particle_state(p)
                    .deformation(p)
                    .arg(&d.bins.order)
                    .arg(node_d)
                    .arg(&self.pass_d)
                    .arg(&self.pass_affine)
                    .colliders(&d.colliders)
                    .arg(&d.counters.device);
            })
        }
    }

    /// The node displacements the particles gather: after the viscosity's sweep where it runs.
    fn node_displacements(&self) -> &CudaSlice<f32> {
        self.diffused.as_ref().unwrap_or(&self.node_d)
    }

    /// Keeps the particles' own displacement sums before the walls' images join them, where the
    /// walls grip under the mirror.
    pub fn own_displacement_before_images(
        &mut self,
        stream: &Arc<CudaStream>,
        d: &DeviceState,
    ) -> Result<()> {
        if let Some(own) = &mut self.own_displacement {
            stream
                .memcpy_dtod(d.grid.fixed_momentum(), own)
                .context("keeping the particles' own displacement")?;
        }
        Ok(())
    }

    /// The node displacements held by the colliders and the walls (pbmpm_grid), then the viscosity's
    /// sweep (pbmpm_diffuse) where a
    /// liquid is viscous.
    pub fn grid(&self, k: &PbmpmKernels, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let g = &d.grid;
        let nodes = g.num_nodes();
        let region = Region::of(params);
        let scale = Self::displacement_scale(params);
        let friction = self.settings.wall_friction;
        let diffusion = params.dt * params.inv_dx * params.inv_dx / self.settings.iterations as f32;
        // SAFETY: the arguments match pbmpm_grid; buffers sized for the grid (null where unread).
        unsafe {
            k.grid.0.launch(l, l.cover(nodes), |a| {
                a.arg(&params.kernel)
                    .arg(&scale)
                    .arg(&friction)
                    .region(&region)
                    .arg(g.fixed_mass())
                    .arg_or_null(self.own_mass.as_ref())
                    .arg(g.fixed_momentum())
                    .arg_or_null(self.own_displacement.as_ref())
                    .arg(&self.node_d)
                    .colliders(&d.colliders);
            })?;
        }
        let (Some(diffused), Some(viscosity)) = (&self.diffused, &self.viscosity) else {
            return Ok(());
        };
        // SAFETY: the arguments match pbmpm_diffuse; the sums hold a u64 per node (own mass null
        // where the mirror is off: the mass is the particles' own), node_d and diffused a float4.
        unsafe {
            k.diffuse.0.launch(l, l.cover(nodes), |a| {
                a.arg(&params.kernel)
                    .arg(&friction)
                    .arg(&diffusion)
                    .region(&region)
                    .arg(g.fixed_mass())
                    .arg_or_null(self.own_mass.as_ref())
                    .arg(viscosity)
                    .arg(&self.node_d)
                    .arg(diffused)
                    .colliders(&d.colliders);
            })
        }
    }
}

/// The parameters the explicit solver's kernels (the walls' mirror) take for the position-based
/// grid: its sums are fixed point whatever the scene's scatter.
pub fn fixed_point(params: &Params) -> Params {
    let mut fixed = *params;
    fixed.scatter_mode = ScatterMode::FixedPoint.code();
    fixed
}

/// What each phase of the position-based substep holds, for the bench tables.
pub fn phase_label(phase: Phase, iterations: u32) -> String {
    match phase {
        Phase::Sort => "bins (by 4x4x4-node block, every substep)".into(),
        Phase::P2gInit => {
            "pbmpm_begin (warm start; mass, viscosity, volume scatters) + mirror_walls + pbmpm_volume_targets"
                .into()
        }
        Phase::P2g => format!(
            "{} x (pbmpm_scatter: gather, constraints, tiled scatter + mirror_walls + pbmpm_grid (+ pbmpm_diffuse))",
            iterations
        ),
        Phase::G2p => "pbmpm_integrate (the last gather, integration)".into(),
        _ => "(none under pbmpm)".into(),
    }
}
