//! The arithmetic a tape is evaluated with.
//!
//! [`Arith`] is what an instruction needs. It is implemented for every [`Scalar`] (through the
//! transparent wrapper [`Num`]) and, for the dual numbers the engine's derivative passes use on
//! `f64` states — num-dual's `DualSVec64<K>` (gradients) and `HyperDualVec64<M, N>` (mass matrix
//! and mixed terms), in the shapes `eval.rs` lists — by plain-array "jets" [`First`] and
//! [`Second`].
//!
//! Why the jets: num-dual stores each derivative part of those types as an `Option`, which
//! compiled Rust models optimise away (the seeding is visible to the compiler after inlining),
//! but an interpreter cannot: every instruction would branch on the tags and move the values
//! through memory in pieces of different widths, and the loads that follow stall on the stores
//! (on the double pendulum, several times the cost of the same instruction as a jet). The jets
//! compute the same numbers (dense, every part present). `f64`, `Dual64` and `Dual2_64` have no
//! `Option` parts and keep their own arithmetic.

use crate::expr::functions::unary_functions;
use crate::expr::graph::sign;
use crate::scalar::Scalar;
use crate::scalar::is;
use nalgebra::{Const, SMatrix, SVector};
use num_dual::{Derivative, DualSVec64, HyperDualVec64};

