//! The singular value decomposition of a 3x3 matrix, F = U Sigma V^T, as the solid laws need it
//! (src/sim/solid.rs): the "rotation variant" of MPM, where U and V are rotations (determinant +1)
//! and the smallest singular value carries the sign of det F, so an inverted element stays visible
//! to the laws instead of hiding in a reflection. Singular values come sorted by magnitude,
//! largest first. The twin of kernels/svd.cuh, operation for operation.
//!
//! The structure is McAdams et al. 2011, "Computing the singular value decomposition of 3x3
//! matrices with minimal branching and elementary floating point operations": a fixed number of
//! cyclic Jacobi sweeps on the symmetric F^T F give V, V's columns are sorted by the lengths of the
//! columns of F V, and a Givens QR of F V gives U and Sigma. The QR, not U = F V / Sigma, makes U
//! orthonormal where singular values repeat or vanish. Two changes:
//!
//! - Every rotation is exact (a square root and divisions, no approximate reciprocal square roots),
//!   so that this and the kernels round alike but for the fused multiply-adds NVRTC contracts.
//! - The Jacobi sweeps are one-sided (Hestenes 1958): each rotation reads the entries of F^T F it
//!   needs from the columns of B = F V, rotated along with V, instead of from a copy of F^T F
//!   rotated on its own. The rotations are the same, but F^T F held as such carries rounding of
//!   eps |F|^2, which at singular values 1e4 : 1 : 1 leaves the two small ones' vectors mixed:
//!   B's columns came out up to 5e-5 |F| from orthogonal, the QR's dropped off-diagonal. Read from B, the
//!   residual stays at 1e-6 |F| (`ill_conditioned_matrices_decompose`). It also costs fewer
//!   operations: no F^T F to form, and no F V to multiply out after the sweeps.
//!
//! Matrices are held as `[[f32; 3]; 3]` indexed `[column][row]`, the kernels' layout and glam's
//! (`Mat3::to_cols_array_2d`), so each loop here reads as its twin's.

use glam::{Mat3, Vec3};

/// Cyclic Jacobi sweeps, three rotations each. Exact rotations converge quadratically: on the
/// tests' matrices (random, near the identity, clustered and 1e4 : 1 singular values) the largest
/// residual |U Sigma V^T - F| / |F| is 4e-2 after two sweeps, 2e-6 after three and 7e-7, rounding,
/// after four; more sweeps change it by their own rounding only (`four_sweeps_are_converged`).
pub const JACOBI_SWEEPS: usize = 4;

/// A 3x3 matrix as `[column][row]`.
pub(crate) type Cols = [[f32; 3]; 3];

const IDENTITY: Cols = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// F = U Sigma V^T: (U, the diagonal of Sigma, V), U and V rotations, |sigma_0| >= |sigma_1| >=
/// |sigma_2|, sigma_0 and sigma_1 non-negative and sigma_2 of the sign of det F.
pub fn svd3(f: Mat3) -> (Mat3, Vec3, Mat3) {
    let (u, sigma, v) = svd3_cols(&f.to_cols_array_2d());
    (
        Mat3::from_cols_array_2d(&u),
        Vec3::from_array(sigma),
        Mat3::from_cols_array_2d(&v),
    )
}

/// The rotation of the polar decomposition F = R S, R = U V^T (`svd_polar` in kernels/svd.cuh).
/// With the rotation variant R is a rotation even where det F < 0: fixed-corotated elasticity pulls
/// an inverted element back through its rest shape rather than towards a mirror image of it.
pub fn polar(f: Mat3) -> Mat3 {
    let (u, _, v) = svd3_cols(&f.to_cols_array_2d());
    Mat3::from_cols_array_2d(&times_transpose(&u, &v))
}

/// A B^T, `[column][row]`: (A B^T)_rc = sum_k A_rk B_ck.
pub(crate) fn times_transpose(a: &Cols, b: &Cols) -> Cols {
    let mut out = [[0.0; 3]; 3];
    for (c, column) in out.iter_mut().enumerate() {
        for (r, entry) in column.iter_mut().enumerate() {
            *entry = a[0][r] * b[0][c] + a[1][r] * b[1][c] + a[2][r] * b[2][c];
        }
    }
    out
}

