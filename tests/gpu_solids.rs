//! The solids' laws on the GPU against their CPU twins: `svd3` (kernels/svd.cuh, src/sim/svd.rs)
//! and `plastic_return_with_stress` (the return mapping and the stress it gives),
//! `kirchhoff_stress` and `solid_wave_speed` of every solid law (kernels/solid.cuh,
//! src/sim/solid.rs), run by kernels/solid_laws.cu over the hard matrices of the CPU tests. Where
//! no CUDA device and driver are usable, the test is reported as ignored, with the reason
//! (tests/harness).
//!
//! Tolerances: the kernels compute the CPU's expressions in the same order, but NVRTC contracts
//! a*b+c into fused multiply-adds (tests/gpu_kernels.rs's header), so each side rounds F's products
//! differently, by eps |F| ~ 6e-8 |F|. The comparisons allow 1e-5 of each quantity's scale, times
//! the condition sigma_0 / |sigma_2| of F (at most 1e4 here) where a quantity amplifies that
//! rounding (the small singular values, ln sigma, ln J, the clamp's volume ratio). Singular vectors
//! are compared only where their singular value stands apart from the others (elsewhere they are not
//! unique, and each side may pick a different, equally right, basis); every device decomposition is
//! checked on its own instead: orthonormal, rotations, sorted, and rebuilding F. Matrices closer to
//! singular than 1e4 : 1 have their laws' results checked for being finite only: their logarithms
//! read the floors (MIN_STRETCH, MIN_VOLUME) on one side and rounding noise on the other.

use glam::{DMat3, Mat3, Quat, Vec3};
use mpm::contract::{
    Material, LAW_FIXED_COROTATED, LAW_HERSCHEL_BULKLEY, LAW_NEO_HOOKEAN, LAW_SAND, LAW_SNOW,
    SNOW_MAX_HARDENING, SNOW_MIN_HARDENING,
};
use mpm::cuda::gpu::Gpu;
use mpm::cuda::solid_laws::{solid_laws_on_device, SolidLawsResult};
use mpm::cuda::{CudaOptions, CudaSolver};
use mpm::sim::solid::{
    drucker_prager_alpha, kirchhoff_stress, lame_parameters, plastic_return_with_stress, rest_plastic,
    solid_wave_speed,
};
use mpm::sim::svd::svd3;
use mpm::sim::{ScatterMode, Solver};

mod common;
mod harness;
mod materials_checks;
mod solids_checks;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![
            svd_and_solid_laws_match_their_cpu_twins,
            solids_follow_the_cpu_in_the_fused_pipeline,
            solids_in_fixed_point_are_byte_identical,
            blocks_float_and_sink_at_finer_cells,
            snow_and_sand_follow_the_cpu,
            a_block_slides_at_mu_g_under_the_mirror,
            sand_stands_at_its_friction_angle_at_finer_cells,
            sand_columns_run_out_at_finer_cells,
            a_snowball_breaks_on_a_wall_where_a_jelly_ball_bounces_whole,
        ],
    )
}

/// A small deterministic generator (xorshift32), as src/sim/svd.rs's tests use.
struct Xorshift(u32);

impl Xorshift {
    /// Uniform in [-1, 1).
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 23) as f32 - 1.0
    }

    fn matrix(&mut self) -> Mat3 {
        Mat3::from_cols_array(&std::array::from_fn(|_| self.next()))
    }

    fn rotation(&mut self) -> Mat3 {
        let axis = Vec3::new(self.next(), self.next(), self.next() + 2.0).normalize();
        Mat3::from_quat(Quat::from_axis_angle(axis, 3.0 * self.next()))
    }

    /// R diag(values) W for random rotations R and W.
    fn rotated(&mut self, values: Vec3) -> Mat3 {
        self.rotation() * Mat3::from_diagonal(values) * self.rotation()
    }
}

