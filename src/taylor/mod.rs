//! Taylor coefficients of the motion by series arithmetic on the expression graph.
//!
//! Lagrange's equations are implicit in q̈: M(t, q) q̈ = f(t, q, q̇) (eq. 55, derived on the graph
//! by [`eom_graph`](super::eom_graph)). The normalized Taylor coefficients xₖ = x⁽ᵏ⁾(t₀)/k! of
//! the solution through (t₀, q₀, q̇₀) follow order by order: at order k the coefficients of q
//! and q̇ are known (qₖ = q̇ₖ₋₁/k, q̇ₖ = q̈ₖ₋₁/k), so every node of M and f gets its coefficient k
//! from the standard recurrences of truncated power series (products by convolution, quotients,
//! exp, log, sin and cos together, …), and q̈'s coefficient k from one solve with M₀ = M(t₀, q₀),
//! factored once per expansion:
//!
//! M₀ q̈ₖ = fₖ − Σⱼ₌₁..ₖ Mⱼ q̈ₖ₋ⱼ.
//!
//! No symbolic inverse of M is formed, so the cost is a few evaluations of the graph per order
//! at any number of coordinates.
//!
//! The graph is lowered once to a list of recurrences ([`Op`]) over the rows of one table: a row
//! per node and the auxiliary rows some recurrences need (cos beside sin, 1 + tan² beside tan,
//! the squares of a power by squaring, …). Nodes that depend on none of t, q, q̇ have a series
//! with nothing beyond order 0, so they are evaluated once per expansion and skipped at higher
//! orders, and a product or quotient by one of them is a scaling. The recurrences are
//! interpreted here and compiled to machine code by `taylor_native.rs` (feature `jit`), with the
//! same operations in the same order, so both give the same coefficients bit for bit.

use std::collections::{HashMap, HashSet};
#[cfg(feature = "jit")]
use std::sync::OnceLock;
#[cfg(feature = "jit")]
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

#[cfg(feature = "jit")]
mod kernel;

use crate::eom;
use crate::error::{Error, Result};
use crate::expr::graph::{Binary, Graph, Node, Unary, sign};
use crate::linalg;
#[cfg(feature = "jit")]
use kernel::{Buffers, Status, Step, StepControl};

/// One recurrence: coefficient k of row `out` (and of its partner rows) from the coefficients
/// of its operands up to k and its own below k. Rows hold series; row r's coefficient j is at
/// `r·w + j`, w = order + 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Op {
    /// aₖ.
    Copy { out: usize, a: usize },
    /// −aₖ.
    Neg { out: usize, a: usize },
    /// aₖ + bₖ.
    Add { out: usize, a: usize, b: usize },
    /// aₖ − bₖ.
    Sub { out: usize, a: usize, b: usize },
    /// aₖ c₀, c constant.
    Scale { out: usize, a: usize, c: usize },
    /// Σⱼ₌₀..ₖ aⱼ bₖ₋ⱼ.
    Mul { out: usize, a: usize, b: usize },
    /// a²: 2 Σⱼ₌₀..ₕ aⱼ aₖ₋ⱼ with h = ⌊(k − 1)/2⌋, plus a²ₖ/₂ for even k (a₀² at order 0): the
    /// product a a in half its terms.
    Square { out: usize, a: usize },
    /// aₖ / c₀, c constant.
    DivC { out: usize, a: usize, c: usize },
    /// (aₖ − Σⱼ₌₁..ₖ bⱼ outₖ₋ⱼ) / b₀.
    Div { out: usize, a: usize, b: usize },
    /// 1 / b: −Σⱼ₌₁..ₖ bⱼ outₖ₋ⱼ / b₀ (1 / b₀ at order 0).
    Recip { out: usize, b: usize },
    /// Σⱼ₌₁..ₖ j aⱼ outₖ₋ⱼ / k.
    Exp { out: usize, a: usize },
    /// (aₖ − Σⱼ₌₁..ₖ₋₁ j outⱼ aₖ₋ⱼ / k) / a₀.
    Ln { out: usize, a: usize },
    /// (aₖ − Σⱼ₌₁..ₖ₋₁ outⱼ outₖ₋ⱼ) / (2 out₀).
    Sqrt { out: usize, a: usize },
    /// s = sin a, c = cos a (`hyperbolic`: sinh, cosh): sₖ = Σⱼ₌₁..ₖ j aⱼ cₖ₋ⱼ / k and
    /// cₖ = ∓Σⱼ₌₁..ₖ j aⱼ sₖ₋ⱼ / k (− for sin and cos). When a is a polynomial in t of degree
    /// d (`degree`: ωt + φ, a forcing's phase, has d = 1), aⱼ = 0 beyond d and the sums stop
    /// at j = min(k, d): each order costs O(d), not O(k). When a′ is a row of its own (`da`: a
    /// coordinate's is its velocity, θ₁ − θ₂'s is θ̇₁ − θ̇₂, ωt's is ω), the weights go: j aⱼ
    /// is a′ⱼ₋₁, and sₖ = Σₘ₌₀..ₖ₋₁ a′ₘ cₖ₋₁₋ₘ / k, cₖ = ∓Σₘ a′ₘ sₖ₋₁₋ₘ / k, sums that read no
    /// coefficient of order k at all.
    SinCos {
        s: usize,
        c: usize,
        a: usize,
        hyperbolic: bool,
        degree: Option<usize>,
        da: Option<usize>,
    },
    /// t = tan a with w = 1 + t² (`hyperbolic`: tanh, w = 1 − t²): tₖ = Σⱼ₌₁..ₖ j aⱼ wₖ₋ⱼ / k,
    /// wₖ = ±Σⱼ₌₀..ₖ tⱼ tₖ₋ⱼ.
    Tan {
        out: usize,
        w: usize,
        a: usize,
        hyperbolic: bool,
    },
    /// |a|: aₖ with the sign of a₀.
    Abs { out: usize, a: usize },
    /// sign(a): ±1 at order 0, nothing beyond.
    Sign { out: usize, a: usize },
    /// θ = atan2(y, x) with D = x² + y² (row d) and R = θ′ = (x y′ − y x′) / D (row r, its
    /// coefficient k − 1 found at order k): Dₖ = Σⱼ₌₀..ₖ xⱼ xₖ₋ⱼ + Σⱼ₌₀..ₖ yⱼ yₖ₋ⱼ,
    /// Rₖ₋₁ = (Σⱼ₌₁..ₖ j yⱼ xₖ₋ⱼ − Σⱼ₌₁..ₖ j xⱼ yₖ₋ⱼ − Σⱼ₌₁..ₖ₋₁ Dⱼ Rₖ₋₁₋ⱼ) / D₀, θₖ = Rₖ₋₁ / k.
    Atan2 {
        out: usize,
        y: usize,
        x: usize,
        d: usize,
        r: usize,
    },
}

/// The highest order an expansion may be asked for: far beyond what double precision can use
/// (the Taylor method's order is about 20 at a tolerance of 1e-16), and a bound on the table.
pub const MAX_TAYLOR_ORDER: usize = 100;

/// Lanes of a convolution: independent partial sums, so that the additions do not wait on each
/// other (measured: the sums of one lane were bound by the latency of the addition).
pub(crate) const LANES: usize = 4;

/// Σⱼ₌ₗₒ..ₕᵢ aⱼ b_(kk − j) (`weighted`: Σ j aⱼ b_(kk − j)) of rows a and b of the table at
/// order k; 0 when hi < lo. At k ≥ 1 the terms that read a coefficient of order k — j = 0 when
/// lo = 0 and kk = k (b_k), j = k when hi = k (a_k) — are computed last in the order, so they
/// are added last: first the other terms, term lo + i to lane i mod 4 while four are left and
/// the rest to lane 0, the lanes added as (l₀ + l₁) + (l₂ + l₃), then the j = 0 term, then
/// the j = k term. (The lanes do not wait on each other, and the sum of the older terms does
/// not wait for order k; the compiled code sums them in two-lane vectors.) The compiled
/// recurrences sum in the same order ([`conv_rows`], through [`lagrangian_conv`]), so both
/// give the same bits.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn conv(
    s: &[f64],
    w: usize,
    a: usize,
    b: usize,
    lo: usize,
    hi: usize,
    kk: usize,
    k: usize,
    weighted: bool,
) -> f64 {
    conv_rows(
        &s[a * w..(a + 1) * w],
        &s[b * w..(b + 1) * w],
        lo,
        hi,
        kk,
        k,
        weighted,
    )
}

/// Which of a convolution's end terms read a coefficient of the order k being computed, and
/// are added last ([`conv`]): (j = 0, j = k).
#[inline(always)]
pub(crate) fn fresh_ends(lo: usize, hi: usize, kk: usize, k: usize) -> (bool, bool) {
    let first = k > 0 && lo == 0 && kk == k && lo <= hi;
    let last = k > 0 && hi == k && lo <= hi;
    (first, last)
}

/// [`conv`] on two rows.
#[inline(always)]
fn conv_rows(
    a: &[f64],
    b: &[f64],
    lo: usize,
    hi: usize,
    kk: usize,
    k: usize,
    weighted: bool,
) -> f64 {
    let term = |j: usize| {
        let x = a[j];
        let x = if weighted { j as f64 * x } else { x };
        x * b[kk - j]
    };
    let (first, last) = fresh_ends(lo, hi, kk, k);
    let mut lanes = [0.0; LANES];
    let mut j = lo + usize::from(first);
    let end = hi + 1 - usize::from(last);
    while j + LANES <= end {
        for (i, lane) in lanes.iter_mut().enumerate() {
            *lane += term(j + i);
        }
        j += LANES;
    }
    while j < end {
        lanes[0] += term(j);
        j += 1;
    }
    let mut sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    if first {
        sum += term(0);
    }
    if last {
        sum += term(k);
    }
    sum
}

/// [`conv_rows`] for the compiled recurrences: rows a and b from their first coefficient.
///
/// # Safety
/// `a` is valid for reads of `hi + 1` values and `b` of `kk + 1` (the kernel passes rows of a
/// table it was checked against, with hi, kk below the row width), and lo ≤ kk when lo ≤ hi.
#[cfg(feature = "jit")]
pub(crate) unsafe extern "C" fn lagrangian_conv(
    a: *const f64,
    b: *const f64,
    lo: i64,
    hi: i64,
    kk: i64,
    k: i64,
    weighted: i32,
) -> f64 {
    if hi < lo {
        return 0.0;
    }
    // SAFETY: see the function's contract.
    let (a, b) = unsafe {
        (
            std::slice::from_raw_parts(a, hi as usize + 1),
            std::slice::from_raw_parts(b, kk as usize + 1),
        )
    };
    conv_rows(
        a,
        b,
        lo as usize,
        hi as usize,
        kk as usize,
        k as usize,
        weighted != 0,
    )
}

impl Op {
    /// Whether order 0 of this recurrence calls the maths library.
    fn calls_libm(&self) -> bool {
        !self.libm().is_empty()
    }

