//! A liquid's constitutive law on the CPU: the Tait equation of state with its pressure floor, the
//! viscosity as its law makes it of the shear rate, the viscous stress, and the sound speed the time
//! step follows (docs/physics.md). The twins of kernels/material.cuh, operation for operation, so
//! the reference and the kernels compute the same expressions: a new law changes these methods and
//! those functions, nothing else.

use super::params::Material;
use crate::contract::{
    LAW_CARREAU_YASUDA, LAW_HERSCHEL_BULKLEY, LAW_NEWTONIAN, LAW_POWER_LAW, VISCOUS_REST_VOLUME_FROM,
};
use glam::{Mat3, Vec3};

/// One row of a scene's material table: the law the solvers read and what the scene calls it.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedMaterial {
    pub name: String,
    /// Linear RGB in [0, 1].
    pub colour: [f32; 3],
    /// The rendered surface's absorption, a multiple of what its colour gives (`absorption` in
    /// the scene; 1 by default).
    pub absorption: f32,
    pub law: Material,
}

/// The rest density of the densest liquid among `materials`, kg/m^3 (0 where every one is a solid):
/// the most a rigid body's boundary band can hold ([`crate::sim::colliders::Dynamics::check_band_mass`]).
pub fn densest_liquid(materials: &[NamedMaterial]) -> f64 {
    materials
        .iter()
        .filter(|m| !m.law.is_solid())
        .map(|m| f64::from(m.law.rest_density))
        .fold(0.0, f64::max)
}

/// The largest `absorption` a scene may give a material: the liquid's colour then hides 95 % of
/// what is behind it within 1.2 cm.
pub const MAX_ABSORPTION: f32 = 100.0;

/// The colour of a material the scene gives none: water's blue, then a few that tell liquids apart.
pub fn default_colour(row: usize) -> [f32; 3] {
    const COLOURS: [[f32; 3]; 4] = [
        [0.10, 0.35, 0.80],
        [0.85, 0.60, 0.10],
        [0.45, 0.30, 0.15],
        [0.70, 0.10, 0.10],
    ];
    COLOURS[row % COLOURS.len()]
}

/// The substep's explicit viscous limit, dt <= VISCOUS_LIMIT rho0 dx^2 / mu: diffusion of momentum
/// over a cell in a substep, with the margin the quadratic stencil needs (docs/physics.md).
pub const VISCOUS_LIMIT: f32 = 1.0 / 6.0;

/// The materials of a scene, as every solver sees them (`Params::materials`).
pub trait MaterialTable {
    /// The rows in use.
    fn rows(&self) -> &[Material];

    /// Whether any row carries a deformation (a solid's, or an elastoviscoplastic liquid's): then
    /// every particle has one.
    fn has_deformation(&self) -> bool {
        self.rows().iter().any(Material::carries_deformation)
    }

    /// Whether the rest densities differ (`sim::params::gathers_volume`).
    fn several_densities(&self) -> bool {
        let rows = self.rows();
        rows.iter().any(|m| m.rest_density != rows[0].rest_density)
    }

    /// The largest sound speed at rest, m/s.
    fn fastest_sound_speed(&self) -> f32 {
        self.rows().iter().map(Material::sound_speed).fold(0.0, f32::max)
    }

    /// The largest substep the viscous limit allows at node spacing `dx`, s; infinite where no
    /// material has viscosity.
    fn viscous_dt(&self, dx: f32) -> f32 {
        self.rows()
            .iter()
            .map(|m| VISCOUS_LIMIT * m.rest_density * dx * dx / m.viscosity_ceiling())
            .fold(f32::INFINITY, f32::min)
    }