/// The rows of the material table: each solid law, and sand with cohesion (E = 1e5 Pa, nu = 0.3);
/// the elastic part of an elastoviscoplastic liquid (G = 1e5 Pa, tau_y = 800 Pa: it yields past a
/// deviatoric strain of 5.7e-3).
fn materials() -> Vec<Material> {
    let (shear_modulus, lame_lambda) = lame_parameters(1.0e5, 0.3);
    let solid = |law| Material {
        rest_density: 400.0,
        law,
        shear_modulus,
        lame_lambda,
        critical_compression: 2.5e-2,
        critical_stretch: 7.5e-3,
        hardening: 10.0,
        friction_alpha: drucker_prager_alpha(30.0),
        ..Default::default()
    };
    let mut cohesive = solid(LAW_SAND);
    cohesive.cohesion = 0.01;
    vec![
        solid(LAW_FIXED_COROTATED),
        solid(LAW_NEO_HOOKEAN),
        solid(LAW_SNOW),
        solid(LAW_SAND),
        cohesive,
        Material {
            rest_density: 1000.0,
            law: LAW_HERSCHEL_BULKLEY,
            shear_modulus: 1.0e5,
            yield_stress: 800.0,
            ..Default::default()
        },
    ]
}

/// The hard matrices of src/sim/svd.rs's tests and the deformations of src/sim/solid.rs's, named.
fn matrices() -> Vec<(String, Mat3)> {
    let mut rng = Xorshift(0x5eed_0041);
    let mut out: Vec<(String, Mat3)> = vec![("identity".into(), Mat3::IDENTITY), ("zero".into(), Mat3::ZERO)];
    for k in 0..20 {
        out.push((format!("near identity {k}"), Mat3::IDENTITY + rng.matrix() * 1e-6));
    }
    let named_values = [
        ("2, 2, 2", Vec3::splat(2.0)),
        ("3, 1, 1", Vec3::new(3.0, 1.0, 1.0)),
        ("1, 1, 3", Vec3::new(1.0, 1.0, 3.0)),
        ("one zero", Vec3::new(2.0, 0.5, 0.0)),
        ("two zeros", Vec3::new(0.0, 1.5, 0.0)),
        ("reflection", Vec3::new(1.0, 1.0, -1.0)),
        ("reflection, distinct", Vec3::new(-2.0, 0.5, 1.0)),
        ("1e4 : 1 : 1", Vec3::new(1e4, 1.0, 1.0)),
        ("1 : 1 : 1e-4", Vec3::new(1.0, 1.0, 1e-4)),
        ("1e4 : 1.3 : 1", Vec3::new(1e4, 1.3, 1.0)),
        ("1 : 1e-2 : 1e-4", Vec3::new(1.0, 1e-2, 1e-4)),
    ];
    for (name, values) in named_values {
        out.push((name.to_string(), Mat3::from_diagonal(values)));
        for k in 0..5 {
            out.push((format!("{name}, rotated {k}"), rng.rotated(values)));
        }
    }
    let (a, b) = (Vec3::new(0.3, -1.2, 0.8), Vec3::new(-0.5, 0.1, 2.0));
    out.push(("outer product".into(), Mat3::from_cols(a * b.x, a * b.y, a * b.z)));
    for k in 0..20 {
        let values = Vec3::new(2.0 + rng.next(), 1.0 + 0.4 * rng.next(), 0.3 + 0.2 * rng.next());
        out.push((format!("rotated diagonal {k}"), rng.rotated(values)));
    }
    for k in 0..200 {
        out.push((format!("random {k}"), rng.matrix()));
    }
    for k in 0..100 {
        out.push((format!("deformation {k}"), Mat3::IDENTITY + rng.matrix() * 0.3));
    }
    // Snow's range: singular values about its clamp.
    for k in 0..50 {
        let values = Vec3::new(
            1.0 + 0.05 * rng.next(),
            1.0 + 0.05 * rng.next(),
            1.0 + 0.05 * rng.next(),
        );
        out.push((format!("snow range {k}"), rng.rotated(values)));
    }
    // Sand's: compressed and sheared about its cone, expanded past its tip.
    for k in 0..50 {
        let shear = 0.1 * rng.next();
        let eps = Vec3::new(shear, -0.4 * shear, -0.6 * shear) + Vec3::splat(0.02 * rng.next());
        out.push((
            format!("sand range {k}"),
            rng.rotated(eps.to_array().map(f32::exp).into()),
        ));
    }
    out
}

