//! The small dense linear algebra the equations of motion need: an LDLᵀ factorization of the
//! mass matrix over any [`Scalar`], so that the same solve also runs on dual numbers (AD Jacobians
//! of the accelerations) and a failing pivot is a typed error instead of a NaN.
//!
//! LDLᵀ rather than Cholesky: no square roots and one reciprocal per pivot, with the solve made of
//! multiplications only. For the small matrices of mechanics the factor-and-solve is a serial
//! chain of dependent operations, and each square root or division on it is ~15–20 cycles of
//! latency; LDLᵀ halves their number. The pivots d_j are the squares of Cholesky's diagonal, so
//! the checks (and the errors they return) are the same.

use crate::error::Error;
use crate::scalar::Scalar;
use std::ops::{Add, Mul, Sub};

/// Why a symmetric matrix could not be factored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FactorFailure {
    NonFinite,
    Singular,
    NotPositiveDefinite,
}

impl FactorFailure {
    pub(crate) fn reason(self) -> &'static str {
        match self {
            Self::NonFinite => "non-finite",
            Self::Singular => "singular",
            Self::NotPositiveDefinite => "not positive definite",
        }
    }
}

/// Pivots below this fraction of the largest diagonal entry count as zero.
pub(crate) const RELATIVE_PIVOT_FLOOR: f64 = 1e-13;

/// Whether [`ldlt_in_place`] accepts a matrix with this `diagonal` whose factorization has these
/// `pivots` d_j: every entry finite, every pivot positive and above the floor. For a solve
/// computed elsewhere (the compiled programs of small systems) that must fail exactly where the
/// factorization would.
#[cfg_attr(not(feature = "jit"), allow(dead_code))]
pub(crate) fn pivots_hold(pivots: &[f64], diagonal: &[f64]) -> bool {
    let mut scale = 0.0_f64;
    for &d in diagonal {
        if !d.is_finite() {
            return false;
        }
        scale = scale.max(d.abs());
    }
    let floor = RELATIVE_PIVOT_FLOOR * scale;
    scale > 0.0 && pivots.iter().all(|&d| d.is_finite() && d > floor)
}

/// Factor the row-major `n × n` symmetric positive definite matrix `a` in place as L D Lᵀ.
///
/// Only the lower triangle of `a` is read. Afterwards the strict lower triangle holds the unit
/// lower factor L, the diagonal holds the reciprocal pivots 1/d_j, and the strict upper triangle
/// holds the scratch products w_jk = L_jk d_k (k < j) of each row j, packed contiguously into
/// row n − 1 − j (see [`scratch`]); only [`ldlt_solve`] should read the result.
#[inline(always)]
pub(crate) fn ldlt_in_place<D: Scalar>(a: &mut [D], n: usize) -> Result<(), FactorFailure> {
    debug_assert_eq!(a.len(), n * n);
    let mut scale = 0.0_f64;
    for i in 0..n {
        let d = a[i * n + i].re();
        if !d.is_finite() {
            return Err(FactorFailure::NonFinite);
        }
        scale = scale.max(d.abs());
    }
    if n == 2 {
        return ldlt_2x2(a, scale);
    }
    for j in 0..n {
        // d_j = a_jj − Σ_k L_jk w_jk: row j of L and row j of the scratch, both contiguous.
        let wj = scratch(n, j);
        let d = a[j * n + j] - dot(&a[j * n..j * n + j], &a[wj..wj + j]);
        let dr = d.re();
        if !dr.is_finite() {
            return Err(FactorFailure::NonFinite);
        }
        if dr.abs() <= RELATIVE_PIVOT_FLOOR * scale || scale == 0.0 {
            return Err(FactorFailure::Singular);
        }
        if dr < 0.0 {
            return Err(FactorFailure::NotPositiveDefinite);
        }
        let inv = d.recip();
        a[j * n + j] = inv;
        for i in j + 1..n {
            // w_ij = L_ij d_j = a_ij − Σ_k L_ik w_jk.
            let w = a[i * n + j] - dot(&a[i * n..i * n + j], &a[wj..wj + j]);
            a[scratch(n, i) + j] = w;
            a[i * n + j] = w * inv;
        }
    }
    Ok(())
}

/// Where row j of the scratch products w_jk (k < j) starts in [`ldlt_in_place`]'s matrix: the
/// j entries of row n − 1 − j right of the diagonal, so that each row of w is contiguous like the
/// rows of L (read as a column of the upper triangle, one entry per row, it was most of the
/// factorization's time at n = 32).
#[inline(always)]
fn scratch(n: usize, j: usize) -> usize {
    (n - 1 - j) * n + (n - j)
}

