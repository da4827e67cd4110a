//! A solid's constitutive law on the CPU (issue 41): the plasticity that follows the advection of a
//! particle's deformation gradient, the Kirchhoff stress it scatters, and the wave speed the time
//! step follows. The twins of kernels/solid.cuh, operation for operation (matrices as
//! `[column][row]` arrays, the kernels' layout, and the same scalar functions the kernels call out
//! of line), so the reference and the kernels compute the same expressions.
//!
//! A solid particle carries the elastic part F of its deformation gradient and one plastic scalar:
//! J_p = det F_P for snow (1 at rest), the log-volume correction for sand (0 at rest), unused by the
//! elastic laws ([`rest_plastic`]). Each substep the solver advects F (F_trial = (I + dt C) F) and
//! calls [`plastic_return`]; the particle then scatters [`kirchhoff_stress`] of the result.
//!
//! A Herschel-Bulkley liquid with the elastic regularisation (a `shear_modulus`,
//! [`carries_deformation`]) carries one too: the isochoric elastic part of its deformation, whose
//! deviatoric stress bears the yield stress (von Mises, [`yield_return`]); its pressure and viscous
//! stress stay the liquid's (docs/physics.md, "Yield stress").

use super::params::Material;
use super::svd::{svd3_cols, times_transpose, Cols};
use crate::contract::{
    FIRST_SOLID_LAW, LAW_HERSCHEL_BULKLEY, LAW_NEO_HOOKEAN, LAW_SAND, LAW_SNOW, SNOW_MAX_HARDENING,
    SNOW_MIN_HARDENING, SOLID_MIN_STRETCH as MIN_STRETCH, SOLID_MIN_VOLUME as MIN_VOLUME,
};
use glam::Mat3;

/// Whether particles of `law` are solid: they carry a deformation gradient and scatter its stress
/// instead of a pressure.
pub fn is_solid(law: u32) -> bool {
    law >= FIRST_SOLID_LAW
}

/// Whether a row of `law` with shear modulus `shear_modulus` carries a deformation gradient: a
/// solid's, or a Herschel-Bulkley liquid's with the elastic regularisation (a shear modulus), whose
/// yield stress its elastic part bears.
pub fn carries_deformation(law: u32, shear_modulus: f32) -> bool {
    is_solid(law) || (law == LAW_HERSCHEL_BULKLEY && shear_modulus > 0.0)
}

/// Lame's shear modulus mu and first parameter lambda, Pa, of Young's modulus `young` (Pa) and
/// Poisson's ratio `poisson`: mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu) (1 - 2 nu)).
pub fn lame_parameters(young: f32, poisson: f32) -> (f32, f32) {
    (
        young / (2.0 * (1.0 + poisson)),
        young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson)),
    )
}

/// The Drucker-Prager coefficient alpha = sqrt(2/3) 2 sin(phi) / (3 - sin(phi)) of friction angle
/// `degrees` (Klar et al. 2016: the cone through Mohr-Coulomb's in triaxial compression).
pub fn drucker_prager_alpha(degrees: f32) -> f32 {
    let sin_phi = degrees.to_radians().sin();
    (2.0f32 / 3.0).sqrt() * 2.0 * sin_phi / (3.0 - sin_phi)
}

/// The plastic scalar of a particle of `law` at rest: J_p = 1 for snow, 0 (no volume correction)
/// for sand and for the elastic laws, which do not read it.
pub fn rest_plastic(law: u32) -> f32 {
    if law == LAW_SNOW {
        1.0
    } else {
        0.0
    }
}

/// Snow's hardening, mu and lambda times exp(xi (1 - J_p)) (Stomakhin et al. 2013, "A material
/// point method for snow simulation"): packed snow (J_p < 1) stiffens, snow that has been pulled
/// apart (J_p > 1) softens; held within [`SNOW_MIN_HARDENING`, `SNOW_MAX_HARDENING`]. 1 for other
/// laws.
fn hardening(law: u32, xi: f32, plastic: f32) -> f32 {
    if law == LAW_SNOW {
        // max then min, not clamp: the kernels' fmaxf and fminf, which turn a NaN into the bound.
        #[allow(clippy::manual_clamp)]
        (xi * (1.0 - plastic))
            .exp()
            .max(SNOW_MIN_HARDENING)
            .min(SNOW_MAX_HARDENING)
    } else {
        1.0
    }
}

/// The plasticity of a substep: the elastic part F_E of the advected `f_trial`, and the plastic
/// scalar after it. The elastic laws return both unchanged; snow and sand as [`plastic_law`] says,
/// a yield-stress liquid as [`yield_return`] says.
pub fn plastic_return(mat: &Material, f_trial: Mat3, plastic: f32) -> (Mat3, f32) {
    let (f, plastic, _) = plastic_return_with_stress(mat, f_trial, plastic);
    (f, plastic)
}

/// [`plastic_return`], and for a law with a return mapping (snow, sand, a yield-stress liquid's
/// elastic part) the Kirchhoff stress of what it returns, from the return's own decomposition: the
/// fused GPU pass scatters it in the substep that returned it (`solid_plastic_return` in
/// kernels/solid.cuh), where [`kirchhoff_stress`] of the result would decompose F_E again. The two
/// agree to rounding (the unit tests hold them within 1e-5 of the stress's scale).
pub fn plastic_return_with_stress(mat: &Material, f_trial: Mat3, plastic: f32) -> (Mat3, f32, Option<Mat3>) {
    let mut f = f_trial.to_cols_array_2d();
    let mut tau = [[0.0f32; 3]; 3];
    if mat.law == LAW_HERSCHEL_BULKLEY {
        yield_return(mat.shear_modulus, mat.yield_stress, &mut f, &mut tau);
    } else if mat.law == LAW_SNOW || mat.law == LAW_SAND {
        let plastic = plastic_law(
            mat.law,
            mat.lame_lambda,
            mat.shear_modulus,
            mat.critical_compression,
            mat.critical_stretch,
            mat.hardening,
            mat.friction_alpha,
            mat.cohesion,
            plastic,
            &mut f,
            &mut tau,
        );
        return (
            Mat3::from_cols_array_2d(&f),
            plastic,
            Some(Mat3::from_cols_array_2d(&tau)),
        );
    } else {
        return (f_trial, plastic, None);
    }
    (
        Mat3::from_cols_array_2d(&f),
        plastic,
        Some(Mat3::from_cols_array_2d(&tau)),
    )
}