/// 2^e as a float, for e in [-126, 127].
fn power_of_two(e: i32) -> f32 {
    f32::from_bits(((127 + e) as u32) << 23)
}

/// [`svd3`] of and into `[column][row]` arrays, for the laws that compute as their kernels do
/// (src/sim/solid.rs).
pub(crate) fn svd3_cols(f: &Cols) -> (Cols, [f32; 3], Cols) {
    svd3_sweeps(f, JACOBI_SWEEPS)
}

fn svd3_sweeps(f: &Cols, sweeps: usize) -> (Cols, [f32; 3], Cols) {
    // F is scaled by a power of two that brings its largest entry into [1, 2): exact, so matrices
    // already there (deformation gradients) decompose bit for bit as they would unscaled, while the
    // dot products of a tiny or huge F's columns neither underflow (leaving V = I and a QR that is
    // not diagonal) nor overflow. The exponent is clamped so that both 2^-e and 2^e are normal floats.
    let mut largest = 0.0f32;
    for column in f {
        for entry in column {
            largest = largest.max(entry.abs());
        }
    }
    if largest == 0.0 {
        return (IDENTITY, [0.0; 3], IDENTITY);
    }
    let exponent = (((largest.to_bits() >> 23) & 0xff) as i32 - 127).clamp(-126, 126);
    let (down, up) = (power_of_two(-exponent), power_of_two(exponent));
    let f = f.map(|column| column.map(|entry| entry * down));

    // B = F V from V = I: the sweeps rotate B's columns with V's, so B = F V throughout.
    let mut b = f;
    let mut v = IDENTITY;
    for _ in 0..sweeps {
        jacobi(&mut b, &mut v, 0, 1);
        jacobi(&mut b, &mut v, 0, 2);
        jacobi(&mut b, &mut v, 1, 2);
    }

    // B's columns' squared lengths are F^T F's eigenvalues.
    let mut rho = [dot(&b, 0, 0), dot(&b, 1, 1), dot(&b, 2, 2)];
    sort_pair(&mut b, &mut v, &mut rho, 0, 1);
    sort_pair(&mut b, &mut v, &mut rho, 0, 2);
    sort_pair(&mut b, &mut v, &mut rho, 1, 2);

    // B = Q R by Givens rotations, zeroing below the diagonal column by column: R's diagonal is
    // Sigma (the off-diagonal entries are what V's error left, at rounding) and U = Q.
    let mut u = IDENTITY;
    givens(&mut b, &mut u, 0, 1, 0);
    givens(&mut b, &mut u, 0, 2, 0);
    givens(&mut b, &mut u, 1, 2, 1);
    (u, [b[0][0] * up, b[1][1] * up, b[2][2] * up], v)
}

/// Column i of B dotted with column j.
fn dot(b: &Cols, i: usize, j: usize) -> f32 {
    b[i][0] * b[j][0] + b[i][1] * b[j][1] + b[i][2] * b[j][2]
}

/// One Jacobi rotation J in the (p, q) plane, p < q, zeroing S_pq of S = B^T B: B <- B J, V <- V J,
/// with J_pp = J_qq = c, J_pq = s, J_qp = -s and t = s / c the root of t^2 + 2 theta t - 1 = 0
/// smaller in magnitude, theta = (S_qq - S_pp) / (2 S_pq) (Numerical Recipes, "Jacobi
/// transformations of a symmetric matrix"): the rotation of at most 45 degrees, which keeps the
/// sweeps convergent. t is computed from d = S_qq - S_pp and
/// 2 S_pq divided by the larger of them, so that no square underflows where both are at rounding.
fn jacobi(b: &mut Cols, v: &mut Cols, p: usize, q: usize) {
    let s_pq = dot(b, p, q);
    if s_pq == 0.0 {
        return;
    }
    let d = dot(b, q, q) - dot(b, p, p);
    let twice = 2.0 * s_pq;
    let scale = d.abs().max(twice.abs());
    let (dn, an) = (d / scale, twice / scale);
    let root = (dn * dn + an * an).sqrt();
    let t = (if d >= 0.0 { an } else { -an }) / (dn.abs() + root);
    let c = 1.0 / (1.0 + t * t).sqrt();
    let sn = t * c;
    let (bp, bq, vp, vq) = (b[p], b[q], v[p], v[q]);
    b[p] = std::array::from_fn(|i| c * bp[i] - sn * bq[i]);
    b[q] = std::array::from_fn(|i| sn * bp[i] + c * bq[i]);
    v[p] = std::array::from_fn(|i| c * vp[i] - sn * vq[i]);
    v[q] = std::array::from_fn(|i| sn * vp[i] + c * vq[i]);
}