    /// The functions of the maths library order 0 of this recurrence calls, by the names the
    /// compiled code imports them under (`native.rs`).
    pub(crate) fn libm(&self) -> &'static [&'static str] {
        match self {
            Op::Exp { .. } => &["lagrangian_exp"],
            Op::Ln { .. } => &["lagrangian_ln"],
            Op::SinCos {
                hyperbolic: true, ..
            } => &["lagrangian_sinh", "lagrangian_cosh"],
            Op::SinCos { .. } => &["lagrangian_sin_cos"],
            Op::Tan {
                hyperbolic: true, ..
            } => &["lagrangian_tanh"],
            Op::Tan { .. } => &["lagrangian_tan"],
            Op::Atan2 { .. } => &["lagrangian_atan2"],
            _ => &[],
        }
    }

    /// The rows whose coefficients below k this recurrence reads at order k (the operands of
    /// its sums, its own row in a recursive one): the only rows whose coefficients must be kept
    /// past the order that computes them. The others are read at their own order only (and
    /// coefficient 0 of every row is computed apart, at order 0).
    #[cfg(feature = "jit")]
    pub(crate) fn history(&self) -> Vec<usize> {
        match *self {
            Op::Mul { a, b, .. } => vec![a, b],
            Op::Square { a, .. } => vec![a],
            Op::Div { out, b, .. } | Op::Recip { out, b } => vec![out, b],
            Op::Exp { out, a } | Op::Ln { out, a } => vec![out, a],
            Op::Sqrt { out, .. } => vec![out],
            Op::SinCos { s, c, a, da, .. } => vec![s, c, da.unwrap_or(a)],
            Op::Tan { out, w, a, .. } => vec![out, w, a],
            Op::Atan2 { y, x, d, r, .. } => vec![y, x, d, r],
            Op::Copy { .. }
            | Op::Neg { .. }
            | Op::Add { .. }
            | Op::Sub { .. }
            | Op::Scale { .. }
            | Op::DivC { .. }
            | Op::Abs { .. }
            | Op::Sign { .. } => Vec::new(),
        }
    }

    /// The rows this recurrence reads that others write (not its own rows).
    fn operands(&self) -> Vec<usize> {
        let mut op = *self;
        op.operands_mut().into_iter().map(|r| *r).collect()
    }

    /// The rows this recurrence reads at the orders above 0: its operands, less the argument
    /// of a sine and cosine summed through its derivative (`da`), which only order 0 reads.
    fn operands_above_zero(&self) -> Vec<usize> {
        match *self {
            Op::SinCos { da: Some(da), .. } => vec![da],
            _ => self.operands(),
        }
    }

    /// [`Op::operands`], to rewrite.
    fn operands_mut(&mut self) -> Vec<&mut usize> {
        match self {
            Op::SinCos {
                a, da: Some(da), ..
            } => vec![a, da],
            Op::Copy { a, .. }
            | Op::Neg { a, .. }
            | Op::Square { a, .. }
            | Op::Exp { a, .. }
            | Op::Ln { a, .. }
            | Op::Sqrt { a, .. }
            | Op::Abs { a, .. }
            | Op::Sign { a, .. }
            | Op::SinCos { a, .. }
            | Op::Tan { a, .. } => vec![a],
            Op::Recip { b, .. } => vec![b],
            Op::Add { a, b, .. } | Op::Sub { a, b, .. } | Op::Mul { a, b, .. } => vec![a, b],
            Op::Div { a, b, .. } => vec![a, b],
            Op::Scale { a, c, .. } | Op::DivC { a, c, .. } => vec![a, c],
            Op::Atan2 { y, x, .. } => vec![y, x],
        }
    }

    /// The rows this recurrence writes.
    fn outputs(&self) -> Vec<usize> {
        match *self {
            Op::SinCos { s, c, .. } => vec![s, c],
            Op::Tan { out, w, .. } => vec![out, w],
            Op::Atan2 { out, d, r, .. } => vec![out, d, r],
            _ => vec![self.out()],
        }
    }

    /// The row of this recurrence's value (sin's of `SinCos`, tan's of `Tan`).
    fn out(&self) -> usize {
        match *self {
            Op::SinCos { s, .. } => s,
            Op::Copy { out, .. }
            | Op::Neg { out, .. }
            | Op::Add { out, .. }
            | Op::Sub { out, .. }
            | Op::Scale { out, .. }
            | Op::Mul { out, .. }
            | Op::Square { out, .. }
            | Op::DivC { out, .. }
            | Op::Div { out, .. }
            | Op::Recip { out, .. }
            | Op::Exp { out, .. }
            | Op::Ln { out, .. }
            | Op::Sqrt { out, .. }
            | Op::Abs { out, .. }
            | Op::Sign { out, .. }
            | Op::Tan { out, .. }
            | Op::Atan2 { out, .. } => out,
        }
    }

    /// Terms of the convolutions this recurrence sums at order k ≥ 1.
    fn terms(&self, k: usize) -> usize {
        match self {
            Op::Mul { .. } => k + 1,
            Op::Square { .. } => k / 2 + 1,
            Op::Div { .. } | Op::Recip { .. } | Op::Exp { .. } => k,
            Op::Ln { .. } | Op::Sqrt { .. } => k - 1,
            Op::SinCos { degree, .. } => 2 * degree.map_or(k, |d| d.min(k)),
            Op::Tan { .. } => 2 * k + 1,
            Op::Atan2 { .. } => 5 * k + 1,
            _ => 0,
        }
    }

    /// Coefficient k of the rows this recurrence writes, in the table `s` of row width `w`.
    pub(crate) fn apply(&self, s: &mut [f64], w: usize, k: usize) {
        let at = |s: &[f64], r: usize, j: usize| s[r * w + j];
        // 1/k: the recurrences scale by it (a product, not a quotient, on the path from one
        // order to the next).
        let inv_k = 1.0 / k as f64;
        let value = match *self {
            Op::Copy { a, .. } => at(s, a, k),
            Op::Neg { a, .. } => -at(s, a, k),
            Op::Add { a, b, .. } => at(s, a, k) + at(s, b, k),
            Op::Sub { a, b, .. } => at(s, a, k) - at(s, b, k),
            Op::Scale { a, c, .. } => at(s, a, k) * at(s, c, 0),
            Op::Mul { a, b, .. } => conv(s, w, a, b, 0, k, k, k, false),
            Op::Square { a, .. } if k == 0 => conv(s, w, a, a, 0, 0, 0, 0, false),
            Op::Square { a, .. } => {
                let half = conv(s, w, a, a, 0, (k - 1) / 2, k, k, false);
                let twice = half + half;
                if k.is_multiple_of(2) {
                    let mid = at(s, a, k / 2);
                    twice + mid * mid
                } else {
                    twice
                }
            }
            Op::DivC { a, c, .. } => at(s, a, k) / at(s, c, 0),
            Op::Div { out, a, b } => {
                (at(s, a, k) - conv(s, w, b, out, 1, k, k, k, false)) / at(s, b, 0)
            }
            Op::Recip { out, b } => {
                if k == 0 {
                    1.0 / at(s, b, 0)
                } else {
                    -conv(s, w, b, out, 1, k, k, k, false) / at(s, b, 0)
                }
            }
            Op::Exp { out, a } => {
                if k == 0 {
                    at(s, a, 0).exp()
                } else {
                    conv(s, w, a, out, 1, k, k, k, true) * inv_k
                }
            }
            Op::Ln { out, a } => {
                if k == 0 {
                    at(s, a, 0).ln()
                } else {
                    (at(s, a, k) - conv(s, w, out, a, 1, k - 1, k, k, true) * inv_k) / at(s, a, 0)
                }
            }
            Op::Sqrt { out, a } => {
                if k == 0 {
                    at(s, a, 0).sqrt()
                } else {
                    (at(s, a, k) - conv(s, w, out, out, 1, k - 1, k, k, false))
                        / (2.0 * at(s, out, 0))
                }
            }
            Op::SinCos {
                s: sr,
                c: cr,
                a,
                hyperbolic,
                degree,
                da,
            } => {
                let (sv, cv) = if k == 0 {
                    let x = at(s, a, 0);
                    if hyperbolic {
                        (x.sinh(), x.cosh())
                    } else {
                        x.sin_cos()
                    }
                } else if let Some(da) = da {
                    let hi = degree.map_or(k - 1, |d| d.saturating_sub(1).min(k - 1));
                    let sv = conv(s, w, da, cr, 0, hi, k - 1, k, false) * inv_k;
                    let cv = conv(s, w, da, sr, 0, hi, k - 1, k, false) * inv_k;
                    (sv, if hyperbolic { cv } else { -cv })
                } else {
                    let hi = degree.map_or(k, |d| d.min(k));
                    let sv = conv(s, w, a, cr, 1, hi, k, k, true) * inv_k;
                    let cv = conv(s, w, a, sr, 1, hi, k, k, true) * inv_k;
                    (sv, if hyperbolic { cv } else { -cv })
                };
                s[sr * w + k] = sv;
                s[cr * w + k] = cv;
                return;
            }
            Op::Tan {
                out,
                w: wr,
                a,
                hyperbolic,
            } => {
                let t = if k == 0 {
                    let x = at(s, a, 0);
                    if hyperbolic { x.tanh() } else { x.tan() }
                } else {
                    conv(s, w, a, wr, 1, k, k, k, true) * inv_k
                };
                s[out * w + k] = t;
                let sq = conv(s, w, out, out, 0, k, k, k, false);
                let sq = if hyperbolic { -sq } else { sq };
                s[wr * w + k] = if k == 0 { 1.0 + sq } else { sq };
                return;
            }
            Op::Abs { a, .. } => {
                let x = at(s, a, k);
                if k == 0 {
                    x.abs()
                } else if at(s, a, 0) > 0.0 {
                    x
                } else {
                    -x
                }
            }
            Op::Sign { a, .. } => {
                if k == 0 {
                    sign(at(s, a, 0))
                } else {
                    0.0
                }
            }
            Op::Atan2 { y, x, d, r, .. } => {
                let dk = conv(s, w, x, x, 0, k, k, k, false) + conv(s, w, y, y, 0, k, k, k, false);
                s[d * w + k] = dk;
                if k == 0 {
                    at(s, y, 0).atan2(at(s, x, 0))
                } else {
                    let n = conv(s, w, y, x, 1, k, k, k, true) - conv(s, w, x, y, 1, k, k, k, true);
                    let rk = (n - conv(s, w, d, r, 1, k - 1, k - 1, k, false)) / at(s, d, 0);
                    s[r * w + k - 1] = rk;
                    rk * inv_k
                }
            }
        };
        // (SinCos and Tan write their two rows above.)
        s[self.out() * w + k] = value;
    }
}

/// The part of a graph that M and f need, lowered to recurrences, ready to expand.
#[derive(Debug)]
pub struct TaylorProgram {
    pub(crate) dof: usize,
    /// Rows in the table: one per node, then the auxiliary rows.
    pub(crate) rows: usize,
    /// The recurrences of the rows fixed by the parameters: run once per binding.
    fixed: Vec<Op>,
    /// The recurrences of the rows the state sets: what order 0 runs.
    pub(crate) order0: Vec<Op>,
    /// The recurrences of the nodes that depend on t, q or q̇: what orders ≥ 1 run.
    pub(crate) varying: Vec<Op>,
    /// Rows of the numbers and parameters (index into the parameters), written at binding.
    numbers: Vec<(usize, f64)>,
    params: Vec<(usize, usize)>,
    /// Rows of t and of each qᵢ, q̇ᵢ the model reads.
    pub(crate) time: Option<usize>,
    pub(crate) coords: Vec<Option<usize>>,
    pub(crate) velocities: Vec<Option<usize>>,
    /// Rows of f.
    pub(crate) force: Vec<usize>,
    /// Row of M(r, c) at r·n + c.
    pub(crate) mass_full: Vec<usize>,
    /// Whether M(r, c) (at r·n + c) depends on t or q: the entries that do not have Mⱼ = 0 for
    /// j ≥ 1 and no terms in Σⱼ Mⱼ q̈ₖ₋ⱼ (the diagonal of a chain's M, all of a constant M).
    pub(crate) mass_varying: Vec<bool>,
    /// Whether M depends on the parameters alone (then M₀ is factored once per expansion's
    /// work space).
    pub(crate) mass_constant: bool,
    /// Which entries of M₀'s factor L (at r·n + c, below the diagonal) may be nonzero, when
    /// M's zeros by structure make some zero ([`linalg::ldlt_pattern`]; `None`: none do): the
    /// solves skip those (a diagonal M: the ball, Kepler in polar coordinates, the forced
    /// two-mass).
    pub(crate) factor_nonzero: Option<Vec<bool>>,
    /// The recurrences as machine code, compiled at the first expansion (`None`: not allowed,
    /// or Cranelift could not compile them, and the interpreter runs).
    #[cfg(feature = "jit")]
    native: OnceLock<Option<kernel::SeriesKernel>>,
    /// The whole expansion to order p unrolled into machine code, at index p, compiled after
    /// `UNROLL_AFTER` expansions to that order (`None`: too large to unroll, not allowed, or
    /// Cranelift failed), and the expansions to each order so far.
    #[cfg(feature = "jit")]
    unrolled: Box<[OnceLock<Option<kernel::ExpansionKernel>>]>,
    #[cfg(feature = "jit")]
    expansions: Box<[AtomicUsize]>,
    #[cfg(feature = "jit")]
    allow_native: bool,
    /// Work spaces of dropped expansions, for the next ones ([`Workspace`]).
    spares: Mutex<Vec<Workspace>>,
}

/// How far a row's series reaches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Reach {
    /// A number fixed by the parameters: computed once per binding.
    Fixed,
    /// Set by the state at order 0, nothing beyond (sign(q), and what only scales it).
    Order0,
    /// A series in t.
    Varying,
}

/// Builds the recurrences, allocating auxiliary rows after the node rows.
struct Lowering {
    rows: usize,
    fixed: Vec<Op>,
    order0: Vec<Op>,
    varying: Vec<Op>,
}

impl Lowering {
    fn row(&mut self) -> usize {
        self.rows += 1;
        self.rows - 1
    }

    fn push(&mut self, op: Op, reach: Reach) {
        match reach {
            Reach::Fixed => self.fixed.push(op),
            Reach::Order0 => self.order0.push(op),
            Reach::Varying => {
                self.order0.push(op);
                self.varying.push(op);
            }
        }
    }
}

impl Lowering {
    /// Take the negations off every order where that changes no bit: a negation −a read by a
    /// sum or a difference becomes its sign (x + (−a) = x − a and x − (−a) = x + a exactly),
    /// one squared goes ((−a)² = a², every product of its sum exactly),
    /// read by a scaling it moves onto the constant ((−a) c = a (−c) exactly, −c computed once
    /// per binding); one left unread (and not M or f, which `outside` holds) is dropped. The
    /// derivatives of energies are full of them (∂U/∂q of −m g l cos θ, the signs of eq. 55).
    fn fold_negations(&mut self, outside: &HashSet<usize>) {
        let negated: HashMap<usize, usize> = (self.order0.iter())
            .filter_map(|op| match *op {
                Op::Neg { out, a } => Some((out, a)),
                _ => None,
            })
            .collect();
        if negated.is_empty() {
            return;
        }
        // The negated constants, as rows fixed at binding (of constants fixed at binding: not
        // of a row set at order 0 by the state, sign(x)).
        let state: HashSet<usize> = self.order0.iter().flat_map(Op::outputs).collect();
        let mut minus: HashMap<usize, usize> = HashMap::new();
        let mut rewrite = |op: Op, rows: &mut usize, fixed: &mut Vec<Op>| -> Op {
            match op {
                Op::Add { out, a, b } if negated.contains_key(&b) && a != b => Op::Sub {
                    out,
                    a,
                    b: negated[&b],
                },
                Op::Add { out, a, b } if negated.contains_key(&a) && a != b => Op::Sub {
                    out,
                    a: b,
                    b: negated[&a],
                },
                Op::Sub { out, a, b } if negated.contains_key(&b) && a != b => Op::Add {
                    out,
                    a,
                    b: negated[&b],
                },
                Op::Square { out, a } if negated.contains_key(&a) => Op::Square {
                    out,
                    a: negated[&a],
                },
                Op::Scale { out, a, c } if negated.contains_key(&a) && !state.contains(&c) => {
                    let c = *minus.entry(c).or_insert_with(|| {
                        *rows += 1;
                        fixed.push(Op::Neg {
                            out: *rows - 1,
                            a: c,
                        });
                        *rows - 1
                    });
                    Op::Scale {
                        out,
                        a: negated[&a],
                        c,
                    }
                }
                op => op,
            }
        };
        // Each operation is in `order0`, and the ones that vary in `varying` too: rewritten
        // alike, by their output.
        let mut rewritten: HashMap<Op, Op> = HashMap::new();
        for op in &mut self.order0 {
            let new = rewrite(*op, &mut self.rows, &mut self.fixed);
            rewritten.insert(*op, new);
            *op = new;
        }
        for op in &mut self.varying {
            *op = rewritten[op];
        }
        let read: HashSet<usize> = (self.order0.iter())
            .flat_map(Op::operands)
            .chain(outside.iter().copied())
            .collect();
        let unread = |op: &Op| matches!(op, Op::Neg { out, .. } if !read.contains(out));
        self.order0.retain(|op| !unread(op));
        self.varying.retain(|op| !unread(op));
    }
}

