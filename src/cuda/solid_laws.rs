//! kernels/solid_laws.cu: the solids' laws (kernels/solid.cuh, kernels/svd.cuh) run on a batch of
//! matrices, for tests/gpu_solids.rs to compare each device function with its CPU twin
//! (src/sim/svd.rs, src/sim/solid.rs). No pipeline launches it.

use super::gpu::Gpu;
use super::launch::host_kernel;
use super::modules::{LoadedModules, TEST_ONLY_MODULES};
use crate::contract::{Material, MAX_MATERIALS};
use anyhow::{ensure, Context, Result};
use cudarc::driver::PushKernelArg;
use glam::{Mat3, Vec3};

host_kernel!(SolidLawsCheck = "solid_laws" / "solid_laws_check");

/// Floats the kernel writes per matrix (`SOLID_LAWS_OUT` in kernels/solid_laws.cu).
const FLOATS_PER_RESULT: usize = 50;

/// What the device computed for one matrix F and plastic scalar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolidLawsResult {
    /// `svd3(F)`.
    pub u: Mat3,
    pub sigma: Vec3,
    pub v: Mat3,
    /// `plastic_return(material, F, plastic)`.
    pub elastic: Mat3,
    pub plastic: f32,
    /// `kirchhoff_stress(material, F, plastic)`, of the input.
    pub stress: Mat3,
    /// The stress of the returned state as the fused pass scatters it: `plastic_return_with_stress`'s
    /// for a law with a return mapping, else `kirchhoff_stress(material, elastic, plastic after the
    /// return)`.
    pub returned_stress: Mat3,
    /// `solid_wave_speed(material, plastic after the return)`.
    pub wave_speed: f32,
}

impl SolidLawsResult {
    fn read(floats: &[f32]) -> SolidLawsResult {
        let mat = |at: usize| Mat3::from_cols_slice(&floats[at..at + 9]);
        SolidLawsResult {
            u: mat(0),
            sigma: Vec3::from_slice(&floats[9..12]),
            v: mat(12),
            elastic: mat(21),
            plastic: floats[30],
            stress: mat(31),
            returned_stress: mat(40),
            wave_speed: floats[49],
        }
    }
}

/// Runs every solid-law function on the device for each `f[i]` with plastic scalar `plastic[i]`
/// under row `rows[i]` of `materials`, and waits for the results. Loads kernels/solid_laws.cu on its
/// own (a GPU's start-up leaves it out: `TEST_ONLY_MODULES`) and writes `materials` into that
/// module's material table alone, so a solver on the same `Gpu` keeps its own.
pub fn solid_laws_on_device(
    gpu: &Gpu,
    materials: &[Material],
    rows: &[u8],
    f: &[Mat3],
    plastic: &[f32],
) -> Result<Vec<SolidLawsResult>> {
    ensure!(
        !materials.is_empty() && materials.len() <= MAX_MATERIALS as usize,
        "{} material rows: give 1 to {MAX_MATERIALS}",
        materials.len()
    );
    ensure!(
        rows.len() == f.len() && plastic.len() == f.len(),
        "{} rows, {} matrices and {} plastic scalars: give one of each per matrix",
        rows.len(),
        f.len(),
        plastic.len()
    );
    ensure!(
        rows.iter().all(|&row| usize::from(row) < materials.len()),
        "a row past the {} materials given",
        materials.len()
    );
    if f.is_empty() {
        return Ok(Vec::new());
    }
    let mut table = [Material::default(); MAX_MATERIALS as usize];
    table[..materials.len()].copy_from_slice(materials);
    let stream = gpu.stream();
    let modules = LoadedModules::load_named(&gpu.ctx, &TEST_ONLY_MODULES)?;
    modules.write_material_table(stream, &table)?;
    let kernel = SolidLawsCheck::load(&modules)?;

    let matrices: Vec<f32> = f.iter().flat_map(|m| m.to_cols_array()).collect();
    let rows: Vec<u32> = rows.iter().map(|&row| u32::from(row)).collect();
    let count = u32::try_from(f.len()).context("too many matrices for one launch")?;
    let upload = "uploading the solid-law checks' inputs";
    let matrices = stream.clone_htod(&matrices).context(upload)?;
    let plastic = stream.clone_htod(plastic).context(upload)?;
    let rows = stream.clone_htod(&rows).context(upload)?;
    let mut out = stream
        .alloc_zeros::<f32>(FLOATS_PER_RESULT * f.len())
        .context("allocating the solid-law checks' results")?;
    let config = gpu.launcher.cover(f.len());
    // SAFETY: the arguments match solid_laws_check in kernels/solid_laws.cu; `matrices` holds 9
    // floats, `plastic` and `rows` one value, and `out` FLOATS_PER_RESULT floats per matrix.
    unsafe {
        kernel.0.launch(&gpu.launcher, config, |a| {
            a.arg(&count)
                .arg(&matrices)
                .arg(&plastic)
                .arg(&rows)
                .arg(&mut out);
        })?;
    }
    let floats = gpu.download(&out)?;
    Ok(floats
        .chunks_exact(FLOATS_PER_RESULT)
        .map(SolidLawsResult::read)
        .collect())
}