    /// The largest signal speed c(rho) + speed of any material, given the largest density and
    /// speed any particle reached. The solvers report the density in row 0's terms, rho_p rho0_0 /
    /// rho0_p ([`Material::reported_density`]): the most compressed particle's, whatever its material.
    fn signal_speed(&self, max_density: f32, speed: f32) -> f32 {
        let rows = self.rows();
        let first = rows[0].rest_density;
        rows.iter()
            .map(|m| {
                let rho = if m.rest_density == first {
                    max_density
                } else {
                    max_density / first * m.rest_density
                };
                m.signal_speed(rho, speed)
            })
            // A NaN (a diverged state) must reach the time-step policy: f32::max would drop it.
            .reduce(|a, b| if a.is_nan() || a >= b { a } else { b })
            .unwrap_or(0.0)
    }
}

impl MaterialTable for [Material] {
    fn rows(&self) -> &[Material] {
        self
    }
}

impl MaterialTable for super::params::Params {
    /// Row 0 at least: parameters made by hand (tests, tools) may leave the count at 0.
    fn rows(&self) -> &[Material] {
        &self.materials[..(self.material_count as usize).max(1)]
    }
}

impl Material {
    /// Whether the row is a solid's: its particles carry a deformation gradient and scatter the
    /// law's stress from it, with no equation of state.
    #[inline(always)]
    pub fn is_solid(&self) -> bool {
        super::solid::is_solid(self.law)
    }

    /// Whether the row is a Herschel-Bulkley liquid's with the elastic regularisation: its
    /// particles carry the elastic part of their deformation, whose deviatoric stress bears the
    /// yield stress (`solid::yield_return`), beside the liquid's pressure and its viscous stress
    /// K gammadot^(n - 1).
    #[inline(always)]
    pub fn is_elastoviscoplastic(&self) -> bool {
        self.law == LAW_HERSCHEL_BULKLEY && self.shear_modulus > 0.0
    }

    /// Whether the row's particles carry a deformation: a solid's or an elastoviscoplastic
    /// liquid's.
    #[inline(always)]
    pub fn carries_deformation(&self) -> bool {
        super::solid::carries_deformation(self.law, self.shear_modulus)
    }

    /// Row `index` of `params`' table (row 0 in a scene of one material, whatever the index).
    #[inline(always)]
    pub fn of(params: &super::params::Params, index: u8) -> &Material {
        if params.material_count > 1 {
            &params.materials[usize::from(index).min(crate::contract::MAX_MATERIALS as usize - 1)]
        } else {
            &params.materials[0]
        }
    }

    /// A particle's density `rho` as the solvers report it for the time step: in terms of row 0's
    /// rest density `first`, rho rho0_0 / rho0 (rho itself for row 0's rest density, bit for bit).
    #[inline(always)]
    pub fn reported_density(&self, rho: f32, first: f32) -> f32 {
        rho * (first / self.rest_density)
    }

    /// Tait pressure, clamped to the floor: p(rho) = max(p_min, k ((rho / rho0)^gamma - 1)).
    pub fn pressure(&self, rho: f32) -> f32 {
        let ratio = rho / self.rest_density;
        (self.eos_stiffness * (power(ratio, self.eos_power) - 1.0)).max(self.pressure_floor)
    }

    /// Cauchy stress sigma = -p I + mu (C + C^T) of a particle with affine velocity `c` at density
    /// `rho`, mu the viscosity it is scattered with ([`Material::scattered_viscosity`]).
    pub fn stress(&self, pressure: f32, c: Mat3, rho: f32) -> Mat3 {
        let viscosity = self.scattered_viscosity(c, rho);
        Mat3::from_diagonal(Vec3::splat(-pressure)) + (c + c.transpose()) * viscosity
    }

    /// Whether the liquid scatters its viscous stress with its rest volume m / rho0 where it reads
    /// less than its rest density, rather than with the volume m / rho it reads: every law but the
    /// Newtonian, and Newtonian liquids of [`VISCOUS_REST_VOLUME_FROM`] or more. A particle at a free
    /// surface, at a collider or in a thin thread reads less than its rest density because its
    /// stencil reaches past the liquid, not because the liquid has expanded; with the volume it
    /// reads, its viscous stress would count up to eight times over there, the film on a no-slip
    /// collider would shear too little at its foot, and a rope of honey (reading 0.12 of its rest
    /// density) would outrun the viscous limit on the substep. The pressure keeps the volume it
    /// reads. Thinner Newtonian liquids keep it for their viscous stress too: water's is far below
    /// its pressure, and every water scene keeps its results bit for bit (docs/physics.md, "The
    /// viscous stress's volume").
    #[inline(always)]
    pub fn viscous_at_rest_volume(&self) -> bool {
        self.law != LAW_NEWTONIAN || self.viscosity >= VISCOUS_REST_VOLUME_FROM
    }