/// U diag(principal) U^T: the Kirchhoff stress of principal stresses `principal` along U's columns.
fn principal_stress(u: &Cols, principal: &[f32; 3]) -> Cols {
    let mut tau = [[0.0f32; 3]; 3];
    for (c, column) in tau.iter_mut().enumerate() {
        for (r, entry) in column.iter_mut().enumerate() {
            *entry = u[0][r] * principal[0] * u[0][c]
                + u[1][r] * principal[1] * u[1][c]
                + u[2][r] * principal[2] * u[2][c];
        }
    }
    tau
}

/// Hencky's St. Venant-Kirchhoff stress, U (2 mu eps + lambda tr(eps) I) U^T, of principal
/// strains `eps`.
fn hencky_stress(mu: f32, lambda: f32, u: &Cols, eps: &[f32; 3]) -> Cols {
    let trace = eps[0] + eps[1] + eps[2];
    principal_stress(u, &eps.map(|e| 2.0 * mu * e + lambda * trace))
}

/// The fixed-corotated stress 2 mu (F - R) F^T + lambda (J - 1) J I of `f` = U diag(sigma) V^T,
/// R = U V^T, J = sigma_0 sigma_1 sigma_2.
fn corotated_stress(mu: f32, lambda: f32, u: &Cols, sigma: &[f32; 3], v: &Cols, f: &Cols) -> Cols {
    let mut tau = [[0.0f32; 3]; 3];
    let rotation = times_transpose(u, v);
    let volume = sigma[0] * sigma[1] * sigma[2];
    let pressure = lambda * (volume - 1.0) * volume;
    for (c, column) in tau.iter_mut().enumerate() {
        for (r, entry) in column.iter_mut().enumerate() {
            let shear = (f[0][r] - rotation[0][r]) * f[0][c]
                + (f[1][r] - rotation[1][r]) * f[1][c]
                + (f[2][r] - rotation[2][r]) * f[2][c];
            *entry = 2.0 * mu * shear;
            if r == c {
                *entry += pressure;
            }
        }
    }
    tau
}

/// U diag(s) V^T.
fn compose(u: &Cols, s: &[f32; 3], v: &Cols) -> Cols {
    let mut out = [[0.0f32; 3]; 3];
    for (c, column) in out.iter_mut().enumerate() {
        for (r, entry) in column.iter_mut().enumerate() {
            *entry = u[0][r] * s[0] * v[0][c] + u[1][r] * s[1] * v[1][c] + u[2][r] * s[2] * v[2][c];
        }
    }
    out
}