/// x · y in four partial sums, so that the additions do not wait for each other.
#[inline(always)]
fn dot<F: Copy, D: Scalar + std::ops::Mul<F, Output = D>>(x: &[D], y: &[F]) -> D {
    let mut s = [D::zero(); 4];
    let (xs, ys) = (x.chunks_exact(4), y.chunks_exact(4));
    let (xr, yr) = (xs.remainder(), ys.remainder());
    for (x, y) in xs.zip(ys) {
        for l in 0..4 {
            s[l] += x[l] * y[l];
        }
    }
    for (&x, &y) in xr.iter().zip(yr) {
        s[0] += x * y;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// [`ldlt_in_place`] for n = 2 with its two divisions independent of each other: d₁ = det/a₀₀,
/// so 1/d₁ = a₀₀/det needs no 1/a₀₀ first and the two reciprocals overlap instead of queueing.
#[inline(always)]
fn ldlt_2x2<D: Scalar>(a: &mut [D], scale: f64) -> Result<(), FactorFailure> {
    let (a00, a10, a11) = (a[0], a[2], a[3]);
    let det = a00 * a11 - a10 * a10;
    let d0 = a00.re();
    if d0 <= RELATIVE_PIVOT_FLOOR * scale || scale == 0.0 {
        return Err(if d0 < 0.0 {
            FactorFailure::NotPositiveDefinite
        } else {
            FactorFailure::Singular
        });
    }
    let (r0, r1) = (a00.recip(), a00 / det);
    let d1 = det.re() / d0;
    if !d1.is_finite() {
        return Err(FactorFailure::NonFinite);
    }
    if d1.abs() <= RELATIVE_PIVOT_FLOOR * scale {
        return Err(FactorFailure::Singular);
    }
    if d1 < 0.0 {
        return Err(FactorFailure::NotPositiveDefinite);
    }
    a[0] = r0;
    a[1] = a10;
    a[2] = a10 * r0;
    a[3] = r1;
    Ok(())
}

/// Solve L D Lᵀ x = b in place, with `f` the factor from [`ldlt_in_place`]. `F` may be `f64`
/// (a factor computed once) while `b` carries dual numbers.
#[inline(always)]
pub(crate) fn ldlt_solve<F: Copy, D>(f: &[F], n: usize, b: &mut [D])
where
    D: Scalar + std::ops::Mul<F, Output = D>,
{
    // L y = b by rows of L, D z = y, then Lᵀ x = z by rows of L again (x_k, once known, is
    // taken out of every earlier entry): both read L row by row, contiguously.
    for i in 1..n {
        b[i] -= dot(&b[..i], &f[i * n..i * n + i]);
    }
    for i in 0..n {
        b[i] = b[i] * f[i * n + i];
    }
    for k in (1..n).rev() {
        let x = b[k];
        for (b, &l) in b[..k].iter_mut().zip(&f[k * n..k * n + k]) {
            *b -= x * l;
        }
    }
}

/// Which entries of the factor L of an n × n symmetric matrix (at i·n + j, j < i) may be
/// nonzero when the entries where `zero(i·n + j)` holds are zero by structure: such an entry
/// of L is zero unless some column k < j fills it in (L_ik L_jk ≠ 0). Entries on and above
/// the diagonal are `true`.
pub(crate) fn ldlt_pattern(n: usize, zero: impl Fn(usize) -> bool) -> Vec<bool> {
    let mut nonzero = vec![true; n * n];
    for i in 0..n {
        for j in 0..i {
            nonzero[i * n + j] =
                !zero(i * n + j) || (0..j).any(|k| nonzero[i * n + k] && nonzero[j * n + k]);
        }
    }
    nonzero
}

/// [`ldlt_solve`] without the products by the entries of L that `nonzero` (from
/// [`ldlt_pattern`]) says are zero: each row's other terms summed in `dot`'s lanes by their
/// rank among the terms kept (so the roundings may differ from `ldlt_solve`'s where a row is
/// partly zero; with every entry nonzero it is `ldlt_solve` bit for bit). Unrolled Taylor
/// expansions solve as this does (`taylor/kernel.rs`).
/// Generic over the entries, so that the batch expansions (`taylor/batch.rs`) solve several
/// runs' systems at once, lane by lane, in the same operations.
#[inline(always)]
pub(crate) fn ldlt_solve_pattern<T>(f: &[T], n: usize, nonzero: &[bool], b: &mut [T])
where
    T: Copy + Default + Add<Output = T> + Sub<Output = T> + Mul<Output = T>,
{
    for i in 1..n {
        let row = &nonzero[i * n..i * n + i];
        let count = row.iter().filter(|&&x| x).count();
        if count == 0 {
            continue;
        }
        // `dot`'s lanes over the terms kept: chunks of four, the rest into the first lane.
        let full = count / 4 * 4;
        let mut s = [T::default(); 4];
        for (m, j) in (0..i).filter(|&j| row[j]).enumerate() {
            let lane = if m < full { m % 4 } else { 0 };
            s[lane] = s[lane] + b[j] * f[i * n + j];
        }
        b[i] = b[i] - ((s[0] + s[1]) + (s[2] + s[3]));
    }
    for i in 0..n {
        b[i] = b[i] * f[i * n + i];
    }
    for k in (1..n).rev() {
        let x = b[k];
        for j in (0..k).filter(|&j| nonzero[k * n + j]) {
            b[j] = b[j] - x * f[k * n + j];
        }
    }
}

// The mass matrix's LDLᵀ with the typed errors of eq. 55 (t and q named).

/// Factor the row-major n × n mass matrix `m` in place as LDLᵀ (only [`solve_mass`] reads the result).
///
/// # Errors
/// [`Error::SingularMassMatrix`] with t and q when M is singular, not positive definite or not
/// finite.
#[inline(always)]
pub(crate) fn factor_mass<D: Scalar>(
    m: &mut [D],
    n: usize,
    t: D,
    q: &[D],
) -> crate::error::Result<()> {
    ldlt_in_place(m, n).map_err(|f| singular_mass(f, t, q))
}

/// The typed error for a mass matrix whose factorization failed at (t, q).
pub(crate) fn singular_mass<D: Scalar>(failure: FactorFailure, t: D, q: &[D]) -> Error {
    Error::SingularMassMatrix {
        t: t.re(),
        q: q.iter().map(|x| x.re()).collect(),
        reason: failure.reason(),
    }
}

/// Solve M q̈ = `rhs` in place with the factor `m` from [`factor_mass`] (`f64` for a constant M, or
/// the scalar of `rhs`).
///
/// # Errors
/// [`Error::NonFinite`] when q̈ is not finite.
#[inline(always)]
pub(crate) fn solve_mass<F: Copy, D>(
    m: &[F],
    n: usize,
    t: D,
    rhs: &mut [D],
) -> crate::error::Result<()>
where
    D: Scalar + std::ops::Mul<F, Output = D>,
{
    ldlt_solve(m, n, rhs);
    if rhs.iter().all(|v| v.re().is_finite()) {
        Ok(())
    } else {
        Err(Error::NonFinite {
            what: "accelerations",
            t: t.re(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn ldlt_solves_spd_system() {
        let mut a = [4.0, 2.0, 0.6, 2.0, 5.0, 1.0, 0.6, 1.0, 3.0];
        let orig = a;
        let x = [1.0, -2.0, 0.5];
        let mut b = [0.0; 3];
        for i in 0..3 {
            for j in 0..3 {
                b[i] += orig[i * 3 + j] * x[j];
            }
        }
        ldlt_in_place(&mut a, 3).unwrap();
        ldlt_solve(&a, 3, &mut b);
        for i in 0..3 {
            assert_relative_eq!(b[i], x[i], epsilon = 1e-14);
        }
    }

    /// An arrow matrix (its last row and column full, a diagonal otherwise) factors without
    /// fill-in; with the full row first instead, L fills in completely below it. The solve that
    /// skips L's structural zeros gives the full solve's bits: with a full pattern on a dense
    /// matrix (6 × 6, the sums in all four lanes and a remainder), and on the arrow matrix.
    #[test]
    fn ldlt_pattern_fills_in_and_the_solve_skips_only_zeros() {
        let n = 6;
        let last = |e: usize| e / n == n - 1 || e % n == n - 1 || e / n == e % n;
        let first = |e: usize| e / n == 0 || e.is_multiple_of(n) || e / n == e % n;
        let arrow = ldlt_pattern(n, |e| !last(e));
        let filled = ldlt_pattern(n, |e| !first(e));
        for i in 0..n {
            for j in 0..i {
                assert_eq!(arrow[i * n + j], i == n - 1, "arrow ({i}, {j})");
                assert!(filled[i * n + j], "filled ({i}, {j})");
            }
        }
        let value = |e: usize| ((e * 7 % 11) as f64 - 5.0) / 3.0;
        let spd = |keep: &dyn Fn(usize) -> bool| {
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..=i {
                    let x = if i == j {
                        20.0 + value(i)
                    } else if keep(i * n + j) {
                        value(i * n + j)
                    } else {
                        0.0
                    };
                    (a[i * n + j], a[j * n + i]) = (x, x);
                }
            }
            ldlt_in_place(&mut a, n).unwrap();
            a
        };
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.9).sin() + 0.2).collect();
        for (factor, pattern) in [(spd(&|_| true), vec![true; n * n]), (spd(&last), arrow)] {
            let (mut x, mut y) = (rhs.clone(), rhs.clone());
            ldlt_solve(&factor, n, &mut x);
            ldlt_solve_pattern(&factor, n, &pattern, &mut y);
            for (x, y) in x.iter().zip(&y) {
                assert_eq!(x.to_bits(), y.to_bits(), "{x} against {y}");
            }
        }
        // The last row partly zero (columns 0, 2, 3 kept: its terms in other lanes than their
        // columns): the factor is exactly zero where the pattern says so, and the solve agrees
        // with the full one to rounding.
        let kept =
            |e: usize| e / n == e % n || [30, 32, 33].contains(&e) || [5, 17, 23].contains(&e);
        let pattern = ldlt_pattern(n, |e| !kept(e));
        let factor = spd(&kept);
        for i in 0..n {
            for j in 0..i {
                assert_eq!(pattern[i * n + j], kept(i * n + j), "({i}, {j})");
                if !pattern[i * n + j] {
                    assert_eq!(factor[i * n + j], 0.0, "({i}, {j})");
                }
            }
        }
        let (mut x, mut y) = (rhs.clone(), rhs.clone());
        ldlt_solve(&factor, n, &mut x);
        ldlt_solve_pattern(&factor, n, &pattern, &mut y);
        for (x, y) in x.iter().zip(&y) {
            assert!((x - y).abs() <= 1e-15 * x.abs().max(1.0), "{x} against {y}");
        }
    }

    /// A 6 × 6 SPD matrix A = BᵀB + I with only its lower triangle filled (the upper holds
    /// garbage that must not be read), solved against a known x, on f64 and on dual numbers: the
    /// derivative of x(s) for A(s) = A + s·E must be −A⁻¹ E x.
    #[test]
    fn ldlt_reads_only_the_lower_triangle_and_differentiates() {
        use num_dual::Dual64;
        let n = 6;
        let b: Vec<f64> = (0..n * n)
            .map(|k| ((k * 7 % 11) as f64 - 5.0) / 3.0)
            .collect();
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = (0..n).map(|k| b[k * n + i] * b[k * n + j]).sum::<f64>()
                    + if i == j { 1.0 } else { 0.0 };
            }
        }
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.9).sin() + 0.2).collect();
        let rhs: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| a[i * n + j] * x[j]).sum())
            .collect();
        let mut lower = a.clone();
        for i in 0..n {
            for j in i + 1..n {
                lower[i * n + j] = f64::NAN;
            }
        }
        let mut sol = rhs.clone();
        ldlt_in_place(&mut lower, n).unwrap();
        ldlt_solve(&lower, n, &mut sol);
        for i in 0..n {
            assert_relative_eq!(sol[i], x[i], epsilon = 1e-12);
        }
        // d/ds of the solution of (A + s E) x = rhs at s = 0 is −A⁻¹ E x, with E = e_0 e_0ᵀ.
        let mut ad: Vec<Dual64> = a.iter().map(|&v| Dual64::from_re(v)).collect();
        ad[0] = Dual64::new(a[0], 1.0);
        let mut xd: Vec<Dual64> = rhs.iter().map(|&v| Dual64::from_re(v)).collect();
        ldlt_in_place(&mut ad, n).unwrap();
        ldlt_solve(&ad, n, &mut xd);
        let mut expected = vec![0.0; n];
        expected[0] = -x[0];
        ldlt_solve(&lower, n, &mut expected);
        for i in 0..n {
            assert_relative_eq!(xd[i].re, x[i], epsilon = 1e-12);
            assert_relative_eq!(xd[i].eps, expected[i], epsilon = 1e-12);
        }
    }

    #[test]
    fn ldlt_reports_singular_and_indefinite() {
        let mut singular = [1.0, 1.0, 1.0, 1.0];
        assert_eq!(
            ldlt_in_place(&mut singular, 2),
            Err(FactorFailure::Singular)
        );
        let mut indefinite = [1.0, 2.0, 2.0, 1.0];
        assert_eq!(
            ldlt_in_place(&mut indefinite, 2),
            Err(FactorFailure::NotPositiveDefinite)
        );
        let mut nan = [f64::NAN, 0.0, 0.0, 1.0];
        assert_eq!(ldlt_in_place(&mut nan, 2), Err(FactorFailure::NonFinite));
    }
}