    /// The viscosity a particle's stress is scattered with at density `rho`: the law's
    /// ([`Material::effective_viscosity`]), times rho / rho0 where the liquid scatters at its rest
    /// volume and reads less than its rest density (V mu = (m / rho) mu (rho / rho0) = (m / rho0)
    /// mu). kernels/material.cuh's `material_viscosity`, operation for operation.
    #[inline(always)]
    pub fn scattered_viscosity(&self, c: Mat3, rho: f32) -> f32 {
        let viscosity = self.effective_viscosity(c);
        if self.viscous_at_rest_volume() && rho < self.rest_density {
            viscosity * (rho / self.rest_density)
        } else {
            viscosity
        }
    }

    /// The viscosity at velocity gradient `c`: the constant one of a Newtonian liquid, else the law's
    /// at the shear rate [`shear_rate`], held within [min_viscosity, max_viscosity]. An
    /// elastoviscoplastic liquid's yield stress is its elastic part's, not its viscosity's: it
    /// takes K gammadot^(n - 1) alone.
    pub fn effective_viscosity(&self, c: Mat3) -> f32 {
        if self.law == LAW_NEWTONIAN {
            return self.viscosity;
        }
        let rate = shear_rate(c);
        let n = self.flow_index;
        let viscosity = match self.law {
            LAW_POWER_LAW => self.viscosity * power(rate, n - 1.0),
            LAW_CARREAU_YASUDA => {
                let a = self.transition_exponent;
                let thinning = power(1.0 + power(self.relaxation_time * rate, a), (n - 1.0) / a);
                self.min_viscosity + (self.viscosity - self.min_viscosity) * thinning
            }
            LAW_HERSCHEL_BULKLEY => {
                let viscosity = self.viscosity * power(rate, n - 1.0);
                let yield_stress = if self.shear_modulus > 0.0 {
                    0.0
                } else {
                    self.yield_stress
                };
                if yield_stress > 0.0 {
                    viscosity + yield_stress / rate
                } else {
                    viscosity
                }
            }
            _ => self.viscosity,
        };
        viscosity.max(self.min_viscosity).min(self.max_viscosity)
    }

    /// The largest viscosity the law can take, Pa s: what the explicit viscous limit on the substep
    /// follows. An elastoviscoplastic Bingham liquid's (n = 1) is its constant K gammadot^0, held
    /// within [min_viscosity, max_viscosity] as [`Material::effective_viscosity`] holds it.
    pub fn viscosity_ceiling(&self) -> f32 {
        if self.is_solid() {
            return 0.0;
        }
        if self.law == LAW_NEWTONIAN {
            self.viscosity
        } else if self.is_elastoviscoplastic() && self.flow_index == 1.0 {
            self.viscosity.max(self.min_viscosity).min(self.max_viscosity)
        } else {
            self.max_viscosity
        }
    }

    /// Sound speed at rest, c0 = sqrt(k gamma / rho0); a solid's P-wave speed, sqrt((lambda + 2
    /// mu) / rho0), unhardened ([`super::solid::solid_wave_speed`] gives a particle's own); an
    /// elastoviscoplastic liquid's as [`Material::sound_speed_at`] says.
    pub fn sound_speed(&self) -> f32 {
        self.sound_speed_at(self.rest_density)
    }