/// Puts the longer of columns i < j of B first, moving V's columns with B's. The column moved back
/// is negated, which keeps det V = +1 (a plain swap would make V a reflection) and B = F V.
fn sort_pair(b: &mut Cols, v: &mut Cols, rho: &mut [f32; 3], i: usize, j: usize) {
    if rho[i] < rho[j] {
        rho.swap(i, j);
        for k in 0..3 {
            let (bi, vi) = (b[i][k], v[i][k]);
            b[i][k] = b[j][k];
            b[j][k] = -bi;
            v[i][k] = v[j][k];
            v[j][k] = -vi;
        }
    }
}

/// The Givens rotation G in rows (p, q), p < q, that zeroes B_qk against B_pk: B <- G B, U <- U G^T,
/// G_pp = G_qq = c, G_pq = s, G_qp = -s, (c, s) = (B_pk, B_qk) / |(B_pk, B_qk)|, which leaves B_pk =
/// the length, non-negative: so are sigma_0 and sigma_1, and sigma_2 is left with det F's sign. A
/// zero pair needs no rotation. Scaled by the larger entry, as in `jacobi`.
fn givens(b: &mut Cols, u: &mut Cols, p: usize, q: usize, k: usize) {
    let (x, y) = (b[k][p], b[k][q]);
    let scale = x.abs().max(y.abs());
    if scale == 0.0 {
        return;
    }
    let (xn, yn) = (x / scale, y / scale);
    let length = (xn * xn + yn * yn).sqrt();
    let (c, sn) = (xn / length, yn / length);
    for column in b.iter_mut() {
        let (bp, bq) = (column[p], column[q]);
        column[p] = c * bp + sn * bq;
        column[q] = c * bq - sn * bp;
    }
    b[k][q] = 0.0;
    let (up, uq) = (u[p], u[q]);
    u[p] = std::array::from_fn(|i| c * up[i] + sn * uq[i]);
    u[q] = std::array::from_fn(|i| c * uq[i] - sn * up[i]);
}

#[cfg(test)]
pub(crate) mod tests {
    use super::{polar, svd3, svd3_sweeps, JACOBI_SWEEPS};
    use glam::{DMat3, Mat3, Quat, Vec3};

    /// A small deterministic generator (xorshift32): the same matrices on every machine.
    pub(crate) struct Xorshift(pub u32);

    impl Xorshift {
        /// Uniform in [-1, 1).
        pub fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            (self.0 >> 8) as f32 / (1u32 << 23) as f32 - 1.0
        }

        pub fn matrix(&mut self) -> Mat3 {
            Mat3::from_cols_array(&std::array::from_fn(|_| self.next()))
        }