/// The [`Arith`] methods of the functions of one argument, from their table
/// (`expr/functions.rs`; `sign` is a step, so its derivatives are zero).
macro_rules! arith_methods {
    ($($name:ident {
        doc: $doc:expr,
        name: $($py:literal)?,
        value: |$x:ident| $value:expr,
        tangent: |$d:ident, $a:ident, $y:ident, $da:ident| $tangent:expr,
        num: |$nx:ident| $num:expr,
        jet: |$jx:ident| $jet:expr,
        series: $series:expr,
        libm: $($sym:ident = $f:ident)?,
        ins: $u:ident, $ua:ident: $m:ident,
        dual_num: $($dn:ident)?,
    })*) => {
        $(#[doc = $doc] fn $m(self) -> Self;)*
    };
}

/// [`Num`]'s methods of the functions of one argument: each row's `num` on the wrapped scalar.
macro_rules! num_methods {
    ($($name:ident {
        doc: $doc:expr,
        name: $($py:literal)?,
        value: |$x:ident| $value:expr,
        tangent: |$d:ident, $a:ident, $y:ident, $da:ident| $tangent:expr,
        num: |$nx:ident| $num:expr,
        jet: |$jx:ident| $jet:expr,
        series: $series:expr,
        libm: $($sym:ident = $f:ident)?,
        ins: $u:ident, $ua:ident: $m:ident,
        dual_num: $($dn:ident)?,
    })*) => {
        $(
            #[inline(always)]
            fn $m(self) -> Self {
                let $nx = self.0;
                Num($num)
            }
        )*
    };
}

/// [`Jet`]'s methods of the functions of one argument: each row's `jet`.
macro_rules! jet_methods {
    ($($name:ident {
        doc: $doc:expr,
        name: $($py:literal)?,
        value: |$x:ident| $value:expr,
        tangent: |$d:ident, $a:ident, $y:ident, $da:ident| $tangent:expr,
        num: |$nx:ident| $num:expr,
        jet: |$jx:ident| $jet:expr,
        series: $series:expr,
        libm: $($sym:ident = $f:ident)?,
        ins: $u:ident, $ua:ident: $m:ident,
        dual_num: $($dn:ident)?,
    })*) => {
        $(
            #[inline(always)]
            fn $m(self) -> Self {
                let $jx = self;
                $jet
            }
        )*
    };
}

/// The operations of a tape instruction.
pub(crate) trait Arith: Copy {
    fn cst(x: f64) -> Self;
    fn zero() -> Self {
        Self::cst(0.0)
    }
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn add_c(self, c: f64) -> Self;
    fn sub_c(self, c: f64) -> Self;
    fn c_sub(self, c: f64) -> Self;
    fn mul_c(self, c: f64) -> Self;
    fn div_c(self, c: f64) -> Self;
    fn c_div(self, c: f64) -> Self;
    fn pow_c(self, c: f64) -> Self;
    fn c_pow(self, c: f64) -> Self;
    fn powd(self, o: Self) -> Self;
    fn atan2(self, o: Self) -> Self;
    fn atan2_c(self, c: f64) -> Self;
    fn c_atan2(self, c: f64) -> Self;
    fn sin_cos(self) -> (Self, Self);
    fn sqr(self) -> Self;
    fn powi(self, n: i32) -> Self;
    unary_functions!(arith_methods);
}

/// atan2(y, x) of dual numbers with derivatives wherever (x, y) ≠ 0: num-dual's is atan(y/x),
/// whose derivatives are NaN at x = 0. atan(y/x) where |x| ≥ |y|, −atan(x/y) elsewhere (the
/// same derivatives), its value replaced by `f64::atan2` of the real parts bit for bit (also
/// −0.0); where the ratio is not finite (the origin, infinities), num-dual's.
#[inline(always)]
fn atan2<D: Scalar>(y: D, x: D) -> D {
    let (yr, xr) = (y.re(), x.re());
    let a = if xr.abs() >= yr.abs() {
        (y / x).atan()
    } else {
        -(x / y).atan()
    };
    if !a.re().is_finite() {
        return y.atan2(x);
    }
    // a.re − a has the value +0.0 and the derivatives of −a.
    D::from(yr.atan2(xr)) - (D::from(a.re()) - a)
}

/// Any [`Scalar`], evaluated with its own (num-dual) arithmetic.
#[derive(Debug, Clone, Copy)]
#[repr(transparent)]
pub(crate) struct Num<D>(pub(crate) D);

impl<D: Scalar> Arith for Num<D> {
    unary_functions!(num_methods);

    #[inline(always)]
    fn cst(x: f64) -> Self {
        Num(D::from(x))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Num(self.0 + o.0)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Num(self.0 - o.0)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Num(self.0 * o.0)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        Num(self.0 / o.0)
    }
    #[inline(always)]
    fn add_c(self, c: f64) -> Self {
        Num(self.0 + c)
    }
    #[inline(always)]
    fn sub_c(self, c: f64) -> Self {
        Num(self.0 - c)
    }
    #[inline(always)]
    fn c_sub(self, c: f64) -> Self {
        Num(-self.0 + c)
    }
    #[inline(always)]
    fn mul_c(self, c: f64) -> Self {
        Num(self.0 * c)
    }
    #[inline(always)]
    fn div_c(self, c: f64) -> Self {
        Num(self.0 / c)
    }
    #[inline(always)]
    fn c_div(self, c: f64) -> Self {
        Num(self.0.recip() * c)
    }
    #[inline(always)]
    fn pow_c(self, c: f64) -> Self {
        Num(self.0.powf(c))
    }
    #[inline(always)]
    fn c_pow(self, c: f64) -> Self {
        Num((self.0 * c.ln()).exp())
    }
    #[inline(always)]
    fn powd(self, o: Self) -> Self {
        Num(self.0.powd(o.0))
    }
    #[inline(always)]
    fn atan2(self, o: Self) -> Self {
        Num(atan2(self.0, o.0))
    }
    #[inline(always)]
    fn atan2_c(self, c: f64) -> Self {
        Num(atan2(self.0, D::from(c)))
    }
    #[inline(always)]
    fn c_atan2(self, c: f64) -> Self {
        Num(atan2(D::from(c), self.0))
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.0.sin_cos();
        (Num(s), Num(c))
    }
    #[inline(always)]
    fn sqr(self) -> Self {
        Num(self.0 * self.0)
    }
    #[inline(always)]
    fn powi(self, n: i32) -> Self {
        Num(self.0.powi(n))
    }
}

/// A truncated Taylor expansion to which the chain rule applies: the jets below.
pub(crate) trait Chain: Copy {
    fn re(&self) -> f64;
    fn cst(x: f64) -> Self;
    /// f(self) from f and its first two derivatives at the real part.
    fn chain(self, f0: f64, f1: f64, f2: f64) -> Self;
    /// f(a, b) from f, its gradient (fa, fb) and Hessian (faa, fab, fbb) at the real parts.
    #[allow(clippy::too_many_arguments)]
    fn chain2(a: Self, b: Self, f0: f64, fa: f64, fb: f64, faa: f64, fab: f64, fbb: f64) -> Self;
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn scale(self, c: f64) -> Self;
    fn shift(self, c: f64) -> Self;
}

/// First derivatives in `K` directions: `DualSVec64<K>` without the `Option`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct First<const K: usize> {
    pub(crate) re: f64,
    pub(crate) e: [f64; K],
}