/// The return mapping of snow or sand (`solid_plastic_law` in kernels/solid.cuh, which takes the
/// row's scalars for the reason kernels/material.cuh gives): replaces `f` (F_trial) by F_E and
/// returns the plastic scalar. F_trial = U Sigma V^T.
///
/// Snow (Stomakhin et al. 2013): Sigma is clamped to [1 - theta_c, 1 + theta_s], F_E = U
/// Sigma_clamped V^T, and what the clamp took goes to the plastic part, J_p <- J_p det Sigma / det
/// Sigma_clamped, so that J_p det F_E is what J_p det F_trial was. Within the limits, F is returned
/// as it came.
///
/// Sand: the Drucker-Prager return mapping in Hencky strain of Klar et al. 2016 ("Drucker-Prager
/// elastoplasticity for sand animation"), with the volume correction of Tampubolon et al. 2017
/// ("Multi-species simulation of porous sand and water mixtures") and a cohesion that moves the
/// cone's tip from zero strain to a trace `cohesion` of isotropic tension. With eps = ln |sigma|
/// (|sigma| at least [`MIN_STRETCH`]) and v the volume correction (the log-volume gained by earlier
/// projections to the tip, as gaps between grains):
///
/// - tr = sum eps + v, the volume strain counting the gaps closed first;
/// - tr >= cohesion (expansion past the tip): eps = cohesion / 3 each, the tip (Klar's case II:
///   F_E = U V^T where cohesion = 0), and v <- tr - cohesion (Tampubolon's v collecting the volume
///   the tip dropped);
/// - otherwise, eps_hat = eps - (sum eps) / 3 I, the deviatoric part, and
///   delta_gamma = |eps_hat| + (3 lambda + 2 mu) / (2 mu) (tr - cohesion) alpha (Klar's, in
///   three dimensions, the cone shifted by the cohesion). delta_gamma <= 0 is inside the cone (case I);
///   otherwise eps_hat shrinks by delta_gamma along itself onto the cone's surface (case III). The
///   elastic strain becomes tr / 3 I + eps_hat (scaled): the gaps v closes first, so v <- 0, as
///   Tampubolon's v <- v + ln det F_trial - ln det F_E gives. F_E = U exp(eps) V^T. Inside the cone
///   with no gaps (v = 0) and not inverted, F is returned as it came.
///
/// F_E is U exp(eps) V^T in every branch, so it is continuous in F_trial (the kernels' rounding may
/// take the other branch near a boundary and still agree), and an inverted F (sigma_2 < 0, which the
/// Hencky strain reads as |sigma_2|) comes back the right way round wherever it is rebuilt; the one
/// F kept as it came is one that neither the cone nor the floor of |sigma| changes.
///
/// `tau` receives the Kirchhoff stress of the returned F_E ([`stress_law`]'s) from this
/// decomposition: snow's hardened at the returned J_p, sand's of the returned strains.
#[allow(clippy::too_many_arguments)]
fn plastic_law(
    law: u32,
    lambda: f32,
    mu: f32,
    theta_c: f32,
    theta_s: f32,
    xi: f32,
    alpha: f32,
    cohesion: f32,
    plastic: f32,
    f: &mut Cols,
    tau: &mut Cols,
) -> f32 {
    let (u, sigma, v) = svd3_cols(f);
    if law == LAW_SNOW {
        let (lowest, highest) = (1.0 - theta_c, 1.0 + theta_s);
        let clamped = sigma.map(|s| s.max(lowest).min(highest));
        let mut returned = plastic;
        if clamped != sigma {
            // |det|: an inverted F_trial comes out of the clamp the right way round, its volume kept.
            let ratio = (sigma[0] * sigma[1] * sigma[2]).abs() / (clamped[0] * clamped[1] * clamped[2]);
            *f = compose(&u, &clamped, &v);
            returned = plastic * ratio;
        }
        let scale = hardening(law, xi, returned);
        *tau = corotated_stress(mu * scale, lambda * scale, &u, &clamped, &v, f);
        return returned;
    }
    let eps = sigma.map(|s| s.abs().max(MIN_STRETCH).ln());
    let sum = eps[0] + eps[1] + eps[2];
    let trace = sum + plastic;
    if trace >= cohesion {
        let third = cohesion / 3.0;
        *f = compose(&u, &[third.exp(); 3], &v);
        *tau = hencky_stress(mu, lambda, &u, &[third; 3]);
        return trace - cohesion;
    }
    let mean = sum / 3.0;
    let hat = eps.map(|e| e - mean);
    let norm = (hat[0] * hat[0] + hat[1] * hat[1] + hat[2] * hat[2]).sqrt();
    let excess = norm + (3.0 * lambda + 2.0 * mu) / (2.0 * mu) * (trace - cohesion) * alpha;
    if excess <= 0.0 && plastic == 0.0 && sigma[2] >= MIN_STRETCH {
        *tau = hencky_stress(mu, lambda, &u, &eps);
        return plastic;
    }
    // excess > 0 only where norm > 0: the cone's term is not positive below the tip.
    let shrink = if excess > 0.0 { 1.0 - excess / norm } else { 1.0 };
    let third = trace / 3.0;
    let returned = hat.map(|h| third + shrink * h);
    *f = compose(&u, &returned.map(f32::exp), &v);
    *tau = hencky_stress(mu, lambda, &u, &returned);
    0.0
}

/// The elastic regularisation of a yield-stress liquid (`solid_yield_return` in kernels/solid.cuh):
/// replaces `f` (F_trial = U Sigma V^T) by its isochoric elastic part, returned to the von Mises
/// yield surface. With eps = ln |sigma| (|sigma| at least [`MIN_STRETCH`]) and eps_hat its
/// deviatoric part, the liquid's elastic stress is s = 2 mu eps_hat ([`stress_law`]), whose
/// equivalent shear stress sqrt(s:s / 2) = sqrt(2) mu |eps_hat| may not pass the yield stress
/// tau_y: where |eps_hat| > tau_y / (sqrt(2) mu), eps_hat shrinks along itself onto that radius
/// (the radial return of perfect plasticity; the liquid's viscous stress, in parallel, carries the
/// Herschel-Bulkley K gammadot^n). F_E = U exp(eps_hat) V^T: det F_E = 1 always, for the volume is
/// the liquid's, which its density and equation of state follow.
/// `tau` receives its stress, U (2 mu eps_hat) U^T of the returned eps_hat, from this decomposition.
pub fn yield_return(mu: f32, yield_stress: f32, f: &mut Cols, tau: &mut Cols) {
    let (u, sigma, v) = svd3_cols(f);
    let hat = deviatoric_strain(&sigma);
    let norm = (hat[0] * hat[0] + hat[1] * hat[1] + hat[2] * hat[2]).sqrt();
    let limit = yield_stress / (std::f32::consts::SQRT_2 * mu);
    let shrink = if norm > limit { limit / norm } else { 1.0 };
    let returned = hat.map(|h| shrink * h);
    *f = compose(&u, &returned.map(f32::exp), &v);
    *tau = principal_stress(&u, &returned.map(|h| 2.0 * mu * h));
}

/// The deviatoric Hencky strain of singular values `sigma`: ln |sigma| (|sigma| at least
/// [`MIN_STRETCH`]) less a third of its trace.
fn deviatoric_strain(sigma: &[f32; 3]) -> [f32; 3] {
    let eps = sigma.map(|s| s.abs().max(MIN_STRETCH).ln());
    let mean = (eps[0] + eps[1] + eps[2]) / 3.0;
    eps.map(|e| e - mean)
}

/// The Kirchhoff stress tau = P F^T = J sigma of elastic deformation `f` with plastic scalar
/// `plastic`, Pa: what a particle scatters, times its rest volume. A yield-stress liquid's is the
/// deviatoric part its elastic regularisation adds to its pressure and viscous stress; zero for a
/// row that carries no deformation.
pub fn kirchhoff_stress(mat: &Material, f: Mat3, plastic: f32) -> Mat3 {
    if !carries_deformation(mat.law, mat.shear_modulus) {
        return Mat3::ZERO;
    }
    Mat3::from_cols_array_2d(&stress_law(
        mat.law,
        mat.shear_modulus,
        mat.lame_lambda,
        mat.hardening,
        plastic,
        &f.to_cols_array_2d(),
    ))
}