    /// Sound speed at density `rho`: c0 (rho/rho0)^((gamma-1)/2), from dp/drho of the Tait law; a
    /// solid's whatever its density. An elastoviscoplastic liquid's elastic part stiffens it:
    /// sqrt(c^2 + 4 mu / (3 rho0)), the P-wave speed of bulk modulus rho0 c^2 and shear modulus mu
    /// (`material_elastic_signal_speed` in kernels/material.cuh).
    pub fn sound_speed_at(&self, rho: f32) -> f32 {
        if self.is_solid() {
            return ((self.lame_lambda + 2.0 * self.shear_modulus) / self.rest_density).sqrt();
        }
        let ratio = (rho / self.rest_density).max(0.0);
        let at_rest = (self.eos_stiffness * self.eos_power / self.rest_density).sqrt();
        let sound = at_rest * power(ratio, 0.5 * (self.eos_power - 1.0));
        if self.is_elastoviscoplastic() {
            (sound * sound + 4.0 * self.shear_modulus / (3.0 * self.rest_density)).sqrt()
        } else {
            sound
        }
    }

    /// The signal speed of the CFL bound, c(rho) + speed.
    pub fn signal_speed(&self, rho: f32, speed: f32) -> f32 {
        self.sound_speed_at(rho) + speed
    }
}

/// The shear rate gammadot = sqrt(2 D':D') of velocity gradient `c`, D' the deviatoric part of the
/// strain rate D = (C + C^T) / 2: the rate of shape change alone, so that the slight compression of
/// the weakly compressible liquid does not thin or thicken it.
pub fn shear_rate(c: Mat3) -> f32 {
    let third_trace = (c.x_axis.x + c.y_axis.y + c.z_axis.z) * (1.0 / 3.0);
    let (d0, d1, d2) = (
        c.x_axis.x - third_trace,
        c.y_axis.y - third_trace,
        c.z_axis.z - third_trace,
    );
    // Off the diagonal, D_ij = (C_ij + C_ji) / 2; C's column j holds C_ij in row i.
    let d01 = 0.5 * (c.y_axis.x + c.x_axis.y);
    let d02 = 0.5 * (c.z_axis.x + c.x_axis.z);
    let d12 = 0.5 * (c.z_axis.y + c.y_axis.z);
    let squares = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (d01 * d01 + d02 * d02 + d12 * d12);
    (2.0 * squares).sqrt()
}

/// `x^e` as kernels/material.cuh's `material_power` takes it: by squaring where `2e` is a whole
/// number up to 32 (water's `gamma = 7` and `(gamma - 1) / 2 = 3`), with a square root for a half,
/// `powf` otherwise. The same operations in the same order (IEEE multiplies and a correctly rounded
/// square root), so the reference and the kernels get the same bits.
pub fn power(x: f32, e: f32) -> f32 {
    let twice = 2.0 * e;
    if !((0.0..=32.0).contains(&twice) && twice == twice.floor()) {
        return x.powf(e);
    }
    let mut n = twice as u32;
    let mut result = if n & 1 == 1 { x.sqrt() } else { 1.0 };
    let mut base = x;
    n >>= 1;
    while n != 0 {
        if n & 1 == 1 {
            result *= base;
        }
        base *= base;
        n >>= 1;
    }
    result
}

#[cfg(test)]
mod tests {
    use super::{power, shear_rate, Material};
    use crate::contract::{
        LAW_CARREAU_YASUDA, LAW_HERSCHEL_BULKLEY, LAW_NEWTONIAN, LAW_POWER_LAW, VISCOUS_REST_VOLUME_FROM,
    };
    use glam::Mat3;

    /// Simple shear u_x = gamma y: C has the one entry C_xy = gamma (column y, row x).
    fn simple_shear(gamma: f32) -> Mat3 {
        let mut c = Mat3::ZERO;
        c.y_axis.x = gamma;
        c
    }

    fn law(law: u32, viscosity: f32, flow_index: f32) -> Material {
        Material {
            rest_density: 1000.0,
            eos_stiffness: 1.0e5,
            eos_power: 7.0,
            viscosity,
            law,
            flow_index,
            max_viscosity: f32::INFINITY,
            ..Default::default()
        }
    }

