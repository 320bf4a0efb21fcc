//! The instruction set, stated once: `instruction_set!` generates from one table the [`Ins`]
//! enum, the lowering of an [`InsOp`] to an instruction ([`lower`]) and its evaluation ([`step`]).
//!
//! Every result is stored in its slot and also kept in an accumulator; the `…A` forms take their
//! (first) variable operand from the accumulator and the `…B` forms their second, so that a
//! value consumed by the very next instruction never makes a round trip through memory (an
//! interpreter's store-to-load stalls cost more than the dual-number arithmetic itself).
//!
//! To add a function of one argument: its row in the table of `expr/functions.rs`, which gives
//! the `unary` block below, its [`Arith`] arithmetic (`jet.rs`) and its [`Emit`] call. A function of two
//! arguments: one line in `commutative` or `ordered`, which also gives its forms with a constant
//! operand (`x op c`, and `c op x` for the ordered ones). With the `jit` feature, a new
//! [`Arith`] method also needs its [`Emit`] twin (its native code, `native/tape.rs`): the compiler
//! says so.

use super::jet::Arith;
#[cfg(feature = "jit")]
use crate::error::Result;
use crate::expr::functions::unary_functions;
use crate::expr::graph::{Binary, Unary};

/// What an instruction computes, before slots are assigned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum InsOp {
    Un(Unary),
    Sqr,
    PowI(i32),
    SinCos,
    /// Both operands variable.
    Bin(Binary),
    /// Variable operand first, constant `c` second.
    BinVC(Binary, u32),
    /// Constant `c` first, variable operand second.
    BinCV(Binary, u32),
}

/// Store `v` in slot `d` and in the accumulator.
macro_rules! put {
    ($s:ident, $acc:ident, $d:expr, $v:expr) => {{
        let v = $v;
        *$acc = v;
        // SAFETY: see `step`.
        unsafe { *$s.get_unchecked_mut($d as usize) = v };
    }};
}

