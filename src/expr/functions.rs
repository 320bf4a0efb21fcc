//! The elementary functions of one argument, each stated once: what it is, its value on a
//! number, its derivative on the graph, and the maths library's function the compiled code
//! calls for it. The table is a macro that hands the list to a macro of the file that needs a
//! piece of it — `graph.rs` generates [`Unary`](super::graph::Unary), `Unary::ALL` and
//! `Unary::apply` from it, `derive.rs` the tangent rule, `program/ins.rs` the instructions (and
//! the `Emit` methods), `program/jet.rs` the `Arith` methods' declarations, `src/native/mod.rs`
//! the `extern "C"` wrappers it registers and `native/tape.rs` the calls of them — so a new
//! function's value, derivative, instruction and maths-library call are one entry here. Its jet
//! arithmetic (`program/jet.rs`: how dual numbers carry it) and its Taylor recurrence
//! (`taylor/series.rs`, lowered in `taylor/lower.rs`, emitted in `taylor/emit.rs`) are written in
//! their own floors: five files for a new function, against seven before.
//!
//! Each entry: `Variant { doc, value: |x| f(x), tangent: |d, a, y, da| ẏ, libm: symbol = f64
//! method or nothing, ins: slot form, accumulator form: method }`, where the tangent gets the graph builder `d`, the argument's node `a`,
//! the function's node `y` and the argument's tangent `da` (an `Option`, always `Some`), and
//! gives ẏ (`None` for zero); the arithmetic is exactly the former match arms', so the graphs
//! and their values are the same bits.

/// Expands `$then! { entries }` with one entry per function of one argument (see the module).
macro_rules! unary_functions {
    ($then:ident) => {
        $then! {
            Neg {
                doc: "−x",
                value: |x| -x,
                tangent: |d, a, y, da| da.map(|g| d.neg(g)).transpose(),
                libm: ,
                ins: Neg, NegA: neg,
            }
            Sin {
                doc: "sin x",
                value: |x| x.sin(),
                tangent: |d, a, y, da| {
                    let c = d.unary(Unary::Cos, a)?;
                    d.mul_opt(da, c)
                },
                libm: lagrangian_sin = sin,
                ins: Sin, SinA: sin,
            }
            Cos {
                doc: "cos x",
                value: |x| x.cos(),
                tangent: |d, a, y, da| {
                    let s = d.unary(Unary::Sin, a)?;
                    let ns = d.neg(s)?;
                    d.mul_opt(da, ns)
                },
                libm: lagrangian_cos = cos,
                ins: Cos, CosA: cos,
            }
            Tan {
                doc: "tan x",
                value: |x| x.tan(),
                tangent: |d, a, y, da| {
                    // (1 + tan²a) ȧ
                    let one = d.0.constant(1.0);
                    let y2 = d.powi(y, 2)?;
                    let k = d.add(one, y2)?;
                    d.mul_opt(da, k)
                },
                libm: lagrangian_tan = tan,
                ins: Tan, TanA: tan,
            }
            Exp {
                doc: "eˣ",
                value: |x| x.exp(),
                tangent: |d, a, y, da| d.mul_opt(da, y),
                libm: lagrangian_exp = exp,
                ins: Exp, ExpA: exp,
            }
            Ln {
                doc: "ln x",
                value: |x| x.ln(),
                tangent: |d, a, y, da| da.map(|g| d.div(g, a)).transpose(),
                libm: lagrangian_ln = ln,
                ins: Ln, LnA: ln,
            }
            Sqrt {
                doc: "√x",
                value: |x| x.sqrt(),
                tangent: |d, a, y, da| {
                    // ȧ / (2 √a)
                    let two = d.0.constant(2.0);
                    let k = d.mul(two, y)?;
                    da.map(|g| d.div(g, k)).transpose()
                },
                libm: ,
                ins: Sqrt, SqrtA: sqrt,
            }
            Sinh {
                doc: "sinh x",
                value: |x| x.sinh(),
                tangent: |d, a, y, da| {
                    let c = d.unary(Unary::Cosh, a)?;
                    d.mul_opt(da, c)
                },
                libm: lagrangian_sinh = sinh,
                ins: Sinh, SinhA: sinh,
            }
            Cosh {
                doc: "cosh x",
                value: |x| x.cosh(),
                tangent: |d, a, y, da| {
                    let s = d.unary(Unary::Sinh, a)?;
                    d.mul_opt(da, s)
                },
                libm: lagrangian_cosh = cosh,
                ins: Cosh, CoshA: cosh,
            }
            Tanh {
                doc: "tanh x",
                value: |x| x.tanh(),
                tangent: |d, a, y, da| {
                    // (1 − tanh²a) ȧ
                    let one = d.0.constant(1.0);
                    let y2 = d.powi(y, 2)?;
                    let k = d.sub(one, y2)?;
                    d.mul_opt(da, k)
                },
                libm: lagrangian_tanh = tanh,
                ins: Tanh, TanhA: tanh,
            }
            Abs {
                doc: "|x|",
                value: |x| x.abs(),
                tangent: |d, a, y, da| {
                    // sign(a) ȧ, with the dual numbers' sign at a = 0 (a / |a| would be 0/0 there)
                    let sign = d.unary(Unary::Sign, a)?;
                    d.mul_opt(da, sign)
                },
                libm: ,
                ins: Abs, AbsA: abs,
            }
            Sign {
                doc: "The slope of |x| as the dual numbers take it: 1 for x > 0, −1 otherwise (so \
at 0 it is −1, as num-dual's `abs`). The derivative of |x| on the graph, \
finite at x = 0.",
                value: |x| sign(x),
                tangent: |d, a, y, da| Ok(None),
                libm: ,
                ins: Sign, SignA: sign,
            }
        }
    };
}

pub(crate) use unary_functions;