/// det F, by the columns' triple product.
fn determinant(f: &Cols) -> f32 {
    let cross = [
        f[1][1] * f[2][2] - f[1][2] * f[2][1],
        f[1][2] * f[2][0] - f[1][0] * f[2][2],
        f[1][0] * f[2][1] - f[1][1] * f[2][0],
    ];
    f[0][0] * cross[0] + f[0][1] * cross[1] + f[0][2] * cross[2]
}

/// The Kirchhoff stress of each solid law (`solid_stress_law` in kernels/solid.cuh):
///
/// - Neo-Hookean: tau = mu (F F^T - I) + lambda ln(J) I, J at least [`MIN_VOLUME`]; no
///   decomposition needed.
/// - Fixed-corotated (Stomakhin et al. 2012): tau = 2 mu (F - R) F^T + lambda (J - 1) J I, R = U V^T
///   and J = sigma_0 sigma_1 sigma_2 (negative for an inverted F, which the (J - 1) J term then
///   pushes back through zero volume).
/// - Snow: fixed-corotated with mu and lambda times exp(xi (1 - J_p)) (Stomakhin et al. 2013).
/// - Sand: St. Venant-Kirchhoff in Hencky strain (Klar et al. 2016): tau = U (2 mu eps +
///   lambda tr(eps) I) U^T, eps = ln |Sigma| (|sigma| at least [`MIN_STRETCH`], as in the return
///   mapping).
/// - A yield-stress liquid's elastic part: its deviator alone, s = U (2 mu eps_hat) U^T, eps_hat
///   the deviatoric part of eps ([`yield_return`]).
fn stress_law(law: u32, mu: f32, lambda: f32, xi: f32, plastic: f32, f: &Cols) -> Cols {
    let mut tau = [[0.0f32; 3]; 3];
    if law == LAW_NEO_HOOKEAN {
        let log_volume = determinant(f).max(MIN_VOLUME).ln();
        for (c, column) in tau.iter_mut().enumerate() {
            for (r, entry) in column.iter_mut().enumerate() {
                let left = f[0][r] * f[0][c] + f[1][r] * f[1][c] + f[2][r] * f[2][c];
                *entry = mu * (left - if r == c { 1.0 } else { 0.0 });
                if r == c {
                    *entry += lambda * log_volume;
                }
            }
        }
        return tau;
    }
    let (u, sigma, v) = svd3_cols(f);
    if law == LAW_SAND {
        return hencky_stress(mu, lambda, &u, &sigma.map(|s| s.abs().max(MIN_STRETCH).ln()));
    }
    if law == LAW_HERSCHEL_BULKLEY {
        return principal_stress(&u, &deviatoric_strain(&sigma).map(|h| 2.0 * mu * h));
    }
    let scale = hardening(law, xi, plastic);
    corotated_stress(mu * scale, lambda * scale, &u, &sigma, &v, f)
}

/// The P-wave speed sqrt((lambda + 2 mu) h / rho0), m/s, h snow's hardening at `plastic` (1 for the
/// other laws): the fastest signal of the linearised solid, which the substep's CFL bound follows as
/// a liquid's follows its sound speed.
pub fn solid_wave_speed(mat: &Material, plastic: f32) -> f32 {
    let scale = hardening(mat.law, mat.hardening, plastic);
    ((mat.lame_lambda + 2.0 * mat.shear_modulus) * scale / mat.rest_density).sqrt()
}

/// A solid particle's volume ratio det F, for export: its elastic part's, times snow's plastic
/// J_p (the volume it lost or gained for good). Sand's expansion past its tip leaves no trace in F
/// (the volume correction stores it as a strain to recover), so its ratio is the elastic part's.
pub fn volume_ratio(mat: &Material, f: Mat3, plastic: f32) -> f32 {
    let elastic = f.determinant();
    if mat.law == LAW_SNOW {
        elastic * plastic
    } else {
        elastic
    }
}

/// A solid particle's von Mises stress, Pa, for export: sqrt(3/2 s:s), s the deviatoric part of its
/// Cauchy stress sigma = tau / J, tau its [`kirchhoff_stress`] and J = det F_E.
pub fn von_mises(mat: &Material, f: Mat3, plastic: f32) -> f32 {
    let sigma = kirchhoff_stress(mat, f, plastic) * (1.0 / f.determinant());
    let mean = (sigma.x_axis.x + sigma.y_axis.y + sigma.z_axis.z) / 3.0;
    let deviator = sigma - Mat3::from_diagonal(glam::Vec3::splat(mean));
    let squares: f32 = deviator.to_cols_array().iter().map(|s| s * s).sum();
    (1.5 * squares).sqrt()
}

#[cfg(test)]
mod tests {
    use super::{
        is_solid, kirchhoff_stress, plastic_return, plastic_return_with_stress, rest_plastic,
        solid_wave_speed,
    };
    use crate::contract::{
        LAW_FIXED_COROTATED, LAW_HERSCHEL_BULKLEY, LAW_NEO_HOOKEAN, LAW_NEWTONIAN, LAW_SAND, LAW_SNOW,
    };
    use crate::sim::params::Material;
    use crate::sim::svd::svd3;
    use crate::sim::svd::tests::Xorshift;
    use glam::{Mat3, Vec3};

    const SOLID_LAWS: [u32; 4] = [LAW_FIXED_COROTATED, LAW_NEO_HOOKEAN, LAW_SNOW, LAW_SAND];

