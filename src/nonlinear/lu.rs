//! An in-place LU factorization for Newton's linear systems, real and complex.

use nalgebra::{ComplexField, DMatrix};

/// The scalars the LU works on: `f64`, and `Complex<f64>` for Radau's complex system.
pub(crate) trait Field: ComplexField<RealField = f64> + Copy {}
impl<T: ComplexField<RealField = f64> + Copy> Field for T {}

/// An LU factorization with partial pivoting that overwrites a preallocated matrix, so that
/// refactoring allocates nothing (nalgebra's `LU::new` takes the matrix by value and allocates
/// its permutation on every call). The elimination is the one of nalgebra's `LU`.
pub(crate) struct Lu<T: Field> {
    /// The matrix to factor; after [`factor`](Self::factor), L (unit diagonal) and U packed.
    a: DMatrix<T>,
    /// Row exchanged with row k at step k.
    piv: Vec<usize>,
}

impl<T: Field> Lu<T> {
    /// Work space for an `n × n` matrix.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            a: DMatrix::from_element(n, n, T::zero()),
            piv: vec![0; n],
        }
    }

    /// The matrix to fill before [`factor`](Self::factor).
    pub(crate) fn matrix(&mut self) -> &mut DMatrix<T> {
        &mut self.a
    }

    /// Factor in place; `false` when a pivot is zero or not finite (the matrix is singular).
    pub(crate) fn factor(&mut self) -> bool {
        let n = self.a.nrows();
        let a = self.a.as_mut_slice();
        for k in 0..n {
            let mut p = k;
            let mut best = -1.0;
            for i in k..n {
                let v = a[k * n + i].norm1();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best.is_finite() && best > 0.0) {
                return false;
            }
            self.piv[k] = p;
            if p != k {
                for j in 0..n {
                    a.swap(j * n + k, j * n + p);
                }
            }
            let inv = T::one() / a[k * n + k];
            for i in k + 1..n {
                a[k * n + i] *= inv;
            }
            for j in k + 1..n {
                let akj = a[j * n + k];
                if akj != T::zero() {
                    for i in k + 1..n {
                        let lik = a[k * n + i];
                        a[j * n + i] -= lik * akj;
                    }
                }
            }
        }
        true
    }

    /// Solve A x = b in place with the factored A.
    pub(crate) fn solve(&self, b: &mut [T]) {
        let n = self.a.nrows();
        let a = self.a.as_slice();
        for k in 0..n {
            b.swap(k, self.piv[k]);
        }
        for j in 0..n {
            let bj = b[j];
            if bj != T::zero() {
                for i in j + 1..n {
                    b[i] -= a[j * n + i] * bj;
                }
            }
        }
        for j in (0..n).rev() {
            b[j] /= a[j * n + j];
            let bj = b[j];
            for i in 0..j {
                b[i] -= a[j * n + i] * bj;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Complex;

    #[test]
    fn lu_solves_real_and_complex_systems() {
        // A matrix that needs pivoting (zero in the first diagonal entry).
        let rows = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, -1.0, 4.0]];
        let x = [1.0, -2.0, 0.5];
        let mut lu = Lu::<f64>::new(3);
        let mut b = [0.0; 3];
        for i in 0..3 {
            for j in 0..3 {
                lu.matrix()[(i, j)] = rows[i][j];
                b[i] += rows[i][j] * x[j];
            }
        }
        assert!(lu.factor());
        lu.solve(&mut b);
        for i in 0..3 {
            assert_relative_eq!(b[i], x[i], epsilon = 1e-14);
        }
        // (μ I − J) with complex μ, as in Radau.
        let mu = Complex::new(2.0, -1.5);
        let mut lu = Lu::<Complex<f64>>::new(3);
        let z = [
            Complex::new(1.0, 1.0),
            Complex::new(0.0, -2.0),
            Complex::new(0.5, 0.0),
        ];
        let mut b = [Complex::new(0.0, 0.0); 3];
        for i in 0..3 {
            for j in 0..3 {
                let e = if i == j { mu } else { Complex::new(0.0, 0.0) } - rows[i][j];
                lu.matrix()[(i, j)] = e;
                b[i] += e * z[j];
            }
        }
        assert!(lu.factor());
        lu.solve(&mut b);
        for i in 0..3 {
            assert!((b[i] - z[i]).norm() < 1e-14);
        }
        let mut singular = Lu::<f64>::new(2);
        singular.matrix().fill(1.0);
        assert!(!singular.factor());
    }
}