/// The largest entry's magnitude.
fn largest(m: Mat3) -> f32 {
    m.to_cols_array().iter().fold(0.0f32, |a, x| a.max(x.abs()))
}

/// The Frobenius norm, in f64.
fn frobenius(m: DMat3) -> f64 {
    m.to_cols_array().iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Worst error over tolerance seen for each quantity, printed at the end.
#[derive(Default)]
struct Worst(Vec<(&'static str, f32, String)>);

impl Worst {
    /// Records `error / tolerance` for `what` of `case`; returns whether it is within tolerance.
    fn check(&mut self, what: &'static str, error: f32, tolerance: f32, case: &str) -> bool {
        let ratio = if error == 0.0 { 0.0 } else { error / tolerance };
        match self.0.iter_mut().find(|(name, _, _)| *name == what) {
            Some(entry) if ratio > entry.1 || ratio.is_nan() => *entry = (what, ratio, case.to_string()),
            Some(_) => {}
            None => self.0.push((what, ratio, case.to_string())),
        }
        ratio <= 1.0
    }
}

/// Checks the device's decomposition of `f` on its own, and against the CPU's where it is unique.
fn check_svd(f: Mat3, gpu: &SolidLawsResult, case: &str, worst: &mut Worst, failures: &mut Vec<String>) {
    let (u, sigma, v) = svd3(f);
    let scale = sigma.x.abs();
    let mut fail = |what: &str| failures.push(format!("{case}: {what}"));
    if !worst.check(
        "sigma",
        (gpu.sigma - sigma).abs().max_element(),
        1e-5 * scale,
        case,
    ) {
        fail(&format!("singular values {:?}, the CPU's {sigma:?}", gpu.sigma));
    }
    // The device's decomposition on its own.
    let rebuilt =
        gpu.u.as_dmat3() * DMat3::from_diagonal(gpu.sigma.as_dvec3()) * gpu.v.transpose().as_dmat3();
    let norm = frobenius(f.as_dmat3()).max(f64::MIN_POSITIVE);
    let reconstruction = (frobenius(rebuilt - f.as_dmat3()) / norm) as f32;
    if !worst.check("U S V^T - F", reconstruction, 1e-5, case) {
        fail(&format!("|U S V^T - F| / |F| = {reconstruction:e}"));
    }
    for (name, m) in [("U", gpu.u), ("V", gpu.v)] {
        let off = largest(m.transpose() * m - Mat3::IDENTITY);
        let det = m.determinant();
        if !worst.check("orthonormality", off, 1e-5, case) || (det - 1.0).abs() > 1e-5 {
            fail(&format!(
                "{name} is not a rotation: |{name}^T {name} - I| = {off:e}, det {det}"
            ));
        }
    }
    let s = gpu.sigma;
    let slack = 1e-5 * s.x.abs();
    if !(s.x.abs() + slack >= s.y.abs() && s.y.abs() + slack >= s.z.abs() && s.x >= 0.0 && s.y >= 0.0) {
        fail(&format!(
            "singular values out of order or of the wrong sign: {s:?}"
        ));
    }
    // Against the CPU's vectors, where their singular value stands apart: each column pair (u_i,
    // v_i) is then unique up to a sign they share.
    let magnitudes = sigma.abs().to_array();
    for i in 0..3 {
        let gap = (0..3)
            .filter(|&j| j != i)
            .map(|j| (magnitudes[i] - magnitudes[j]).abs())
            .fold(f32::INFINITY, f32::min);
        if scale == 0.0 || gap < 1e-3 * scale {
            continue;
        }
        let tolerance = 1e-5 + 2e-6 * scale / gap;
        let sign = gpu.u.col(i).dot(u.col(i)).signum();
        let error = (gpu.u.col(i) - sign * u.col(i))
            .abs()
            .max_element()
            .max((gpu.v.col(i) - sign * v.col(i)).abs().max_element());
        if !worst.check("separated U, V columns", error, tolerance, case) {
            fail(&format!(
                "column {i} of U or V: {error:e} from the CPU's (sign {sign}):\nU {:?}\n  {u:?}\nV {:?}\n  {v:?}",
                gpu.u, gpu.v
            ));
        }
    }
}

/// Checks the device's return mapping, stresses and wave speed of `f` under `mat` against the CPU's.
fn check_laws(
    mat: &Material,
    f: Mat3,
    plastic: f32,
    gpu: &SolidLawsResult,
    case: &str,
    worst: &mut Worst,
    failures: &mut Vec<String>,
) {
    let (_, sigma, _) = svd3(f);
    let mut condition = sigma.x.abs() / sigma.z.abs();
    if sigma.z < 0.0 {
        // Inverted: the sign goes to the smallest singular value, and where the two smallest are
        // tied it could go to either, which sends the laws (whose rotation R = U V^T follows it)
        // different ways. Near a tie, the laws amplify rounding by as much as the tie is close.
        condition = condition.max(sigma.x / (sigma.y - sigma.z.abs()).abs());
    }
    // NaN for the zero matrix.
    if condition.is_nan() || condition > 1.001e4 {
        let finite = [gpu.elastic, gpu.stress, gpu.returned_stress]
            .iter()
            .all(|m| m.is_finite())
            && gpu.plastic.is_finite()
            && gpu.wave_speed.is_finite();
        if !finite {
            failures.push(format!("{case}: not finite: {gpu:?}"));
        }
        return;
    }
    let amplified = 1e-5 * condition.max(1.0);
    let (elastic, returned, return_stress) = plastic_return_with_stress(mat, f, plastic);
    let stress = kirchhoff_stress(mat, f, plastic);
    let returned_stress = return_stress.unwrap_or_else(|| kirchhoff_stress(mat, elastic, returned));
    let speed = solid_wave_speed(mat, returned);
    let stiffness = |p: f32| {
        let hardening = if mat.law == LAW_SNOW {
            (mat.hardening * (1.0 - p))
                .exp()
                .clamp(SNOW_MIN_HARDENING, SNOW_MAX_HARDENING)
        } else {
            1.0
        };
        (2.0 * mat.shear_modulus + 3.0 * mat.lame_lambda) * hardening
    };
    let mut fail = |what: String| failures.push(format!("{case}: {what}"));
    let error = largest(gpu.elastic - elastic);
    if !worst.check("F_E", error, amplified * largest(elastic).max(1.0), case) {
        fail(format!("F_E {:?}, the CPU's {elastic:?}", gpu.elastic));
    }
    if !worst.check(
        "plastic",
        (gpu.plastic - returned).abs(),
        amplified * returned.abs().max(1.0),
        case,
    ) {
        fail(format!("plastic scalar {}, the CPU's {returned}", gpu.plastic));
    }
    // The stresses' terms grow as |F|^2 (the shear terms) and J^2 (fixed-corotated's volume term).
    let growth = |m: Mat3| largest(m).powi(2).max(m.determinant().powi(2)).max(1.0);
    let scale = stiffness(plastic) * growth(f);
    if !worst.check("tau(F)", largest(gpu.stress - stress), amplified * scale, case) {
        fail(format!("stress {:?}, the CPU's {stress:?}", gpu.stress));
    }
    // Snow's returned J_p carries the plastic scalar's rounding into the hardening exp(xi (1 - J_p)),
    // times xi |J_p| (as the wave speed's below).
    let hardened = if mat.law == LAW_SNOW {
        1.0 + mat.hardening * returned.abs()
    } else {
        1.0
    };
    let scale = stiffness(returned) * growth(elastic) * hardened;
    let error = largest(gpu.returned_stress - returned_stress);
    if !worst.check("tau(F_E)", error, amplified * scale, case) {
        fail(format!(
            "returned stress {:?}, the CPU's {returned_stress:?}",
            gpu.returned_stress
        ));
    }
    let tolerance = amplified * speed * (1.0 + mat.hardening * returned.abs());
    if !worst.check("wave speed", (gpu.wave_speed - speed).abs(), tolerance, case) {
        fail(format!("wave speed {}, the CPU's {speed}", gpu.wave_speed));
    }
}

fn svd_and_solid_laws_match_their_cpu_twins() {
    let gpu = Gpu::open(&CudaOptions::default()).expect("opening the GPU");
    let materials = materials();
    let matrices = matrices();
    let mut rng = Xorshift(0x0dd_ba11);
    let (mut rows, mut fs, mut plastics, mut names) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, (name, f)) in matrices.iter().enumerate() {
        for (row, mat) in materials.iter().enumerate() {
            // At rest half the time; otherwise some J_p of snow, some volume correction of sand.
            let plastic = match (mat.law, k % 2) {
                (LAW_SNOW, 1) => 1.0 + 0.2 * rng.next(),
                (LAW_SAND, 1) => 0.1 * rng.next().abs(),
                _ => rest_plastic(mat.law),
            };
            rows.push(row as u8);
            fs.push(*f);
            plastics.push(plastic);
            names.push(format!("{name}, row {row} (law {}), plastic {plastic}", mat.law));
        }
    }
    let results =
        solid_laws_on_device(&gpu, &materials, &rows, &fs, &plastics).expect("running solid_laws_check");
    assert_eq!(results.len(), fs.len());

    let mut worst = Worst::default();
    let mut failures = Vec::new();
    for (i, result) in results.iter().enumerate() {
        let mat = &materials[usize::from(rows[i])];
        // The decomposition does not depend on the row: checked once a matrix.
        if rows[i] == 0 {
            check_svd(fs[i], result, &names[i], &mut worst, &mut failures);
        }
        check_laws(
            mat,
            fs[i],
            plastics[i],
            result,
            &names[i],
            &mut worst,
            &mut failures,
        );
    }
    println!(
        "{} matrices, {} cases; worst error / tolerance:",
        matrices.len(),
        fs.len()
    );
    for (what, ratio, case) in &worst.0 {
        println!("  {what}: {ratio:.3} ({case})");
    }
    assert!(
        failures.is_empty(),
        "{} of {} checks failed; the first:\n{}",
        failures.len(),
        fs.len(),
        failures.iter().take(10).cloned().collect::<Vec<_>>().join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// Solids in the fused pipeline against the CPU reference
// ---------------------------------------------------------------------------------------------

/// The colliding cubes (solids alone) and a light block in water (solids in water, two rest
/// densities), each scatter.
fn solids_follow_the_cpu_in_the_fused_pipeline() {
    for scatter in ["float", "fixed-point"] {
        let solver = format!("[solver]\nscatter = \"{scatter}\"\n");
        // In the 300 substeps the cubes collide and the light block settles into the water by about
        // half a cell: a quarter of a cell moved at least.
        for (scene, what) in [
            (solids_checks::colliding_cubes(scatter), "colliding cubes"),
            (
                solids_checks::block_in_water(0.01, 500.0, &solver),
                "a block in water",
            ),
        ] {
            let params = common::cfl_params(&scene);
            common::follow_cpu(&scene, &params, 300, 0.25, &format!("{what}, {scatter}"));
        }
    }
}

/// Two fixed-point runs of a light block in water, through several binnings (each moving the particles
/// and their deformation into bin order): the same bits, the deformation included.
fn solids_in_fixed_point_are_byte_identical() {
    let scene = solids_checks::block_in_water(0.01, 500.0, "[solver]\nscatter = \"fixed-point\"\n");
    let params = common::cfl_params(&scene);
    let run = || {
        let mut gpu = CudaSolver::new(&scene, CudaOptions::default()).unwrap();
        for _ in 0..200 {
            gpu.step(&params).unwrap();
        }
        gpu.read_particles().unwrap()
    };
    let (first, second) = (run(), run());
    assert!(!first.deformation.is_empty(), "the solids carry no deformation");
    assert!(
        common::same_particles(&first, &second),
        "two fixed-point runs of solids in water differ"
    );
}

/// The light and heavy blocks of tests/solids.rs ([`solids_checks::block_in_water`]) at cells of 1,
/// 0.5 and 0.25 cm: the light block's depth under the surface against Archimedes' half its height,
/// within 5 % at the finest, and the heavy block resting on the floor at each. In fixed point, so a
/// run gives the same numbers every time (H200, 2026-11-29, averaged over the last 1.5 s: 42.2,
/// 45.9 and 48.4 % under); `MPM_BLOCKS_SCATTER=float` runs the float scatter, whose sums' order
/// varies: 47.6, 50.6 and 52.5 % under at the finest in three runs, the last past the bound.
fn blocks_float_and_sink_at_finer_cells() {
    for dx in [0.01f32, 0.005, 0.0025] {
        for rho in [500.0f32, 1500.0] {
            let scatter = std::env::var("MPM_BLOCKS_SCATTER").unwrap_or_else(|_| "fixed-point".into());
            let scene =
                solids_checks::block_in_water(dx, rho, &format!("[solver]\nscatter = \"{scatter}\"\n"));
            let mut sim = materials_checks::simulation(&scene, mpm::backend::BackendKind::Cuda);
            let settled = solids_checks::settle_block(&mut sim, dx);
            println!(
                "dx = {dx} m, a block of {rho} kg/m^3: {:.2} % under (Archimedes {:.0} %), its bottom {:.2} cells \
                 above the floor",
                100.0 * settled.fraction,
                50.0 * rho / 500.0,
                settled.bottom_cells,
            );
            if rho > 1000.0 {
                assert!(
                    settled.bottom_cells < 2.5,
                    "dx = {dx} m: the heavy block has not sunk"
                );
            } else if dx < 0.005 {
                assert!(
                    (settled.fraction / 0.5 - 1.0).abs() < 0.05,
                    "dx = {dx} m: the light block floats {:.1} % under, Archimedes 50 % (5 % allowed)",
                    100.0 * settled.fraction
                );
            }
        }
    }
}

/// The snowball at the wall, a sand column collapsing (tests/solids.rs's scenes at 1 cm cells) and a
/// jelly block sliding on a Coulomb floor under the walls' mirror (the grid update's own sums and
/// the friction's image push), each scatter: through the snowball's impact (at the fixed substep of
/// [`common::cfl_params`], 0.14 ms, it meets the wall after about 100 of the 300 substeps), the
/// column's first slump and the block's first 4 cm.
fn snow_and_sand_follow_the_cpu() {
    for scatter in [ScatterMode::Float, ScatterMode::FixedPoint] {
        for (toml, what) in [
            (
                solids_checks::ball_at_wall_toml(0.01, "snow"),
                "a snowball at a wall",
            ),
            (solids_checks::sand_column_toml(0.01, 0.2, 0.1), "a sand column"),
            (
                solids_checks::sliding_block_toml(0.3, true),
                "a block sliding under the mirror",
            ),
        ] {
            let mut scene = common::scene(&toml);
            scene.scatter = scatter;
            let params = common::cfl_params(&scene);
            common::follow_cpu(&scene, &params, 300, 0.25, &format!("{what}, {scatter:?}"));
        }
    }
}

/// A jelly block sliding on a Coulomb floor (mu = 0.3) under the walls' mirror slows at mu g within
/// 6 % on the GPU, as on the CPU (tests/colliders.rs).
fn a_block_slides_at_mu_g_under_the_mirror() {
    let mu = 0.3f32;
    let scene = common::scene(&solids_checks::sliding_block_toml(mu, true));
    let mut sim = materials_checks::simulation(&scene, mpm::backend::BackendKind::Cuda);
    let deceleration = solids_checks::sliding_deceleration(&mut sim, mu, "GPU, the mirror on");
    assert!((deceleration / (mu * 9.81) - 1.0).abs() < 0.06);
}

/// The lifting-gate bank of tests/solids.rs ([`solids_checks::sand_behind_gate`]) at cells of 10,
/// 5, 2.5 and 1.25 mm: its slope at the friction angle, 30 degrees, within 3 at each.
fn sand_stands_at_its_friction_angle_at_finer_cells() {
    let mut angles = Vec::new();
    for dx in [0.01f32, 0.005, 0.0025, 0.00125] {
        let scene = solids_checks::sand_behind_gate(dx);
        let mut sim = materials_checks::simulation(&scene, mpm::backend::BackendKind::Cuda);
        let angle = solids_checks::repose_angle(&mut sim, dx, 4.0);
        println!("dx = {dx} m: the bank stands at {angle:.1} degrees, its friction angle 30");
        angles.push((dx, angle));
    }
    for (dx, angle) in angles {
        assert!(
            (angle - 30.0).abs() <= 3.0,
            "dx = {dx} m: the bank stands at {angle:.1} degrees, not 30 +- 3"
        );
    }
}

/// The sand columns of tests/solids.rs ([`solids_checks::sand_column`], aspect ratios 0.5 and 3, on
/// a floor of the sand's own friction) at 2.5 and 1.25 mm cells run out within 15 % of Lube et al.
/// (2005)'s runouts (docs/physics.md, "Solids", gives the numbers).
fn sand_columns_run_out_at_finer_cells() {
    for dx in [0.0025f32, 0.00125] {
        for (length, height) in [(0.2f32, 0.1f32), (0.08, 0.24)] {
            let a = height / length;
            let scene = solids_checks::sand_column(dx, length, height);
            let mut sim = materials_checks::simulation(&scene, mpm::backend::BackendKind::Cuda);
            let runout = solids_checks::sand_runout(&mut sim, dx, length, 1.5);
            let off = runout / solids_checks::lube_runout(a) - 1.0;
            println!(
                "dx = {dx} m, a = {a:.2}: runout {runout:.3}, Lube et al. {:.3} ({:+.1} %)",
                solids_checks::lube_runout(a),
                100.0 * off
            );
            assert!(
                off.abs() < 0.15,
                "dx = {dx} m, a = {a}: the runout strays {:.1} % from Lube et al.'s",
                100.0 * off
            );
        }
    }
}

/// The `snowball` preset, which is tests/solids.rs's snowball ([`solids_checks::ball_at_wall`]) at
/// 2.5 mm cells, 40 across (the jelly ball is that scene's): it breaks into more than one piece of
/// a thousandth of its particles or more, where the jelly ball of the same stiffness comes off
/// whole; no particle is lost and the snow stays inside its clamp (2026-11-28, H200: the snow in 7
/// such pieces after 0.4 s, the largest 93 % of it, and 5,800 grains of spray; at 5 mm and 1 cm,
/// and at 2.5 mm with the reference theta_s = 7.5e-3, it stays whole).
fn a_snowball_breaks_on_a_wall_where_a_jelly_ball_bounces_whole() {
    let dx = 0.0025f32;
    let preset = common::scene(mpm::sim::presets::get("snowball").unwrap());
    let [snow, jelly] = [preset, solids_checks::ball_at_wall(dx, "fixed-corotated")].map(|scene| {
        println!("a ball of {}:", scene.materials[0].name);
        assert_eq!(scene.dx, dx);
        let mut sim = materials_checks::simulation(&scene, mpm::backend::BackendKind::Cuda);
        solids_checks::throw_at_wall(&mut sim, &scene, dx, 0.4)
    });
    assert!(snow.pieces.len() > 1, "the snowball stayed in one piece");
    assert_eq!(
        jelly.pieces.len(),
        1,
        "the jelly ball broke into {} pieces",
        jelly.pieces.len()
    );
}