    fn assert_close(ours: f32, expected: f32, what: &str) {
        let tolerance = 1e-5 * expected.abs();
        assert!(
            (ours - expected).abs() <= tolerance,
            "{what}: {ours} against the closed form {expected}"
        );
    }

    const RATES: [f32; 5] = [0.01, 0.3, 1.0, 7.5, 200.0];

    #[test]
    fn simple_shear_has_the_shear_rate_of_its_one_entry() {
        for gamma in [-50.0f32, -0.2, 0.0, 1.0, 3.7, 1000.0] {
            assert_close(shear_rate(simple_shear(gamma)), gamma.abs(), "shear rate");
            // In any plane and either way round.
            let mut c = Mat3::ZERO;
            c.x_axis.z = gamma;
            assert_close(shear_rate(c), gamma.abs(), "shear rate, C_zx");
        }
        // A pure expansion (trace only) changes volume, not shape: no shear.
        assert_eq!(shear_rate(Mat3::from_diagonal(glam::Vec3::splat(4.0))), 0.0);
        // Planar extension u = (e x, -e y, 0): D' = diag(e, -e, 0), sqrt(2 D':D') = 2 e.
        let e = 1.5;
        assert_close(
            shear_rate(Mat3::from_diagonal(glam::Vec3::new(e, -e, 0.0))),
            2.0 * e,
            "extension",
        );
        // A rotation (antisymmetric C) deforms nothing.
        let mut spin = simple_shear(2.0);
        spin.x_axis.y = -2.0;
        assert!(shear_rate(spin) < 1e-6, "rotation: {}", shear_rate(spin));
    }

    #[test]
    fn newtonian_returns_its_viscosity_exactly_whatever_the_shear() {
        let mut water = law(LAW_NEWTONIAN, 1.0e-3, 1.0);
        // The clamps are not consulted: a Newtonian row's floor and ceiling do not change mu.
        water.min_viscosity = 5.0;
        water.max_viscosity = 1.0e-6;
        for gamma in [0.0f32, 1e-8, 1.0, 1e6] {
            assert_eq!(water.effective_viscosity(simple_shear(gamma)), 1.0e-3);
        }
        assert_eq!(water.viscosity_ceiling(), 1.0e-3);
    }

    #[test]
    fn power_law_follows_k_gamma_to_the_n_minus_one_within_its_clamps() {
        for n in [0.5f32, 1.5] {
            let m = law(LAW_POWER_LAW, 2.0, n);
            for gamma in RATES {
                let expected = 2.0 * gamma.powf(n - 1.0);
                assert_close(m.effective_viscosity(simple_shear(gamma)), expected, "power law");
            }
        }
        // Shear-thinning at rest: infinite, held at the ceiling; fast: held at the floor.
        let mut thinning = law(LAW_POWER_LAW, 2.0, 0.5);
        thinning.max_viscosity = 40.0;
        thinning.min_viscosity = 0.5;
        assert_eq!(thinning.effective_viscosity(Mat3::ZERO), 40.0);
        assert_eq!(thinning.effective_viscosity(simple_shear(1e-4)), 40.0); // 200 unclamped
        assert_eq!(thinning.effective_viscosity(simple_shear(100.0)), 0.5); // 0.2 unclamped
        assert_close(
            thinning.effective_viscosity(simple_shear(4.0)),
            1.0,
            "inside the clamps",
        );
        assert_eq!(thinning.viscosity_ceiling(), 40.0);
        // Shear-thickening at rest: zero, held at the floor.
        let mut thickening = law(LAW_POWER_LAW, 2.0, 1.5);
        thickening.min_viscosity = 0.1;
        thickening.max_viscosity = 8.0;
        assert_eq!(thickening.effective_viscosity(Mat3::ZERO), 0.1);
        assert_eq!(thickening.effective_viscosity(simple_shear(100.0)), 8.0); // 20 unclamped
    }