impl<const K: usize> Chain for First<K> {
    #[inline(always)]
    fn re(&self) -> f64 {
        self.re
    }
    #[inline(always)]
    fn cst(x: f64) -> Self {
        Self { re: x, e: [0.0; K] }
    }
    #[inline(always)]
    fn chain(self, f0: f64, f1: f64, _f2: f64) -> Self {
        Self {
            re: f0,
            e: self.e.map(|e| f1 * e),
        }
    }
    #[inline(always)]
    fn chain2(a: Self, b: Self, f0: f64, fa: f64, fb: f64, _: f64, _: f64, _: f64) -> Self {
        Self {
            re: f0,
            e: std::array::from_fn(|i| fa * a.e[i] + fb * b.e[i]),
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            re: self.re + o.re,
            e: std::array::from_fn(|i| self.e[i] + o.e[i]),
        }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            re: self.re - o.re,
            e: std::array::from_fn(|i| self.e[i] - o.e[i]),
        }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self {
            re: self.re * o.re,
            e: std::array::from_fn(|i| self.e[i] * o.re + self.re * o.e[i]),
        }
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        Self {
            re: self.re * c,
            e: self.e.map(|e| e * c),
        }
    }
    #[inline(always)]
    fn shift(self, c: f64) -> Self {
        Self {
            re: self.re + c,
            e: self.e,
        }
    }
}

/// First derivatives in `M` and `N` directions and the mixed second derivatives:
/// `HyperDualSVec64<M, N>` without the `Option`s.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Second<const M: usize, const N: usize> {
    pub(crate) re: f64,
    pub(crate) e1: [f64; M],
    pub(crate) e2: [f64; N],
    pub(crate) e12: [[f64; N]; M],
}

impl<const M: usize, const N: usize> Chain for Second<M, N> {
    #[inline(always)]
    fn re(&self) -> f64 {
        self.re
    }
    #[inline(always)]
    fn cst(x: f64) -> Self {
        Self {
            re: x,
            e1: [0.0; M],
            e2: [0.0; N],
            e12: [[0.0; N]; M],
        }
    }
    #[inline(always)]
    fn chain(self, f0: f64, f1: f64, f2: f64) -> Self {
        Self {
            re: f0,
            e1: self.e1.map(|e| f1 * e),
            e2: self.e2.map(|e| f1 * e),
            e12: std::array::from_fn(|i| {
                std::array::from_fn(|j| f1 * self.e12[i][j] + f2 * self.e1[i] * self.e2[j])
            }),
        }
    }
    #[inline(always)]
    fn chain2(a: Self, b: Self, f0: f64, fa: f64, fb: f64, faa: f64, fab: f64, fbb: f64) -> Self {
        Self {
            re: f0,
            e1: std::array::from_fn(|i| fa * a.e1[i] + fb * b.e1[i]),
            e2: std::array::from_fn(|j| fa * a.e2[j] + fb * b.e2[j]),
            e12: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    fa * a.e12[i][j]
                        + fb * b.e12[i][j]
                        + faa * a.e1[i] * a.e2[j]
                        + fab * (a.e1[i] * b.e2[j] + b.e1[i] * a.e2[j])
                        + fbb * b.e1[i] * b.e2[j]
                })
            }),
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            re: self.re + o.re,
            e1: std::array::from_fn(|i| self.e1[i] + o.e1[i]),
            e2: std::array::from_fn(|j| self.e2[j] + o.e2[j]),
            e12: std::array::from_fn(|i| std::array::from_fn(|j| self.e12[i][j] + o.e12[i][j])),
        }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            re: self.re - o.re,
            e1: std::array::from_fn(|i| self.e1[i] - o.e1[i]),
            e2: std::array::from_fn(|j| self.e2[j] - o.e2[j]),
            e12: std::array::from_fn(|i| std::array::from_fn(|j| self.e12[i][j] - o.e12[i][j])),
        }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self {
            re: self.re * o.re,
            e1: std::array::from_fn(|i| self.e1[i] * o.re + self.re * o.e1[i]),
            e2: std::array::from_fn(|j| self.e2[j] * o.re + self.re * o.e2[j]),
            e12: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    self.e12[i][j] * o.re
                        + self.re * o.e12[i][j]
                        + self.e1[i] * o.e2[j]
                        + o.e1[i] * self.e2[j]
                })
            }),
        }
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        Self {
            re: self.re * c,
            e1: self.e1.map(|e| e * c),
            e2: self.e2.map(|e| e * c),
            e12: self.e12.map(|row| row.map(|e| e * c)),
        }
    }
    #[inline(always)]
    fn shift(self, c: f64) -> Self {
        Self {
            re: self.re + c,
            ..self
        }
    }
}