impl Lowering {
    /// Turn a quotient of a quotient by the same series, (x / b) / b, into one quotient by the
    /// square the program already computes, x / b², and −(x / b) / b into −(x / b²), when the
    /// inner quotient (and the negation) is read nowhere else: a convolution fewer at every
    /// order. Polar coordinates make them: ∂U/∂r of −μ/r is μ/r / r, beside M's r². The
    /// coefficients move by an ulp or so (one quotient by a rounded square for two quotients).
    fn fold_quotients(&mut self, outside: &HashSet<usize>) {
        let mut reads: HashMap<usize, usize> = HashMap::new();
        for r in self.order0.iter().flat_map(Op::operands) {
            *reads.entry(r).or_insert(0) += 1;
        }
        let once = |r: usize| reads.get(&r) == Some(&1) && !outside.contains(&r);
        let made: HashMap<usize, Op> = self.order0.iter().map(|op| (op.out(), *op)).collect();
        let varies: HashSet<Op> = self.varying.iter().copied().collect();
        // The squares the program computes at every order it computes them, by their operand.
        let squares: HashMap<usize, Op> = (self.order0.iter())
            .filter_map(|op| match *op {
                Op::Square { a, .. } => Some((a, *op)),
                _ => None,
            })
            .collect();
        // (old outer quotient, the inner ops it replaces, its replacements).
        let mut rewrites: Vec<(Op, Vec<Op>, Vec<Op>)> = Vec::new();
        // The rows of the ops rewritten so far: a rewrite touching one is left out (a quotient
        // of a quotient of a quotient folds its first two).
        let mut touched: HashSet<usize> = HashSet::new();
        for &op in &self.order0 {
            let Op::Div { out, a, b } = op else { continue };
            let Some(&square) = squares.get(&b) else {
                continue;
            };
            // Computed before the quotient, at every order the quotient is.
            let position = |x: Op| self.order0.iter().position(|&o| o == x);
            if position(square) > position(op) || varies.contains(&op) && !varies.contains(&square)
            {
                continue;
            }
            let inner = |r: usize| match made.get(&r) {
                Some(&Op::Div { a: x, b: c, .. }) if c == b && once(r) => Some(x),
                _ => None,
            };
            let sq = square.out();
            if let Some(x) = inner(a) {
                let new = Op::Div { out, a: x, b: sq };
                if ![x, out, a].iter().any(|r| touched.contains(r)) {
                    touched.extend([out, a]);
                    rewrites.push((op, vec![made[&a]], vec![new]));
                }
            } else if let Some(&Op::Neg { a: m, .. }) = made.get(&a)
                && once(a)
                && let Some(x) = inner(m)
            {
                let quotient = Op::Div {
                    out: m,
                    a: x,
                    b: sq,
                };
                let negation = Op::Neg { out, a: m };
                if ![x, out, a, m].iter().any(|r| touched.contains(r)) {
                    touched.extend([out, a, m]);
                    rewrites.push((op, vec![made[&a], made[&m]], vec![quotient, negation]));
                }
            }
        }
        for (old, gone, new) in rewrites {
            for list in [&mut self.order0, &mut self.varying] {
                if let Some(at) = list.iter().position(|&o| o == old) {
                    list.splice(at..=at, new.iter().copied());
                }
                list.retain(|op| !gone.contains(op));
            }
        }
    }
}

impl Lowering {
    /// Fold a scaling of a scaling read nowhere else, (x c₁) c₂, into one, x (c₁ c₂), with
    /// c₁ c₂ a row fixed at binding (of constants fixed at binding): one operation fewer at every
    /// order. The derivatives of quadratic energies are full of them (∂U/∂x of ½ k (x₂ − x₁)²
    /// is (x₂ − x₁) 2 · ½ k). The products round once where they rounded twice: the
    /// coefficients move by an ulp or so, as the same model stated in another order would.
    fn fold_scalings(&mut self, outside: &HashSet<usize>) {
        let state: HashSet<usize> = self.order0.iter().flat_map(Op::outputs).collect();
        loop {
            let mut reads: HashMap<usize, usize> = HashMap::new();
            for r in self.order0.iter().flat_map(Op::operands) {
                *reads.entry(r).or_insert(0) += 1;
            }
            let inner: HashMap<usize, (usize, usize)> = (self.order0.iter())
                .filter_map(|op| match *op {
                    Op::Scale { out, a, c }
                        if reads.get(&out) == Some(&1)
                            && !outside.contains(&out)
                            && !state.contains(&c) =>
                    {
                        Some((out, (a, c)))
                    }
                    _ => None,
                })
                .collect();
            // The first scaling of an inner one, folded.
            let Some((at, outer)) = self
                .order0
                .iter()
                .enumerate()
                .find_map(|(i, op)| match *op {
                    Op::Scale { out, a, c } if inner.contains_key(&a) && !state.contains(&c) => {
                        Some((i, (out, a, c)))
                    }
                    _ => None,
                })
            else {
                return;
            };
            let (out, s, c2) = outer;
            let (x, c1) = inner[&s];
            let c12 = self.row();
            self.fixed.push(Op::Scale {
                out: c12,
                a: c1,
                c: c2,
            });
            let old = self.order0[at];
            let new = Op::Scale { out, a: x, c: c12 };
            let gone = |op: &Op| matches!(op, Op::Scale { out, .. } if *out == s);
            for list in [&mut self.order0, &mut self.varying] {
                for op in list.iter_mut().filter(|op| **op == old) {
                    *op = new;
                }
                list.retain(|op| !gone(op));
            }
        }
    }
}

impl Lowering {
    /// Read the row a copy copies, or a scaling by exactly 1 scales, in place of theirs, and drop
    /// them (in M and f, `outside`, too): no bit changes, and an operation fewer at every order.
    /// Powers make copies (x² is a square, copied into the node's row), and so does sin beside
    /// cos of one argument; the derivatives of ½ m v² scale by ½ · 2. Which numbers are 1 is
    /// known here, where the rows fixed by numbers alone are computed once (`numbers`): a row
    /// that reads a parameter, however far back, is not (sign(p) is ±1 whatever p is).
    fn alias_rows(&mut self, numbers: &[(usize, f64)], outside: [&mut [usize]; 2]) {
        let mut values = vec![0.0; self.rows];
        let mut known = vec![false; self.rows];
        for &(r, x) in numbers {
            (values[r], known[r]) = (x, true);
        }
        for op in &self.fixed {
            if op.operands().iter().all(|&r| known[r]) {
                op.apply(&mut values, 1, 0);
                for r in op.outputs() {
                    known[r] = true;
                }
            }
        }
        let alias: HashMap<usize, usize> = (self.order0.iter())
            .filter_map(|op| match *op {
                Op::Copy { out, a } => Some((out, a)),
                Op::Scale { out, a, c } if known[c] && values[c] == 1.0 => Some((out, a)),
                _ => None,
            })
            .collect();
        if alias.is_empty() {
            return;
        }
        // A row an alias reads may be an alias itself (chains end: each reads an earlier row).
        let resolve = |mut r: usize| {
            while let Some(&a) = alias.get(&r) {
                r = a;
            }
            r
        };
        for list in [&mut self.order0, &mut self.varying] {
            list.retain(|op| !alias.contains_key(&op.out()));
            for op in list.iter_mut() {
                for r in op.operands_mut() {
                    *r = resolve(*r);
                }
            }
        }
        for r in outside.into_iter().flatten() {
            *r = resolve(*r);
        }
    }

    /// Drop from the orders above 0 the recurrences whose rows no order above 0 reads there
    /// (nor M and f, `outside`): ω t feeding only sin ω t and cos ω t, which sum ω instead.
    /// Order 0 still computes them; no bit changes, and an operation fewer at every order.
    fn drop_unread_orders(&mut self, outside: &[usize]) {
        let mut read: HashSet<usize> = outside.iter().copied().collect();
        let mut kept = Vec::with_capacity(self.varying.len());
        for op in self.varying.iter().rev() {
            if op.outputs().iter().any(|r| read.contains(r)) {
                read.extend(op.operands_above_zero());
                kept.push(*op);
            }
        }
        kept.reverse();
        self.varying = kept;
    }
}

/// The derivative of a node's series, as a row: d/dt of what it is ([`Derivatives::of`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Derivative {
    /// Zero: a number or a parameter.
    Zero,
    Row(usize),
}

/// Rows for the derivatives a′ of the arguments of sin and cos where they are linear in the
/// velocities and t, so that `Op::SinCos` sums a′ₘ instead of weighing j aⱼ (made during the
/// lowering, whose state it borrows).
struct Derivatives<'a> {
    all: &'a [Node],
    row: &'a [usize],
    reach: &'a [Reach],
    velocity_rows: &'a [Option<usize>],
    low: &'a mut Lowering,
    numbers: &'a mut Vec<(usize, f64)>,
    velocities: &'a mut Vec<Option<usize>>,
    done: &'a mut HashMap<usize, Option<(Derivative, Reach)>>,
}

impl Derivatives<'_> {
    /// d/dt of node k's series and how far the derivative's series reaches: qᵢ′ is q̇ᵢ's row
    /// (made, and written with the other velocities, if the graph reads none), t′ a row of 1,
    /// a number's 0, and sums, differences, negations and products and quotients by constants
    /// follow; `None` for anything else (its series has no row of its derivative).
    fn of(&mut self, k: usize) -> Option<(Derivative, Reach)> {
        if let Some(&known) = self.done.get(&k) {
            return known;
        }
        // Fixed by the parameters (or, sign(x), by the state at order 0): nothing beyond order 0.
        if self.reach[self.row[k]] != Reach::Varying {
            return Some((Derivative::Zero, Reach::Fixed));
        }
        let fixed = |g: &Self, x: usize| g.reach[g.row[x]] != Reach::Varying;
        let derivative = match self.all[k] {
            Node::Const(_) | Node::Param(_) => Some((Derivative::Zero, Reach::Fixed)),
            Node::Coord(i) => {
                let r = match self.velocity_rows[i].or(self.velocities[i]) {
                    Some(r) => r,
                    None => {
                        let r = self.low.row();
                        self.velocities[i] = Some(r);
                        r
                    }
                };
                Some((Derivative::Row(r), Reach::Varying))
            }
            Node::Time => {
                let r = self.low.row();
                self.numbers.push((r, 1.0));
                Some((Derivative::Row(r), Reach::Fixed))
            }
            Node::Unary(Unary::Neg, a) => match self.of(a)? {
                (Derivative::Zero, reach) => Some((Derivative::Zero, reach)),
                (Derivative::Row(a), reach) => Some(self.push(|out| Op::Neg { out, a }, reach)),
            },
            Node::Binary(f @ (Binary::Add | Binary::Sub), a, b) => {
                match (self.of(a)?, self.of(b)?) {
                    ((Derivative::Zero, _), (Derivative::Zero, _)) => {
                        Some((Derivative::Zero, Reach::Fixed))
                    }
                    (x, (Derivative::Zero, _)) => Some(x),
                    ((Derivative::Zero, _), (Derivative::Row(b), reach)) => match f {
                        Binary::Add => Some((Derivative::Row(b), reach)),
                        _ => Some(self.push(|out| Op::Neg { out, a: b }, reach)),
                    },
                    ((Derivative::Row(a), ra), (Derivative::Row(b), rb)) => {
                        let reach = ra.max(rb);
                        Some(match f {
                            Binary::Add => self.push(|out| Op::Add { out, a, b }, reach),
                            _ => self.push(|out| Op::Sub { out, a, b }, reach),
                        })
                    }
                }
            }
            Node::Binary(Binary::Mul, a, b) if fixed(self, a) || fixed(self, b) => {
                let (x, c) = if fixed(self, a) { (b, a) } else { (a, b) };
                let c = self.row[c];
                match self.of(x)? {
                    (Derivative::Zero, reach) => Some((Derivative::Zero, reach)),
                    (Derivative::Row(a), reach) => {
                        let reach = reach.max(self.reach[c]);
                        Some(self.push(|out| Op::Scale { out, a, c }, reach))
                    }
                }
            }
            Node::Binary(Binary::Div, a, b) if fixed(self, b) => {
                let c = self.row[b];
                match self.of(a)? {
                    (Derivative::Zero, reach) => Some((Derivative::Zero, reach)),
                    (Derivative::Row(a), reach) => {
                        let reach = reach.max(self.reach[c]);
                        Some(self.push(|out| Op::DivC { out, a, c }, reach))
                    }
                }
            }
            _ => None,
        };
        self.done.insert(k, derivative);
        derivative
    }

    /// A new row computed by `op`, reaching as far as `reach`.
    fn push(&mut self, op: impl FnOnce(usize) -> Op, reach: Reach) -> (Derivative, Reach) {
        let out = self.low.row();
        self.low.push(op(out), reach);
        (Derivative::Row(out), reach)
    }
}