/// The table → `Ins`, `lower`, `step` (and `emit`, native code, with the `jit` feature). Each line names the variants of one function and the
/// [`Arith`] method that evaluates them:
/// - `unary`: `F => slot form, accumulator form: method`;
/// - `commutative`: `F => a∘b, acc∘b: method; x∘c, acc∘c: method` (`c∘x` is `x∘c`);
/// - `ordered`: `F => a∘b, acc∘b, a∘acc: method; x∘c, acc∘c: method; c∘x, c∘acc: method`.
///
/// The square, integer powers and `sin_cos` (two results) are written out in the macro.
macro_rules! instruction_set {
    (
        unary { $($uf:ident => $u:ident, $ua:ident: $um:ident;)* }
        commutative {
            $($cf:ident => $c:ident, $ca:ident: $cm:ident; $cc:ident, $cca:ident: $ccm:ident;)*
        }
        ordered {
            $($of:ident => $o:ident, $oa:ident, $ob:ident: $om:ident;
                $oc:ident, $oca:ident: $ocm:ident; $co:ident, $coa:ident: $com:ident;)*
        }
    ) => {
        /// One instruction over slots: destination first, then operand slots or constant
        /// indices (see the module docs for the accumulator forms).
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub(crate) enum Ins {
            $($u(u32, u32), $ua(u32),)*
            $($c(u32, u32, u32), $ca(u32, u32), $cc(u32, u32, u32), $cca(u32, u32),)*
            $(
                $o(u32, u32, u32), $oa(u32, u32), $ob(u32, u32),
                $oc(u32, u32, u32), $oca(u32, u32), $co(u32, u32, u32), $coa(u32, u32),
            )*
            Sqr(u32, u32),
            SqrA(u32),
            PowI(u32, u32, i32),
            PowIA(u32, i32),
            SinCos(u32, u32, u32),
            SinCosA(u32, u32),
        }

        /// The instruction for `op` writing slot(s) `d`, reading operand slots `a`, `b`, with
        /// the operand equal to the accumulator (if any) read from it: `from_acc` is 1 for the
        /// first operand, 2 for the second, 0 for none.
        pub(crate) fn lower(op: InsOp, d: [u32; 2], a: u32, b: u32, from_acc: u8) -> Ins {
            let d0 = d[0];
            match (op, from_acc) {
                $(
                    (InsOp::Un(Unary::$uf), 0) => Ins::$u(d0, a),
                    (InsOp::Un(Unary::$uf), _) => Ins::$ua(d0),
                )*
                $(
                    (InsOp::Bin(Binary::$cf), 0) => Ins::$c(d0, a, b),
                    (InsOp::Bin(Binary::$cf), 1) => Ins::$ca(d0, b),
                    (InsOp::Bin(Binary::$cf), _) => Ins::$ca(d0, a),
                    (InsOp::BinVC(Binary::$cf, c) | InsOp::BinCV(Binary::$cf, c), 0) => {
                        Ins::$cc(d0, a, c)
                    }
                    (InsOp::BinVC(Binary::$cf, c) | InsOp::BinCV(Binary::$cf, c), _) => {
                        Ins::$cca(d0, c)
                    }
                )*
                $(
                    (InsOp::Bin(Binary::$of), 0) => Ins::$o(d0, a, b),
                    (InsOp::Bin(Binary::$of), 1) => Ins::$oa(d0, b),
                    (InsOp::Bin(Binary::$of), _) => Ins::$ob(d0, a),
                    (InsOp::BinVC(Binary::$of, c), 0) => Ins::$oc(d0, a, c),
                    (InsOp::BinVC(Binary::$of, c), _) => Ins::$oca(d0, c),
                    (InsOp::BinCV(Binary::$of, c), 0) => Ins::$co(d0, a, c),
                    (InsOp::BinCV(Binary::$of, c), _) => Ins::$coa(d0, c),
                )*
                (InsOp::Sqr, 0) => Ins::Sqr(d0, a),
                (InsOp::Sqr, _) => Ins::SqrA(d0),
                (InsOp::PowI(k), 0) => Ins::PowI(d0, a, k),
                (InsOp::PowI(k), _) => Ins::PowIA(d0, k),
                (InsOp::SinCos, 0) => Ins::SinCos(d0, d[1], a),
                (InsOp::SinCos, _) => Ins::SinCosA(d0, d[1]),
            }
        }

        /// One instruction on the slots `s` with the constants `c`.
        #[inline(always)]
        pub(crate) fn step<A: Arith>(ins: &Ins, c: &[f64], s: &mut [A], acc: &mut A) {
            // SAFETY (every `get_unchecked`, here and in `put!`): `Tape::new` gives every slot
            // an index below the tape's slot count and every constant an index below its
            // constant program's length; `Tape::run` hands `step` a buffer of that many slots
            // and checks that `c` has that many constants.
            let ld = |s: &[A], i: u32| -> A { unsafe { *s.get_unchecked(i as usize) } };
            let k = |i: u32| -> f64 { unsafe { *c.get_unchecked(i as usize) } };
            let x = *acc;
            match *ins {
                $(
                    Ins::$u(d, a) => put!(s, acc, d, ld(s, a).$um()),
                    Ins::$ua(d) => put!(s, acc, d, x.$um()),
                )*
                $(
                    Ins::$c(d, a, b) => put!(s, acc, d, ld(s, a).$cm(ld(s, b))),
                    Ins::$ca(d, b) => put!(s, acc, d, x.$cm(ld(s, b))),
                    Ins::$cc(d, a, i) => put!(s, acc, d, ld(s, a).$ccm(k(i))),
                    Ins::$cca(d, i) => put!(s, acc, d, x.$ccm(k(i))),
                )*
                $(
                    Ins::$o(d, a, b) => put!(s, acc, d, ld(s, a).$om(ld(s, b))),
                    Ins::$oa(d, b) => put!(s, acc, d, x.$om(ld(s, b))),
                    Ins::$ob(d, a) => put!(s, acc, d, ld(s, a).$om(x)),
                    Ins::$oc(d, a, i) => put!(s, acc, d, ld(s, a).$ocm(k(i))),
                    Ins::$oca(d, i) => put!(s, acc, d, x.$ocm(k(i))),
                    Ins::$co(d, a, i) => put!(s, acc, d, ld(s, a).$com(k(i))),
                    Ins::$coa(d, i) => put!(s, acc, d, x.$com(k(i))),
                )*
                Ins::Sqr(d, a) => put!(s, acc, d, ld(s, a).sqr()),
                Ins::SqrA(d) => put!(s, acc, d, x.sqr()),
                Ins::PowI(d, a, n) => put!(s, acc, d, ld(s, a).powi(n)),
                Ins::PowIA(d, n) => put!(s, acc, d, x.powi(n)),
                Ins::SinCos(ds, dc, a) => {
                    let (sn, cs) = ld(s, a).sin_cos();
                    put!(s, acc, ds, sn);
                    put!(s, acc, dc, cs);
                }
                Ins::SinCosA(ds, dc) => {
                    let (sn, cs) = x.sin_cos();
                    put!(s, acc, ds, sn);
                    put!(s, acc, dc, cs);
                }
            }
        }

        /// Lower one instruction through `e` (native code, `native/tape.rs`): the same table as
        /// [`step`], with the arithmetic of [`Emit`] instead of [`Arith`].
        #[cfg(feature = "jit")]
        pub(crate) fn emit<E: Emit>(ins: &Ins, e: &mut E) -> Result<()> {
            match *ins {
                $(
                    Ins::$u(d, a) => {
                        let x = e.slot(a)?;
                        let v = e.$um(x);
                        e.set(d, v)
                    }
                    Ins::$ua(d) => {
                        let x = e.acc()?;
                        let v = e.$um(x);
                        e.set(d, v)
                    }
                )*
                $(
                    Ins::$c(d, a, b) => {
                        let (x, y) = (e.slot(a)?, e.slot(b)?);
                        let v = e.$cm(x, y);
                        e.set(d, v)
                    }
                    Ins::$ca(d, b) => {
                        let (x, y) = (e.acc()?, e.slot(b)?);
                        let v = e.$cm(x, y);
                        e.set(d, v)
                    }
                    Ins::$cc(d, a, i) => {
                        let (x, c) = (e.slot(a)?, e.constant(i)?);
                        let v = e.$ccm(x, c);
                        e.set(d, v)
                    }
                    Ins::$cca(d, i) => {
                        let (x, c) = (e.acc()?, e.constant(i)?);
                        let v = e.$ccm(x, c);
                        e.set(d, v)
                    }
                )*
                $(
                    Ins::$o(d, a, b) => {
                        let (x, y) = (e.slot(a)?, e.slot(b)?);
                        let v = e.$om(x, y);
                        e.set(d, v)
                    }
                    Ins::$oa(d, b) => {
                        let (x, y) = (e.acc()?, e.slot(b)?);
                        let v = e.$om(x, y);
                        e.set(d, v)
                    }
                    Ins::$ob(d, a) => {
                        let (x, y) = (e.slot(a)?, e.acc()?);
                        let v = e.$om(x, y);
                        e.set(d, v)
                    }
                    Ins::$oc(d, a, i) => {
                        let (x, c) = (e.slot(a)?, e.constant(i)?);
                        let v = e.$ocm(x, c);
                        e.set(d, v)
                    }
                    Ins::$oca(d, i) => {
                        let (x, c) = (e.acc()?, e.constant(i)?);
                        let v = e.$ocm(x, c);
                        e.set(d, v)
                    }
                    Ins::$co(d, a, i) => {
                        let (x, c) = (e.slot(a)?, e.constant(i)?);
                        let v = e.$com(x, c);
                        e.set(d, v)
                    }
                    Ins::$coa(d, i) => {
                        let (x, c) = (e.acc()?, e.constant(i)?);
                        let v = e.$com(x, c);
                        e.set(d, v)
                    }
                )*
                Ins::Sqr(d, a) => {
                    let x = e.slot(a)?;
                    let v = e.sqr(x);
                    e.set(d, v)
                }
                Ins::SqrA(d) => {
                    let x = e.acc()?;
                    let v = e.sqr(x);
                    e.set(d, v)
                }
                Ins::PowI(d, a, n) => {
                    let x = e.slot(a)?;
                    let v = e.powi(x, n);
                    e.set(d, v)
                }
                Ins::PowIA(d, n) => {
                    let x = e.acc()?;
                    let v = e.powi(x, n);
                    e.set(d, v)
                }
                Ins::SinCos(ds, dc, a) => {
                    let x = e.slot(a)?;
                    let (sn, cs) = e.sin_cos(x);
                    e.set(ds, sn)?;
                    e.set(dc, cs)
                }
                Ins::SinCosA(ds, dc) => {
                    let x = e.acc()?;
                    let (sn, cs) = e.sin_cos(x);
                    e.set(ds, sn)?;
                    e.set(dc, cs)
                }
            }
        }
    };
}

