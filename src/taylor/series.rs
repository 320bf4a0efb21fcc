//! The series arithmetic of the Taylor method: one recurrence ([`SeriesOp`]) gives coefficient k
//! of its rows from the coefficients of its operands, by the standard recurrences of truncated
//! power series (products by convolution, quotients, exp, log, sin and cos together, …), and
//! the convolution every compiled kernel calls so that both sum in the same order.

use crate::expr::graph::{Unary, sign};
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// A Taylor coefficient as the recurrences compute it: an `f64`, or the same coefficient of
/// several runs side by side ([`Lanes`], the batch expansions of `batch.rs`). Every operation
/// is the `f64` one lane by lane, so a run in a lane gets its coefficients bit for bit.
pub(crate) trait Coefficient:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
{
    /// x in every lane.
    fn splat(x: f64) -> Self;
    /// f of each lane.
    fn map(self, f: impl Fn(f64) -> f64) -> Self;
    /// (f(x).0, f(x).1) of each lane x.
    fn map2(self, f: impl Fn(f64) -> (f64, f64)) -> (Self, Self);
    /// f(x, y) of each lane x of `self` and y of `other`.
    fn zip_map(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self;
    /// Lane by lane: `a` where `self > 0`, else `b`.
    fn positive_then(self, a: Self, b: Self) -> Self;
}

impl Coefficient for f64 {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        f(self)
    }
    #[inline(always)]
    fn map2(self, f: impl Fn(f64) -> (f64, f64)) -> (Self, Self) {
        f(self)
    }
    #[inline(always)]
    fn zip_map(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        f(self, other)
    }
    #[inline(always)]
    fn positive_then(self, a: Self, b: Self) -> Self {
        if self > 0.0 { a } else { b }
    }
}

/// The coefficients of `L` runs side by side: one vector register at L = 8 with AVX-512
/// (aligned to its 64 bytes), operated on lane by lane as `f64`s. Only the ensembles' lanes
/// (`batch.rs`, feature `parallel`) take it.
#[cfg(feature = "parallel")]
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub(crate) struct Lanes<const L: usize>(pub [f64; L]);

#[cfg(feature = "parallel")]
impl<const L: usize> Default for Lanes<L> {
    fn default() -> Self {
        Self([0.0; L])
    }
}

#[cfg(feature = "parallel")]
macro_rules! lanewise {
    ($($trait:ident $method:ident $op:tt),*) => {$(
        impl<const L: usize> $trait for Lanes<L> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                let mut out = self;
                for (x, y) in out.0.iter_mut().zip(o.0) {
                    *x $op y;
                }
                out
            }
        }
    )*};
}
#[cfg(feature = "parallel")]
lanewise!(Add add +=, Sub sub -=, Mul mul *=, Div div /=);

#[cfg(feature = "parallel")]
impl<const L: usize> Neg for Lanes<L> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self(self.0.map(|x| -x))
    }
}

#[cfg(feature = "parallel")]
impl<const L: usize> AddAssign for Lanes<L> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

#[cfg(feature = "parallel")]
impl<const L: usize> Coefficient for Lanes<L> {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Self([x; L])
    }
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self(self.0.map(f))
    }
    #[inline(always)]
    fn map2(self, f: impl Fn(f64) -> (f64, f64)) -> (Self, Self) {
        let (mut a, mut b) = (self, self);
        for (i, &x) in self.0.iter().enumerate() {
            (a.0[i], b.0[i]) = f(x);
        }
        (a, b)
    }
    #[inline(always)]
    fn zip_map(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut out = self;
        for (x, y) in out.0.iter_mut().zip(other.0) {
            *x = f(*x, y);
        }
        out
    }
    #[inline(always)]
    fn positive_then(self, a: Self, b: Self) -> Self {
        let mut out = b;
        for i in 0..L {
            if self.0[i] > 0.0 {
                out.0[i] = a.0[i];
            }
        }
        out
    }
}

