//! The elementary functions of one argument, each stated once: one row of the table below holds
//! everything the crate knows of a function — its value, its derivative on the graph, how the
//! dual numbers and the jets carry it, its Taylor recurrence, the maths library's function the
//! compiled code calls, its instructions, and its name in the expression language (Python's
//! `lg.<name>`). The table is a macro that hands the rows to a macro of the file that needs a
//! piece of them (each consumer names the table in a comment): `graph.rs` generates
//! [`Unary`](super::graph::Unary) and its methods, `derive.rs` the tangent rule,
//! `program/ins.rs` the instructions and the `Emit` methods, `program/jet.rs` the `Arith`
//! methods of the dual numbers and the jets, `taylor/lower.rs` the recurrence each function is
//! lowered to, `native/` the maths-library wrappers and their calls, `trace.rs` the `DualNum`
//! methods that record the function, `python/model.rs` the name the Python side sends. Adding a
//! function is a row here and its Python symbol (`python/lagrangian/_expr.py`): see "Adding an
//! elementary function" in `docs/ARCHITECTURE.md`.
//!
//! Each row: `Variant { doc, name, value, tangent, num, jet, series, libm, ins, dual_num }`:
//! - `name`: its name in the expression language (`lg.<name>`, the nodes Python sends), or
//!   nothing for a function only the crate builds;
//! - `value: |x| f(x)` on an `f64`;
//! - `tangent: |d, a, y, da| ẏ`, with the graph builder `d`, the argument's node `a`, the
//!   function's node `y` and the argument's tangent `da` (an `Option`, always `Some`); `None`
//!   for zero;
//! - `num: |x| f(x)` on a [`Scalar`](crate::scalar::Scalar) `x` of type `D` (num-dual's
//!   arithmetic);
//! - `jet: |x| …` on a jet `x: Jet<J>`, usually `Jet(x.0.chain(f, f′, f″))` at the real part;
//! - `series`: the Taylor recurrence it is lowered to (`taylor/lower.rs`'s `Recurrence`, each a
//!   dedicated `SeriesOp`);
//! - `libm: symbol = f64 method` the compiled code calls (order 0 of its series too), or nothing
//!   when it is an instruction of its own;
//! - `ins: slot form, accumulator form: method` (the instructions and the `Arith` method);
//! - `dual_num`: the `DualNum` method that records it when a Rust model is traced, or nothing.
//!
//! The arithmetic of each piece is exactly what it was before the table (the tangents, the
//! dual-number and jet methods moved here verbatim), so graphs, tapes and series are the same
//! bits.

