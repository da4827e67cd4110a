//! kernels/one_pass.cu: the fused pipeline's particle pass. With `Gather::Substep` it gathers
//! velocity, C and the grid mass, applies the soft wall, colliders and sinks, advects, advances the
//! particle's density, and scatters the next substep's mass and momentum; with `Gather::None` it is
//! the scatter alone, from the state and density the particles carry (the first substep after they
//! were spawned or uploaded). One kernel for both (an entry point per scatter, each serving both
//! uses), so both scatter with the same instructions. The float scatter has two entry points, the
//! size of the scene choosing (`FloatScatter`).

use super::gpu::FloatScatter;
use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::contract::{LAW_NEWTONIAN, TILE_THREADS};
use crate::sim::material::MaterialTable;
use crate::sim::{Params, ScatterMode};
use anyhow::Result;
use cudarc::driver::PushKernelArg;

/// Channels per tile node of the fixed-point scatter: mass, momentum xyz.
const SCATTER_CHANNELS: u32 = 4;

/// What the pass does before it scatters.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Gather {
    /// Nothing: scatter the particles as they are.
    None,
    /// The end of a substep: g2p, advection and the density, from the grid the substep updated.
    Substep,
    /// The end of a frame's last substep: as `Substep`, but a plastic solid scatters the stress of
    /// its stored deformation, as `None` does, not the one its return mapping gave: a run resumed
    /// from a checkpoint of the frame scatters these bits again (`Solver::ends_frame_next`).
    SubstepEndingFrame,
}

/// The planes kernel from this many times the particles the device holds of it at once (its
/// resident threads: 67,584 on an H100). Measured there (BENCHMARKS.md 0t), planes against runs:
/// columns of 65,536 particles +6.4 %, 131,072 +0.9 %, 196,608 -1.2 %, 524,288 -5.1 %; the dam break
/// -6.4 %, `dam-break-1m` -14.5 % (the fountain, 60,000 slots of sparse jets, -5.2 % under one wave: the
/// rule misses it).
const PLANES_FROM_WAVES: u64 = 2;

/// The kernel's entry points: one per scatter (two for the float scatter), each compiled for its own
/// blocks per SM.
struct Entries {
    float: Kernel,
    float_planes: Kernel,
    fixed: Kernel,
}

impl Entries {
    /// The entries named `[float, float_planes, fixed]`.
    fn load(modules: &LoadedModules, [float, float_planes, fixed]: [&'static str; 3]) -> Result<Entries> {
        Ok(Entries {
            float: Kernel::load(modules, "one_pass", float)?,
            float_planes: Kernel::load(modules, "one_pass", float_planes)?,
            fixed: Kernel::load(modules, "one_pass", fixed)?,
        })
    }
}

/// The pass's entries for water (a scene of one Newtonian liquid thinner than
/// `VISCOUS_REST_VOLUME_FROM`, compiled without the material table's index and laws), for any
/// table of liquids, and for a table with solids (which reads and advances their deformation).
pub struct OnePass {
    water: Entries,
    liquids: Entries,
    solids: Entries,
    /// The particles from which the float scatter runs by planes (0: always, u64::MAX: never).
    planes_from: u64,
}

impl OnePass {
    pub fn load(
        modules: &LoadedModules,
        float_scatter: FloatScatter,
        multiprocessors: u32,
    ) -> Result<OnePass> {
        let water = Entries::load(
            modules,
            ["one_pass_float", "one_pass_float_planes", "one_pass_fixed"],
        )?;
        let planes_from = match float_scatter {
            FloatScatter::Runs => u64::MAX,
            FloatScatter::Planes => 0,
            FloatScatter::BySize => {
                let resident_threads = u64::from(water.float_planes.resident_blocks(TILE_THREADS as u32, 0)?)
                    * u64::from(TILE_THREADS as u32)
                    * u64::from(multiprocessors);
                PLANES_FROM_WAVES * resident_threads
            }
        };
        Ok(OnePass {
            water,
            liquids: Entries::load(
                modules,
                [
                    "one_pass_float_liquids",
                    "one_pass_float_planes_liquids",
                    "one_pass_fixed_liquids",
                ],
            )?,
            solids: Entries::load(
                modules,
                [
                    "one_pass_float_solids",
                    "one_pass_float_planes_solids",
                    "one_pass_fixed_solids",
                ],
            )?,
            planes_from,
        })
    }

    /// The entry point that runs for `params`: water's or the liquids', for its scatter mode and
    /// particles.
    pub fn kernel(&self, params: &Params) -> &Kernel {
        let first = &params.materials[0];
        let water =
            params.material_count == 1 && first.law == LAW_NEWTONIAN && !first.viscous_at_rest_volume();
        let entries = if water {
            &self.water
        } else if params.has_deformation() {
            &self.solids
        } else {
            &self.liquids
        };
        if params.scatter_mode == ScatterMode::FixedPoint.code() {
            &entries.fixed
        } else if u64::from(params.num_particles) >= self.planes_from {
            &entries.float_planes
        } else {
            &entries.float
        }
    }

    pub fn launch(&self, l: &Launcher, gather: Gather, params: &Params, d: &DeviceState) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        let list = d.bins.list()?;
        let kernel = self.kernel(params);
        // The float scatter sums in registers and needs no tile.
        let tile_channels = if params.scatter_mode == ScatterMode::FixedPoint.code() {
            SCATTER_CHANNELS
        } else {
            0
        };
        let config = d.bins.tiled_pass(l, kernel, tile_channels)?;
        // kernels/one_pass.cu's `gather` argument.
        let gather: u32 = match gather {
            Gather::None => 0,
            Gather::Substep => 1,
            Gather::SubstepEndingFrame => 2,
        };
        // SAFETY: the arguments match every one_pass entry in kernels/one_pass.cu (one parameter
        // list); the bin list, order and node-block list are
        // sized for this grid and these particles; a null order where the particles are stored in
        // bin order (the kernel reads places). Without a flow the sink and free-slot pointers are
        // null and never read (no sinks); without `gather` the node velocities are not read. The
        // deformation is null where the scene has no solid, and only the solids' entries read it.
        unsafe {
            kernel.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(&gather)
                    .arg(list)
                    .bin_order_or_places(d)
                    .particle_state(p)
                    .arg(&p.slot)
                    .deformation(p)
                    .arg(&g.vel)
                    .accumulators(g)
                    .node_block_list(d)
                    .colliders(&d.colliders)
                    .sinks(d.flow.as_ref());
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::FloatScatter;

    #[test]
    fn float_scatter_names_parse_and_others_are_refused_with_the_choices() {
        assert_eq!(FloatScatter::parse("runs").unwrap(), FloatScatter::Runs);
        assert_eq!(FloatScatter::parse(" planes\n").unwrap(), FloatScatter::Planes);
        let err = FloatScatter::parse("plane").unwrap_err().to_string();
        assert!(
            err.contains("MPM_FLOAT_SCATTER=\"plane\"") && err.contains("runs or planes"),
            "{err}"
        );
    }
}
