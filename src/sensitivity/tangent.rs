//! The sensitivities of a constrained model projected onto the tangent space of its constraints:
//! at the start of a run, and after each step whose state the constraints project
//! ([`super::projected`]).
//!
//! The state's projection is a map P(x) onto the constraints, and the sensitivities move with
//! its Jacobian: G s + ∂g/∂p = 0 at the position level, then V_q s + V_v ṡ + ∂v/∂p = 0 at the
//! velocity level, each by the M-orthogonal correction that [`Constrained::project`]'s steps
//! make (`s − M⁻¹Gᵀ (G M⁻¹ Gᵀ)⁻¹ (G s + r)`).
//!
//! [`Constrained::project`]: crate::constrained::Constrained::project

use crate::error::{Error, Result};
use crate::program::{compile::Tape, eval::Function};
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// What projects the sensitivities: the tape of
/// [`projection_outputs`](crate::derived::variational::projection_outputs) over the model's
/// (t, q, q̇), and the numbers of holonomic rows and of all rows.
#[derive(Debug, Clone)]
pub(super) struct TangentSpace {
    pub(super) tape: Arc<Tape>,
    pub(super) holonomic: usize,
    pub(super) rows: usize,
}

impl TangentSpace {
    /// Project the m sensitivity columns of x = (q, s₁, …, sₘ), (q̇, ṡ₁, …) in place onto the
    /// tangent space at the model's state, the first n entries; `f` is the tape bound to the
    /// parameter values; `initial` for the run's initial sensitivities (for the error).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] where M or G M⁻¹ Gᵀ cannot be solved.
    pub(super) fn project(
        &self,
        f: &Function,
        t: f64,
        n: usize,
        q: &mut [f64],
        qd: &mut [f64],
        initial: bool,
    ) -> Result<()> {
        let (kh, k) = (self.holonomic, self.rows);
        let m = q.len() / n - 1;
        let mut out = vec![0.0; self.tape.outputs()];
        f.eval_into(t, &q[..n], &qd[..n], &mut out);
        let mut from = 0;
        let mut take = |count: usize| {
            let part = out[from..from + count].to_vec();
            from += count;
            part
        };
        let upper = take(n * (n + 1) / 2);
        let mut mass = DMatrix::zeros(n, n);
        let mut i = 0;
        for r in 0..n {
            for c in r..n {
                mass[(r, c)] = upper[i];
                mass[(c, r)] = upper[i];
                i += 1;
            }
        }
        let gh = DMatrix::from_row_slice(kh, n, &take(kh * n));
        let vq = DMatrix::from_row_slice(k, n, &take(k * n));
        let vv = DMatrix::from_row_slice(k, n, &take(k * n));
        let (when, which) = if initial {
            ("t0", "initial sensitivities")
        } else {
            ("t", "sensitivities")
        };
        let singular = |what: &str| Error::InvalidInput {
            what: "sensitivities",
            why: format!(
                "{what} cannot be solved at {when} = {t}: the {which} of the constrained model \
                 cannot be projected there"
            ),
        };
        let lu = mass.clone().lu();
        let minv = lu.try_inverse().ok_or_else(|| singular("M"))?;
        // s − M⁻¹Gᵀ (G M⁻¹ Gᵀ)⁻¹ (G s + r): the M-orthogonal correction onto G s = −r.
        let project = |g: &DMatrix<f64>, s: &mut DVector<f64>, r: DVector<f64>| -> Result<()> {
            if g.nrows() == 0 {
                return Ok(());
            }
            let mg = &minv * g.transpose();
            let schur = g * &mg;
            let residual = g * &*s + r;
            let y = schur
                .lu()
                .solve(&residual)
                .ok_or_else(|| singular("G M⁻¹ Gᵀ"))?;
            *s -= mg * y;
            Ok(())
        };
        for j in 0..m {
            let gp = DVector::from_vec(take(kh));
            let vp = DVector::from_vec(take(k));
            let cols = n + j * n..n + (j + 1) * n;
            let mut sq = DVector::from_column_slice(&q[cols.clone()]);
            let mut sv = DVector::from_column_slice(&qd[cols.clone()]);
            project(&gh, &mut sq, gp)?;
            let r = &vq * &sq + vp;
            project(&vv, &mut sv, r)?;
            q[cols.clone()].copy_from_slice(sq.as_slice());
            qd[cols].copy_from_slice(sv.as_slice());
        }
        Ok(())
    }
}