impl TaylorProgram {
    /// The nodes of `graph` that `eom`'s M and f read, lowered to recurrences.
    pub fn new(graph: &Graph, dof: usize, mass_nodes: &[usize], force_nodes: &[usize]) -> Self {
        let all = graph.nodes();
        let mut needed = vec![false; all.len()];
        for &o in mass_nodes.iter().chain(force_nodes) {
            needed[o] = true;
        }
        for k in (0..all.len()).rev() {
            if !needed[k] {
                continue;
            }
            match all[k] {
                Node::Unary(_, a) | Node::PowI(a, _) => needed[a] = true,
                Node::Binary(_, a, b) => {
                    needed[a] = true;
                    needed[b] = true;
                }
                _ => {}
            }
        }
        // Node rows first, in topological order.
        let mut row = vec![usize::MAX; all.len()];
        let mut kept = Vec::new();
        for (k, _) in all.iter().enumerate().filter(|&(k, _)| needed[k]) {
            row[k] = kept.len();
            kept.push(k);
        }
        let mut low = Lowering {
            rows: kept.len(),
            fixed: Vec::new(),
            order0: Vec::new(),
            varying: Vec::new(),
        };
        let (mut numbers, mut params) = (Vec::new(), Vec::new());
        let (mut time, mut coords, mut velocities) = (None, vec![None; dof], vec![None; dof]);
        let mut reach = vec![Reach::Fixed; kept.len()];
        // The rows of the velocities the graph reads, and the derivatives of the arguments of sin
        // and cos made so far, by node.
        let velocity_rows: Vec<Option<usize>> = (0..dof)
            .map(|i| (kept.iter()).position(|&k| matches!(all[k], Node::Velocity(j) if j == i)))
            .collect();
        let mut derivatives: HashMap<usize, Option<(Derivative, Reach)>> = HashMap::new();
        // The degree of each node row's series when it is a polynomial in t (numbers 0, t 1),
        // None when it is not (the state's rows, and what they reach).
        let mut degree = vec![Some(0); kept.len()];
        // sin and cos (or sinh and cosh) of a row, computed together: (row, hyperbolic) → (s, c).
        let mut trig: HashMap<(usize, bool), (usize, usize)> = HashMap::new();
        for (out, &k) in kept.iter().enumerate() {
            let at = |r: usize| reach[r];
            let v = |r: usize| reach[r] == Reach::Varying;
            degree[out] = match all[k] {
                Node::Time => Some(1),
                Node::Coord(_) | Node::Velocity(_) => None,
                Node::Unary(_, a) | Node::PowI(a, _) if !v(row[a]) => Some(0),
                Node::Unary(Unary::Neg, a) => degree[row[a]],
                Node::PowI(a, n) if n >= 0 => degree[row[a]].map(|d| d * n.unsigned_abs() as usize),
                Node::Binary(Binary::Add | Binary::Sub, a, b) => {
                    degree[row[a]].zip(degree[row[b]]).map(|(x, y)| x.max(y))
                }
                Node::Binary(Binary::Mul, a, b) => {
                    degree[row[a]].zip(degree[row[b]]).map(|(x, y)| x + y)
                }
                Node::Binary(Binary::Div, a, b) if !v(row[b]) => degree[row[a]],
                Node::Binary(_, a, b) if !v(row[a]) && !v(row[b]) => Some(0),
                Node::Const(_) | Node::Param(_) => Some(0),
                _ => None,
            };
            let (op, var) = match all[k] {
                Node::Const(x) => {
                    numbers.push((out, x));
                    (None, Reach::Fixed)
                }
                Node::Param(p) => {
                    params.push((out, p));
                    (None, Reach::Fixed)
                }
                Node::Time | Node::Coord(_) | Node::Velocity(_) => {
                    match all[k] {
                        Node::Time => time = Some(out),
                        Node::Coord(i) => coords[i] = Some(out),
                        Node::Velocity(i) => velocities[i] = Some(out),
                        _ => unreachable!(),
                    }
                    (None, Reach::Varying)
                }
                Node::Unary(f, a) => {
                    let a = row[a];
                    let op = match f {
                        Unary::Neg => Op::Neg { out, a },
                        Unary::Sin | Unary::Cos | Unary::Sinh | Unary::Cosh => {
                            let hyperbolic = matches!(f, Unary::Sinh | Unary::Cosh);
                            let sine = matches!(f, Unary::Sin | Unary::Sinh);
                            if let Some(&(s, c)) = trig.get(&(a, hyperbolic)) {
                                // Its partner is computed already (sin(θ₁ − θ₂) beside
                                // cos(θ₁ − θ₂)): a copy, not a second pair of sums.
                                Op::Copy {
                                    out,
                                    a: if sine { s } else { c },
                                }
                            } else {
                                let partner = low.row();
                                let (s, c) = if sine { (out, partner) } else { (partner, out) };
                                trig.insert((a, hyperbolic), (s, c));
                                let mut d = Derivatives {
                                    all,
                                    row: &row,
                                    reach: &reach,
                                    velocity_rows: &velocity_rows,
                                    low: &mut low,
                                    numbers: &mut numbers,
                                    velocities: &mut velocities,
                                    done: &mut derivatives,
                                };
                                let da = match d.of(kept[a]) {
                                    Some((Derivative::Row(r), _)) => Some(r),
                                    _ => None,
                                };
                                Op::SinCos {
                                    s,
                                    c,
                                    a,
                                    hyperbolic,
                                    degree: degree[a],
                                    da,
                                }
                            }
                        }
                        Unary::Tan | Unary::Tanh => Op::Tan {
                            out,
                            w: low.row(),
                            a,
                            hyperbolic: f == Unary::Tanh,
                        },
                        Unary::Exp => Op::Exp { out, a },
                        Unary::Ln => Op::Ln { out, a },
                        Unary::Sqrt => Op::Sqrt { out, a },
                        Unary::Abs => Op::Abs { out, a },
                        // ±1: nothing beyond order 0.
                        Unary::Sign => {
                            let r = at(a).min(Reach::Order0);
                            low.push(Op::Sign { out, a }, r);
                            reach[out] = r;
                            continue;
                        }
                    };
                    (Some(op), at(a))
                }
                Node::Binary(f, a, b) => {
                    let (a, b) = (row[a], row[b]);
                    let var = at(a).max(at(b));
                    let op = match f {
                        Binary::Add => Op::Add { out, a, b },
                        Binary::Sub => Op::Sub { out, a, b },
                        Binary::Mul if !v(a) => Op::Scale { out, a: b, c: a },
                        Binary::Mul if !v(b) => Op::Scale { out, a, c: b },
                        Binary::Mul if a == b => Op::Square { out, a },
                        Binary::Mul => Op::Mul { out, a, b },
                        Binary::Div if !v(b) => Op::DivC { out, a, c: b },
                        Binary::Div => Op::Div { out, a, b },
                        Binary::Pow => {
                            // aᵇ = exp(b ln a).
                            let (l, m) = (low.row(), low.row());
                            low.push(Op::Ln { out: l, a }, at(a));
                            low.push(Op::Mul { out: m, a: b, b: l }, var);
                            Op::Exp { out, a: m }
                        }
                        Binary::Atan2 => Op::Atan2 {
                            out,
                            y: a,
                            x: b,
                            d: low.row(),
                            r: low.row(),
                        },
                    };
                    (Some(op), var)
                }
                Node::PowI(a, n) => {
                    let a = row[a];
                    if n == 0 {
                        // 1: a number.
                        numbers.push((out, 1.0));
                        reach[out] = Reach::Fixed;
                        continue;
                    }
                    // a^|n| by squaring, each product in a row of its own.
                    let (mut base, mut acc, mut m) = (a, None, n.unsigned_abs());
                    loop {
                        if m & 1 == 1 {
                            acc = Some(match acc {
                                None => base,
                                Some(r) => {
                                    let p = low.row();
                                    low.push(
                                        Op::Mul {
                                            out: p,
                                            a: r,
                                            b: base,
                                        },
                                        at(a),
                                    );
                                    p
                                }
                            });
                        }
                        m >>= 1;
                        if m == 0 {
                            break;
                        }
                        let sq = low.row();
                        low.push(Op::Square { out: sq, a: base }, at(a));
                        base = sq;
                    }
                    let power = acc.unwrap_or(a);
                    let op = if n > 0 {
                        Op::Copy { out, a: power }
                    } else {
                        Op::Recip { out, b: power }
                    };
                    (Some(op), at(a))
                }
            };
            reach[out] = var;
            if let Some(op) = op {
                low.push(op, var);
            }
        }
        let mut mass: Vec<usize> = mass_nodes.iter().map(|&o| row[o]).collect();
        let mut force: Vec<usize> = force_nodes.iter().map(|&o| row[o]).collect();
        let outside: HashSet<usize> = mass.iter().chain(&force).copied().collect();
        low.fold_quotients(&outside);
        low.fold_negations(&outside);
        low.fold_scalings(&outside);
        // M's reach is its node rows' (the rows they may read through after `alias_rows` are
        // auxiliary rows of the same reach).
        let mass_reach: Vec<Reach> = mass.iter().map(|&r| reach[r]).collect();
        low.alias_rows(&numbers, [&mut mass, &mut force]);
        low.drop_unread_orders(&[&mass[..], &force[..]].concat());
        // Entry of M(r, c) from the upper triangle, row by row.
        let upper = |r: usize, c: usize| {
            let (i, l) = if r <= c { (r, c) } else { (c, r) };
            i * dof - i * (i + 1) / 2 + l
        };
        let entries = (0..dof * dof).map(|e| upper(e / dof, e % dof));
        let mass_varying: Vec<bool> = entries
            .clone()
            .map(|e| mass_reach[e] == Reach::Varying)
            .collect();
        let mass_full: Vec<usize> = entries.map(|e| mass[e]).collect();
        let zero = |e: usize| {
            !mass_varying[e] && numbers.iter().any(|&(r, x)| r == mass_full[e] && x == 0.0)
        };
        let factor_nonzero =
            Some(linalg::ldlt_pattern(dof, zero)).filter(|p| !p.iter().all(|&x| x));
        Self {
            factor_nonzero,
            mass_varying,
            mass_full,
            dof,
            rows: low.rows,
            mass_constant: mass_reach.iter().all(|&r| r == Reach::Fixed),
            force,
            fixed: low.fixed,
            order0: low.order0,
            varying: low.varying,
            numbers,
            params,
            time,
            coords,
            velocities,
            #[cfg(feature = "jit")]
            native: OnceLock::new(),
            #[cfg(feature = "jit")]
            unrolled: (0..=MAX_TAYLOR_ORDER).map(|_| OnceLock::new()).collect(),
            #[cfg(feature = "jit")]
            expansions: (0..=MAX_TAYLOR_ORDER)
                .map(|_| AtomicUsize::new(0))
                .collect(),
            #[cfg(feature = "jit")]
            allow_native: true,
            spares: Mutex::new(Vec::new()),
        }
    }

    /// Number of coordinates.
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// The same program, never compiled: the interpreter's reference (`backend="interpreter"`).
    pub(crate) fn interpreted(&self) -> Self {
        Self {
            dof: self.dof,
            rows: self.rows,
            fixed: self.fixed.clone(),
            order0: self.order0.clone(),
            varying: self.varying.clone(),
            numbers: self.numbers.clone(),
            params: self.params.clone(),
            time: self.time,
            coords: self.coords.clone(),
            velocities: self.velocities.clone(),
            mass_full: self.mass_full.clone(),
            force: self.force.clone(),
            mass_varying: self.mass_varying.clone(),
            mass_constant: self.mass_constant,
            factor_nonzero: self.factor_nonzero.clone(),
            #[cfg(feature = "jit")]
            native: OnceLock::new(),
            #[cfg(feature = "jit")]
            unrolled: Box::new([]),
            #[cfg(feature = "jit")]
            expansions: Box::new([]),
            #[cfg(feature = "jit")]
            allow_native: false,
            spares: Mutex::new(Vec::new()),
        }
    }

    /// The recurrences as machine code, compiled on the first call (`None` without the `jit`
    /// feature, for an interpreted program, or where Cranelift failed).
    #[cfg(feature = "jit")]
    fn kernel(&self) -> Option<&kernel::SeriesKernel> {
        if !self.allow_native {
            return None;
        }
        self.native
            .get_or_init(|| kernel::SeriesKernel::compile(&self.varying, self.rows).ok())
            .as_ref()
    }

    /// The expansion to `order` unrolled into machine code, once this program has expanded to
    /// that order `UNROLL_AFTER` times (compiled then); `None` before, without the `jit`
    /// feature, for an interpreted program, for one too large to unroll, or where Cranelift
    /// failed.
    #[cfg(feature = "jit")]
    fn unrolled(&self, order: usize) -> Option<&kernel::ExpansionKernel> {
        let cell = self.unrolled.get(order)?;
        if let Some(kernel) = cell.get() {
            return kernel.as_ref();
        }
        let count = self.expansions[order].fetch_add(1, Ordering::Relaxed);
        if count < kernel::UNROLL_AFTER {
            return None;
        }
        self.compile_unrolled(order)
    }

    /// The expansion to `order` unrolled, if it is compiled (not counted as an expansion).
    #[cfg(feature = "jit")]
    fn compiled(&self, order: usize) -> Option<&kernel::ExpansionKernel> {
        self.unrolled.get(order)?.get()?.as_ref()
    }