    /// E = 1e5 Pa, nu = 0.3: mu = 38,462 Pa, lambda = 57,692 Pa; a friction angle of 30 degrees.
    fn solid(law: u32) -> Material {
        let (shear_modulus, lame_lambda) = super::lame_parameters(1.0e5, 0.3);
        Material {
            rest_density: 400.0,
            law,
            shear_modulus,
            lame_lambda,
            critical_compression: 2.5e-2,
            critical_stretch: 7.5e-3,
            hardening: 10.0,
            friction_alpha: super::drucker_prager_alpha(30.0),
            ..Default::default()
        }
    }

    fn largest(m: Mat3) -> f32 {
        m.to_cols_array().iter().fold(0.0f32, |a, x| a.max(x.abs()))
    }

    /// U diag(exp(eps)) V^T for random rotations U and V: a deformation of principal Hencky strains
    /// `eps`.
    fn with_strains(rng: &mut Xorshift, eps: Vec3) -> Mat3 {
        rng.rotation()
            * Mat3::from_diagonal(Vec3::new(eps.x.exp(), eps.y.exp(), eps.z.exp()))
            * rng.rotation()
    }

    /// The principal Hencky strains of `f`: ln of its singular values.
    fn strains(f: Mat3) -> Vec3 {
        let (_, sigma, _) = svd3(f);
        Vec3::new(sigma.x.ln(), sigma.y.ln(), sigma.z.ln())
    }

    /// The deviatoric part's length and the trace of strains `eps`.
    fn deviator_and_trace(eps: Vec3) -> (f32, f32) {
        let trace = eps.element_sum();
        ((eps - Vec3::splat(trace / 3.0)).length(), trace)
    }

    #[test]
    fn only_the_solid_laws_are_solid() {
        assert!(!is_solid(LAW_NEWTONIAN) && !is_solid(LAW_HERSCHEL_BULKLEY));
        assert!(SOLID_LAWS.iter().all(|&law| is_solid(law)));
        assert_eq!(rest_plastic(LAW_SNOW), 1.0);
        assert_eq!(rest_plastic(LAW_SAND), 0.0);
        // A liquid's row has no solid stress.
        assert_eq!(
            kirchhoff_stress(&solid(LAW_NEWTONIAN), Mat3::IDENTITY * 1.1, 0.0),
            Mat3::ZERO
        );
    }

    /// The elastic part of a yield-stress liquid (G = 1e5 Pa, tau_y = 800 Pa: the yield radius
    /// |eps_hat| = tau_y / (sqrt(2) G) = 5.7e-3): its volume dropped (det F_E = 1), its deviatoric
    /// strain kept below the yield stress and returned along itself onto the radius past it, where
    /// the stress's equivalent shear sqrt(s:s / 2) is then tau_y.
    #[test]
    fn a_yield_stress_liquid_returns_to_its_yield_surface() {
        let (mu, tau) = (1.0e5f32, 800.0f32);
        let mat = Material {
            rest_density: 1000.0,
            law: LAW_HERSCHEL_BULKLEY,
            shear_modulus: mu,
            yield_stress: tau,
            ..Default::default()
        };
        let radius = tau / (std::f32::consts::SQRT_2 * mu);
        let mut rng = Xorshift(0x9e1d_5e55);
        for k in 0..60 {
            let times = [0.3f32, 0.9, 1.5, 4.0][k % 4];
            let direction = Vec3::new(rng.next(), rng.next(), rng.next());
            let deviator = direction - Vec3::splat(direction.element_sum() / 3.0);
            let eps = deviator.normalize() * (times * radius) + Vec3::splat(0.01 * rng.next());
            let f = with_strains(&mut rng, eps);
            let (elastic, plastic) = plastic_return(&mat, f, 0.0);
            assert_eq!(plastic, 0.0);
            assert!(
                (elastic.determinant() - 1.0).abs() < 1e-5,
                "case {k}: det F_E = {}",
                elastic.determinant()
            );
            let (length, trace) = deviator_and_trace(strains(elastic));
            let expected = times.min(1.0) * radius;
            assert!(trace.abs() < 1e-5, "case {k}: volume strain {trace}");
            assert!(
                (length - expected).abs() < 1e-3 * radius,
                "case {k}: |eps_hat| = {length} where {expected} ({times} of the radius)"
            );
            // Along itself: the returned principal strains are the trial's deviator, scaled.
            let trial = strains(f);
            let trial_deviator = trial - Vec3::splat(trial.element_sum() / 3.0);
            let returned = strains(elastic);
            let gap = (returned - trial_deviator * (expected / trial_deviator.length()))
                .abs()
                .max_element();
            assert!(
                gap < 1e-3 * radius,
                "case {k}: returned {returned}, trial {trial_deviator}"
            );
            let s = kirchhoff_stress(&mat, elastic, plastic);
            let squares: f32 = s.to_cols_array().iter().map(|x| x * x).sum();
            let shear = (0.5 * squares).sqrt();
            assert!(
                (shear - times.min(1.0) * tau).abs() < 2e-3 * tau,
                "case {k}: equivalent shear stress {shear} Pa, {times} of tau_y = {tau}"
            );
            assert!(
                (s.x_axis.x + s.y_axis.y + s.z_axis.z).abs() < 1e-3 * tau,
                "case {k}: the elastic part's stress has a trace"
            );
        }
    }

