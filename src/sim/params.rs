//! What a substep needs: the scatter mode and pipeline choices, and `Params`. `Material` and `Params`
//! themselves are defined in the host/device contract (src/contract/items.rs), which the kernels'
//! header is written from; the material's law is in `material.rs`.

pub use crate::contract::{Material, Params};
use crate::contract::{SCATTER_FIXED_POINT, SCATTER_FLOAT};

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

/// Which sequence of GPU kernels takes a substep. The CPU reference always runs the report's phases.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Pipeline {
    /// Particles binned by 4x4x4-node block, scatters through shared-memory tiles, g2p fused with the
    /// next substep's mass scatter, grid update over the touched blocks only (the default).
    #[default]
    Binned,
    /// The report's four kernels, p2g_init, p2g, grid_update (whole grid), g2p, with global atomics:
    /// the baseline the benchmark tables compare with.
    Report,
}

impl Pipeline {
    pub fn name(self) -> &'static str {
        match self {
            Pipeline::Binned => "binned",
            Pipeline::Report => "report",
        }
    }
}

impl Params {
    pub fn num_nodes(&self) -> usize {
        self.grid_res.iter().map(|&r| r as usize).product()
    }
}