    #[cfg(feature = "jit")]
    fn compile_unrolled(&self, order: usize) -> Option<&kernel::ExpansionKernel> {
        self.unrolled
            .get(order)?
            .get_or_init(|| kernel::ExpansionKernel::compile(self, order).ok())
            .as_ref()
    }

    /// Compile the expansion to `order` unrolled into machine code now, rather than after
    /// `UNROLL_AFTER` expansions (for a test or a benchmark of the steady state): whether
    /// expansions to `order` run it from now on (false without the `jit` feature, for an
    /// interpreted program, for one too large to unroll, or where Cranelift failed).
    pub fn unroll(&self, order: usize) -> bool {
        #[cfg(feature = "jit")]
        return self.compile_unrolled(order).is_some();
        #[cfg(not(feature = "jit"))]
        {
            let _ = order;
            false
        }
    }

    /// Whether expansions to `order` run the unrolled code now (compiled by [`Self::unroll`]
    /// or after `UNROLL_AFTER` expansions to that order).
    pub fn is_unrolled(&self, order: usize) -> bool {
        #[cfg(feature = "jit")]
        return self.compiled(order).is_some();
        #[cfg(not(feature = "jit"))]
        {
            let _ = order;
            false
        }
    }

    /// Recurrences run at each order ≥ 1 (the nodes that vary and their auxiliary rows).
    pub fn recurrences(&self) -> usize {
        self.varying.len()
    }

    /// About the machine instructions of one expansion to `order` compiled unrolled (orders
    /// 1 to p − 1 of q̈; order 0 is evaluated as the accelerations are): three per term of a
    /// convolution (two loads and a product, and its sum) and a few per recurrence, per
    /// Σⱼ Mⱼ q̈ₖ₋ⱼ term and per entry of the solve, at each order. It decides which programs
    /// are small enough to unroll, and `Method::Auto`'s estimate of a Taylor step's cost.
    pub fn expansion_instructions(&self, order: usize) -> usize {
        let n = self.dof;
        (1..order)
            .map(|k| {
                let ops: usize = self.varying.iter().map(|op| 3 * op.terms(k) + 4).sum();
                let mass = 4 * self.mass_varying.iter().filter(|&&v| v).count() * k;
                ops + mass + 3 * n * n + 8 * n
            })
            .sum()
    }

    /// Operations of order 0 (the rows of M and f at the expansion point, evaluated as the
    /// accelerations are), and how many of them call the maths library (eˣ, ln, sin and cos,
    /// tan, atan2): `Method::Auto` weighs a step's cost with them.
    pub fn order0_operations(&self) -> (usize, usize) {
        let calls = self.order0.iter().filter(|op| op.calls_libm()).count();
        (self.order0.len(), calls)
    }

    /// Whether the motion has a Taylor series wherever the model is defined: no |x| or sign(x)
    /// of the state, whose series say nothing of the kink at 0 (a step would run past it).
    pub fn is_analytic(&self) -> bool {
        !self
            .order0
            .iter()
            .any(|op| matches!(op, Op::Abs { .. } | Op::Sign { .. }))
    }

    /// Whether the expansions run machine code (compiling it now if it is not yet).
    pub fn is_native(&self) -> bool {
        #[cfg(feature = "jit")]
        return self.kernel().is_some();
        #[cfg(not(feature = "jit"))]
        false
    }

    /// Work space for expansions up to `order` with these parameter values: a spare one when
    /// an expansion to `order` was dropped before (rebound if its parameters differ).
    ///
    /// # Panics
    /// If `params` is shorter than the parameters the program reads.
    pub fn expansion(self: &Arc<Self>, params: &[f64], order: usize) -> Expansion {
        let same = |a: &[f64]| {
            a.len() == params.len()
                && a.iter()
                    .zip(params)
                    .all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let spare = {
            let mut spares = self.spares.lock().unwrap_or_else(|p| p.into_inner());
            let at = (spares.iter())
                .position(|w| w.order == order && same(&w.params))
                .or_else(|| spares.iter().position(|w| w.order == order));
            at.map(|i| spares.swap_remove(i))
        };
        let work = match spare {
            Some(work) if same(&work.params) => work,
            Some(mut work) => {
                self.bind(&mut work, params);
                work
            }
            None => {
                let (n, w) = (self.dof, order + 1);
                let mut work = Workspace {
                    order,
                    params: Vec::new(),
                    series: vec![0.0; self.rows * w],
                    q: vec![0.0; n * (w + 1)],
                    v: vec![0.0; n * (w + 1)],
                    m0: vec![0.0; n * n],
                    m0_fixed: false,
                    qdd: vec![0.0; n * w],
                    rhs: vec![0.0; n],
                    #[cfg(feature = "jit")]
                    reversed: Vec::new(),
                };
                self.bind(&mut work, params);
                work
            }
        };
        Expansion {
            program: self.clone(),
            work,
        }
    }

    /// Order 0 of the rows of the numbers and parameters and of those fixed by them (and t's
    /// coefficient 1), into `work`'s table: no expansion writes them.
    fn bind(&self, work: &mut Workspace, params: &[f64]) {
        let w = work.order + 1;
        let series = &mut work.series;
        for &(r, x) in &self.numbers {
            series[r * w] = x;
        }
        for &(r, p) in &self.params {
            series[r * w] = params[p];
        }
        if let (Some(r), true) = (self.time, work.order >= 1) {
            series[r * w + 1] = 1.0;
        }
        for op in &self.fixed {
            op.apply(series, w, 0);
        }
        work.params.clear();
        work.params.extend_from_slice(params);
        work.m0_fixed = false;
    }
}

/// What a Taylor step needs besides the expansion and the state ([`Expansion::step`]); the
/// compiled step reads it at the offsets of this layout.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepRule {
    /// The relative tolerance: the error is held to atol + rtol |yᵢ| per component.
    pub rtol: f64,
    /// The absolute tolerance.
    pub atol: f64,
    /// The largest step.
    pub h_max: f64,
    /// The smallest step before the run is given up (the floor is at least 10 ε |t|).
    pub min_step: f64,
    /// Where the run ends.
    pub t_end: f64,
    /// The direction of the run, ±1.
    pub dir: f64,
}

/// The Taylor coefficients of one expansion and their work space.
#[derive(Debug, Clone)]
pub struct Expansion {
    program: Arc<TaylorProgram>,
    work: Workspace,
}

/// An expansion's buffers: back to its program's spares when the expansion is dropped, for the
/// next one to the same order (a short run's fixed cost was mostly their allocation, zeroing
/// and binding).
#[derive(Debug, Clone, Default)]
struct Workspace {
    order: usize,
    /// The parameter values bound (order 0 of their rows and of the rows fixed by them).
    params: Vec<f64>,
    /// The table of series: row r's coefficient k at `r * (order + 1) + k`.
    series: Vec<f64>,
    /// Coefficients of q and q̇: order k of coordinate i at `k * dof + i`, k = 0..=order.
    q: Vec<f64>,
    v: Vec<f64>,
    /// M₀ factored (LDLᵀ).
    m0: Vec<f64>,
    /// Whether `m0` holds the factor of a mass matrix that depends on the parameters alone,
    /// factored at the first expansion and kept.
    m0_fixed: bool,
    /// Coefficients of q̈: order k of coordinate i at `i * (order + 1) + k`.
    qdd: Vec<f64>,
    rhs: Vec<f64>,
    /// Work space of the unrolled expansion (the series it reads backwards, mirrored), sized
    /// at its first run.
    #[cfg(feature = "jit")]
    reversed: Vec<f64>,
}

#[cfg(feature = "jit")]
impl Workspace {
    /// The buffers the compiled expansion reads and writes, the mirror work space grown to
    /// `reversed_len` entries first (sized at the first compiled run).
    fn buffers(&mut self, reversed_len: usize) -> Buffers<'_> {
        if self.reversed.len() < reversed_len {
            self.reversed.resize(reversed_len, 0.0);
        }
        Buffers {
            table: &mut self.series,
            q: &mut self.q,
            v: &mut self.v,
            qdd: &mut self.qdd,
            m0: &mut self.m0,
            reversed: &mut self.reversed,
        }
    }
}

/// Spare work spaces a program keeps at most (more than the threads of a parallel ensemble on
/// most machines, few enough to bound the memory they hold).
const SPARES: usize = 8;

impl Drop for Expansion {
    fn drop(&mut self) {
        let work = std::mem::take(&mut self.work);
        let mut spares = self
            .program
            .spares
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if spares.len() < SPARES {
            spares.push(work);
        }
    }
}

impl Expansion {
    /// The highest order computed.
    pub fn order(&self) -> usize {
        self.work.order
    }

    /// Coefficient k of q (k = 0..=order).
    pub fn q(&self, k: usize) -> &[f64] {
        let n = self.program.dof;
        &self.work.q[k * n..(k + 1) * n]
    }

    /// Coefficient k of q̇ (k = 0..=order).
    pub fn qd(&self, k: usize) -> &[f64] {
        let n = self.program.dof;
        &self.work.v[k * n..(k + 1) * n]
    }

    /// Write coefficient k of q's and q̇'s rows.
    fn leaves(&mut self, k: usize) {
        let (p, w, n) = (&self.program, self.work.order + 1, self.program.dof);
        for (i, r) in p.coords.iter().enumerate() {
            if let Some(r) = *r {
                self.work.series[r * w + k] = self.work.q[k * n + i];
            }
        }
        for (i, r) in p.velocities.iter().enumerate() {
            if let Some(r) = *r {
                self.work.series[r * w + k] = self.work.v[k * n + i];
            }
        }
    }

    /// Coefficient k ≥ 1 of every row that varies.
    fn recurrences(&mut self, k: usize) {
        let w = self.work.order + 1;
        #[cfg(feature = "jit")]
        if let Some(kernel) = self.program.kernel() {
            kernel.run(&mut self.work.series, w, k);
            return;
        }
        for op in &self.program.varying {
            op.apply(&mut self.work.series, w, k);
        }
    }

    /// Expand the motion through (t₀, q₀, q̇₀) to `order` (given at creation).
    ///
    /// # Errors
    /// [`Error::SingularMassMatrix`] when M(t₀, q₀) cannot be factored, [`Error::NonFinite`]
    /// when a coefficient is not finite (a singularity of the model within reach, or a
    /// function at a point where its series does not exist, such as √x at x = 0).
    pub fn expand(&mut self, t0: f64, q0: &[f64], qd0: &[f64]) -> Result<()> {
        #[cfg(feature = "jit")]
        if let Some(status) = self.run_unrolled(t0, q0, qd0, None) {
            return match status? {
                Status::Expanded => Ok(()),
                _ => Err(non_finite(t0)),
            };
        }
        self.expand_interpreted(t0, q0, qd0)
    }

    /// [`Expansion::expand`] order by order (the interpreter or [`SeriesKernel`]'s
    /// recurrences).
    fn expand_interpreted(&mut self, t0: f64, q0: &[f64], qd0: &[f64]) -> Result<()> {
        let n = self.program.dof;
        let w = self.work.order + 1;
        self.work.q[..n].copy_from_slice(q0);
        self.work.v[..n].copy_from_slice(qd0);
        if let Some(r) = self.program.time {
            // t's coefficients beyond 0 are fixed at creation.
            self.work.series[r * w] = t0;
        }
        self.order0();
        let Workspace {
            series,
            m0,
            m0_fixed,
            ..
        } = &mut self.work;
        factor_m0(&self.program, series, w, m0, m0_fixed, t0, q0)?;
        self.orders();
        self.check(t0)
    }

    /// The expansion through (t₀, q₀, q̇₀) unrolled (and the step with `step`): order 0, M₀, then
    /// the rest in one call of the compiled code; `None` when the program has no unrolled
    /// expansion to this order (yet: this counts as an expansion towards it).
    #[cfg(feature = "jit")]
    fn run_unrolled(
        &mut self,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
        step: Option<Step<'_>>,
    ) -> Option<Result<Status>> {
        let Self { program, work } = self;
        let kernel = program.unrolled(work.order)?;
        let w = work.order + 1;
        if let Some(r) = program.time {
            // t's coefficients beyond 0 are fixed at creation.
            work.series[r * w] = t0;
        }
        kernel.order0(&mut work.series, q0, qd0, &mut work.q, &mut work.v);
        let (series, m0, m0_fixed) = (&work.series, &mut work.m0, &mut work.m0_fixed);
        if let Err(e) = factor_m0(program, series, w, m0, m0_fixed, t0, q0) {
            return Some(Err(e));
        }
        let buffers = work.buffers(kernel.reversed_len());
        Some(Ok(match step {
            None => kernel.run(buffers),
            Some(step) => kernel.step(buffers, step),
        }))
    }