    /// The stress a return mapping gives from its own decomposition is the stress of what it
    /// returns, decomposed again: snow (within and past its limits, hardened at the returned J_p),
    /// sand (inside the cone, on it, at the tip, with and without cohesion) and a yield-stress
    /// liquid's elastic part, over random deformations up to 30 % strain: within 1e-6 of the
    /// (hardened) stiffness.
    #[test]
    fn a_return_s_stress_is_the_stress_of_what_it_returns() {
        let mut cohesive = solid(LAW_SAND);
        cohesive.cohesion = 0.01;
        let liquid = Material {
            rest_density: 1000.0,
            law: LAW_HERSCHEL_BULKLEY,
            shear_modulus: 1.0e5,
            yield_stress: 800.0,
            ..Default::default()
        };
        let mut rng = Xorshift(0x51ab_0ff5);
        for mat in [solid(LAW_SNOW), solid(LAW_SAND), cohesive, liquid] {
            for k in 0..200 {
                let eps = Vec3::new(rng.next(), rng.next(), rng.next()) * [0.003, 0.03, 0.3][k % 3];
                let f = with_strains(&mut rng, eps);
                let plastic = if mat.law == LAW_SNOW {
                    1.0 + 0.1 * rng.next()
                } else {
                    rest_plastic(mat.law)
                };
                let (elastic, returned, tau) = plastic_return_with_stress(&mat, f, plastic);
                let tau = tau.expect("a law with a return mapping gives its stress");
                let again = kirchhoff_stress(&mat, elastic, returned);
                // Rounding of the decompositions, a few 1e-7 of F, times the stiffness (fixed-corotated's
                // (F - R) F^T cancels, so its error is not relative to the stress).
                let stiffness = (2.0 * mat.shear_modulus + 3.0 * mat.lame_lambda)
                    * super::hardening(mat.law, mat.hardening, returned)
                    * largest(f).powi(2).max(1.0);
                assert!(
                    largest(tau - again) <= 1e-6 * stiffness,
                    "law {} case {k}: {tau} against {again}",
                    mat.law
                );
            }
        }
        assert!(
            plastic_return_with_stress(&solid(LAW_FIXED_COROTATED), Mat3::IDENTITY, 0.0)
                .2
                .is_none()
        );
    }

    #[test]
    fn every_law_is_stress_free_and_unchanged_at_rest() {
        for law in SOLID_LAWS {
            let mat = solid(law);
            let plastic = rest_plastic(law);
            assert_eq!(
                kirchhoff_stress(&mat, Mat3::IDENTITY, plastic),
                Mat3::ZERO,
                "law {law}"
            );
            assert_eq!(
                plastic_return(&mat, Mat3::IDENTITY, plastic),
                (Mat3::IDENTITY, plastic),
                "law {law}"
            );
        }
    }

    #[test]
    fn small_strains_give_linear_elasticity() {
        let mut rng = Xorshift(41);
        for k in 0..50 {
            // A small symmetric strain, F = I + eps.
            let a = rng.matrix() * 1e-3;
            let eps = (a + a.transpose()) * 0.5;
            let f = Mat3::IDENTITY + eps;
            for law in [LAW_FIXED_COROTATED, LAW_NEO_HOOKEAN, LAW_SNOW, LAW_SAND] {
                let mat = solid(law);
                let trace = eps.x_axis.x + eps.y_axis.y + eps.z_axis.z;
                let linear = eps * (2.0 * mat.shear_modulus) + Mat3::IDENTITY * (mat.lame_lambda * trace);
                let tau = kirchhoff_stress(&mat, f, rest_plastic(law));
                // The laws differ from the linear one at second order, |eps|^2 ~ 1e-6, against a
                // stress of order |eps| ~ 1e-3.
                let error = largest(tau - linear) / largest(linear);
                assert!(
                    error <= 1e-2,
                    "law {law}, strain {k}: {error:e}\n{tau:?}\n{linear:?}"
                );
            }
            let corotated = kirchhoff_stress(&solid(LAW_FIXED_COROTATED), f, 0.0);
            let neo_hookean = kirchhoff_stress(&solid(LAW_NEO_HOOKEAN), f, 0.0);
            assert!(largest(corotated - neo_hookean) <= 1e-2 * largest(corotated));
        }
    }

    #[test]
    fn the_stresses_are_objective() {
        let mut rng = Xorshift(43);
        for law in SOLID_LAWS {
            let mat = solid(law);
            // A pure rotation strains nothing: no stress (to rounding of mu).
            for _ in 0..20 {
                let tau = kirchhoff_stress(&mat, rng.rotation(), rest_plastic(law));
                assert!(largest(tau) <= 1e-5 * mat.shear_modulus, "law {law}: {tau:?}");
            }
            // Rotating a deformed body rotates its stress: tau(R F) = R tau(F) R^T.
            for _ in 0..20 {
                let f = with_strains(&mut rng, Vec3::new(0.05, -0.02, -0.04));
                let r = rng.rotation();
                let (tau, rotated) = (
                    kirchhoff_stress(&mat, f, rest_plastic(law)),
                    kirchhoff_stress(&mat, r * f, rest_plastic(law)),
                );
                assert!(
                    largest(rotated - r * tau * r.transpose()) <= 1e-4 * largest(tau),
                    "law {law}"
                );
                // And the stress is symmetric.
                assert!(largest(tau - tau.transpose()) <= 1e-5 * largest(tau), "law {law}");
            }
        }
    }

    #[test]
    fn elastic_laws_keep_their_deformation() {
        let mut rng = Xorshift(47);
        for law in [LAW_FIXED_COROTATED, LAW_NEO_HOOKEAN] {
            for _ in 0..10 {
                let f = Mat3::IDENTITY + rng.matrix() * 0.5;
                assert_eq!(plastic_return(&solid(law), f, 0.25), (f, 0.25));
            }
        }
    }

    #[test]
    fn an_inverted_element_has_finite_stress() {
        let inverted = Mat3::from_diagonal(Vec3::new(1.0, 1.0, -0.5));
        let flat = Mat3::from_diagonal(Vec3::new(1.0, 1.0, 0.0));
        for law in SOLID_LAWS {
            for f in [inverted, flat] {
                let tau = kirchhoff_stress(&solid(law), f, rest_plastic(law));
                assert!(tau.is_finite(), "law {law}: {tau:?}");
            }
        }
        // Fixed-corotated pushes an inverted element back out along the inverted axis.
        let tau = kirchhoff_stress(&solid(LAW_FIXED_COROTATED), inverted, 0.0);
        assert!(tau.z_axis.z > 0.0, "{tau:?}");
    }

