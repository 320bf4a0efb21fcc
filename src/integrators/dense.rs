//! Dense output: the state between two steps without changing the step sequence.
//!
//! Methods with a continuous extension (DOPRI5, DOP853) evaluate Hairer's polynomial in θ; the
//! others use the quintic Hermite interpolant in q through (q, q̇, q̈) at both ends of the step,
//! whose error is O(h⁶) in q and O(h⁵) in q̇ — enough for the order-4 methods, and below the
//! global error of the higher-order splittings for the step sizes they are run at.
//!
//! Each accepted step hands its [`Interpolant`] to the run, which finds requested output times
//! and events on it; with [`Options::dense`](super::Options::dense) the run keeps every step's
//! interpolant as a [`Dense`] solution, callable anywhere in the span.

use crate::error::{Error, Result};
use crate::taylor::Expansion;

/// y(θ) = y₀ + θ(F₀ + (1−θ)(F₁ + θ(F₂ + (1−θ)(F₃ + …)))), the form of Hairer's `CONTD5`/`CONTD8`.
pub(crate) fn polynomial(theta: f64, y0: &[f64], f: &[Vec<f64>], out: &mut [f64]) {
    horner(theta, y0, f.len(), |r, i| f[r][i], out);
}

/// [`polynomial`] with row r, component i read by `f(r, i)`.
fn horner(theta: f64, y0: &[f64], rows: usize, f: impl Fn(usize, usize) -> f64, out: &mut [f64]) {
    let one_minus = 1.0 - theta;
    for (i, o) in out.iter_mut().enumerate() {
        let mut acc = 0.0;
        for r in (0..rows).rev() {
            acc = (acc + f(r, i)) * if r % 2 == 0 { theta } else { one_minus };
        }
        *o = y0[i] + acc;
    }
}

/// The state inside one accepted step, as the method interpolates it.
pub(crate) enum Interpolant<'a> {
    /// Hairer's continuous extension of order `order`: y(t + θh) = [`polynomial`](θ, y0, f).
    Polynomial {
        t: f64,
        h: f64,
        y0: &'a [f64],
        f: &'a [Vec<f64>],
        order: usize,
    },
    /// The quintic Hermite interpolant through the step's ends.
    Hermite { t: f64, h: f64, ends: Ends<'a> },
    /// The Taylor polynomial of the step (the Taylor method's expansion at t).
    Taylor { t: f64, expansion: &'a Expansion },
}

impl Interpolant<'_> {
    /// y = (q, q̇) at `time`, inside the step.
    pub(crate) fn eval(&self, time: f64, out: &mut [f64]) {
        match self {
            Self::Polynomial { t, h, y0, f, .. } => polynomial((time - t) / h, y0, f, out),
            Self::Hermite { t, h, ends } => hermite5((time - t) / h, *h, ends, out),
            Self::Taylor { t, expansion } => expansion.eval(time - t, out),
        }
    }
}

/// [`Dense`]'s contents: (dim, rows, taylor, order, dir, start, step, end, data).
pub type DenseParts = (
    usize,
    usize,
    bool,
    usize,
    f64,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
);

/// The continuous solution of a run ([`Options::dense`](super::Options::dense)): every
/// accepted step's own interpolant, callable anywhere in the span.
///
/// The explicit Runge–Kutta methods with a continuous extension keep Hairer's polynomial
/// (DOPRI5: order 4, DOP853: order 7); every other method the quintic Hermite interpolant in q
/// through (q, q̇, q̈) at both ends of each step (error O(h⁶) in q, O(h⁵) in q̇: order 5). Across
/// a reset of an event the solution jumps; at the event's time it gives the state before the
/// reset, as the event's record and the requested output times do.
#[derive(Debug, Clone, PartialEq)]
pub struct Dense {
    /// Components of y = (q, q̇).
    dim: usize,
    /// Rows F of the continuous extension; 0 for Hermite pieces.
    rows: usize,
    /// Whether the pieces are Taylor polynomials (of degree `order`).
    taylor: bool,
    order: usize,
    /// +1 forward in time, −1 backward.
    dir: f64,
    /// Each piece: the step's start t and size h, and where the piece ends (t + h, or an
    /// event that stopped the step early).
    start: Vec<f64>,
    step: Vec<f64>,
    end: Vec<f64>,
    /// Per piece: y₀ and the rows F (continuous extension), or q₀, q̇₀, q̈₀, q₁, q̇₁, q̈₁.
    data: Vec<f64>,
}

impl Dense {
    pub(crate) fn new(dim: usize, dir: f64) -> Self {
        Self {
            dim,
            rows: 0,
            taylor: false,
            order: 0,
            dir,
            start: Vec::new(),
            step: Vec::new(),
            end: Vec::new(),
            data: Vec::new(),
        }
    }