    #[test]
    fn carreau_yasuda_follows_its_closed_form() {
        let (mu0, mu_inf, lambda) = (10.0f32, 0.01f32, 0.5f32);
        for (n, a) in [(0.4f32, 2.0f32), (0.6, 1.3)] {
            let mut m = law(LAW_CARREAU_YASUDA, mu0, n);
            m.min_viscosity = mu_inf;
            m.max_viscosity = mu0;
            m.relaxation_time = lambda;
            m.transition_exponent = a;
            for gamma in RATES {
                let expected = mu_inf + (mu0 - mu_inf) * (1.0 + (lambda * gamma).powf(a)).powf((n - 1.0) / a);
                assert_close(
                    m.effective_viscosity(simple_shear(gamma)),
                    expected,
                    "Carreau-Yasuda",
                );
            }
            // At rest: the zero-shear viscosity; very fast: down towards mu_inf (within 3 mu_inf
            // at 1e7 1/s for these n and a), never below it.
            assert_eq!(m.effective_viscosity(Mat3::ZERO), mu0);
            let fast = m.effective_viscosity(simple_shear(1e7));
            assert!(fast >= mu_inf && fast < 4.0 * mu_inf, "{fast}");
        }
        // A ceiling below mu_0 holds.
        let mut capped = law(LAW_CARREAU_YASUDA, mu0, 0.4);
        capped.relaxation_time = lambda;
        capped.transition_exponent = 2.0;
        capped.max_viscosity = 3.0;
        assert_eq!(capped.effective_viscosity(Mat3::ZERO), 3.0);
    }

    #[test]
    fn herschel_bulkley_adds_the_yield_stress_over_the_rate_and_holds_the_ceiling() {
        let (k, tau) = (0.8f32, 50.0f32);
        for n in [1.0f32, 0.6] {
            let mut m = law(LAW_HERSCHEL_BULKLEY, k, n);
            m.yield_stress = tau;
            m.max_viscosity = 1.0e3;
            for gamma in [0.1f32, 1.0, 7.5, 200.0] {
                let expected = (k * gamma.powf(n - 1.0) + tau / gamma).min(1.0e3);
                assert_close(
                    m.effective_viscosity(simple_shear(gamma)),
                    expected,
                    "Herschel-Bulkley",
                );
            }
            // Below the rate tau / mu_max the bi-viscous ceiling holds (the "unyielded" branch),
            // at rest too (tau / 0 is infinite, never NaN).
            assert_eq!(m.effective_viscosity(simple_shear(0.01)), 1.0e3);
            assert_eq!(m.effective_viscosity(Mat3::ZERO), 1.0e3);
            assert_eq!(m.viscosity_ceiling(), 1.0e3);
            // The stress it carries in simple shear is tau_y + K gamma^n once yielded.
            let gamma = 20.0;
            let sigma = m.stress(0.0, simple_shear(gamma), m.rest_density);
            assert_close(sigma.y_axis.x, tau + k * gamma.powf(n), "shear stress");
        }
    }

    #[test]
    fn viscous_liquids_scatter_their_viscous_stress_at_their_rest_volume() {
        let shear = simple_shear(2.0);
        // Water keeps the volume it reads, bit for bit, at any density.
        let water = law(LAW_NEWTONIAN, 1.0e-3, 1.0);
        assert!(!water.viscous_at_rest_volume());
        for rho in [120.0, 620.0, 1000.0, 1040.0] {
            assert_eq!(water.scattered_viscosity(shear, rho), 1.0e-3);
        }
        // Honey, and every other law: mu rho / rho0 below the rest density, so V mu = (m / rho0) mu.
        let honey = law(LAW_NEWTONIAN, 10.0, 1.0);
        let thinning = law(LAW_POWER_LAW, 2.0, 0.5);
        for m in [honey, thinning] {
            assert!(m.viscous_at_rest_volume());
            let mu = m.effective_viscosity(shear);
            let rho0 = m.rest_density;
            assert_eq!(
                m.scattered_viscosity(shear, 0.12 * rho0),
                mu * (0.12 * rho0 / rho0)
            );
            assert_eq!(m.scattered_viscosity(shear, rho0), mu);
            assert_eq!(m.scattered_viscosity(shear, 1.04 * rho0), mu);
            let (volume_read, volume_rest) = (1.0 / (0.12 * rho0), 1.0 / rho0);
            assert_close(
                volume_read * m.scattered_viscosity(shear, 0.12 * rho0),
                volume_rest * mu,
                "the viscous stress's volume",
            );
        }
        // The threshold is the Newtonian viscosity's, inclusive.
        assert!(law(LAW_NEWTONIAN, VISCOUS_REST_VOLUME_FROM, 1.0).viscous_at_rest_volume());
    }