/// One recurrence: coefficient k of row `out` (and of its partner rows) from the coefficients
/// of its operands up to k and its own below k. Rows hold series; row r's coefficient j is at
/// `r·w + j`, w = order + 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum SeriesOp {
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
    /// t = f(a) with w = 1 + t² (f = tan; `hyperbolic`: w = 1 − t², f its hyperbolic twin):
    /// tₖ = Σⱼ₌₁..ₖ j aⱼ wₖ₋ⱼ / k, wₖ = ±Σⱼ₌₀..ₖ tⱼ tₖ₋ⱼ; t₀ = f(a₀).
    Tan {
        out: usize,
        w: usize,
        a: usize,
        f: Unary,
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
pub(crate) fn conv<C: Coefficient>(
    s: &[C],
    w: usize,
    a: usize,
    b: usize,
    lo: usize,
    hi: usize,
    kk: usize,
    k: usize,
    weighted: bool,
) -> C {
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
pub(crate) fn conv_rows<C: Coefficient>(
    a: &[C],
    b: &[C],
    lo: usize,
    hi: usize,
    kk: usize,
    k: usize,
    weighted: bool,
) -> C {
    let (first, last) = fresh_ends(lo, hi, kk, k);
    let weight = |j: usize, x: C| if weighted { C::splat(j as f64) * x } else { x };
    let zero = C::splat(0.0);
    let mut lanes = [zero; LANES];
    let (start, end) = (lo + usize::from(first), hi + 1 - usize::from(last));
    if start < end {
        // Terms j = start..end: aⱼ against b read backwards from b_(kk − start), as slices
        // (no bounds check per term).
        let (a_run, b_run) = (&a[start..end], &b[kk + 1 - end..=kk - start]);
        let whole = a_run.len() / LANES * LANES;
        let mut j = start;
        for (x, y) in a_run[..whole]
            .chunks_exact(LANES)
            .zip(b_run[b_run.len() - whole..].rchunks_exact(LANES))
        {
            for i in 0..LANES {
                lanes[i] += weight(j + i, x[i]) * y[LANES - 1 - i];
            }
            j += LANES;
        }
        let rest = b_run.len() - whole;
        for (x, y) in a_run[whole..].iter().zip(b_run[..rest].iter().rev()) {
            lanes[0] += weight(j, *x) * *y;
            j += 1;
        }
    }
    let mut sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    if first {
        sum += weight(0, a[0]) * b[kk];
    }
    if last {
        sum += weight(k, a[k]) * b[kk - k];
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

impl SeriesOp {
    /// Whether order 0 of this recurrence calls the maths library.
    pub(crate) fn calls_libm(&self) -> bool {
        !self.libm().is_empty()
    }

    /// The functions of the maths library order 0 of this recurrence calls, by the names the
    /// compiled code imports them under (`native/mod.rs`).
    pub(crate) fn libm(&self) -> &'static [&'static str] {
        match self {
            SeriesOp::Exp { .. } => &["lagrangian_exp"],
            SeriesOp::Ln { .. } => &["lagrangian_ln"],
            SeriesOp::SinCos {
                hyperbolic: true, ..
            } => &["lagrangian_sinh", "lagrangian_cosh"],
            SeriesOp::SinCos { .. } => &["lagrangian_sin_cos"],
            SeriesOp::Tan { f, .. } => f.libm(),
            SeriesOp::Atan2 { .. } => &["lagrangian_atan2"],
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
            SeriesOp::Mul { a, b, .. } => vec![a, b],
            SeriesOp::Square { a, .. } => vec![a],
            SeriesOp::Div { out, b, .. } | SeriesOp::Recip { out, b } => vec![out, b],
            SeriesOp::Exp { out, a } | SeriesOp::Ln { out, a } => vec![out, a],
            SeriesOp::Sqrt { out, .. } => vec![out],
            SeriesOp::SinCos { s, c, a, da, .. } => vec![s, c, da.unwrap_or(a)],
            SeriesOp::Tan { out, w, a, .. } => vec![out, w, a],
            SeriesOp::Atan2 { y, x, d, r, .. } => vec![y, x, d, r],
            SeriesOp::Copy { .. }
            | SeriesOp::Neg { .. }
            | SeriesOp::Add { .. }
            | SeriesOp::Sub { .. }
            | SeriesOp::Scale { .. }
            | SeriesOp::DivC { .. }
            | SeriesOp::Abs { .. }
            | SeriesOp::Sign { .. } => Vec::new(),
        }
    }

    /// The rows this recurrence reads that others write (not its own rows).
    pub(crate) fn operands(&self) -> Vec<usize> {
        let mut op = *self;
        op.operands_mut().into_iter().map(|r| *r).collect()
    }

    /// The rows this recurrence reads at the orders above 0: its operands, less the argument
    /// of a sine and cosine summed through its derivative (`da`), which only order 0 reads.
    pub(crate) fn operands_above_zero(&self) -> Vec<usize> {
        match *self {
            SeriesOp::SinCos { da: Some(da), .. } => vec![da],
            _ => self.operands(),
        }
    }

    /// [`SeriesOp::operands`], to rewrite.
    pub(crate) fn operands_mut(&mut self) -> Vec<&mut usize> {
        match self {
            SeriesOp::SinCos {
                a, da: Some(da), ..
            } => vec![a, da],
            SeriesOp::Copy { a, .. }
            | SeriesOp::Neg { a, .. }
            | SeriesOp::Square { a, .. }
            | SeriesOp::Exp { a, .. }
            | SeriesOp::Ln { a, .. }
            | SeriesOp::Sqrt { a, .. }
            | SeriesOp::Abs { a, .. }
            | SeriesOp::Sign { a, .. }
            | SeriesOp::SinCos { a, .. }
            | SeriesOp::Tan { a, .. } => vec![a],
            SeriesOp::Recip { b, .. } => vec![b],
            SeriesOp::Add { a, b, .. }
            | SeriesOp::Sub { a, b, .. }
            | SeriesOp::Mul { a, b, .. } => vec![a, b],
            SeriesOp::Div { a, b, .. } => vec![a, b],
            SeriesOp::Scale { a, c, .. } | SeriesOp::DivC { a, c, .. } => vec![a, c],
            SeriesOp::Atan2 { y, x, .. } => vec![y, x],
        }
    }

    /// The rows this recurrence writes.
    pub(crate) fn outputs(&self) -> Vec<usize> {
        match *self {
            SeriesOp::SinCos { s, c, .. } => vec![s, c],
            SeriesOp::Tan { out, w, .. } => vec![out, w],
            SeriesOp::Atan2 { out, d, r, .. } => vec![out, d, r],
            _ => vec![self.out()],
        }
    }

    /// The row of this recurrence's value (sin's of `SinCos`, tan's of `Tan`).
    pub(crate) fn out(&self) -> usize {
        match *self {
            SeriesOp::SinCos { s, .. } => s,
            SeriesOp::Copy { out, .. }
            | SeriesOp::Neg { out, .. }
            | SeriesOp::Add { out, .. }
            | SeriesOp::Sub { out, .. }
            | SeriesOp::Scale { out, .. }
            | SeriesOp::Mul { out, .. }
            | SeriesOp::Square { out, .. }
            | SeriesOp::DivC { out, .. }
            | SeriesOp::Div { out, .. }
            | SeriesOp::Recip { out, .. }
            | SeriesOp::Exp { out, .. }
            | SeriesOp::Ln { out, .. }
            | SeriesOp::Sqrt { out, .. }
            | SeriesOp::Abs { out, .. }
            | SeriesOp::Sign { out, .. }
            | SeriesOp::Tan { out, .. }
            | SeriesOp::Atan2 { out, .. } => out,
        }
    }

    /// Terms of the convolutions this recurrence sums at order k ≥ 1.
    pub(crate) fn terms(&self, k: usize) -> usize {
        match self {
            SeriesOp::Mul { .. } => k + 1,
            SeriesOp::Square { .. } => k / 2 + 1,
            SeriesOp::Div { .. } | SeriesOp::Recip { .. } | SeriesOp::Exp { .. } => k,
            SeriesOp::Ln { .. } | SeriesOp::Sqrt { .. } => k - 1,
            SeriesOp::SinCos { degree, .. } => 2 * degree.map_or(k, |d| d.min(k)),
            SeriesOp::Tan { .. } => 2 * k + 1,
            SeriesOp::Atan2 { .. } => 5 * k + 1,
            _ => 0,
        }
    }

    /// Coefficient k of the rows this recurrence writes, in the table `s` of row width `w`.
    #[inline(always)]
    pub(crate) fn apply<C: Coefficient>(&self, s: &mut [C], w: usize, k: usize) {
        let at = |s: &[C], r: usize, j: usize| s[r * w + j];
        let c = C::splat;
        // 1/k: the recurrences scale by it (a product, not a quotient, on the path from one
        // order to the next).
        let inv_k = c(1.0 / k as f64);
        let value = match *self {
            SeriesOp::Copy { a, .. } => at(s, a, k),
            SeriesOp::Neg { a, .. } => -at(s, a, k),
            SeriesOp::Add { a, b, .. } => at(s, a, k) + at(s, b, k),
            SeriesOp::Sub { a, b, .. } => at(s, a, k) - at(s, b, k),
            SeriesOp::Scale { a, c, .. } => at(s, a, k) * at(s, c, 0),
            SeriesOp::Mul { a, b, .. } => conv(s, w, a, b, 0, k, k, k, false),
            SeriesOp::Square { a, .. } if k == 0 => conv(s, w, a, a, 0, 0, 0, 0, false),
            SeriesOp::Square { a, .. } => {
                let half = conv(s, w, a, a, 0, (k - 1) / 2, k, k, false);
                let twice = half + half;
                if k.is_multiple_of(2) {
                    let mid = at(s, a, k / 2);
                    twice + mid * mid
                } else {
                    twice
                }
            }
            SeriesOp::DivC { a, c, .. } => at(s, a, k) / at(s, c, 0),
            SeriesOp::Div { out, a, b } => {
                (at(s, a, k) - conv(s, w, b, out, 1, k, k, k, false)) / at(s, b, 0)
            }
            SeriesOp::Recip { out, b } => {
                if k == 0 {
                    c(1.0) / at(s, b, 0)
                } else {
                    -conv(s, w, b, out, 1, k, k, k, false) / at(s, b, 0)
                }
            }
            SeriesOp::Exp { out, a } => {
                if k == 0 {
                    at(s, a, 0).map(f64::exp)
                } else {
                    conv(s, w, a, out, 1, k, k, k, true) * inv_k
                }
            }
            SeriesOp::Ln { out, a } => {
                if k == 0 {
                    at(s, a, 0).map(f64::ln)
                } else {
                    (at(s, a, k) - conv(s, w, out, a, 1, k - 1, k, k, true) * inv_k) / at(s, a, 0)
                }
            }
            SeriesOp::Sqrt { out, a } => {
                if k == 0 {
                    at(s, a, 0).map(f64::sqrt)
                } else {
                    (at(s, a, k) - conv(s, w, out, out, 1, k - 1, k, k, false))
                        / (c(2.0) * at(s, out, 0))
                }
            }
            SeriesOp::SinCos {
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
                        (x.map(f64::sinh), x.map(f64::cosh))
                    } else {
                        x.map2(f64::sin_cos)
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
            SeriesOp::Tan {
                out,
                w: wr,
                a,
                f,
                hyperbolic,
            } => {
                let t = if k == 0 {
                    at(s, a, 0).map(|x| f.apply(x))
                } else {
                    conv(s, w, a, wr, 1, k, k, k, true) * inv_k
                };
                s[out * w + k] = t;
                let sq = conv(s, w, out, out, 0, k, k, k, false);
                let sq = if hyperbolic { -sq } else { sq };
                s[wr * w + k] = if k == 0 { c(1.0) + sq } else { sq };
                return;
            }
            SeriesOp::Abs { a, .. } => {
                let x = at(s, a, k);
                if k == 0 {
                    x.map(f64::abs)
                } else {
                    at(s, a, 0).positive_then(x, -x)
                }
            }
            SeriesOp::Sign { a, .. } => {
                if k == 0 {
                    at(s, a, 0).map(sign)
                } else {
                    c(0.0)
                }
            }
            SeriesOp::Atan2 { y, x, d, r, .. } => {
                let dk = conv(s, w, x, x, 0, k, k, k, false) + conv(s, w, y, y, 0, k, k, k, false);
                s[d * w + k] = dk;
                if k == 0 {
                    at(s, y, 0).zip_map(at(s, x, 0), f64::atan2)
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

#[cfg(test)]
mod tests {
    use super::*;

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
                SeriesOp::Square { out: 1, a: 0 }.apply(&mut s, w, k);
                SeriesOp::Mul { out: 2, a: 0, b: 0 }.apply(&mut s, w, k);
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
}