/// Everything the energy route needs from T in one pass: [`Second`] with first directions q̇
/// and second directions (q̇, the motion (q̇, 1) in (q, t)) gives M and the mixed terms, and the
/// first-order part `g` in the directions q gives ∂T/∂q.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lagrange<const N: usize, const N1: usize> {
    pub(crate) s: Second<N, N1>,
    pub(crate) g: [f64; N],
}

impl<const N: usize, const N1: usize> Chain for Lagrange<N, N1> {
    #[inline(always)]
    fn re(&self) -> f64 {
        self.s.re
    }
    #[inline(always)]
    fn cst(x: f64) -> Self {
        Self {
            s: Second::cst(x),
            g: [0.0; N],
        }
    }
    #[inline(always)]
    fn chain(self, f0: f64, f1: f64, f2: f64) -> Self {
        Self {
            s: self.s.chain(f0, f1, f2),
            g: self.g.map(|g| f1 * g),
        }
    }
    #[inline(always)]
    fn chain2(a: Self, b: Self, f0: f64, fa: f64, fb: f64, faa: f64, fab: f64, fbb: f64) -> Self {
        Self {
            s: Second::chain2(a.s, b.s, f0, fa, fb, faa, fab, fbb),
            g: std::array::from_fn(|i| fa * a.g[i] + fb * b.g[i]),
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            s: self.s.add(o.s),
            g: std::array::from_fn(|i| self.g[i] + o.g[i]),
        }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            s: self.s.sub(o.s),
            g: std::array::from_fn(|i| self.g[i] - o.g[i]),
        }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self {
            s: self.s.mul(o.s),
            g: std::array::from_fn(|i| self.g[i] * o.s.re + self.s.re * o.g[i]),
        }
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        Self {
            s: self.s.scale(c),
            g: self.g.map(|g| g * c),
        }
    }
    #[inline(always)]
    fn shift(self, c: f64) -> Self {
        Self {
            s: self.s.shift(c),
            g: self.g,
        }
    }
}

/// Jets get the tape's arithmetic from the chain rule.
#[derive(Debug, Clone, Copy)]
#[repr(transparent)]
pub(crate) struct Jet<J>(pub(crate) J);

impl<J: Chain> Arith for Jet<J> {
    unary_functions!(jet_methods);