    #[test]
    fn snow_clamps_its_singular_values_and_keeps_the_volume_in_j_p() {
        let mut rng = Xorshift(53);
        let mat = solid(LAW_SNOW);
        let (lowest, highest) = (1.0 - mat.critical_compression, 1.0 + mat.critical_stretch);
        for k in 0..50 {
            let values = Vec3::new(
                1.0 + 0.05 * rng.next(),
                1.0 + 0.05 * rng.next(),
                1.0 + 0.05 * rng.next(),
            );
            let f_trial = rng.rotation() * Mat3::from_diagonal(values) * rng.rotation();
            let j_p = 1.0 + 0.1 * rng.next();
            let (f_e, new_j_p) = plastic_return(&mat, f_trial, j_p);
            let (_, sigma, _) = svd3(f_e);
            let tolerance = 1e-5;
            assert!(
                sigma.min_element() >= lowest - tolerance && sigma.max_element() <= highest + tolerance,
                "{k}: {sigma:?} outside [{lowest}, {highest}]"
            );
            // Where a singular value was inside the limits it is kept.
            let (_, trial_sigma, _) = svd3(f_trial);
            for i in 0..3 {
                let expected = trial_sigma[i].clamp(lowest, highest);
                assert!(
                    (sigma[i] - expected).abs() <= tolerance,
                    "{k}: {sigma:?} from {trial_sigma:?}"
                );
            }
            // What the clamp took from F_E's volume went to J_p.
            let before = j_p * f_trial.determinant();
            let after = new_j_p * f_e.determinant();
            assert!(
                (after - before).abs() <= 1e-5 * before.abs(),
                "{k}: {after} against {before}"
            );
        }
        // Within the limits, nothing changes, bit for bit.
        let inside = Mat3::from_diagonal(Vec3::new(1.005, 0.99, 0.98));
        assert_eq!(plastic_return(&mat, inside, 0.9), (inside, 0.9));
    }

    #[test]
    fn compressed_snow_hardens() {
        let mat = solid(LAW_SNOW);
        // Squeezed 10 % on one axis, past theta_c: most of it becomes plastic, J_p < 1.
        let f_trial = Mat3::from_diagonal(Vec3::new(1.0, 1.0, 0.9));
        let (f_e, j_p) = plastic_return(&mat, f_trial, 1.0);
        assert!(j_p < 1.0 && (j_p - 0.9 / 0.975).abs() <= 1e-6, "{j_p}");
        let hardening = (mat.hardening * (1.0 - j_p)).exp();
        assert!(hardening > 1.0);
        // The stress of the same elastic part is hardening times larger, and so is the wave speed
        // squared.
        let (hard, soft) = (kirchhoff_stress(&mat, f_e, j_p), kirchhoff_stress(&mat, f_e, 1.0));
        assert!(largest(hard - soft * hardening) <= 1e-5 * largest(hard));
        let speed = |j_p| solid_wave_speed(&mat, j_p);
        assert!((speed(j_p) / speed(1.0) - hardening.sqrt()).abs() <= 1e-5);
        // Stretched snow softens.
        let (_, stretched) = plastic_return(&mat, Mat3::from_diagonal(Vec3::new(1.1, 1.0, 1.0)), 1.0);
        assert!(stretched > 1.0 && speed(stretched) < speed(1.0));
    }

    #[test]
    fn the_wave_speed_is_the_p_wave_s() {
        for law in SOLID_LAWS {
            let mat = solid(law);
            let expected = ((mat.lame_lambda + 2.0 * mat.shear_modulus) / mat.rest_density).sqrt();
            let speed = solid_wave_speed(&mat, rest_plastic(law));
            assert!((speed - expected).abs() <= 1e-6 * expected, "law {law}");
        }
    }

    #[test]
    fn expanded_sand_goes_to_the_tip_and_keeps_the_volume_it_gained() {
        let mat = solid(LAW_SAND);
        let mut rng = Xorshift(59);
        for k in 0..20 {
            // Expansion with some shear: the trace of the Hencky strain is positive.
            let eps = Vec3::new(0.05, 0.02, -0.01) + Vec3::splat(0.01 * rng.next());
            let f = with_strains(&mut rng, eps);
            let (f_e, gained) = plastic_return(&mat, f, 0.0);
            // F_E = U V^T: a rotation, unstrained.
            assert!(
                largest(f_e * f_e.transpose() - Mat3::IDENTITY) <= 1e-5,
                "{k}: {f_e:?}"
            );
            assert!((gained - eps.element_sum()).abs() <= 1e-5, "{k}: {gained}");
            let tau = kirchhoff_stress(&mat, f_e, gained);
            assert!(largest(tau) <= 1e-5 * mat.shear_modulus, "{k}: {tau:?}");
        }
        // Isotropic expansion, then a compression smaller than the gain: the gaps close, still at
        // the tip, stress-free.
        let (f_e, gained) = plastic_return(&mat, Mat3::IDENTITY * 1.1, 0.0);
        assert_eq!(f_e, Mat3::IDENTITY);
        assert!((gained - 3.0 * 1.1f32.ln()).abs() <= 1e-6);
        let (f_e, left) = plastic_return(&mat, Mat3::IDENTITY * 0.97, gained);
        assert_eq!(f_e, Mat3::IDENTITY);
        assert!((left - (gained + 3.0 * 0.97f32.ln())).abs() <= 1e-6, "{left}");
        // Compressed past the gain: what is left of the compression is elastic, and v is spent.
        let (f_e, spent) = plastic_return(&mat, Mat3::IDENTITY * 0.9, left);
        assert_eq!(spent, 0.0);
        let trace = strains(f_e).element_sum();
        assert!((trace - (left + 3.0 * 0.9f32.ln())).abs() <= 1e-5, "{trace}");
        assert!(kirchhoff_stress(&mat, f_e, spent).x_axis.x < 0.0);
    }