    /// Keep `step`'s interpolant, valid up to `end`.
    pub(crate) fn push(&mut self, step: &Interpolant<'_>, end: f64) {
        let (t, h) = match step {
            Interpolant::Polynomial {
                t, h, y0, f, order, ..
            } => {
                self.rows = f.len();
                self.order = *order;
                self.data.extend_from_slice(y0);
                for row in f.iter() {
                    self.data.extend_from_slice(row);
                }
                (*t, *h)
            }
            Interpolant::Hermite { t, h, ends } => {
                self.order = 5;
                for part in [ends.q0, ends.v0, ends.a0, ends.q1, ends.v1, ends.a1] {
                    self.data.extend_from_slice(part);
                }
                (*t, *h)
            }
            Interpolant::Taylor { t, expansion } => {
                self.taylor = true;
                self.order = expansion.order();
                for k in 0..=self.order {
                    self.data.extend_from_slice(expansion.q(k));
                    self.data.extend_from_slice(expansion.qd(k));
                }
                (*t, end - t)
            }
        };
        self.start.push(t);
        self.step.push(h);
        self.end.push(end);
    }

    /// Everything it holds, for pickling: (dim, rows, taylor, order, dir, start, step, end,
    /// data).
    pub fn to_parts(&self) -> DenseParts {
        (
            self.dim,
            self.rows,
            self.taylor,
            self.order,
            self.dir,
            self.start.clone(),
            self.step.clone(),
            self.end.clone(),
            self.data.clone(),
        )
    }

    /// The solution [`Dense::to_parts`] gave.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the parts do not fit together.
    pub fn from_parts(parts: DenseParts) -> Result<Self> {
        let (dim, rows, taylor, order, dir, start, step, end, data) = parts;
        let pieces = start.len();
        let width = if taylor {
            (order + 1) * dim
        } else if rows > 0 {
            (1 + rows) * dim
        } else {
            3 * dim
        };
        let fits = dim > 0
            && dim % 2 == 0
            && (dir == 1.0 || dir == -1.0)
            && step.len() == pieces
            && end.len() == pieces
            && width.checked_mul(pieces) == Some(data.len())
            && start.iter().chain(&step).chain(&end).all(|x| x.is_finite());
        if !fits {
            return Err(Error::InvalidInput {
                what: "dense solution",
                why: "its parts do not fit together".into(),
            });
        }
        Ok(Self {
            dim,
            rows,
            taylor,
            order,
            dir,
            start,
            step,
            end,
            data,
        })
    }

    /// Order of the interpolant (in q for the Hermite pieces).
    pub fn order(&self) -> usize {
        self.order
    }

    /// What interpolates between the steps.
    pub fn interpolant(&self) -> &'static str {
        if self.taylor {
            "the Taylor polynomial of each step"
        } else if self.rows > 0 {
            "continuous extension of the Runge–Kutta method (Hairer)"
        } else {
            "quintic Hermite interpolation through q, q̇, q̈ at the ends of each step"
        }
    }

    /// Components of y = (q, q̇): twice the number of coordinates.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of steps kept.
    pub fn steps(&self) -> usize {
        self.start.len()
    }

    /// The span covered, (first time, last time), in the direction of integration; `None`
    /// before the first step.
    pub fn span(&self) -> Option<(f64, f64)> {
        Some((*self.start.first()?, *self.end.last()?))
    }

    /// y = (q, q̇) at `t`, written to `out` (length 2 · dof).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `t` lies outside the span or is not finite,
    /// [`Error::DimensionMismatch`] for a wrong `out`.
    pub fn eval(&self, t: f64, out: &mut [f64]) -> Result<()> {
        if out.len() != self.dim {
            return Err(Error::DimensionMismatch {
                what: "dense output buffer",
                expected: self.dim,
                got: out.len(),
            });
        }
        let outside = || Error::InvalidInput {
            what: "time",
            why: match self.span() {
                Some((a, b)) => format!("t = {t} lies outside the solution's span {a} → {b}"),
                None => "the solution has no steps".into(),
            },
        };
        let (first, last) = self.span().ok_or_else(outside)?;
        let dir = self.dir;
        if !t.is_finite() || (t - first) * dir < 0.0 || (t - last) * dir > 0.0 {
            return Err(outside());
        }
        // The last piece that starts before t (at a reset's time, the piece before it: the
        // state before the reset, as the event records and the output times give it).
        let k = self.start.partition_point(|&s| (s - t) * dir < 0.0).max(1) - 1;
        let (t0, h) = (self.start[k], self.step[k]);
        if self.taylor {
            // Coefficient j of (q, q̇) at data[(k·(order+1) + j)·dim ..]; Horner in t − t₀.
            let width = (self.order + 1) * self.dim;
            let piece = &self.data[k * width..(k + 1) * width];
            let dt = t - t0;
            for (i, o) in out.iter_mut().enumerate() {
                let mut acc = 0.0;
                for j in (0..=self.order).rev() {
                    acc = acc * dt + piece[j * self.dim + i];
                }
                *o = acc;
            }
        } else if self.rows > 0 {
            let width = (1 + self.rows) * self.dim;
            let piece = &self.data[k * width..(k + 1) * width];
            let (y0, f) = piece.split_at(self.dim);
            let dim = self.dim;
            horner((t - t0) / h, y0, self.rows, |r, i| f[r * dim + i], out);
        } else {
            let n = self.dim / 2;
            let piece = &self.data[k * 6 * n..(k + 1) * 6 * n];
            let part = |i: usize| &piece[i * n..(i + 1) * n];
            let ends = Ends {
                q0: part(0),
                v0: part(1),
                a0: part(2),
                q1: part(3),
                v1: part(4),
                a1: part(5),
            };
            hermite5((t - t0) / h, h, &ends, out);
        }
        Ok(())
    }
}