    #[inline(always)]
    fn cst(x: f64) -> Self {
        Jet(J::cst(x))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Jet(self.0.add(o.0))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Jet(self.0.sub(o.0))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Jet(self.0.mul(o.0))
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let (a, b) = (self.0.re(), o.0.re());
        let r = b.recip();
        let q = a * r;
        Jet(J::chain2(
            self.0,
            o.0,
            a / b,
            r,
            -q * r,
            0.0,
            -r * r,
            2.0 * q * r * r,
        ))
    }
    #[inline(always)]
    fn add_c(self, c: f64) -> Self {
        Jet(self.0.shift(c))
    }
    #[inline(always)]
    fn sub_c(self, c: f64) -> Self {
        Jet(self.0.shift(-c))
    }
    #[inline(always)]
    fn c_sub(self, c: f64) -> Self {
        Jet(self.0.scale(-1.0).shift(c))
    }
    #[inline(always)]
    fn mul_c(self, c: f64) -> Self {
        Jet(self.0.scale(c))
    }
    #[inline(always)]
    fn div_c(self, c: f64) -> Self {
        let x = self.0.re();
        let r = c.recip();
        Jet(self.0.chain(x / c, r, 0.0))
    }
    #[inline(always)]
    fn c_div(self, c: f64) -> Self {
        let x = self.0.re();
        let r = x.recip();
        Jet(self.0.chain(c / x, -c * r * r, 2.0 * c * r * r * r))
    }
    #[inline(always)]
    fn pow_c(self, c: f64) -> Self {
        if c == 0.0 {
            return Jet(J::cst(1.0));
        }
        if c == 1.0 {
            return self;
        }
        if c == 2.0 {
            return Jet(self.0.mul(self.0));
        }
        let x = self.0.re();
        let p2 = x.powf(c - 2.0);
        let p1 = p2 * x;
        Jet(self.0.chain(p1 * x, c * p1, c * (c - 1.0) * p2))
    }
    #[inline(always)]
    fn c_pow(self, c: f64) -> Self {
        let l = c.ln();
        let f = (self.0.re() * l).exp();
        Jet(self.0.chain(f, f * l, f * l * l))
    }
    #[inline(always)]
    fn powd(self, o: Self) -> Self {
        // aᵇ = exp(b ln a)
        let (a, b) = (self.0.re(), o.0.re());
        let l = a.ln();
        let f = (b * l).exp();
        let r = a.recip();
        Jet(J::chain2(
            self.0,
            o.0,
            f,
            f * b * r,
            f * l,
            f * b * (b - 1.0) * r * r,
            f * r * (1.0 + b * l),
            f * l * l,
        ))
    }
    #[inline(always)]
    fn atan2(self, o: Self) -> Self {
        let (y, x) = (self.0.re(), o.0.re());
        let r2 = (x * x + y * y).recip();
        let r4 = r2 * r2;
        Jet(J::chain2(
            self.0,
            o.0,
            y.atan2(x),
            x * r2,
            -y * r2,
            -2.0 * x * y * r4,
            (y * y - x * x) * r4,
            2.0 * x * y * r4,
        ))
    }
    #[inline(always)]
    fn atan2_c(self, c: f64) -> Self {
        let y = self.0.re();
        let r2 = (c * c + y * y).recip();
        Jet(self.0.chain(y.atan2(c), c * r2, -2.0 * c * y * r2 * r2))
    }
    #[inline(always)]
    fn c_atan2(self, c: f64) -> Self {
        let x = self.0.re();
        let r2 = (c * c + x * x).recip();
        Jet(self.0.chain(c.atan2(x), -c * r2, 2.0 * c * x * r2 * r2))
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.0.re().sin_cos();
        (Jet(self.0.chain(s, c, -s)), Jet(self.0.chain(c, -s, -c)))
    }
    #[inline(always)]
    fn sqr(self) -> Self {
        Jet(self.0.mul(self.0))
    }
    #[inline(always)]
    fn powi(self, n: i32) -> Self {
        match n {
            0 => Jet(J::cst(1.0)),
            1 => self,
            2 => self.sqr(),
            _ => {
                let x = self.0.re();
                let p2 = x.powi(n - 2);
                let p1 = p2 * x;
                let n = n as f64;
                Jet(self.0.chain(p1 * x, n * p1, n * (n - 1.0) * p2))
            }
        }
    }
}

/// Conversions between a num-dual type and its jet.
pub(crate) trait Convert<D>: Arith {
    fn from_dual(x: &D) -> Self;
    fn into_dual(self) -> D;
}

impl<const K: usize> Convert<DualSVec64<K>> for Jet<First<K>> {
    #[inline(always)]
    fn from_dual(x: &DualSVec64<K>) -> Self {
        Jet(First {
            re: x.re,
            e: x.eps
                .0
                .as_ref()
                .map_or([0.0; K], |e| std::array::from_fn(|i| e[i])),
        })
    }
    #[inline(always)]
    fn into_dual(self) -> DualSVec64<K> {
        DualSVec64::new(self.0.re, Derivative::some(SVector::from(self.0.e)))
    }
}

impl<const M: usize, const N: usize> Convert<HyperDualVec64<Const<M>, Const<N>>>
    for Jet<Second<M, N>>
{
    #[inline(always)]
    fn from_dual(x: &HyperDualVec64<Const<M>, Const<N>>) -> Self {
        Jet(Second {
            re: x.re,
            e1: x
                .eps1
                .0
                .as_ref()
                .map_or([0.0; M], |e| std::array::from_fn(|i| e[i])),
            e2: x
                .eps2
                .0
                .as_ref()
                .map_or([0.0; N], |e| std::array::from_fn(|j| e[j])),
            e12: x.eps1eps2.0.as_ref().map_or([[0.0; N]; M], |e| {
                std::array::from_fn(|i| std::array::from_fn(|j| e[(i, j)]))
            }),
        })
    }
    #[inline(always)]
    fn into_dual(self) -> HyperDualVec64<Const<M>, Const<N>> {
        let s = self.0;
        HyperDualVec64::new(
            s.re,
            Derivative::some(SVector::from(s.e1)),
            Derivative::some(SMatrix::<f64, 1, N>::from_fn(|_, j| s.e2[j])),
            Derivative::some(SMatrix::<f64, M, N>::from_fn(|i, j| s.e12[i][j])),
        )
    }
}