    /// Expand about the state y = (q, q̇) at t and take Jorba and Zou's step from it (the Taylor
    /// method's step, `integrators::taylor`): h = ρ e^(−2 − 0.7/(p−1)) with ln ρ =
    /// min(−ln ‖xₚ₋₁‖ / (p − 1), −ln ‖xₚ‖ / p) from [`Expansion::norms`], at most `rule.h_max`;
    /// a step that would end within 1 % of `rule.t_end` ends on it; the new state by
    /// [`Expansion::advance`]. The time reached, and whether it is t_end. Compiled with the
    /// expansion once it is unrolled, the whole step is one call of machine code.
    ///
    /// # Errors
    /// Those of [`Expansion::expand`]; [`Error::StepSizeTooSmall`] when h is not above
    /// max(`rule.min_step`, 10 ε |t|) (a vanishing radius of convergence: a singularity of the
    /// solution within reach); [`Error::NonFinite`] when a value of the new state is not finite.
    ///
    /// # Panics
    /// If a buffer has fewer than 2 · dof entries.
    pub fn step(
        &mut self,
        t: f64,
        y: &[f64],
        rule: &StepRule,
        lost: &mut [f64],
        y_new: &mut [f64],
    ) -> Result<(f64, bool)> {
        let n = self.program.dof;
        let (q0, qd0) = y[..2 * n].split_at(n);
        #[cfg(feature = "jit")]
        {
            let mut control = StepControl {
                t,
                rule: *rule,
                ..StepControl::default()
            };
            let step = Step {
                control: &mut control,
                y: &y[..2 * n],
                lost: &mut *lost,
                y_new: &mut *y_new,
            };
            if let Some(status) = self.run_unrolled(t, q0, qd0, Some(step)) {
                return stepped(status?, &control);
            }
        }
        self.expand_interpreted(t, q0, qd0)?;
        let p = self.work.order;
        let (below, top) = self.norms(y, rule.rtol, rule.atol);
        // ln ρ = min(−ln ‖xₚ₋₁‖ / (p − 1), −ln ‖xₚ‖ / p), and h = ρ e^(−2 − 0.7/(p−1)) as one
        // exponential (a zero norm gives ρ = ∞: a polynomial solution, capped by h_max).
        let (p1, p) = ((p - 1) as f64, p as f64);
        let ln_rho = (-below.ln() / p1).min(-top.ln() / p);
        let h = (ln_rho - 2.0 - 0.7 / p1).exp().min(rule.h_max);
        let floor = rule.min_step.max(10.0 * f64::EPSILON * t.abs());
        // A vanishing ρ is a singularity of the solution within reach (NaN is refused with it).
        if h.partial_cmp(&floor) != Some(std::cmp::Ordering::Greater) {
            return Err(Error::StepSizeTooSmall { t, h });
        }
        let dir = rule.dir;
        let last = (t + dir * 1.01 * h - rule.t_end) * dir >= 0.0;
        let t_new = if last { rule.t_end } else { t + dir * h };
        if !self.advance(t_new - t, y, lost, y_new) {
            return Err(Error::NonFinite {
                what: "state",
                t: t_new,
            });
        }
        Ok((t_new, last))
    }

    /// Steps from (t, y) as [`Expansion::step`] takes them, in a row, by one call of the
    /// compiled code: at most `limit`, until one is the last of the run or fails. Each step
    /// of the row that is neither moves (t, y) to its end (`y_new` and `lost` as
    /// [`Expansion::step`] leaves them). `None` when the expansion is not compiled unrolled
    /// (or a mass matrix fixed by the parameters is yet to be factored): take the step with
    /// [`Expansion::step`]. Otherwise how many steps moved (t, y), and what ended the row.
    ///
    /// # Panics
    /// If a buffer has fewer than 2 · dof entries, or `limit` is 0.
    #[cfg(feature = "jit")]
    pub(crate) fn steps(
        &mut self,
        (t, y): (&mut f64, &mut [f64]),
        rule: &StepRule,
        lost: &mut [f64],
        y_new: &mut [f64],
        limit: usize,
    ) -> Option<(usize, RowEnd)> {
        let Self { program, work } = self;
        let kernel = program.compiled(work.order)?;
        if program.mass_constant && !work.m0_fixed {
            return None;
        }
        let mut control = StepControl {
            t: *t,
            rule: *rule,
            ..StepControl::default()
        };
        let buffers = work.buffers(kernel.reversed_len());
        let (status, taken) = kernel.steps(buffers, &mut control, [y, lost, y_new], limit);
        *t = control.t;
        let end = match status {
            Status::Step => RowEnd::Limit,
            Status::Unfactored => RowEnd::Unfactored,
            status => RowEnd::Next(stepped(status, &control)),
        };
        Some((taken, end))
    }

    /// [`Error::NonFinite`] when a coefficient of q̈ is not finite.
    fn check(&self, t0: f64) -> Result<()> {
        match self.work.qdd.iter().all(|x| x.is_finite()) {
            true => Ok(()),
            false => Err(non_finite(t0)),
        }
    }

    /// Order 0 of every row the state sets: what the unrolled kernel's order 0 computes.
    fn order0(&mut self) {
        self.leaves(0);
        let w = self.work.order + 1;
        for op in &self.program.order0 {
            op.apply(&mut self.work.series, w, 0);
        }
    }

    /// Orders 0, …, p − 1 of q̈ (and 1, …, p of q and q̇) given order 0 of every row and M₀
    /// factored, order by order: what the unrolled kernel computes, in the same operations and
    /// order.
    fn orders(&mut self) {
        let program = self.program.clone();
        let (n, w) = (program.dof, self.work.order + 1);
        for k in 0..self.work.order {
            if k > 0 {
                self.leaves(k);
                self.recurrences(k);
            }
            // M₀ q̈ₖ = fₖ − Σ_c Σⱼ₌₁..ₖ M_rc,ⱼ q̈_c,ₖ₋ⱼ: a convolution per entry of M that varies.
            for r in 0..n {
                let f = self.work.series[program.force[r] * w + k];
                let varying = &program.mass_varying[r * n..(r + 1) * n];
                self.work.rhs[r] = if k > 0 && varying.contains(&true) {
                    let mut s = 0.0;
                    for c in (0..n).filter(|&c| varying[c]) {
                        let m = &self.work.series[program.mass_full[r * n + c] * w..][..w];
                        s += conv_rows(m, &self.work.qdd[c * w..][..w], 1, k, k, k, false);
                    }
                    f - s
                } else {
                    f
                };
            }
            match &program.factor_nonzero {
                Some(nonzero) => {
                    linalg::ldlt_solve_pattern(&self.work.m0, n, nonzero, &mut self.work.rhs)
                }
                None => linalg::ldlt_solve(&self.work.m0, n, &mut self.work.rhs),
            }
            let next = 1.0 / (k + 1) as f64;
            for i in 0..n {
                self.work.qdd[i * w + k] = self.work.rhs[i];
                self.work.q[(k + 1) * n + i] = self.work.v[k * n + i] * next;
                self.work.v[(k + 1) * n + i] = self.work.rhs[i] * next;
            }
        }
    }

    /// The scaled sup norms of the last two coefficients that Jorba and Zou's step size reads:
    /// (maxᵢ |xₚ₋₁,ᵢ| sᵢ, maxᵢ |xₚ,ᵢ| sᵢ) over the components i of y = (q, q̇), with sᵢ = ε /
    /// (atol + rtol |yᵢ|) and ε = min(rtol, atol), the tolerance the order is chosen for (each
    /// component measured against its own tolerance).
    ///
    /// # Panics
    /// If `y` has fewer than 2 · dof entries.
    pub fn norms(&self, y: &[f64], rtol: f64, atol: f64) -> (f64, f64) {
        let (n, p) = (self.program.dof, self.work.order);
        let eps = rtol.min(atol);
        let (mut below, mut top) = (0.0_f64, 0.0_f64);
        let (q, qd) = y[..2 * n].split_at(n);
        for (y, x, z) in [
            (q, self.q(p - 1), self.q(p)),
            (qd, self.qd(p - 1), self.qd(p)),
        ] {
            for i in 0..n {
                let scale = eps / (atol + rtol * y[i].abs());
                below = below.max(x[i].abs() * scale);
                top = top.max(z[i].abs() * scale);
            }
        }
        (below, top)
    }

    /// A step of h from the state y = (q, q̇) the expansion is about: `y_new` = y + Σₖ₌₁..ₚ
    /// (q, q̇)ₖ hᵏ, the increment summed by Horner's rule and added to y with Kahan's
    /// compensated summation (`lost` holds what rounding took off the state in the last step,
    /// and is updated: the state's rounding errors do not pile up step after step). False when
    /// a new value is not finite.
    ///
    /// # Panics
    /// If a buffer has fewer than 2 · dof entries.
    pub fn advance(&self, h: f64, y: &[f64], lost: &mut [f64], y_new: &mut [f64]) -> bool {
        let (n, p) = (self.program.dof, self.work.order);
        let coefficients = |k: usize, j: usize| {
            if j < n {
                self.work.q[k * n + j]
            } else {
                self.work.v[k * n + j - n]
            }
        };
        let mut finite = true;
        for j in 0..2 * n {
            let mut sum = coefficients(p, j);
            for k in (1..p).rev() {
                sum = sum * h + coefficients(k, j);
            }
            let increment = sum * h - lost[j];
            y_new[j] = y[j] + increment;
            lost[j] = (y_new[j] - y[j]) - increment;
            finite &= y_new[j].is_finite();
        }
        finite
    }

    /// y(t₀ + h) = Σₖ (q, q̇)ₖ hᵏ by Horner's rule, into `out` = (q, q̇).
    pub fn eval(&self, h: f64, out: &mut [f64]) {
        let n = self.program.dof;
        for i in 0..n {
            let (mut q, mut v) = (0.0, 0.0);
            for k in (0..=self.work.order).rev() {
                q = q * h + self.work.q[k * n + i];
                v = v * h + self.work.v[k * n + i];
            }
            out[i] = q;
            out[n + i] = v;
        }
    }
}

/// What ended a row of steps ([`Expansion::steps`]).
#[cfg(feature = "jit")]
#[derive(Debug)]
pub(crate) enum RowEnd {
    /// The row's `limit` of steps, taken.
    Limit,
    /// The next step: the last of the run (its time), or its failure.
    Next(Result<(f64, bool)>),
    /// M₀ did not factor at the next step: take it with [`Expansion::step`], whose error says
    /// why.
    Unfactored,
}

/// The outcome of the compiled step from t that ended with `status` and `control`.
#[cfg(feature = "jit")]
fn stepped(status: Status, control: &StepControl) -> Result<(f64, bool)> {
    let t = control.t;
    match status {
        Status::Step => Ok((control.t_new, false)),
        Status::Last => Ok((control.t_new, true)),
        Status::Coefficient => Err(non_finite(t)),
        Status::TooSmall => Err(Error::StepSizeTooSmall { t, h: control.h }),
        Status::State => Err(Error::NonFinite {
            what: "state",
            t: control.t_new,
        }),
        Status::Expanded | Status::Unfactored => {
            unreachable!("a step's status, not an expansion's or a factor's")
        }
    }
}

/// The error of an expansion at t₀ with a coefficient that is not finite.
fn non_finite(t0: f64) -> Error {
    Error::NonFinite {
        what: "Taylor coefficient",
        t: t0,
    }
}