/// The [`Emit`] methods of the functions of one argument, from their table.
#[cfg(feature = "jit")]
macro_rules! emit_methods {
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
        $(fn $m(&mut self, a: Self::V) -> Self::V;)*
    };
}

/// A code generator for the instruction set (`native/tape.rs`): [`Arith`]'s operations on the values
/// `V` of the generated code, with constants as values too, and the reads and writes of slots,
/// constants and the accumulator, each checked (an error, not a panic, for a malformed tape).
#[cfg(feature = "jit")]
pub(crate) trait Emit {
    type V: Copy;
    /// The value in slot `i`.
    fn slot(&mut self, i: u32) -> Result<Self::V>;
    /// The last value written.
    fn acc(&mut self) -> Result<Self::V>;
    /// Constant `i`.
    fn constant(&mut self, i: u32) -> Result<Self::V>;
    /// Write slot `d` (and the accumulator).
    fn set(&mut self, d: u32, v: Self::V) -> Result<()>;
    fn add(&mut self, a: Self::V, b: Self::V) -> Self::V;
    fn sub(&mut self, a: Self::V, b: Self::V) -> Self::V;
    fn mul(&mut self, a: Self::V, b: Self::V) -> Self::V;
    fn div(&mut self, a: Self::V, b: Self::V) -> Self::V;
    fn add_c(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn sub_c(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn c_sub(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn mul_c(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn div_c(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn c_div(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn pow_c(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn c_pow(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn powd(&mut self, a: Self::V, b: Self::V) -> Self::V;
    fn atan2(&mut self, a: Self::V, b: Self::V) -> Self::V;
    fn atan2_c(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn c_atan2(&mut self, a: Self::V, c: Self::V) -> Self::V;
    fn sin_cos(&mut self, a: Self::V) -> (Self::V, Self::V);
    fn sqr(&mut self, a: Self::V) -> Self::V;
    fn powi(&mut self, a: Self::V, n: i32) -> Self::V;
    unary_functions!(emit_methods);
}

/// The table, its `unary` block from the functions of one argument (`expr/functions.rs`).
macro_rules! instruction_set_of {
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
        instruction_set! {
            unary { $($u => $u, $ua: $m;)* }
            commutative {
                Add => Add, AddA: add; AddC, AddCA: add_c;
                Mul => Mul, MulA: mul; MulC, MulCA: mul_c;
            }
            ordered {
                Sub => Sub, SubA, SubB: sub; SubC, SubCA: sub_c; CSub, CSubA: c_sub;
                Div => Div, DivA, DivB: div; DivC, DivCA: div_c; CDiv, CDivA: c_div;
                Pow => Pow, PowA, PowB: powd; PowC, PowCA: pow_c; CPow, CPowA: c_pow;
                Atan2 => Atan2, Atan2A, Atan2B: atan2; Atan2C, Atan2CA: atan2_c; CAtan2, CAtan2A: c_atan2;
            }
        }
    };
}

unary_functions!(instruction_set_of);
