//! The code of each recurrence ([`SeriesOp`]) at order 0 and at order k, in the order
//! [`SeriesOp::apply`] computes it, on the emitter's loads, stores and convolutions.

use super::{Ix, SeriesEmitter, Top};
use crate::taylor::series::SeriesOp;
use cranelift_codegen::ir::{InstBuilder, StackSlotData, StackSlotKind, condcodes, types};

impl SeriesEmitter<'_> {
    /// Coefficient 0 of `op`'s rows, as [`SeriesOp::apply`] computes it for k = 0; `ptr` is the
    /// pointer type.
    pub(crate) fn op0(&mut self, op: &SeriesOp, ptr: types::Type) {
        self.k = Ix::Fixed(0);
        let unary = |g: &mut Self, out: usize, a: usize, name: &str| {
            let x = g.at0(a);
            let y = g.call(name, &[x]);
            g.store_k(out, y);
        };
        match *op {
            SeriesOp::Recip { out, b } => {
                let (one, x) = (self.f64(1.0), self.at0(b));
                let y = self.b.ins().fdiv(one, x);
                self.store_k(out, y);
            }
            SeriesOp::Exp { out, a } => unary(self, out, a, "lagrangian_exp"),
            SeriesOp::Ln { out, a } => unary(self, out, a, "lagrangian_ln"),
            SeriesOp::Sqrt { out, a } => {
                let x = self.at0(a);
                let y = self.b.ins().sqrt(x);
                self.store_k(out, y);
            }
            SeriesOp::SinCos {
                s,
                c,
                a,
                hyperbolic: true,
                ..
            } => {
                unary(self, s, a, "lagrangian_sinh");
                unary(self, c, a, "lagrangian_cosh");
            }
            SeriesOp::SinCos { s, c, a, .. } => {
                // One call: the cosine comes back through an 8-byte slot of the frame.
                let slot = self.b.create_sized_stack_slot(StackSlotData::new(
                    StackSlotKind::ExplicitSlot,
                    8,
                    3,
                ));
                let addr = self.b.ins().stack_addr(ptr, slot, 0);
                let x = self.at0(a);
                let sv = self.call("lagrangian_sin_cos", &[x, addr]);
                let cv = self.b.ins().stack_load(ptr, types::F64, slot, 0);
                self.store_k(s, sv);
                self.store_k(c, cv);
            }
            SeriesOp::Tan {
                out,
                w,
                a,
                f,
                hyperbolic,
            } => {
                unary(self, out, a, f.libm()[0]);
                let sq = self.conv(out, out, 0, Top::K, Ix::Fixed(0), false);
                let sq = if hyperbolic {
                    self.b.ins().fneg(sq)
                } else {
                    sq
                };
                let one = self.f64(1.0);
                let wv = self.b.ins().fadd(one, sq);
                self.store_k(w, wv);
            }
            SeriesOp::Abs { out, a } => {
                let x = self.at0(a);
                let y = self.b.ins().fabs(x);
                self.store_k(out, y);
            }
            SeriesOp::Sign { out, a } => {
                // 1 for a > 0, −1 otherwise (NaN included), as `graph::sign`.
                let x = self.at0(a);
                let zero = self.f64(0.0);
                let positive = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, x, zero);
                let (one, minus_one) = (self.f64(1.0), self.f64(-1.0));
                let y = self.b.ins().select(positive, one, minus_one);
                self.store_k(out, y);
            }
            SeriesOp::Atan2 { out, y, x, d, .. } => {
                let xx = self.conv(x, x, 0, Top::K, Ix::Fixed(0), false);
                let yy = self.conv(y, y, 0, Top::K, Ix::Fixed(0), false);
                let d0 = self.b.ins().fadd(xx, yy);
                self.store_k(d, d0);
                let (y0, x0) = (self.at0(y), self.at0(x));
                let theta = self.call("lagrangian_atan2", &[y0, x0]);
                self.store_k(out, theta);
            }
            // The same formula at every order.
            SeriesOp::Copy { .. }
            | SeriesOp::Neg { .. }
            | SeriesOp::Add { .. }
            | SeriesOp::Sub { .. }
            | SeriesOp::Scale { .. }
            | SeriesOp::Mul { .. }
            | SeriesOp::Square { .. }
            | SeriesOp::DivC { .. }
            | SeriesOp::Div { .. } => self.op(op),
        }
    }

    /// Coefficient k of `op`'s rows, as [`SeriesOp::apply`] computes it for k ≥ 1.
    pub(crate) fn op(&mut self, op: &SeriesOp) {
        let (k, inv_k) = (self.k, self.inv_k);
        let (out, value) = match *op {
            SeriesOp::Copy { out, a } => (out, self.at_k(a)),
            SeriesOp::Neg { out, a } => {
                let x = self.at_k(a);
                (out, self.b.ins().fneg(x))
            }
            SeriesOp::Add { out, a, b } => {
                let (x, y) = (self.at_k(a), self.at_k(b));
                (out, self.b.ins().fadd(x, y))
            }
            SeriesOp::Sub { out, a, b } => {
                let (x, y) = (self.at_k(a), self.at_k(b));
                (out, self.b.ins().fsub(x, y))
            }
            SeriesOp::Scale { out, a, c } => {
                let (x, y) = (self.at_k(a), self.at0(c));
                (out, self.b.ins().fmul(x, y))
            }
            SeriesOp::Mul { out, a, b } => (out, self.conv(a, b, 0, Top::K, k, false)),
            SeriesOp::Square { out, a } if k == Ix::Fixed(0) => {
                (out, self.conv(a, a, 0, Top::K, k, false))
            }
            SeriesOp::Square { out, a } => {
                let half = self.conv(a, a, 0, Top::Half, k, false);
                let twice = self.b.ins().fadd(half, half);
                (out, self.square_middle(a, twice))
            }
            SeriesOp::DivC { out, a, c } => {
                let (x, y) = (self.at_k(a), self.at0(c));
                (out, self.b.ins().fdiv(x, y))
            }
            SeriesOp::Div { out, a, b } => {
                let x = self.at_k(a);
                let s = self.conv(b, out, 1, Top::K, k, false);
                let n = self.b.ins().fsub(x, s);
                let d = self.at0(b);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::Recip { out, b } => {
                let s = self.conv(b, out, 1, Top::K, k, false);
                let n = self.b.ins().fneg(s);
                let d = self.at0(b);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::Exp { out, a } => {
                let s = self.conv(a, out, 1, Top::K, k, true);
                (out, self.b.ins().fmul(s, inv_k))
            }
            SeriesOp::Ln { out, a } => {
                let s = self.conv(out, a, 1, Top::Below, k, true);
                let s = self.b.ins().fmul(s, inv_k);
                let x = self.at_k(a);
                let n = self.b.ins().fsub(x, s);
                let d = self.at0(a);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::Sqrt { out, a } => {
                let s = self.conv(out, out, 1, Top::Below, k, false);
                let x = self.at_k(a);
                let n = self.b.ins().fsub(x, s);
                let two = self.f64(2.0);
                let r0 = self.at0(out);
                let d = self.b.ins().fmul(two, r0);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::SinCos {
                s,
                c,
                a,
                hyperbolic,
                degree,
                da,
            } => {
                // j ≤ min(k, degree): a polynomial argument's series ends at its degree; with a′
                // a row, Σₘ₌₀..ₖ₋₁ a′ₘ cₖ₋₁₋ₘ (up to its degree, one less).
                let (sv, cv) = match da {
                    Some(da) => {
                        let top = degree.map_or(Top::Below, |d| Top::BelowDegree(d - 1));
                        let km1 = self.km1();
                        (
                            self.conv(da, c, 0, top, km1, false),
                            self.conv(da, s, 0, top, km1, false),
                        )
                    }
                    None => {
                        let top = degree.map_or(Top::K, Top::Degree);
                        (
                            self.conv(a, c, 1, top, k, true),
                            self.conv(a, s, 1, top, k, true),
                        )
                    }
                };
                let sv = self.b.ins().fmul(sv, inv_k);
                // −(x · 1/k) is x · (−1/k), bit for bit: where k is a constant, one product
                // (a negation is a sign mask made in a register, three instructions).
                let cv = match (hyperbolic, self.k) {
                    (true, _) => self.b.ins().fmul(cv, inv_k),
                    (false, Ix::Fixed(k)) => {
                        let c = self.f64(-1.0 / k as f64);
                        self.b.ins().fmul(cv, c)
                    }
                    (false, _) => {
                        let cv = self.b.ins().fmul(cv, inv_k);
                        self.b.ins().fneg(cv)
                    }
                };
                self.store_k(s, sv);
                (c, cv)
            }
            SeriesOp::Tan {
                out,
                w,
                a,
                hyperbolic,
                ..
            } => {
                let t = self.conv(a, w, 1, Top::K, k, true);
                let t = self.b.ins().fmul(t, inv_k);
                self.store_k(out, t);
                let sq = self.conv(out, out, 0, Top::K, k, false);
                let sq = if hyperbolic {
                    self.b.ins().fneg(sq)
                } else {
                    sq
                };
                (w, sq)
            }
            SeriesOp::Abs { out, a } => {
                let x = self.at_k(a);
                let x0 = self.at0(a);
                let zero = self.f64(0.0);
                let positive = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, x0, zero);
                let m = self.b.ins().fneg(x);
                (out, self.b.ins().select(positive, x, m))
            }
            SeriesOp::Sign { out, .. } => (out, self.f64(0.0)),
            SeriesOp::Atan2 { out, y, x, d, r } => {
                let xx = self.conv(x, x, 0, Top::K, k, false);
                let yy = self.conv(y, y, 0, Top::K, k, false);
                let dk = self.b.ins().fadd(xx, yy);
                self.store_k(d, dk);
                let yx = self.conv(y, x, 1, Top::K, k, true);
                let xy = self.conv(x, y, 1, Top::K, k, true);
                let n = self.b.ins().fsub(yx, xy);
                let km1 = self.km1();
                let dr = self.conv(d, r, 1, Top::Below, km1, false);
                let n = self.b.ins().fsub(n, dr);
                let d0 = self.at0(d);
                let rk = self.b.ins().fdiv(n, d0);
                self.store(r, km1, rk);
                (out, self.b.ins().fmul(rk, inv_k))
            }
        };
        self.store_k(out, value);
    }
}