/// The end states of one step of a second-order system: q, q̇ and q̈ at both ends.
pub(crate) struct Ends<'a> {
    pub(crate) q0: &'a [f64],
    pub(crate) v0: &'a [f64],
    pub(crate) a0: &'a [f64],
    pub(crate) q1: &'a [f64],
    pub(crate) v1: &'a [f64],
    pub(crate) a1: &'a [f64],
}

/// Quintic Hermite interpolation at t₀ + θh: q from the basis that matches q, q̇, q̈ at both
/// ends, q̇ from its derivative. `out` = (q, q̇).
pub(crate) fn hermite5(theta: f64, h: f64, e: &Ends<'_>, out: &mut [f64]) {
    let s = theta;
    let (s2, s3) = (s * s, s * s * s);
    let (s4, s5) = (s3 * s, s3 * s2);
    let h0 = 1.0 - 10.0 * s3 + 15.0 * s4 - 6.0 * s5;
    let h1 = s - 6.0 * s3 + 8.0 * s4 - 3.0 * s5;
    let h2 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5;
    let h3 = 10.0 * s3 - 15.0 * s4 + 6.0 * s5;
    let h4 = -4.0 * s3 + 7.0 * s4 - 3.0 * s5;
    let h5 = 0.5 * s3 - s4 + 0.5 * s5;
    let d0 = -30.0 * s2 + 60.0 * s3 - 30.0 * s4;
    let d1 = 1.0 - 18.0 * s2 + 32.0 * s3 - 15.0 * s4;
    let d2 = s - 4.5 * s2 + 6.0 * s3 - 2.5 * s4;
    let d4 = -12.0 * s2 + 28.0 * s3 - 15.0 * s4;
    let d5 = 1.5 * s2 - 4.0 * s3 + 2.5 * s4;
    let n = e.q0.len();
    let (q, v) = out.split_at_mut(n);
    let hh = h * h;
    for i in 0..n {
        q[i] = h0 * e.q0[i]
            + h1 * h * e.v0[i]
            + h2 * hh * e.a0[i]
            + h3 * e.q1[i]
            + h4 * h * e.v1[i]
            + h5 * hh * e.a1[i];
        // d/dt = (1/h) d/dθ; d3 = −d0.
        v[i] = (d0 * (e.q0[i] - e.q1[i])) / h
            + d1 * e.v0[i]
            + d2 * h * e.a0[i]
            + d4 * e.v1[i]
            + d5 * h * e.a1[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The quintic Hermite interpolant reproduces a quintic exactly.
    #[test]
    fn hermite5_exact_for_quintic() {
        let p = |t: f64| {
            0.3 - 1.2 * t + 0.7 * t * t + 2.0 * t.powi(3) - 0.4 * t.powi(4) + 0.9 * t.powi(5)
        };
        let dp = |t: f64| -1.2 + 1.4 * t + 6.0 * t * t - 1.6 * t.powi(3) + 4.5 * t.powi(4);
        let ddp = |t: f64| 1.4 + 12.0 * t - 4.8 * t * t + 18.0 * t.powi(3);
        let (t0, h) = (0.4, -0.7);
        let t1 = t0 + h;
        let e = Ends {
            q0: &[p(t0)],
            v0: &[dp(t0)],
            a0: &[ddp(t0)],
            q1: &[p(t1)],
            v1: &[dp(t1)],
            a1: &[ddp(t1)],
        };
        for k in 0..=10 {
            let theta = k as f64 / 10.0;
            let mut out = [0.0; 2];
            hermite5(theta, h, &e, &mut out);
            assert_relative_eq!(out[0], p(t0 + theta * h), epsilon = 1e-13);
            assert_relative_eq!(out[1], dp(t0 + theta * h), epsilon = 1e-12);
        }
    }

    /// The alternating Horner form equals the expanded product.
    #[test]
    fn polynomial_matches_expanded_form() {
        let y0 = [1.0];
        let f = vec![vec![0.5], vec![-0.25], vec![2.0], vec![0.75]];
        let th: f64 = 0.3;
        let expanded = 1.0 + th * (0.5 + (1.0 - th) * (-0.25 + th * (2.0 + (1.0 - th) * 0.75)));
        let mut out = [0.0];
        polynomial(th, &y0, &f, &mut out);
        assert_relative_eq!(out[0], expanded, epsilon = 1e-15);
    }
}