        pub fn rotation(&mut self) -> Mat3 {
            let axis = Vec3::new(self.next(), self.next(), self.next() + 2.0).normalize();
            Mat3::from_quat(Quat::from_axis_angle(axis, 3.0 * self.next()))
        }
    }

    /// In f64, so that the tiny and huge matrices' squares neither underflow nor overflow.
    fn frobenius(m: Mat3) -> f32 {
        m.to_cols_array()
            .iter()
            .map(|&x| f64::from(x) * f64::from(x))
            .sum::<f64>()
            .sqrt() as f32
    }

    /// What `check` measured: the largest residual of the reconstruction relative to |F| (absolute
    /// for the zero matrix), and of U^T U - I and V^T V - I.
    #[derive(Default, Debug, Clone, Copy)]
    struct Errors {
        reconstruction: f32,
        orthonormality: f32,
    }

    impl Errors {
        fn max(self, other: Errors) -> Errors {
            Errors {
                reconstruction: self.reconstruction.max(other.reconstruction),
                orthonormality: self.orthonormality.max(other.orthonormality),
            }
        }
    }

    const TOLERANCE: f32 = 1e-5;

    /// Asserts every property of the rotation variant for `f` and returns the residuals.
    fn check(f: Mat3, what: &str) -> Errors {
        let (u, sigma, v) = svd3(f);
        let rebuilt =
            (u.as_dmat3() * DMat3::from_diagonal(sigma.as_dvec3()) * v.transpose().as_dmat3()).as_mat3();
        let norm = frobenius(f);
        let reconstruction = frobenius(rebuilt - f) / if norm > 0.0 { norm } else { 1.0 };
        let orthonormality = [u, v]
            .iter()
            .map(|m| frobenius(m.transpose() * *m - Mat3::IDENTITY))
            .fold(0.0, f32::max);
        assert!(
            reconstruction <= TOLERANCE,
            "{what}: |U S V^T - F| / |F| = {reconstruction:e}\nF = {f:?}\nU = {u:?}\nS = {sigma:?}\nV = {v:?}"
        );
        assert!(
            orthonormality <= TOLERANCE,
            "{what}: U or V not orthonormal ({orthonormality:e})\nU = {u:?}\nV = {v:?}"
        );
        for (name, m) in [("U", u), ("V", v)] {
            let det = m.determinant();
            assert!((det - 1.0).abs() <= TOLERANCE, "{what}: det {name} = {det}");
        }
        let slack = TOLERANCE * sigma.x.abs();
        assert!(
            sigma.x.abs() + slack >= sigma.y.abs() && sigma.y.abs() + slack >= sigma.z.abs(),
            "{what}: singular values out of order: {sigma:?}"
        );
        assert!(
            sigma.x >= 0.0 && sigma.y >= 0.0,
            "{what}: only the smallest may be negative: {sigma:?}"
        );
        let det = f.as_dmat3().determinant();
        if det.abs() > f64::from(TOLERANCE) * f64::from(norm).powi(3) {
            assert_eq!(
                sigma.z < 0.0,
                det < 0.0,
                "{what}: sigma_2 = {} against det F = {det}",
                sigma.z
            );
        }
        Errors {
            reconstruction,
            orthonormality,
        }
    }

    fn assert_singular_values(f: Mat3, expected: Vec3, what: &str) {
        let (_, sigma, _) = svd3(f);
        let scale = expected.abs().max_element().max(1.0);
        assert!(
            (sigma - expected).abs().max_element() <= TOLERANCE * scale,
            "{what}: singular values {sigma:?}, expected {expected:?}"
        );
    }

    #[test]
    fn the_identity_is_its_own_decomposition_exactly() {
        let (u, sigma, v) = svd3(Mat3::IDENTITY);
        assert_eq!((u, sigma, v), (Mat3::IDENTITY, Vec3::ONE, Mat3::IDENTITY));
        assert_eq!(polar(Mat3::IDENTITY), Mat3::IDENTITY);
    }

    #[test]
    fn near_identity_matrices_decompose() {
        let mut rng = Xorshift(0x9e37_79b9);
        for k in 0..200 {
            let f = Mat3::IDENTITY + rng.matrix() * 1e-6;
            check(f, &format!("near identity {k}"));
            // Singular values of I + E are 1 + O(|E|).
            let (_, sigma, _) = svd3(f);
            assert!((sigma - Vec3::ONE).abs().max_element() <= 4e-6, "{sigma:?}");
        }
    }

    #[test]
    fn repeated_singular_values_decompose() {
        let mut rng = Xorshift(7);
        for (values, name) in [
            (Vec3::splat(2.0), "2, 2, 2"),
            (Vec3::new(3.0, 1.0, 1.0), "3, 1, 1"),
            (Vec3::new(1.0, 3.0, 1.0), "1, 3, 1"),
            (Vec3::new(1.0, 1.0, 3.0), "1, 1, 3"),
            (Vec3::new(2.0, 2.0, 0.5), "2, 2, 0.5"),
        ] {
            let mut sorted = values.to_array();
            sorted.sort_by(|a, b| b.total_cmp(a));
            let sorted = Vec3::from_array(sorted);
            let diagonal = Mat3::from_diagonal(values);
            check(diagonal, name);
            assert_singular_values(diagonal, sorted, name);
            for k in 0..20 {
                let f = rng.rotation() * diagonal * rng.rotation();
                check(f, &format!("{name}, rotated {k}"));
                assert_singular_values(f, sorted, name);
            }
        }
    }

    #[test]
    fn rank_deficient_matrices_decompose() {
        let mut rng = Xorshift(11);
        let (_, zero, _) = svd3(Mat3::ZERO);
        assert_eq!(zero, Vec3::ZERO);
        check(Mat3::ZERO, "zero");
        for (values, name) in [
            (Vec3::new(2.0, 0.5, 0.0), "one zero"),
            (Vec3::new(0.0, 1.5, 0.0), "two zeros"),
            (Vec3::new(0.0, 0.0, 0.0), "three zeros"),
        ] {
            let diagonal = Mat3::from_diagonal(values);
            check(diagonal, name);
            for k in 0..20 {
                let f = rng.rotation() * diagonal * rng.rotation();
                check(f, &format!("{name}, rotated {k}"));
                let mut sorted = values.to_array();
                sorted.sort_by(|a, b| b.total_cmp(a));
                assert_singular_values(f, Vec3::from_array(sorted), name);
            }
        }
        // An outer product: rank one, and columns that are all parallel.
        let a = Vec3::new(0.3, -1.2, 0.8);
        let b = Vec3::new(-0.5, 0.1, 2.0);
        let outer = Mat3::from_cols(a * b.x, a * b.y, a * b.z);
        check(outer, "outer product");
        assert_singular_values(outer, Vec3::new(a.length() * b.length(), 0.0, 0.0), "outer");
    }

    #[test]
    fn reflections_put_the_sign_on_the_smallest_singular_value() {
        let mut rng = Xorshift(13);
        for values in [
            Vec3::new(1.0, 1.0, -1.0),
            Vec3::new(-1.0, 1.0, 1.0),
            Vec3::new(-2.0, 0.5, 1.0),
            Vec3::new(-1.0, -1.0, -1.0),
        ] {
            let diagonal = Mat3::from_diagonal(values);
            let mut sorted = values.abs().to_array();
            sorted.sort_by(|a, b| b.total_cmp(a));
            sorted[2] = -sorted[2];
            check(diagonal, &format!("{values:?}"));
            assert_singular_values(diagonal, Vec3::from_array(sorted), "reflection");
            for k in 0..20 {
                let f = rng.rotation() * diagonal * rng.rotation();
                check(f, &format!("{values:?} rotated {k}"));
                assert_singular_values(f, Vec3::from_array(sorted), "rotated reflection");
            }
        }
        // The polar rotation of a reflection is still a rotation.
        let r = polar(Mat3::from_diagonal(Vec3::new(1.0, 1.0, -1.0)));
        assert!((r.determinant() - 1.0).abs() <= TOLERANCE);
    }

    #[test]
    fn rotations_times_diagonals_give_back_their_factors() {
        let mut rng = Xorshift(17);
        for k in 0..50 {
            let (r, w) = (rng.rotation(), rng.rotation());
            let values = Vec3::new(2.0 + rng.next(), 1.0 + 0.4 * rng.next(), 0.3 + 0.2 * rng.next());
            let f = r * Mat3::from_diagonal(values) * w.transpose();
            check(f, &format!("rotated diagonal {k}"));
            let (u, sigma, v) = svd3(f);
            assert!(
                (sigma - values).abs().max_element() <= TOLERANCE * 3.0,
                "{sigma:?} {values:?}"
            );
            // Distinct singular values: each column is R's or W's, up to a sign shared by the pair.
            for i in 0..3 {
                let sign = u.col(i).dot(r.col(i)).signum();
                assert!((u.col(i) - sign * r.col(i)).length() <= 1e-4, "U column {i}");
                assert!((v.col(i) - sign * w.col(i)).length() <= 1e-4, "V column {i}");
            }
            // The polar rotation is R W^T itself.
            assert!(frobenius(polar(f) - r * w.transpose()) <= 1e-4);
        }
    }

    #[test]
    fn random_matrices_decompose() {
        let mut rng = Xorshift(0x1234_5678);
        let mut worst = Errors::default();
        for k in 0..5000 {
            let f = rng.matrix();
            worst = worst.max(check(f, &format!("random {k}")));
        }
        // Deformation gradients: near the identity, then stretched and sheared.
        for k in 0..2000 {
            let f = Mat3::IDENTITY + rng.matrix() * 0.3;
            worst = worst.max(check(f, &format!("deformation {k}")));
        }
        println!("random matrices: {worst:?}");
    }

    #[test]
    fn ill_conditioned_matrices_decompose() {
        let mut rng = Xorshift(19);
        let mut worst = Errors::default();
        for values in [
            Vec3::new(1e4, 1.0, 1.0),
            Vec3::new(1.0, 1.0, 1e-4),
            Vec3::new(1e4, 1e2, 1.0),
            Vec3::new(1.0, 1e-2, 1e-4),
            Vec3::new(1e4, 1.0, -1.0),
            Vec3::new(1e4, 1.3, 1.0),
            Vec3::new(1e4, 1e4 * (1.0 + 1e-3), 1.0),
        ] {
            for k in 0..400 {
                let f = rng.rotation() * Mat3::from_diagonal(values) * rng.rotation();
                worst = worst.max(check(f, &format!("{values:?} {k}")));
                // The largest singular value to rounding; the others relative to the largest only,
                // as F^T F squares the condition (McAdams et al. 2011).
                let (_, sigma, _) = svd3(f);
                let mut sorted = values.abs().to_array();
                sorted.sort_by(|a, b| b.total_cmp(a));
                let expected =
                    Vec3::from_array(sorted) * Vec3::new(1.0, 1.0, values.element_product().signum());
                assert!(
                    (sigma - expected).abs().max_element() <= TOLERANCE * sorted[0],
                    "{values:?} {k}: {sigma:?}"
                );
            }
        }
        println!("ill-conditioned matrices: {worst:?}");
    }

    #[test]
    fn tiny_and_huge_matrices_decompose() {
        let mut rng = Xorshift(23);
        for scale in [1e-30f32, 1e-12, 1e12, 1e30] {
            for k in 0..50 {
                let f = rng.matrix() * scale;
                check(f, &format!("scale {scale:e}, {k}"));
            }
        }
    }

    /// The chosen sweep count is converged: more sweeps only add the rounding of their rotations.
    /// Prints the residual after each count, which is how the count was chosen.
    #[test]
    fn four_sweeps_are_converged() {
        let mut rng = Xorshift(29);
        let matrices: Vec<Mat3> = (0..4000)
            .map(|k| match k % 4 {
                0 => rng.matrix(),
                1 => Mat3::IDENTITY + rng.matrix() * 1e-3,
                2 => {
                    let values = Vec3::new(1.0, 1.0 + 1e-3 * rng.next(), 0.5);
                    rng.rotation() * Mat3::from_diagonal(values) * rng.rotation()
                }
                _ => {
                    let values = Vec3::new(1e4, 1.0 + 0.3 * rng.next(), 1.0);
                    rng.rotation() * Mat3::from_diagonal(values) * rng.rotation()
                }
            })
            .collect();
        let mut by_sweeps = Vec::new();
        for sweeps in 2..=7 {
            let worst = matrices
                .iter()
                .map(|f| {
                    let (u, sigma, v) = svd3_sweeps(&f.to_cols_array_2d(), sweeps);
                    let (u, v) = (Mat3::from_cols_array_2d(&u), Mat3::from_cols_array_2d(&v));
                    frobenius(u * Mat3::from_diagonal(Vec3::from_array(sigma)) * v.transpose() - *f)
                        / frobenius(*f)
                })
                .fold(0.0f32, f32::max);
            println!("{sweeps} sweeps: largest |U S V^T - F| / |F| = {worst:e}");
            by_sweeps.push((sweeps, worst));
        }
        let at = |n: usize| by_sweeps.iter().find(|(s, _)| *s == n).unwrap().1;
        let more = (JACOBI_SWEEPS + 1..=7).map(at).fold(f32::INFINITY, f32::min);
        assert!(at(JACOBI_SWEEPS) <= 1e-6, "{by_sweeps:?}");
        assert!(at(JACOBI_SWEEPS) <= 1.5 * more, "{by_sweeps:?}");
    }
}