/// M₀ = M(t₀, q₀) from order 0 of its rows in `series` (row width w), factored into `m0`;
/// `m0_fixed` keeps a mass matrix that depends on the parameters alone factored for good.
fn factor_m0(
    program: &TaylorProgram,
    series: &[f64],
    w: usize,
    m0: &mut [f64],
    m0_fixed: &mut bool,
    t0: f64,
    q0: &[f64],
) -> Result<()> {
    if *m0_fixed {
        return Ok(());
    }
    for (m, &row) in m0.iter_mut().zip(&program.mass_full) {
        *m = series[row * w];
    }
    eom::factor(m0, program.dof, t0, q0)?;
    *m0_fixed = program.mass_constant;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::Dynamics;
    use crate::integrators::{Method, Options, solve};
    use crate::tape::{Energies, EnergyModel, Function, Inputs, Tape, eom_graph, models};
    use std::sync::Arc;

    /// M, f derived from `parts` on `g`, its expansion program, and the same model through the
    /// tapes' dual numbers (the reference the coefficients are checked against).
    fn setup(
        g: &mut Graph,
        dof: usize,
        parts: &Energies,
        params: &[f64],
    ) -> (TaylorProgram, EnergyModel) {
        let eom = eom_graph(g, dof, parts).unwrap();
        let program = TaylorProgram::new(g, eom.dof, &eom.mass, &eom.force);
        let f = |nodes: &[usize], inputs: Inputs| {
            Function::new(
                Arc::new(Tape::new(g, nodes, inputs, "part").unwrap()),
                params,
            )
            .unwrap()
        };
        let all = Inputs::kinetic(dof, params.len());
        let model = EnergyModel::new(
            dof,
            f(&[parts.kinetic], all),
            parts
                .potential
                .map(|u| f(&[u], Inputs::potential(dof, params.len()))),
            parts.dissipation.map(|r| f(&[r], all)),
            parts.forces.as_ref().map(|q| f(q, all)),
        )
        .unwrap();
        (program, model)
    }

    /// A scaling by a constant that reads a parameter stays, whatever the parameter: U =
    /// sign(p) x²/2 gives ẍ = −sign(p) x, a scaling by −½ · 2 · sign(p), which is 1 for p < 0
    /// only (and which sign(NaN) = −1 would take for 1), for p = ±2.
    #[test]
    fn scalings_by_parameters_stay() {
        let mut g = Graph::new();
        let (x, v, p) = (g.coord(0), g.velocity(0), g.param(0));
        let half = g.constant(0.5);
        let v2 = g.powi(v, 2).unwrap();
        let x2 = g.powi(x, 2).unwrap();
        let sign = g.unary(Unary::Sign, p).unwrap();
        let scaled = g.binary(Binary::Mul, sign, x2).unwrap();
        let parts = Energies {
            kinetic: g.binary(Binary::Mul, half, v2).unwrap(),
            potential: Some(g.binary(Binary::Mul, half, scaled).unwrap()),
            dissipation: None,
            forces: None,
        };
        for p in [2.0, -2.0] {
            let (program, _) = setup(&mut g, 1, &parts, &[p]);
            let mut e = Arc::new(program).expansion(&[p], 4);
            e.expand(0.0, &[1.0], &[0.0]).unwrap();
            // q̇'s coefficient 1 is q̈₀ = −sign(p) x₀.
            assert_eq!(e.qd(1)[0], -p.signum(), "p = {p}");
        }
    }

    /// T = ½ (ṙ² + r² θ̇²), a point in polar coordinates (r, θ) = (q₀, q₁), in `g`.
    fn polar_kinetic(g: &mut Graph) -> usize {
        let (r, _, rd, thd) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
        let half = g.constant(0.5);
        let (rd2, r2, thd2) = (
            g.powi(rd, 2).unwrap(),
            g.powi(r, 2).unwrap(),
            g.powi(thd, 2).unwrap(),
        );
        let rt = g.binary(Binary::Mul, r2, thd2).unwrap();
        let sum = g.binary(Binary::Add, rd2, rt).unwrap();
        g.binary(Binary::Mul, half, sum).unwrap()
    }

    /// Two masses on springs to the wall, the first driven by F cos ω t (U = ½ k (x₁² + x₂²) −
    /// F x₁ cos ω t, M = diag(2, m₂)): ω t is expanded at order 0 alone (sin and cos sum ω
    /// above it), M's factor has no entry below the diagonal to solve with, and the series
    /// still follow the recursion xₖ₊₂ = (−k xₖ + F cₖ) / (m (k + 1)(k + 2)), with cₖ =
    /// ωᵏ cos(ω t₀ + k π/2) / k!, interpreted and unrolled alike, bit for bit.
    #[test]
    fn unread_orders_and_zeros_of_the_mass_matrix_are_skipped() {
        let mut g = Graph::new();
        let (x1, x2, v1, v2) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
        let (m2, omega, t) = (g.param(0), g.param(1), g.time());
        let (half, k, force) = (g.constant(0.5), g.constant(3.0), g.constant(0.7));
        let square = |g: &mut Graph, x: usize| g.powi(x, 2).unwrap();
        let (v1s, v2s, x1s, x2s) = (
            square(&mut g, v1),
            square(&mut g, v2),
            square(&mut g, x1),
            square(&mut g, x2),
        );
        let heavy = g.binary(Binary::Mul, m2, v2s).unwrap();
        let two = g.constant(2.0);
        let light = g.binary(Binary::Mul, two, v1s).unwrap();
        let sum = g.binary(Binary::Add, light, heavy).unwrap();
        let kinetic = g.binary(Binary::Mul, half, sum).unwrap();
        let springs = g.binary(Binary::Add, x1s, x2s).unwrap();
        let springs = g.binary(Binary::Mul, k, springs).unwrap();
        let springs = g.binary(Binary::Mul, half, springs).unwrap();
        let phase = g.binary(Binary::Mul, omega, t).unwrap();
        let drive = g.unary(Unary::Cos, phase).unwrap();
        let drive = g.binary(Binary::Mul, drive, x1).unwrap();
        let drive = g.binary(Binary::Mul, force, drive).unwrap();
        let parts = Energies {
            kinetic,
            potential: Some(g.binary(Binary::Sub, springs, drive).unwrap()),
            dissipation: None,
            forces: None,
        };
        let (m2, omega) = (1.7, 1.3);
        let params = [m2, omega];
        let program = Arc::new(setup(&mut g, 2, &parts, &params).0);
        assert_eq!(program.factor_nonzero, Some(vec![true, true, false, true]));
        let time = program.time.expect("the model reads t");
        let reads_t = |op: &Op| op.operands().contains(&time);
        assert!(program.order0.iter().any(reads_t), "{:?}", program.order0);
        assert!(
            !program.varying.iter().any(reads_t),
            "{:?}",
            program.varying
        );
        let (t0, q, v) = (0.3, [0.4, -0.2], [0.1, 0.5]);
        let order = 20;
        let mut e = program.expansion(&params, order);
        e.expand(t0, &q, &v).unwrap();
        let mut factorial = 1.0;
        let mut c = vec![0.0; order + 1];
        for (j, c) in c.iter_mut().enumerate() {
            factorial *= j.max(1) as f64;
            let phase = omega * t0 + j as f64 * std::f64::consts::FRAC_PI_2;
            *c = omega.powi(j as i32) * phase.cos() / factorial;
        }
        let (mut a, mut b) = (vec![q[0], v[0]], vec![q[1], v[1]]);
        for j in 0..order - 1 {
            let d = ((j + 1) * (j + 2)) as f64;
            a.push((-3.0 * a[j] + 0.7 * c[j]) / (2.0 * d));
            b.push(-3.0 * b[j] / (m2 * d));
        }
        for j in 1..=order {
            let (x, y) = (e.q(j), [a[j], b[j]]);
            for i in 0..2 {
                assert!(
                    (x[i] - y[i]).abs() <= 1e-14 * y[i].abs().max(1e-300),
                    "x{i} order {j}: {} against {}",
                    x[i],
                    y[i]
                );
            }
        }
        let reference = Arc::new(program.interpreted());
        let mut r = reference.expansion(&params, order);
        assert_eq!(program.unroll(order), cfg!(feature = "jit"));
        let mut u = program.expansion(&params, order);
        r.expand(t0, &q, &v).unwrap();
        u.expand(t0, &q, &v).unwrap();
        for j in 0..=order {
            let pairs = (r.q(j).iter().zip(u.q(j))).chain(r.qd(j).iter().zip(u.qd(j)));
            for (x, y) in pairs {
                assert_eq!(x.to_bits(), y.to_bits(), "order {j}: {x} against {y}");
            }
        }
    }

    /// Both forms `fold_quotients` rewrites, on a hand-made program: (x/b)/b and −(x/b)/b
    /// become x/b² and −(x/b²), with b² the program's own square, and give the series of the
    /// two quotients to rounding at every order.
    #[test]
    fn quotients_fold_in_both_forms() {
        // Rows: 0 = x, 1 = b, 2 = b², 3 = x/b, 4 = (x/b)/b, 5 = x/b again, 6 = −(x/b),
        // 7 = −(x/b)/b.
        let ops = vec![
            Op::Square { out: 2, a: 1 },
            Op::Div { out: 3, a: 0, b: 1 },
            Op::Div { out: 4, a: 3, b: 1 },
            Op::Div { out: 5, a: 0, b: 1 },
            Op::Neg { out: 6, a: 5 },
            Op::Div { out: 7, a: 6, b: 1 },
        ];
        let mut low = Lowering {
            rows: 8,
            fixed: Vec::new(),
            order0: ops.clone(),
            varying: ops.clone(),
        };
        low.fold_quotients(&HashSet::from([2, 4, 7]));
        let folded = vec![
            Op::Square { out: 2, a: 1 },
            Op::Div { out: 4, a: 0, b: 2 },
            Op::Div { out: 5, a: 0, b: 2 },
            Op::Neg { out: 7, a: 5 },
        ];
        assert_eq!(low.order0, folded);
        assert_eq!(low.varying, folded);
        let w = 17;
        let run = |ops: &[Op]| {
            let mut s = vec![0.0; 8 * w];
            for k in 0..w {
                s[k] = ((k * 5 % 7) as f64 - 2.9) / (k + 1) as f64;
                s[w + k] = 1.3 / (k * k + 1) as f64;
            }
            for k in 0..w {
                for op in ops {
                    op.apply(&mut s, w, k);
                }
            }
            s
        };
        let (before, after) = (run(&ops), run(&folded));
        for row in [4, 7] {
            for k in 0..w {
                let (a, b) = (after[row * w + k], before[row * w + k]);
                assert!(
                    (a - b).abs() <= 1e-13 * b.abs().max(1e-3),
                    "row {row} order {k}: {a} {b}"
                );
            }
        }
    }

    /// Kepler in polar coordinates, U = −μ/r: ∂U/∂r = (μ/r)/r becomes μ/r², r² being M₁₁'s
    /// square; against μ r⁻¹ (no quotient at all), the series agree to rounding at every order.
    #[test]
    fn quotients_of_quotients_are_one_quotient() {
        let kepler = |inverse: bool| {
            let mut g = Graph::new();
            let kinetic = polar_kinetic(&mut g);
            let (r, mu) = (g.coord(0), g.param(0));
            let over = if inverse {
                let inv = g.powi(r, -1).unwrap();
                g.binary(Binary::Mul, mu, inv).unwrap()
            } else {
                g.binary(Binary::Div, mu, r).unwrap()
            };
            let parts = Energies {
                kinetic,
                potential: Some(g.unary(Unary::Neg, over).unwrap()),
                dissipation: None,
                forces: None,
            };
            setup(&mut g, 2, &parts, &[1.3]).0
        };
        let quotients = |p: &TaylorProgram| {
            (p.varying.iter())
                .filter(|op| matches!(op, Op::Div { .. }))
                .count()
        };
        let (folded, reference) = (kepler(false), kepler(true));
        assert_eq!(quotients(&folded), 1, "{:?}", folded.varying);
        assert_eq!(quotients(&reference), 0, "{:?}", reference.varying);
        let (q, v) = ([0.7, 0.4], [0.2, -1.1]);
        let order = 16;
        let mut e = Arc::new(folded).expansion(&[1.3], order);
        let mut f = Arc::new(reference).expansion(&[1.3], order);
        e.expand(0.0, &q, &v).unwrap();
        f.expand(0.0, &q, &v).unwrap();
        for k in 1..=order {
            for i in 0..2 {
                let (a, b) = (e.q(k)[i], f.q(k)[i]);
                assert!(
                    (a - b).abs() <= 1e-13 * b.abs().max(1e-3),
                    "q{i} order {k}: {a} {b}"
                );
            }
        }
    }

    /// Copies and scalings by exactly 1 are read through and dropped, in M too: T = ½ (ṙ² +
    /// r² θ̇²), U = sin θ cos θ − μ/r has x² as a product copied into the power's row, sin
    /// beside cos, and M₁₁ = r² scaled by ½ · 2. What remains still expands as the dual
    /// numbers of the tapes differentiate (q̈ at order 0, against the accelerations).
    #[test]
    fn copies_and_unit_scalings_are_read_through() {
        let mut g = Graph::new();
        let kinetic = polar_kinetic(&mut g);
        let (r, th, mu) = (g.coord(0), g.coord(1), g.param(0));
        let (s, c) = (
            g.unary(Unary::Sin, th).unwrap(),
            g.unary(Unary::Cos, th).unwrap(),
        );
        let sc = g.binary(Binary::Mul, s, c).unwrap();
        let over = g.binary(Binary::Div, mu, r).unwrap();
        let parts = Energies {
            kinetic,
            potential: Some(g.binary(Binary::Sub, sc, over).unwrap()),
            dissipation: None,
            forces: None,
        };
        let (program, model) = setup(&mut g, 2, &parts, &[1.3]);
        assert!(
            !program
                .order0
                .iter()
                .any(|op| matches!(op, Op::Copy { .. })),
            "{:?}",
            program.order0
        );
        // M₁₁ is the square r² itself; M₀₀ = ½ · 2 a number.
        let r_row = program.coords[0].unwrap();
        let m11 = program.mass_full[3];
        assert!(
            program.varying.contains(&Op::Square { out: m11, a: r_row }),
            "{:?}",
            program.varying
        );
        assert!(program.mass_varying == [false, false, false, true]);
        let program = Arc::new(program);
        let (q, v) = ([0.7, 0.4], [0.2, -1.1]);
        let mut e = program.expansion(&[1.3], 6);
        e.expand(0.0, &q, &v).unwrap();
        let mut qdd = [0.0; 2];
        model.accelerations_into(0.0, &q, &v, &mut qdd).unwrap();
        for i in 0..2 {
            // q̇'s coefficient 1 is q̈₀.
            assert!(
                (e.qd(1)[i] - qdd[i]).abs() < 1e-14 * qdd[i].abs().max(1.0),
                "{i}"
            );
        }
    }

    /// A square's half sum gives the product's coefficients: (1 − t)⁻¹ = Σ tᵏ squared is
    /// Σ (k + 1) tᵏ exactly, and a series of mixed signs squared agrees with its product by
    /// itself to a rounding per term.
    #[test]
    fn squares_are_products_in_half_the_terms() {
        let w = 21;
        for series in [
            vec![1.0; w],
            (0..w)
                .map(|k| ((k * 7 % 5) as f64 - 2.3) / (k + 1) as f64)
                .collect(),
        ] {
            let mut s = [series, vec![0.0; w], vec![0.0; w]].concat();
            for k in 0..w {
                Op::Square { out: 1, a: 0 }.apply(&mut s, w, k);
                Op::Mul { out: 2, a: 0, b: 0 }.apply(&mut s, w, k);
                let (square, product) = (s[w + k], s[2 * w + k]);
                let scale: f64 = (0..=k).map(|j| (s[j] * s[k - j]).abs()).sum();
                assert!(
                    (square - product).abs() <= 4.0 * f64::EPSILON * scale,
                    "{k}"
                );
                if s[0] == 1.0 && s[1] == 1.0 {
                    assert_eq!(square, (k + 1) as f64, "{k}");
                }
            }
        }
    }

    /// x = cos t from (1, 0) under T = ½ẋ², U = ½x²: xₖ = cos⁽ᵏ⁾(0)/k!.
    #[test]
    fn oscillator_coefficients_are_those_of_cos() {
        let mut g = Graph::new();
        let (x, v, half) = (g.coord(0), g.velocity(0), g.constant(0.5));
        let v2 = g.powi(v, 2).unwrap();
        let x2 = g.powi(x, 2).unwrap();
        let parts = Energies {
            kinetic: g.binary(Binary::Mul, half, v2).unwrap(),
            potential: Some(g.binary(Binary::Mul, half, x2).unwrap()),
            dissipation: None,
            forces: None,
        };
        let (program, _) = setup(&mut g, 1, &parts, &[]);
        let program = Arc::new(program);
        let mut e = program.expansion(&[], 24);
        e.expand(0.0, &[1.0], &[0.0]).unwrap();
        let mut factorial = 1.0;
        for k in 0..=24 {
            if k > 0 {
                factorial *= k as f64;
            }
            let want = match k % 4 {
                0 => 1.0,
                2 => -1.0,
                _ => 0.0,
            } / factorial;
            // A rounding or two per order on each side (the product by 1/k here, the
            // factorial there): measured 4.6e-16 at worst (k = 24).
            assert!(
                (e.q(k)[0] - want).abs() <= 8e-16 * want.abs(),
                "{k}: {} vs {want}",
                e.q(k)[0]
            );
        }
    }

    /// The expansion of a model over every function — M depending on q, L on t and q̇,
    /// damping and forces — summed at a step h agrees with a tight DOP853 run to round-off.
    #[test]
    fn chirp_forcing_sums_stop_at_the_phase_degree() {
        // ẍ = cos(u(t)) + sinh(0.4 t) with u = 0.8 t² + 0.3 t (T = ½ẋ², Q the forcing): the
        // phases are polynomials in t of degree 2 and 1, so their sums stop there.
        let mut g = Graph::new();
        let (v, t, half) = (g.velocity(0), g.time(), g.constant(0.5));
        let mul = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Mul, a, b).unwrap();
        let v2 = g.powi(v, 2).unwrap();
        let t2 = g.powi(t, 2).unwrap();
        let (a2, a1, b1) = (g.constant(0.8), g.constant(0.3), g.constant(0.4));
        let (u2, u1) = (mul(&mut g, a2, t2), mul(&mut g, a1, t));
        let u = g.binary(Binary::Add, u2, u1).unwrap();
        let cos_u = g.unary(Unary::Cos, u).unwrap();
        let bt = mul(&mut g, b1, t);
        let sinh_bt = g.unary(Unary::Sinh, bt).unwrap();
        let parts = Energies {
            kinetic: mul(&mut g, half, v2),
            potential: None,
            dissipation: None,
            forces: Some(vec![g.binary(Binary::Add, cos_u, sinh_bt).unwrap()]),
        };
        let (program, _) = setup(&mut g, 1, &parts, &[]);
        let degrees: Vec<_> = program
            .varying
            .iter()
            .filter_map(|op| match *op {
                Op::SinCos { degree, .. } => Some(degree),
                _ => None,
            })
            .collect();
        assert_eq!(degrees, [Some(2), Some(1)]);
        // Reference: cos(u(t₀ + h)) = Re(e^(iu₀) e^(iu₁h) e^(iu₂h²)) with u₁ = 0.3 + 1.6 t₀,
        // u₂ = 0.8, a product of two exponential series; sinh(0.4(t₀ + h)) term by term.
        let (t0, order) = (0.7, 22);
        let (u0, u1, u2) = (0.8 * t0 * t0 + 0.3 * t0, 0.3 + 1.6 * t0, 0.8);
        let mul_c = |(a, b): (f64, f64), (c, d): (f64, f64)| (a * c - b * d, a * d + b * c);
        let series = |w: f64, stride: usize| {
            // e^(iwh^stride) = Σₘ (iw)ᵐ h^(m·stride) / m!
            let mut s = vec![(0.0, 0.0); order + 1];
            let mut term = (1.0, 0.0);
            for m in 0..=order / stride {
                s[m * stride] = term;
                term = mul_c(term, (0.0, w / (m + 1) as f64));
            }
            s
        };
        let (e1, e2) = (series(u1, 1), series(u2, 2));
        let (b, mut sinh_k) = (0.4_f64, (0.4 * t0).sinh());
        let (mut sinh_other, mut scale) = ((0.4 * t0).cosh(), 1.0);
        let mut forcing = Vec::new();
        for k in 0..=order {
            let mut p = (0.0, 0.0);
            for j in 0..=k {
                let x = mul_c(e1[j], e2[k - j]);
                p = (p.0 + x.0, p.1 + x.1);
            }
            let cos_k = mul_c((u0.cos(), u0.sin()), p).0;
            forcing.push(cos_k + sinh_k * scale);
            scale *= b / (k + 1) as f64;
            std::mem::swap(&mut sinh_k, &mut sinh_other);
        }
        let program = Arc::new(program);
        let mut e = program.expansion(&[], order);
        e.expand(t0, &[0.2], &[-0.1]).unwrap();
        // xₖ₊₂ = Fₖ / ((k + 1)(k + 2)), to a few roundings (measured: 2e-15 at worst).
        for k in 0..order - 1 {
            let want = forcing[k] / ((k + 1) * (k + 2)) as f64;
            let got = e.q(k + 2)[0];
            assert!(
                (got - want).abs() <= 1e-14 * want.abs(),
                "x_{}: {got} against {want}",
                k + 2
            );
        }
        // The interpreter and the compiled expansion, unrolled, give the same bits.
        let mut interpreted = Arc::new(program.interpreted()).expansion(&[], order);
        interpreted.expand(t0, &[0.2], &[-0.1]).unwrap();
        assert_eq!(
            (&interpreted.work.q, &interpreted.work.v),
            (&e.work.q, &e.work.v)
        );
        #[cfg(feature = "jit")]
        {
            assert!(program.unroll(order));
            let mut native = program.expansion(&[], order);
            native.expand(t0, &[0.2], &[-0.1]).unwrap();
            assert_eq!((&native.work.q, &native.work.v), (&e.work.q, &e.work.v));
        }
    }

    #[test]
    fn expansion_agrees_with_an_integration_for_every_function() {
        let mut g = Graph::new();
        let (x, v, t, p) = (g.coord(0), g.velocity(0), g.time(), g.param(0));
        let c = |g: &mut Graph, k: f64| g.constant(k);
        let mul = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Mul, a, b).unwrap();
        let add = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Add, a, b).unwrap();
        let un = |g: &mut Graph, f: Unary, a: usize| g.unary(f, a).unwrap();
        // T = ½ (2 + ½ sin x) ẋ² + 0.1 t x ẋ
        let s = un(&mut g, Unary::Sin, x);
        let (half, two) = (c(&mut g, 0.5), c(&mut g, 2.0));
        let hs = mul(&mut g, half, s);
        let m = add(&mut g, two, hs);
        let v2 = g.powi(v, 2).unwrap();
        let mv = mul(&mut g, m, v2);
        let kin = mul(&mut g, half, mv);
        let tenth = c(&mut g, 0.1);
        let tx = mul(&mut g, t, x);
        let txv = mul(&mut g, tx, v);
        let gyro = mul(&mut g, tenth, txv);
        let kinetic = add(&mut g, kin, gyro);
        // U = ½ p x² + 0.01 Σ (every function of x)
        let x2 = g.powi(x, 2).unwrap();
        let px2 = mul(&mut g, p, x2);
        let mut u = mul(&mut g, half, px2);
        let mut terms = Vec::new();
        let k03 = c(&mut g, 0.3);
        let x03 = mul(&mut g, k03, x);
        terms.push(un(&mut g, Unary::Tan, x03));
        terms.push(un(&mut g, Unary::Exp, x03));
        let x2p = add(&mut g, two, x);
        terms.push(un(&mut g, Unary::Ln, x2p));
        terms.push(un(&mut g, Unary::Sqrt, x2p));
        terms.push(un(&mut g, Unary::Sinh, x03));
        terms.push(un(&mut g, Unary::Cosh, x03));
        terms.push(un(&mut g, Unary::Tanh, x));
        terms.push(un(&mut g, Unary::Cos, x03));
        let k17 = c(&mut g, 1.7);
        terms.push(g.binary(Binary::Pow, x2p, k17).unwrap());
        terms.push(g.binary(Binary::Pow, x2p, x03).unwrap());
        terms.push(g.binary(Binary::Atan2, x, two).unwrap());
        terms.push(g.binary(Binary::Atan2, two, x2p).unwrap());
        let five = c(&mut g, 5.0);
        let x5 = add(&mut g, x, five);
        terms.push(un(&mut g, Unary::Abs, x5));
        terms.push(g.powi(x2p, -2).unwrap());
        terms.push(g.powi(x, 3).unwrap());
        let ct = un(&mut g, Unary::Cos, t);
        terms.push(mul(&mut g, ct, x));
        terms.push(g.binary(Binary::Div, x, x2p).unwrap());
        let small = c(&mut g, 0.01);
        for term in terms {
            let st = mul(&mut g, small, term);
            u = add(&mut g, u, st);
        }
        // Φ = 0.05 ẋ², Q = 0.2 sin t
        let k005 = c(&mut g, 0.05);
        let dissipation = Some(mul(&mut g, k005, v2));
        let k02 = c(&mut g, 0.2);
        let st = un(&mut g, Unary::Sin, t);
        let forces = Some(vec![mul(&mut g, k02, st)]);
        let parts = Energies {
            kinetic,
            potential: Some(u),
            dissipation,
            forces,
        };
        let params = [1.3];
        let (program, model) = setup(&mut g, 1, &parts, &params);
        let program = Arc::new(program);
        let (t0, q0, v0) = (0.1, [0.3], [0.2]);
        let mut e = program.expansion(&params, 20);
        e.expand(t0, &q0, &v0).unwrap();
        // Order 2 is half the acceleration.
        let mut a = [0.0];
        crate::Dynamics::accelerations_into(&model, t0, &q0, &v0, &mut a).unwrap();
        assert!((2.0 * e.q(2)[0] - a[0]).abs() < 1e-14 * a[0].abs().max(1.0));
        for h in [0.05, -0.05, 0.1] {
            let options = Options::adaptive(1e-14, 1e-15);
            let sol = solve(&model, &q0, &v0, (t0, t0 + h), Method::Dop853, &options).unwrap();
            let (_, q, qd) = sol.last().unwrap();
            let mut y = [0.0; 2];
            e.eval(h, &mut y);
            assert!((y[0] - q[0]).abs() < 2e-13, "h = {h}: {} vs {}", y[0], q[0]);
            assert!(
                (y[1] - qd[0]).abs() < 2e-12,
                "h = {h}: {} vs {}",
                y[1],
                qd[0]
            );
        }
    }

    /// The double pendulum (M(q), two coordinates): the expansion summed at h against DOP853.
    #[test]
    fn double_pendulum_expansion() {
        let mut g = Graph::new();
        let parts = models::double_pendulum(&mut g).unwrap();
        let params = [1.0, 2.0, 1.5, 0.7, 9.81];
        let (program, model) = setup(&mut g, 2, &parts, &params);
        let program = Arc::new(program);
        let (q0, v0) = ([1.0, -0.5], [0.3, 2.0]);
        let mut e = program.expansion(&params, 22);
        e.expand(0.0, &q0, &v0).unwrap();
        let h = 0.05;
        let sol = solve(
            &model,
            &q0,
            &v0,
            (0.0, h),
            Method::Dop853,
            &Options::adaptive(1e-14, 1e-15),
        )
        .unwrap();
        let (_, q, qd) = sol.last().unwrap();
        let mut y = [0.0; 4];
        e.eval(h, &mut y);
        for i in 0..2 {
            assert!((y[i] - q[i]).abs() < 1e-13, "{y:?} vs {q:?}");
            assert!((y[2 + i] - qd[i]).abs() < 1e-12, "{y:?} vs {qd:?}");
        }
    }

    /// A dropped expansion's work space serves the next one to its order, rebound when the
    /// parameters differ: T = ½ m ẋ², U = ½ k x² from (1, 0) has x₂ = −k / 2m, and M = m is
    /// factored once per binding (a stale factor would keep the old m).
    #[test]
    fn spare_work_spaces_are_rebound_to_new_parameters() {
        let mut g = Graph::new();
        let (x, v, half) = (g.coord(0), g.velocity(0), g.constant(0.5));
        let (m, k) = (g.param(0), g.param(1));
        let v2 = g.powi(v, 2).unwrap();
        let x2 = g.powi(x, 2).unwrap();
        let (mv2, kx2) = (
            g.binary(Binary::Mul, m, v2).unwrap(),
            g.binary(Binary::Mul, k, x2).unwrap(),
        );
        let parts = Energies {
            kinetic: g.binary(Binary::Mul, half, mv2).unwrap(),
            potential: Some(g.binary(Binary::Mul, half, kx2).unwrap()),
            dissipation: None,
            forces: None,
        };
        let (program, _) = setup(&mut g, 1, &parts, &[1.0, 1.0]);
        let program = Arc::new(program);
        let spares = |p: &TaylorProgram| p.spares.lock().unwrap().len();
        for (m, k) in [(1.0, 1.0), (4.0, 1.0), (4.0, 9.0), (1.0, 1.0), (4.0, 9.0)] {
            let mut e = program.expansion(&[m, k], 6);
            e.expand(0.0, &[1.0], &[0.0]).unwrap();
            let x2: f64 = -k / (2.0 * m);
            assert!(
                (e.q(2)[0] - x2).abs() < 1e-15,
                "m = {m}, k = {k}: {:?}",
                e.q(2)
            );
            let fresh = {
                let mut e = Arc::new(program.interpreted()).expansion(&[m, k], 6);
                e.expand(0.0, &[1.0], &[0.0]).unwrap();
                (0..=6).map(|j| e.q(j)[0].to_bits()).collect::<Vec<_>>()
            };
            let reused: Vec<_> = (0..=6).map(|j| e.q(j)[0].to_bits()).collect();
            assert_eq!(reused, fresh, "m = {m}, k = {k}");
            assert_eq!(spares(&program), 0, "the spare is in use");
            drop(e);
            assert_eq!(spares(&program), 1, "one work space, back after each run");
        }
        // Two at once: the second is new; both are kept.
        let (a, b) = (
            program.expansion(&[1.0, 1.0], 6),
            program.expansion(&[1.0, 1.0], 6),
        );
        drop((a, b));
        assert_eq!(spares(&program), 2);
    }
}
