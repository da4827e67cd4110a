//! The transfer identities of docs/physics.md ("The checks physics gives for free"), on random particles.

mod common;

use glam::{DVec3, Vec3};
use mpm::sim::cpu::{CpuSolver, GridShape, Stencil};
use mpm::sim::{DensityRule, Params};

const RES: u32 = 16;
const DX: f32 = 0.01;

/// Parameters for a 16^3 grid at dx = 1 cm. The random clouds are about 1450 kg/m^3; a rest density
/// of 700 gives every particle pressure (the stress term is live), and a soft EOS keeps the velocity
/// kick per step near 0.1 m/s, so nothing reaches the walls and gets clamped. The density is the
/// report's, gathered from the cloud in p2g (`DensityRule::Gathered`), which makes every particle's
/// stress live; the fused pipeline's rule feeds the same stress expression (`p2g_particle`) the
/// particle's own density instead, and its g2p is checked against the GPU in tests/gpu_kernels.rs.
fn params() -> Params {
    let scene = common::scene(&common::water_box(
        RES,
        "[solver]\ngravity = [0.0, 0.0, 0.0]\n[[block]]\nmin = [0.05, 0.05, 0.05]\nmax = [0.1, 0.1, 0.1]",
    ));
    let mut params = scene.params();
    params.density_rule = DensityRule::Gathered.code();
    params.dt = 1.0e-4;
    params.materials[0].rest_density = 700.0;
    params.materials[0].eos_stiffness = 100.0;
    params.materials[0].viscosity = 0.5;
    params
}

/// 4000 random particles away from the walls (so the band never touches them).
fn solver(seed: u64) -> CpuSolver {
    let p = common::random_particles(4000, 4.0 * DX, (RES as f32 - 5.0) * DX, 1.0, 20.0, seed);
    CpuSolver::new(p, [RES; 3])
}

/// sum_i x_i x (mv)_i over the grid, with x_i = node * dx.
fn grid_angular_momentum(shape: GridShape, momentum: &[Vec3], dx: f32) -> DVec3 {
    momentum
        .iter()
        .enumerate()
        .map(|(i, mv)| (shape.node(i).as_dvec3() * f64::from(dx)).cross(mv.as_dvec3()))
        .sum()
}

/// sum_p [x_p x m_p v_p + m_p eps:(C_p D)^T], D = dx^2/4 I: the APIC particle angular momentum.
fn particle_angular_momentum(s: &CpuSolver, m_p: f32, dx: f32) -> DVec3 {
    let d = f64::from(dx * dx) / 4.0;
    (0..s.particles.len())
        .map(|n| {
            let (x, v, c) = (
                s.particles.x[n].as_dvec3(),
                s.particles.v[n].as_dvec3(),
                s.particles.c[n],
            );
            let cc = |row: usize, col: usize| f64::from(c.col(col)[row]);
            let affine = DVec3::new(cc(2, 1) - cc(1, 2), cc(0, 2) - cc(2, 0), cc(1, 0) - cc(0, 1)) * d;
            (x.cross(v) + affine) * f64::from(m_p)
        })
        .sum()
}

fn assert_close(a: DVec3, b: DVec3, tol: f64, what: &str) {
    assert!(
        (a - b).length() <= tol,
        "{what}: {a} vs {b}, |diff| = {:e} > {tol:e}",
        (a - b).length()
    );
}

#[test]
fn weights_partition_unity_and_have_the_exact_moments() {
    let shape = GridShape::whole(glam::UVec3::splat(RES));
    let p = common::random_particles(1000, DX, (RES as f32 - 2.0) * DX, 0.0, 0.0, 1);
    for &x in &p.x {
        let (mut sum_w, mut sum_wd, mut sum_wdd) = (0.0f64, DVec3::ZERO, glam::DMat3::ZERO);
        Stencil::new(x, 1.0 / DX).for_each_node(shape, |_, w, d| {
            let (w, d) = (f64::from(w), d.as_dvec3());
            sum_w += w;
            sum_wd += w * d;
            sum_wdd += glam::DMat3::from_cols(d * d.x, d * d.y, d * d.z) * w;
        });
        assert!((sum_w - 1.0).abs() < 1e-6, "sum w = {sum_w} at {x}");
        assert!(sum_wd.length() < 1e-6, "sum w d = {sum_wd} at {x}");
        let err = (sum_wdd - glam::DMat3::IDENTITY * 0.25).to_cols_array();
        assert!(
            err.iter().all(|e| e.abs() < 1e-6),
            "sum w d d^T - I/4 = {err:?} at {x}"
        );
    }
}