    #[test]
    fn the_viscous_limit_follows_the_stiffest_ceiling() {
        use super::MaterialTable;
        let honey = law(LAW_NEWTONIAN, 10.0, 1.0);
        let mut mud = law(LAW_HERSCHEL_BULKLEY, 1.0, 1.0);
        mud.yield_stress = 100.0;
        mud.max_viscosity = 40.0;
        let dx = 0.01f32;
        assert_close([honey].viscous_dt(dx), 1000.0 * dx * dx / (6.0 * 10.0), "honey");
        // The bi-viscous ceiling, not the consistency, limits the mud's substep.
        assert_close(
            [honey, mud].viscous_dt(dx),
            1000.0 * dx * dx / (6.0 * 40.0),
            "mud",
        );
        let inviscid = law(LAW_NEWTONIAN, 0.0, 1.0);
        assert_eq!([inviscid].viscous_dt(dx), f32::INFINITY);
    }

    /// An elastoviscoplastic Bingham liquid (n = 1, `shear_modulus`) needs no ceiling: the viscous
    /// limit follows its constant viscosity K, as the viewer's control changes it, within the floor
    /// and a ceiling where the scene gives them.
    #[test]
    fn an_elastic_bingham_liquid_s_ceiling_is_its_consistency() {
        let mut mud = Material {
            law: LAW_HERSCHEL_BULKLEY,
            shear_modulus: 1.0e5,
            yield_stress: 800.0,
            ..law(LAW_HERSCHEL_BULKLEY, 50.0, 1.0)
        };
        assert_eq!(mud.viscosity_ceiling(), 50.0);
        assert_eq!(mud.effective_viscosity(simple_shear(3.0)), 50.0);
        mud.viscosity = 80.0;
        assert_eq!(mud.viscosity_ceiling(), 80.0);
        mud.min_viscosity = 100.0;
        assert_eq!(mud.viscosity_ceiling(), 100.0);
        assert_eq!(mud.effective_viscosity(simple_shear(3.0)), 100.0);
        mud.max_viscosity = 60.0;
        assert_eq!(mud.viscosity_ceiling(), 60.0);
        // Its yield stress is the elastic part's: no tau_y / gammadot in its viscosity.
        mud.min_viscosity = 0.0;
        mud.max_viscosity = f32::INFINITY;
        assert_eq!(mud.effective_viscosity(simple_shear(0.01)), 80.0);
    }

    #[test]
    fn power_by_squaring_agrees_with_powf() {
        for e in [0.0f32, 0.5, 1.0, 2.5, 3.0, 7.0, 16.0] {
            for x in [0.0f32, 0.5, 0.97, 1.0, 1.03, 2.0, 10.0] {
                let (ours, reference) = (power(x, e), x.powf(e));
                let tolerance = 4.0 * f32::EPSILON * reference.abs().max(f32::MIN_POSITIVE);
                assert!(
                    (ours - reference).abs() <= tolerance,
                    "{x}^{e}: {ours} against powf's {reference}"
                );
            }
        }
        // Exponents that are not whole or half numbers, and beyond 16, take powf itself.
        for e in [0.3f32, 7.25, 16.5, -1.0] {
            assert_eq!(power(1.7, e), 1.7f32.powf(e));
        }
        assert!(power(f32::NAN, 7.0).is_nan());
    }
}