    #[test]
    fn sheared_sand_is_projected_onto_the_cone() {
        let mat = solid(LAW_SAND);
        let (mu, lambda, alpha) = (mat.shear_modulus, mat.lame_lambda, mat.friction_alpha);
        let slope = alpha * (3.0 * lambda + 2.0 * mu) / (2.0 * mu);
        let mut rng = Xorshift(61);
        for k in 0..50 {
            // Compressed (trace -0.03) and sheared by 0.05 to 0.1, far outside the cone of radius
            // slope * 0.03 = 0.016.
            let shear = 0.05 + 0.05 * rng.next().abs();
            let deviator = Vec3::new(shear, -0.4 * shear, -0.6 * shear);
            let eps = deviator + Vec3::splat(-0.01);
            let (_, trace) = deviator_and_trace(eps);
            let f = with_strains(&mut rng, eps);
            let (f_e, plastic) = plastic_return(&mat, f, 0.0);
            assert_eq!(plastic, 0.0);
            let (new_deviator, new_trace) = deviator_and_trace(strains(f_e));
            assert!(
                (new_trace - trace).abs() <= 1e-5,
                "{k}: the trace moved from {trace} to {new_trace}"
            );
            assert!(
                (new_deviator + slope * trace).abs() <= 1e-5,
                "{k}: |eps_hat| = {new_deviator}, the cone's {}",
                -slope * trace
            );
            // Projected along the deviator itself: the principal strains keep their proportions.
            let direction = (strains(f_e) - Vec3::splat(new_trace / 3.0)) / new_deviator;
            let expected = deviator / deviator.length();
            let mut sorted = expected.to_array();
            sorted.sort_by(|a, b| b.total_cmp(a));
            assert!(
                (direction - Vec3::from_array(sorted)).length() <= 1e-3,
                "{k}: {direction:?}"
            );
        }
    }

    #[test]
    fn sand_inside_its_cone_is_unchanged() {
        let mat = solid(LAW_SAND);
        let mut rng = Xorshift(67);
        for _ in 0..20 {
            // Compressed by 0.03, sheared by 0.005: well inside the cone of radius 0.016.
            let f = with_strains(&mut rng, Vec3::new(-0.005, -0.01, -0.015));
            assert_eq!(plastic_return(&mat, f, 0.0), (f, 0.0));
        }
        // Sheared at no pressure, cohesionless sand holds nothing: to the tip.
        let (f_e, _) = plastic_return(&mat, with_strains(&mut rng, Vec3::new(0.01, 0.0, -0.01)), 0.0);
        assert!(largest(f_e * f_e.transpose() - Mat3::IDENTITY) <= 1e-5, "{f_e:?}");
        // Inverted, inside the cone: rebuilt the right way round, with the same stress.
        let inverted = Mat3::from_diagonal(Vec3::new(0.99, 0.98, -0.97));
        let (f_e, _) = plastic_return(&mat, inverted, 0.0);
        assert!(
            largest(f_e - Mat3::from_diagonal(Vec3::new(0.99, 0.98, 0.97))) <= 1e-6,
            "{f_e:?}"
        );
        let (before, after) = (
            kirchhoff_stress(&mat, inverted, 0.0),
            kirchhoff_stress(&mat, f_e, 0.0),
        );
        assert!(largest(after - before) <= 1e-5 * largest(before));
    }

    #[test]
    fn cohesive_sand_bears_tension_up_to_its_cohesion() {
        let mut mat = solid(LAW_SAND);
        mat.cohesion = 0.01;
        let mut rng = Xorshift(71);
        // Stretched by a trace 0.006 with a little shear: inside the shifted cone, unchanged, under
        // tension.
        let f = with_strains(&mut rng, Vec3::new(0.0025, 0.002, 0.0015));
        assert_eq!(plastic_return(&mat, f, 0.0), (f, 0.0));
        let tau = kirchhoff_stress(&mat, f, 0.0);
        assert!(tau.x_axis.x + tau.y_axis.y + tau.z_axis.z > 0.0);
        // Stretched past the cohesion: held at the tip, the isotropic tension of a trace c.
        let (f_e, gained) = plastic_return(&mat, Mat3::IDENTITY * 1.02, 0.0);
        let tip = (mat.cohesion / 3.0).exp();
        assert!(largest(f_e - Mat3::IDENTITY * tip) <= 1e-6, "{f_e:?}");
        assert!((gained - (3.0 * 1.02f32.ln() - mat.cohesion)).abs() <= 1e-6);
        let tension = kirchhoff_stress(&mat, f_e, gained);
        let expected = 2.0 * mat.shear_modulus * mat.cohesion / 3.0 + mat.lame_lambda * mat.cohesion;
        assert!(
            (tension.x_axis.x - expected).abs() <= 1e-4 * expected,
            "{tension:?} {expected}"
        );
        // And the cone's radius grows by the cohesion: sheared at no pressure, projected onto a cone
        // of radius slope * c.
        let slope = mat.friction_alpha * (3.0 * mat.lame_lambda + 2.0 * mat.shear_modulus)
            / (2.0 * mat.shear_modulus);
        let (f_e, _) = plastic_return(&mat, with_strains(&mut rng, Vec3::new(0.05, 0.0, -0.05)), 0.0);
        let (deviator, trace) = deviator_and_trace(strains(f_e));
        assert!(
            trace.abs() <= 1e-5 && (deviator - slope * mat.cohesion).abs() <= 1e-5,
            "{deviator} {trace}"
        );
    }
}