/// Expands `$then! { rows }` with one row per function of one argument (see the module).
macro_rules! unary_functions {
    ($then:ident) => {
        $then! {
            Neg {
                doc: "−x",
                name: "neg",
                value: |x| -x,
                tangent: |d, a, y, da| da.map(|g| d.neg(g)).transpose(),
                num: |x| -x,
                jet: |x| Jet(x.0.scale(-1.0)),
                series: Recurrence::Neg,
                libm: ,
                ins: Neg, NegA: neg,
                dual_num: ,
            }
            Sin {
                doc: "sin x",
                name: "sin",
                value: |x| x.sin(),
                tangent: |d, a, y, da| {
                    let c = d.unary(Unary::Cos, a)?;
                    d.mul_opt(da, c)
                },
                num: |x| x.sin(),
                jet: |x| {
                    let (s, c) = x.0.re().sin_cos();
                    Jet(x.0.chain(s, c, -s))
                },
                series: Recurrence::SinCos { hyperbolic: false, sine: true },
                libm: lagrangian_sin = sin,
                ins: Sin, SinA: sin,
                dual_num: sin,
            }
            Cos {
                doc: "cos x",
                name: "cos",
                value: |x| x.cos(),
                tangent: |d, a, y, da| {
                    let s = d.unary(Unary::Sin, a)?;
                    let ns = d.neg(s)?;
                    d.mul_opt(da, ns)
                },
                num: |x| x.cos(),
                jet: |x| {
                    let (s, c) = x.0.re().sin_cos();
                    Jet(x.0.chain(c, -s, -c))
                },
                series: Recurrence::SinCos { hyperbolic: false, sine: false },
                libm: lagrangian_cos = cos,
                ins: Cos, CosA: cos,
                dual_num: cos,
            }
            Tan {
                doc: "tan x",
                name: "tan",
                value: |x| x.tan(),
                tangent: |d, a, y, da| {
                    // (1 + tan²a) ȧ
                    let one = d.0.constant(1.0);
                    let y2 = d.powi(y, 2)?;
                    let k = d.add(one, y2)?;
                    d.mul_opt(da, k)
                },
                num: |x| x.tan(),
                jet: |x| {
                    let t = x.0.re().tan();
                    let d = 1.0 + t * t;
                    Jet(x.0.chain(t, d, 2.0 * t * d))
                },
                series: Recurrence::Tan { hyperbolic: false },
                libm: lagrangian_tan = tan,
                ins: Tan, TanA: tan,
                dual_num: tan,
            }
            Exp {
                doc: "eˣ",
                name: "exp",
                value: |x| x.exp(),
                tangent: |d, a, y, da| d.mul_opt(da, y),
                num: |x| x.exp(),
                jet: |x| {
                    let e = x.0.re().exp();
                    Jet(x.0.chain(e, e, e))
                },
                series: Recurrence::Exp,
                libm: lagrangian_exp = exp,
                ins: Exp, ExpA: exp,
                dual_num: exp,
            }
            Ln {
                doc: "ln x",
                name: "log",
                value: |x| x.ln(),
                tangent: |d, a, y, da| da.map(|g| d.div(g, a)).transpose(),
                num: |x| x.ln(),
                jet: |x| {
                    let v = x.0.re();
                    let r = v.recip();
                    Jet(x.0.chain(v.ln(), r, -r * r))
                },
                series: Recurrence::Ln,
                libm: lagrangian_ln = ln,
                ins: Ln, LnA: ln,
                dual_num: ln,
            }
            Sqrt {
                doc: "√x",
                name: "sqrt",
                value: |x| x.sqrt(),
                tangent: |d, a, y, da| {
                    // ȧ / (2 √a)
                    let two = d.0.constant(2.0);
                    let k = d.mul(two, y)?;
                    da.map(|g| d.div(g, k)).transpose()
                },
                num: |x| x.sqrt(),
                jet: |x| {
                    let v = x.0.re();
                    let s = v.sqrt();
                    let d = 0.5 / s;
                    Jet(x.0.chain(s, d, -0.5 * d / v))
                },
                series: Recurrence::Sqrt,
                libm: ,
                ins: Sqrt, SqrtA: sqrt,
                dual_num: sqrt,
            }
            Sinh {
                doc: "sinh x",
                name: "sinh",
                value: |x| x.sinh(),
                tangent: |d, a, y, da| {
                    let c = d.unary(Unary::Cosh, a)?;
                    d.mul_opt(da, c)
                },
                num: |x| x.sinh(),
                jet: |x| {
                    let v = x.0.re();
                    let (s, c) = (v.sinh(), v.cosh());
                    Jet(x.0.chain(s, c, s))
                },
                series: Recurrence::SinCos { hyperbolic: true, sine: true },
                libm: lagrangian_sinh = sinh,
                ins: Sinh, SinhA: sinh,
                dual_num: sinh,
            }
            Cosh {
                doc: "cosh x",
                name: "cosh",
                value: |x| x.cosh(),
                tangent: |d, a, y, da| {
                    let s = d.unary(Unary::Sinh, a)?;
                    d.mul_opt(da, s)
                },
                num: |x| x.cosh(),
                jet: |x| {
                    let v = x.0.re();
                    let (s, c) = (v.sinh(), v.cosh());
                    Jet(x.0.chain(c, s, c))
                },
                series: Recurrence::SinCos { hyperbolic: true, sine: false },
                libm: lagrangian_cosh = cosh,
                ins: Cosh, CoshA: cosh,
                dual_num: cosh,
            }
            Tanh {
                doc: "tanh x",
                name: "tanh",
                value: |x| x.tanh(),
                tangent: |d, a, y, da| {
                    // (1 − tanh²a) ȧ
                    let one = d.0.constant(1.0);
                    let y2 = d.powi(y, 2)?;
                    let k = d.sub(one, y2)?;
                    d.mul_opt(da, k)
                },
                // num-dual's is sinh/cosh, ∞/∞ = NaN beyond |x| ≈ 710: −sign(x) e/(e + 2) with
                // e = expm1(−2|x|) (the same derivatives, without cancellation near 0), its
                // value replaced by `f64::tanh` of the real part bit for bit.
                num: |x| {
                    if is::<D, f64>() {
                        x.tanh()
                    } else {
                        let e = (x.abs() * D::from(-2.0)).exp_m1();
                        let a = -e / (e + D::from(2.0));
                        let a = if x.re() < 0.0 { -a } else { a };
                        // a.re − a has the value +0.0 and the derivatives of −a.
                        D::from(x.re().tanh()) - (D::from(a.re()) - a)
                    }
                },
                jet: |x| {
                    let t = x.0.re().tanh();
                    let d = 1.0 - t * t;
                    Jet(x.0.chain(t, d, -2.0 * t * d))
                },
                series: Recurrence::Tan { hyperbolic: true },
                libm: lagrangian_tanh = tanh,
                ins: Tanh, TanhA: tanh,
                dual_num: tanh,
            }
            Abs {
                doc: "|x|",
                name: "abs",
                value: |x| x.abs(),
                tangent: |d, a, y, da| {
                    // sign(a) ȧ, with the dual numbers' sign at a = 0 (a / |a| would be 0/0 there)
                    let sign = d.unary(Unary::Sign, a)?;
                    d.mul_opt(da, sign)
                },
                num: |x| x.abs(),
                // As num-dual: −x unless x > 0.
                jet: |x| if x.0.re() > 0.0 { x } else { x.neg() },
                series: Recurrence::Abs,
                libm: ,
                ins: Abs, AbsA: abs,
                dual_num: ,
            }
            Sign {
                doc: "The slope of |x| as the dual numbers take it: 1 for x > 0, −1 otherwise (so \
at 0 it is −1, as num-dual's `abs`). The derivative of |x| on the graph, \
finite at x = 0.",
                name: ,
                value: |x| sign(x),
                tangent: |d, a, y, da| Ok(None),
                // A step: its derivatives are zero.
                num: |x| D::from(sign(x.re())),
                jet: |x| Jet(J::cst(sign(x.0.re()))),
                series: Recurrence::Sign,
                libm: ,
                ins: Sign, SignA: sign,
                dual_num: ,
            }
        }
    };
}

pub(crate) use unary_functions;