#[test]
fn p2g_conserves_mass_and_momentum_with_stress() {
    let params = params();
    let mut s = solver(2);
    s.clear_grid();
    s.p2g_init(&params);
    let m_p = params.materials[0].particle_mass;
    let grid_mass: f64 = s.grid.mass.iter().map(|&m| f64::from(m)).sum();
    let particle_mass = s.particles.len() as f64 * f64::from(m_p);
    assert!(
        ((grid_mass - particle_mass) / particle_mass).abs() < 1e-5,
        "grid mass {grid_mass} vs particle mass {particle_mass}"
    );

    s.p2g(&params);
    let compressed = s
        .particles
        .rho
        .iter()
        .filter(|&&r| r > params.materials[0].rest_density)
        .count();
    assert!(
        compressed > s.particles.len() / 2,
        "the stress term must be live: {compressed} compressed"
    );
    let grid_p: DVec3 = s.grid.momentum.iter().map(|m| m.as_dvec3()).sum();
    let particle_p: DVec3 = s.particles.v.iter().map(|v| v.as_dvec3() * f64::from(m_p)).sum();
    // The stress term sums to zero only up to f32 rounding of its per-node contributions.
    let scale: f64 = s.grid.momentum.iter().map(|m| m.as_dvec3().length()).sum();
    assert_close(grid_p, particle_p, 1e-5 * scale, "grid vs particle momentum");
}

/// Runs clear, p2g_init and p2g; returns the grid's angular momentum and the scale of its terms
/// (sum |mv_i| times the domain size), which sets the f32 tolerance.
fn p2g_angular_momentum(s: &mut CpuSolver, params: &Params) -> (DVec3, f64) {
    s.clear_grid();
    s.p2g_init(params);
    s.p2g(params);
    let grid = grid_angular_momentum(s.grid.shape, &s.grid.momentum, DX);
    let scale = s.grid.momentum.iter().map(|m| m.as_dvec3().length()).sum::<f64>() * f64::from(RES) * 0.01;
    (grid, scale)
}

#[test]
fn apic_transfers_conserve_angular_momentum() {
    let mut params = params();
    params.materials[0].viscosity = 0.0; // pressure only here; the next test adds viscosity
    let mut s = solver(3);
    let m_p = params.materials[0].particle_mass;
    let before = particle_angular_momentum(&s, m_p, DX);
    let (grid, scale) = p2g_angular_momentum(&mut s, &params);
    assert_close(
        grid,
        before,
        1e-5 * scale,
        "p2g: grid vs particle angular momentum",
    );

    // grid_update without gravity only divides by mass; g2p must give back the grid's angular momentum.
    s.grid_update(&params);
    let momenta: Vec<Vec3> = s
        .grid
        .momentum
        .iter()
        .zip(&s.grid.mass)
        .map(|(v, &m)| *v * m)
        .collect();
    let grid = grid_angular_momentum(s.grid.shape, &momenta, DX);
    s.g2p(&params);
    let after = particle_angular_momentum(&s, m_p, DX);
    assert_close(
        after,
        grid,
        1e-5 * scale,
        "g2p: particle vs grid angular momentum",
    );
}

#[test]
fn stress_is_symmetric_so_viscosity_adds_no_torque() {
    let params = params(); // viscosity 0.5 Pa s
    let mut s = solver(4);
    let before = particle_angular_momentum(&s, params.materials[0].particle_mass, DX);
    let (grid, scale) = p2g_angular_momentum(&mut s, &params);
    assert_close(grid, before, 1e-5 * scale, "p2g with viscosity");
}
