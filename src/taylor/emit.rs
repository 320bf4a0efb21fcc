//! The code emitter of the Taylor kernels ([`SeriesEmitter`]): one recurrence, a convolution
//! (in lanes, two-lane vectors or a loop), the mirrored series of the unrolled expansion and the
//! end of a step, as Cranelift instructions in the order the interpreter computes them. The code
//! of each recurrence, order 0 and order k, is in `emit/recurrences.rs`.

use super::abi::{KernelStatus, StepControl};
use super::series::{LANES, fresh_ends};
use cranelift_codegen::ir::{
    BlockArg, FuncRef, InstBuilder, MemFlagsData, Value, condcodes, types,
};
use cranelift_frontend::FunctionBuilder;
use std::collections::{HashMap, HashSet};

mod recurrences;

/// The most values an order of the unrolled expansion takes from the registers rather than
/// from a two-lane load ([`SeriesEmitter::pair`]).
pub(crate) const CARRIED: usize = 4;

/// An index the code knows at compilation, or reads at run time.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Ix {
    Fixed(usize),
    Var(Value),
}

/// The last index of a convolution's sum, from the order k being computed.
#[derive(Clone, Copy)]
pub(crate) enum Top {
    /// k: its last term reads a coefficient of order k.
    K,
    /// k − 1.
    Below,
    /// min(k, d): the sum over a polynomial of degree d (its last term reads order k while k ≤ d).
    Degree(usize),
    /// min(k − 1, d): a sum over a polynomial of degree d up to k − 1.
    BelowDegree(usize),
    /// ⌊(k − 1)/2⌋: the first half of a square's sum ([`SeriesOp::Square`](super::series::SeriesOp::Square)).
    Half,
}

/// A series a sum reads: a row of the table, or coordinate c's q̈ (in the unrolled expansion).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Operand {
    Row(usize),
    Qdd(usize),
}

pub(crate) struct SeriesEmitter<'a> {
    pub(crate) b: FunctionBuilder<'a>,
    pub(crate) table: Value,
    /// The row width, and w·8 (bytes).
    pub(crate) w: Ix,
    pub(crate) w8: Value,
    /// The order being computed, and 1/k.
    pub(crate) k: Ix,
    pub(crate) inv_k: Value,
    /// `lagrangian_conv`, imported, when convolutions with an index read at run time are calls
    /// of it; `None`: loops in the code.
    pub(crate) calls: Option<FuncRef>,
    /// The maths library's functions order 0 calls, imported ([`SeriesOp::libm`](super::series::SeriesOp::libm)).
    pub(crate) libm: Vec<(&'static str, FuncRef)>,
    /// Straight-line code (every index fixed, one block): each constant is made once, and an
    /// entry stored in the order at hand is read from the value stored, not from memory (the
    /// chain from qₖ through the recurrences and the solve to qₖ₊₁ then runs in registers, not
    /// through a store and a load at every step: measured 0.70–0.90× the time of a step).
    pub(crate) straight: bool,
    pub(crate) constants: HashMap<u64, Value>,
    pub(crate) memory: HashMap<(Value, i32), Value>,
    /// The unrolled expansion's coefficients of q̈ (coordinate c's order j at c·w + j).
    pub(crate) qdd: Option<Value>,
    /// The unrolled expansion's buffer of reversed series and their slots ([`SeriesEmitter::mirror`]).
    pub(crate) reversed: Option<Value>,
    pub(crate) slots: HashMap<Operand, usize>,
    /// The series whose coefficients beyond 0 the unrolled expansion computes.
    pub(crate) computed: HashSet<Operand>,
    /// The weighted operands j aⱼ of this order's sums (a pair for two lanes, or one), by their
    /// place in the table: sin and cos of one argument both weigh its coefficients, once.
    pub(crate) weighted: HashMap<(Value, i32, bool), Value>,
    /// In the unrolled expansion, the rows whose coefficients are read at later orders: only
    /// those are stored at orders k ≥ 1 (the others are forwarded within their order).
    pub(crate) history: Option<HashSet<usize>>,
    /// In straight-line code, the values stored by the previous order and by this one, by
    /// place, and how many of them this order's two-lane reads have taken from the registers
    /// ([`SeriesEmitter::pair`]).
    pub(crate) stored: [HashMap<(Value, i32), Value>; 2],
    pub(crate) carried: usize,
}

impl<'a> SeriesEmitter<'a> {
    pub(crate) fn new(
        mut b: FunctionBuilder<'a>,
        table: Value,
        w: Ix,
        calls: Option<FuncRef>,
    ) -> Self {
        let w8 = match w {
            Ix::Fixed(w) => b.ins().iconst(types::I64, 8 * w as i64),
            Ix::Var(w) => b.ins().ishl_imm_s(w, 3),
        };
        let inv_k = b.ins().f64const(0.0);
        Self {
            b,
            table,
            w,
            w8,
            k: Ix::Fixed(0),
            inv_k,
            calls,
            libm: Vec::new(),
            straight: matches!(w, Ix::Fixed(_)),
            constants: HashMap::new(),
            memory: HashMap::new(),
            qdd: None,
            reversed: None,
            slots: HashMap::new(),
            computed: HashSet::new(),
            weighted: HashMap::new(),
            history: None,
            stored: [HashMap::new(), HashMap::new()],
            carried: 0,
        }
    }

    pub(crate) fn flags() -> MemFlagsData {
        MemFlagsData::trusted()
    }

    pub(crate) fn f64(&mut self, x: f64) -> Value {
        if !self.straight {
            return self.b.ins().f64const(x);
        }
        if let Some(&v) = self.constants.get(&x.to_bits()) {
            return v;
        }
        let v = self.b.ins().f64const(x);
        self.constants.insert(x.to_bits(), v);
        v
    }

    pub(crate) fn int(&mut self, i: Ix) -> Value {
        match i {
            Ix::Fixed(x) => self.b.ins().iconst(types::I64, x as i64),
            Ix::Var(v) => v,
        }
    }

    /// k − 1.
    pub(crate) fn km1(&mut self) -> Ix {
        match self.k {
            Ix::Fixed(k) => Ix::Fixed(k - 1),
            Ix::Var(k) => Ix::Var(self.b.ins().iadd_imm_s(k, -1)),
        }
    }

    /// The byte offset of entry `i` of an `f64` buffer (its bounds checked at compilation).
    pub(crate) fn offset(i: usize) -> i32 {
        i32::try_from(8 * i).expect("buffer sizes are checked before code is generated")
    }

    /// The address of row r's coefficient 0.
    pub(crate) fn row(&mut self, r: usize) -> Value {
        match self.w {
            Ix::Fixed(w) => self.b.ins().iadd_imm_s(self.table, 8 * (r * w) as i64),
            Ix::Var(_) => {
                let off = self.b.ins().imul_imm_s(self.w8, r as i64);
                self.b.ins().iadd(self.table, off)
            }
        }
    }

    /// Base and byte offset of row r's coefficient j.
    pub(crate) fn slot(&mut self, r: usize, j: Ix) -> (Value, i32) {
        match (self.w, j) {
            (Ix::Fixed(w), Ix::Fixed(j)) => (self.table, Self::offset(r * w + j)),
            (_, Ix::Fixed(j)) => (self.row(r), Self::offset(j)),
            (_, Ix::Var(j)) => {
                let base = self.row(r);
                let off = self.b.ins().ishl_imm_s(j, 3);
                (self.b.ins().iadd(base, off), 0)
            }
        }
    }

    /// Row r's coefficient j.
    pub(crate) fn load(&mut self, r: usize, j: Ix) -> Value {
        let (base, off) = self.slot(r, j);
        self.load_from(base, off)
    }

    pub(crate) fn store(&mut self, r: usize, j: Ix, v: Value) {
        if let Ix::Fixed(1..) = j {
            self.computed.insert(Operand::Row(r));
        }
        let (base, off) = self.slot(r, j);
        if let (Some(history), Ix::Fixed(1..)) = (&self.history, j)
            && !history.contains(&r)
        {
            self.memory.insert((base, off), v);
            return;
        }
        self.store_to(base, off, v);
        if let Ix::Fixed(j) = j {
            self.store_mirror(Operand::Row(r), j, v);
        }
    }

    /// Coordinate c's q̈ₖ, into the unrolled expansion's buffer (and its mirror).
    pub(crate) fn store_qdd(&mut self, c: usize, k: usize, v: Value) {
        let (Some(qdd), Ix::Fixed(w)) = (self.qdd, self.w) else {
            unreachable!("q̈ is stored by the unrolled expansion only")
        };
        self.store_at(qdd, c * w + k, v);
        self.store_mirror(Operand::Qdd(c), k, v);
    }

    /// Coefficient j of a series, in straight-line code.
    pub(crate) fn coefficient(&mut self, x: Operand, j: usize) -> Value {
        match (x, self.qdd, self.w) {
            (Operand::Row(r), ..) => self.load(r, Ix::Fixed(j)),
            (Operand::Qdd(c), Some(qdd), Ix::Fixed(w)) => self.load_at(qdd, c * w + j),
            (Operand::Qdd(_), ..) => unreachable!("q̈ is read by the unrolled expansion only"),
        }
    }

    /// Coefficient j of `x` into its mirror, if it has one.
    pub(crate) fn store_mirror(&mut self, x: Operand, j: usize, v: Value) {
        if let (Some(&slot), Some(reversed), Ix::Fixed(w)) =
            (self.slots.get(&x), self.reversed, self.w)
        {
            let at = Self::offset(slot * w + w - 1 - j);
            self.b.ins().store(Self::flags(), v, reversed, at);
            self.stored[1].insert((reversed, at), v);
        }
    }

    /// The slot of `x`'s mirror in the buffer of reversed series, coefficient j at slot·w + w −
    /// 1 − j: the second operand of a convolution, b in Σ aⱼ b_(kk − j), is read backwards, and
    /// its mirror forwards, two coefficients at a time like a's (a load of two lanes, not two
    /// loads and a shuffle). Made at the first sum that reads it, at order k: coefficients 0
    /// to k are copied then (the expansion runs every order every time, so it is there from
    /// order k on in every run), and every coefficient stored after is mirrored as it is.
    pub(crate) fn mirror(&mut self, x: Operand, k: usize) -> Option<(Value, usize)> {
        let reversed = self.reversed?;
        if let Some(&slot) = self.slots.get(&x) {
            return Some((reversed, slot));
        }
        let slot = self.slots.len();
        self.slots.insert(x, slot);
        for j in 0..=k {
            let v = self.coefficient(x, j);
            self.store_mirror(x, j, v);
        }
        Some((reversed, slot))
    }

    /// Σⱼ₌ₗₒ..ₕᵢ [j] aⱼ b_(kk − j) at order k with every index known at compilation, in the order
    /// of `conv` in `series.rs`: the terms that read no coefficient of order k in the lanes
    /// (four or more of them in two two-lane vectors, [`SeriesEmitter::vector_lanes`]), then the j = 0 term
    /// reading b_k, then the j = k term reading a_k.
    pub(crate) fn sum(
        &mut self,
        a: Operand,
        b: Operand,
        lo: usize,
        hi: usize,
        kk: usize,
        weighted: bool,
    ) -> Value {
        let k = match self.k {
            Ix::Fixed(k) => k,
            Ix::Var(_) => unreachable!("sums with fixed indices are straight-line code"),
        };
        let (first, last) = fresh_ends(lo, hi, kk, k);
        let (from, to) = (
            lo + usize::from(first),
            (hi + 1).saturating_sub(usize::from(last)),
        );
        let count = to.saturating_sub(from);
        let mut sum = match (count >= LANES, a, self.mirror_if(b, count, k)) {
            (true, Operand::Row(a), Some((reversed, slot))) => {
                let w = self.fixed_width();
                let (table, weights) = (self.table, weighted.then_some(from));
                // b_(kk − j) at slot·w + w − 1 − (kk − j): ascending in j.
                let b_at = slot * w + w - 1 - (kk - from);
                self.vector_lanes((table, a * w + from), (reversed, b_at), count, weights)
            }
            _ => {
                let terms = (from..to)
                    .map(|j| self.term(a, b, j, kk, weighted))
                    .collect();
                self.lanes(terms)
            }
        };
        for j in [first.then_some(0), last.then_some(k)]
            .into_iter()
            .flatten()
        {
            let t = self.term(a, b, j, kk, weighted);
            sum = self.b.ins().fadd(sum, t);
        }
        sum
    }

    /// The mirror of `b` when a sum of `count` terms reads it in vectors.
    pub(crate) fn mirror_if(
        &mut self,
        b: Operand,
        count: usize,
        k: usize,
    ) -> Option<(Value, usize)> {
        if count >= LANES {
            self.mirror(b, k)
        } else {
            None
        }
    }

    /// The row width of straight-line code.
    pub(crate) fn fixed_width(&self) -> usize {
        match self.w {
            Ix::Fixed(w) => w,
            Ix::Var(_) => unreachable!("straight-line code knows the row width"),
        }
    }

    /// [j] aⱼ b_(kk − j), in straight-line code (1 · x is x, bit for bit).
    pub(crate) fn term(
        &mut self,
        a: Operand,
        b: Operand,
        j: usize,
        kk: usize,
        weighted: bool,
    ) -> Value {
        let key = match (a, self.w) {
            (Operand::Row(r), Ix::Fixed(w)) => Some((self.table, Self::offset(r * w + j), false)),
            _ => None,
        };
        let x = match key.and_then(|key| self.weighted.get(&key)) {
            Some(&x) if weighted && j != 1 => x,
            _ => {
                let x = self.coefficient(a, j);
                if weighted && j != 1 {
                    let jf = self.f64(j as f64);
                    let x = self.b.ins().fmul(jf, x);
                    if let Some(key) = key {
                        self.weighted.insert(key, x);
                    }
                    x
                } else {
                    x
                }
            }
        };
        let y = self.coefficient(b, kk - j);
        self.b.ins().fmul(x, y)
    }

    /// The sum of `count` ≥ 4 terms [j₀ + i] a[i] b[i] (entries i of two buffers read forwards
    /// from the given entries, `weights` = Some(j₀) for a weighted sum) in the lanes of
    /// [`SeriesEmitter::lanes`]: lanes 0, 1 and lanes 2, 3 in two two-lane vectors (F64X2) through the
    /// groups of four, the rest into lane 0, then (l₀ + l₁) + (l₂ + l₃) — the same operations,
    /// two at a time.
    pub(crate) fn vector_lanes(
        &mut self,
        (a_base, a_at): (Value, usize),
        (b_base, b_at): (Value, usize),
        count: usize,
        weights: Option<usize>,
    ) -> Value {
        debug_assert!(count >= LANES);
        let zero = self.f64(0.0);
        let zeros = self.b.ins().splat(types::F64X2, zero);
        let mut pair = [zeros; 2];
        let full = count / LANES * LANES;
        for i in (0..full).step_by(2) {
            let key = (a_base, Self::offset(a_at + i), true);
            let x = match (weights, self.weighted.get(&key)) {
                (Some(_), Some(&x)) => x,
                _ => {
                    let x = self.pair(a_base, Self::offset(a_at + i));
                    match weights {
                        Some(j0) => {
                            let j = (j0 + i) as f64;
                            let bytes: Vec<u8> =
                                [j, j + 1.0].iter().flat_map(|x| x.to_le_bytes()).collect();
                            let c = self.b.func.dfg.constants.insert(bytes.into());
                            let j = self.b.ins().vconst(types::F64X2, c);
                            let x = self.b.ins().fmul(j, x);
                            self.weighted.insert(key, x);
                            x
                        }
                        None => x,
                    }
                }
            };
            let y = self.pair(b_base, Self::offset(b_at + i));
            let t = self.b.ins().fmul(x, y);
            let h = (i / 2) % 2;
            pair[h] = self.b.ins().fadd(pair[h], t);
        }
        let mut l = [
            self.b.ins().extractlane(pair[0], 0),
            self.b.ins().extractlane(pair[0], 1),
            self.b.ins().extractlane(pair[1], 0),
            self.b.ins().extractlane(pair[1], 1),
        ];
        for i in full..count {
            let x = self
                .b
                .ins()
                .load(types::F64, Self::flags(), a_base, Self::offset(a_at + i));
            let x = match weights {
                Some(j0) if j0 + i != 1 => {
                    let j = self.f64((j0 + i) as f64);
                    self.b.ins().fmul(j, x)
                }
                _ => x,
            };
            let y = self
                .b
                .ins()
                .load(types::F64, Self::flags(), b_base, Self::offset(b_at + i));
            let t = self.b.ins().fmul(x, y);
            l[0] = self.b.ins().fadd(l[0], t);
        }
        let low = self.b.ins().fadd(l[0], l[1]);
        let high = self.b.ins().fadd(l[2], l[3]);
        self.b.ins().fadd(low, high)
    }

    /// The two `f64` at byte `off` from `base`, as a two-lane vector: an unaligned load, or
    /// built in the registers when one of them was stored since the previous order's solve and
    /// this order's values so taken stay within [`CARRIED`].
    ///
    /// Why: the stores are of one `f64` each, and a load of two cannot be forwarded from them
    /// while they are on their way to the cache; it waits for them. Where an order is short (the
    /// ball in a sphere: a sine and cosine and a scaling) that wait was the step's critical
    /// path: measured at 1e-9, 242 against 197 ns per step taking them from the registers. More
    /// values carried from one order into the next cost spills: all of them ran the double
    /// pendulum 10 % slower (12 % more instructions); at most 4 cost Kepler's and the 4-link
    /// chain's steps about 2 %, and moved the double pendulum's and the forced two-mass's by
    /// less than the noise (±3 %).
    pub(crate) fn pair(&mut self, base: Value, off: i32) -> Value {
        let held = |g: &Self, o: i32| {
            g.stored[1]
                .get(&(base, o))
                .or_else(|| g.stored[0].get(&(base, o)))
                .copied()
        };
        let lanes = [held(self, off), held(self, off + 8)];
        let fresh = lanes.iter().flatten().count();
        if fresh == 0 || self.carried + fresh > CARRIED {
            // Unaligned.
            let flags = MemFlagsData::new().with_notrap();
            return self.b.ins().load(types::F64X2, flags, base, off);
        }
        self.carried += fresh;
        let [low, high] = [(lanes[0], off), (lanes[1], off + 8)].map(|(v, o)| {
            v.unwrap_or_else(|| self.b.ins().load(types::F64, Self::flags(), base, o))
        });
        let v = self.b.ins().scalar_to_vector(types::F64X2, low);
        self.b.ins().insertlane(v, high, 1)
    }

    /// Entry i of the buffer at `base`.
    pub(crate) fn load_at(&mut self, base: Value, i: usize) -> Value {
        self.load_from(base, Self::offset(i))
    }

    pub(crate) fn store_at(&mut self, base: Value, i: usize, v: Value) {
        self.store_to(base, Self::offset(i), v);
    }

    /// The `f64` at byte `off` from `base`: in straight-line code, the value stored there
    /// since `memory` was last cleared, if any (the buffers do not overlap, and nothing else
    /// writes them while the code runs).
    pub(crate) fn load_from(&mut self, base: Value, off: i32) -> Value {
        match self.memory.get(&(base, off)) {
            Some(&v) => v,
            None => self.b.ins().load(types::F64, Self::flags(), base, off),
        }
    }

    pub(crate) fn store_to(&mut self, base: Value, off: i32, v: Value) {
        self.b.ins().store(Self::flags(), v, base, off);
        if self.straight {
            self.memory.insert((base, off), v);
            self.stored[1].insert((base, off), v);
        }
    }

    /// The end of the unrolled expansion: the status [`KernelStatus::Coefficient`] when `check` (the
    /// sum of q̈ₖ − q̈ₖ) is not 0, else [`KernelStatus::Expanded`] without a step control (a null
    /// `control`), else the step `Expansion::step` takes, with its operations in its order:
    /// the norms of `Expansion::norms`, Jorba and Zou's step size, the floor and the end of the
    /// span, then `Expansion::advance` from y into `y_new` and `lost`.
    pub(crate) fn finish_step(
        &mut self,
        check: Value,
        [control, yp, lostp, newp]: [Value; 4],
        (qp, vp): (Value, Value),
        n: usize,
        order: usize,
    ) {
        use std::mem::offset_of;
        let status = |g: &mut Self, s: KernelStatus| g.b.ins().iconst(types::I32, s as i64);
        let done = self.b.create_block();
        self.b.append_block_param(done, types::I32);
        // A coefficient that is not finite, or the expansion alone.
        let finite = self.b.ins().fcmp(condcodes::FloatCC::Equal, check, check);
        let (expanded, stepping) = (self.b.create_block(), self.b.create_block());
        let failed = status(self, KernelStatus::Coefficient);
        self.b
            .ins()
            .brif(finite, expanded, &[], done, &[BlockArg::Value(failed)]);
        self.b.switch_to_block(expanded);
        self.b.seal_block(expanded);
        let alone = status(self, KernelStatus::Expanded);
        self.b
            .ins()
            .brif(control, stepping, &[], done, &[BlockArg::Value(alone)]);
        self.b.switch_to_block(stepping);
        self.b.seal_block(stepping);
        let field = |offset: usize| Self::offset(offset / 8);
        let get = |g: &mut Self, offset: usize| g.load_from(control, field(offset));
        let t = get(self, offset_of!(StepControl, t));
        let rtol = get(self, offset_of!(StepControl, rule.rtol));
        let atol = get(self, offset_of!(StepControl, rule.atol));
        let h_max = get(self, offset_of!(StepControl, rule.h_max));
        let min_step = get(self, offset_of!(StepControl, rule.min_step));
        let t_end = get(self, offset_of!(StepControl, rule.t_end));
        let dir = get(self, offset_of!(StepControl, rule.dir));
        let controlled = get(self, offset_of!(StepControl, rule.controlled));
        // The norms: each component's coefficients p − 1 and p over its tolerance; a
        // coordinate at or past `controlled` (and its velocity) scaled by 0, left out.
        let eps = self.min(rtol, atol);
        let zero = self.f64(0.0);
        let (mut below, mut top) = (zero, zero);
        for (half, base) in [(0, qp), (1, vp)] {
            for i in 0..n {
                let y = self.load_at(yp, half * n + i);
                let y = self.b.ins().fabs(y);
                let d = self.b.ins().fmul(rtol, y);
                let d = self.b.ins().fadd(atol, d);
                let scale = self.b.ins().fdiv(eps, d);
                let index = self.f64(i as f64);
                let kept = self
                    .b
                    .ins()
                    .fcmp(condcodes::FloatCC::LessThan, index, controlled);
                let scale = self.b.ins().select(kept, scale, zero);
                for (k, norm) in [(order - 1, &mut below), (order, &mut top)] {
                    let x = self.load_at(base, k * n + i);
                    let x = self.b.ins().fabs(x);
                    let x = self.b.ins().fmul(x, scale);
                    *norm = self.max(*norm, x);
                }
            }
        }
        // h = exp(min(−ln ‖xₚ₋₁‖ / (p − 1), −ln ‖xₚ‖ / p) − 2 − 0.7 / (p − 1)), at most h_max.
        let (p1, p) = ((order - 1) as f64, order as f64);
        let rho = [(below, p1), (top, p)].map(|(norm, d)| {
            let ln = self.call("lagrangian_ln", &[norm]);
            let ln = self.b.ins().fneg(ln);
            let d = self.f64(d);
            self.b.ins().fdiv(ln, d)
        });
        let ln_rho = self.min(rho[0], rho[1]);
        let two = self.f64(2.0);
        let x = self.b.ins().fsub(ln_rho, two);
        let c = self.f64(0.7 / p1);
        let x = self.b.ins().fsub(x, c);
        let h = self.call("lagrangian_exp", &[x]);
        let h = self.min(h, h_max);
        // Above the floor max(min_step, 10 ε |t|), or refused.
        let tiny = self.f64(10.0 * f64::EPSILON);
        let at = self.b.ins().fabs(t);
        let at = self.b.ins().fmul(tiny, at);
        let floor = self.max(min_step, at);
        let above = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, h, floor);
        let (ahead, refused) = (self.b.create_block(), self.b.create_block());
        self.b.ins().brif(above, ahead, &[], refused, &[]);
        self.b.switch_to_block(refused);
        self.b.seal_block(refused);
        let at_h = field(offset_of!(StepControl, h));
        self.b.ins().store(Self::flags(), h, control, at_h);
        let s = status(self, KernelStatus::TooSmall);
        self.b.ins().jump(done, &[BlockArg::Value(s)]);
        self.b.switch_to_block(ahead);
        self.b.seal_block(ahead);
        // The last step ends on t_end: (t + dir 1.01 h − t_end) dir ≥ 0.
        let onward = self.f64(1.01);
        let x = self.b.ins().fmul(dir, onward);
        let x = self.b.ins().fmul(x, h);
        let x = self.b.ins().fadd(t, x);
        let x = self.b.ins().fsub(x, t_end);
        let x = self.b.ins().fmul(x, dir);
        let last = self
            .b
            .ins()
            .fcmp(condcodes::FloatCC::GreaterThanOrEqual, x, zero);
        let x = self.b.ins().fmul(dir, h);
        let x = self.b.ins().fadd(t, x);
        let t_new = self.b.ins().select(last, t_end, x);
        let at_t_new = field(offset_of!(StepControl, t_new));
        self.b.ins().store(Self::flags(), t_new, control, at_t_new);
        let h = self.b.ins().fsub(t_new, t);
        // y + Σₖ₌₁..ₚ (q, q̇)ₖ hᵏ, the 2n sums of Horner's rule side by side, with Kahan's
        // compensation; Σ (yᵢ − yᵢ) is 0 when every new value is finite.
        let components: Vec<(Value, usize)> = (0..n)
            .map(|i| (qp, i))
            .chain((0..n).map(|i| (vp, i)))
            .collect();
        let mut sums: Vec<Value> = components
            .iter()
            .map(|&(base, i)| self.load_at(base, order * n + i))
            .collect();
        for k in (1..order).rev() {
            for (sum, &(base, i)) in sums.iter_mut().zip(&components) {
                let c = self.load_at(base, k * n + i);
                let x = self.b.ins().fmul(*sum, h);
                *sum = self.b.ins().fadd(x, c);
            }
        }
        let mut check = zero;
        for (j, sum) in sums.into_iter().enumerate() {
            let increment = self.b.ins().fmul(sum, h);
            let (y, lost) = (self.load_at(yp, j), self.load_at(lostp, j));
            let increment = self.b.ins().fsub(increment, lost);
            let new = self.b.ins().fadd(y, increment);
            let moved = self.b.ins().fsub(new, y);
            let lost = self.b.ins().fsub(moved, increment);
            self.store_at(newp, j, new);
            self.store_at(lostp, j, lost);
            let nothing = self.b.ins().fsub(new, new);
            check = self.b.ins().fadd(check, nothing);
        }
        let finite = self.b.ins().fcmp(condcodes::FloatCC::Equal, check, check);
        let (step, last_step, state) = (
            status(self, KernelStatus::Step),
            status(self, KernelStatus::Last),
            status(self, KernelStatus::State),
        );
        let taken = self.b.ins().select(last, last_step, step);
        let s = self.b.ins().select(finite, taken, state);
        self.b.ins().jump(done, &[BlockArg::Value(s)]);
        self.b.switch_to_block(done);
        self.b.seal_block(done);
        let s = self.b.block_params(done)[0];
        self.b.ins().return_(&[s]);
    }

    /// `f64::min(a, b)` for a and b that are not NaN: b where b < a, else a.
    pub(crate) fn min(&mut self, a: Value, b: Value) -> Value {
        let less = self.b.ins().fcmp(condcodes::FloatCC::LessThan, b, a);
        self.b.ins().select(less, b, a)
    }

    /// `f64::max(m, x)` for an m that is not NaN: x where x > m, else m (so a NaN x is passed
    /// over, as `f64::max` passes it over).
    pub(crate) fn max(&mut self, m: Value, x: Value) -> Value {
        let greater = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, x, m);
        self.b.ins().select(greater, x, m)
    }

    /// Row r's coefficient k, and its coefficient 0.
    pub(crate) fn at_k(&mut self, r: usize) -> Value {
        let k = self.k;
        self.load(r, k)
    }

    pub(crate) fn at0(&mut self, r: usize) -> Value {
        self.load(r, Ix::Fixed(0))
    }

    pub(crate) fn store_k(&mut self, r: usize, v: Value) {
        let k = self.k;
        self.store(r, k, v);
    }

    /// The sum of `terms` in the lanes and order of `conv` in `series.rs` (and of
    /// `linalg::dot`): term i into lane i mod 4 while four are left, the rest into lane 0, then
    /// (l₀ + l₁) + (l₂ + l₃), each lane from +0. A lane no term reached stays +0 and is left
    /// out of the last sums: a lane that did start from +0 is never −0 (a sum is −0 only when
    /// both terms are), so adding +0 to it changes no bit.
    pub(crate) fn lanes(&mut self, terms: Vec<Value>) -> Value {
        let zero = self.f64(0.0);
        let mut l: [Option<Value>; LANES] = [None; LANES];
        let full = terms.len() / LANES * LANES;
        for (i, &t) in terms.iter().enumerate() {
            let lane = if i < full { i % LANES } else { 0 };
            let sum = l[lane].unwrap_or(zero);
            l[lane] = Some(self.b.ins().fadd(sum, t));
        }
        let mut add = |x: Option<Value>, y: Option<Value>| match (x, y) {
            (Some(x), Some(y)) => Some(self.b.ins().fadd(x, y)),
            (x, None) => x,
            (None, y) => y,
        };
        let low = add(l[0], l[1]);
        let high = add(l[2], l[3]);
        add(low, high).unwrap_or(zero)
    }

    /// Σⱼ₌ₗₒ..ₕᵢ [j] aⱼ b_(kk − j) of rows a and b, hi given by `top`, as `conv` in `series.rs`
    /// sums it: straight-line code when the order is known at compilation ([`SeriesEmitter::sum`]); else
    /// a call of `lagrangian_conv` (large programs), or the terms that read no coefficient of
    /// order k in a loop in the code and then the others.
    pub(crate) fn conv(
        &mut self,
        a: usize,
        b: usize,
        lo: usize,
        top: Top,
        kk: Ix,
        weighted: bool,
    ) -> Value {
        if let (Ix::Fixed(k), Ix::Fixed(kk)) = (self.k, kk) {
            let hi = match top {
                Top::K => k,
                Top::Below => k - 1,
                Top::Degree(d) => d.min(k),
                Top::BelowDegree(d) => d.min(k - 1),
                Top::Half => (k - 1) / 2,
            };
            return self.sum(Operand::Row(a), Operand::Row(b), lo, hi, kk, weighted);
        }
        let Ix::Var(k) = self.k else {
            unreachable!("a run-time index belongs to code for any order")
        };
        let kkv = self.int(kk);
        if let Some(conv_fn) = self.calls {
            let hi = match top {
                Top::K => k,
                Top::Below => self.b.ins().iadd_imm_s(k, -1),
                Top::Degree(d) => {
                    let d = self.b.ins().iconst(types::I64, d as i64);
                    self.b.ins().umin(k, d)
                }
                Top::BelowDegree(d) => {
                    let km1 = self.b.ins().iadd_imm_s(k, -1);
                    let d = self.b.ins().iconst(types::I64, d as i64);
                    self.b.ins().umin(km1, d)
                }
                Top::Half => {
                    let km1 = self.b.ins().iadd_imm_s(k, -1);
                    self.b.ins().ushr_imm_s(km1, 1)
                }
            };
            let (pa, pb) = (self.row(a), self.row(b));
            let lo = self.b.ins().iconst(types::I64, lo as i64);
            let weighted = self.b.ins().iconst(types::I32, i64::from(weighted));
            let call = self
                .b
                .ins()
                .call(conv_fn, &[pa, pb, lo, hi, kkv, k, weighted]);
            return self.b.inst_results(call)[0];
        }
        // Orders k ≥ 1 here: the j = 0 term of a sum from 0 with kk = k reads b_k, and the
        // j = k term of a sum up to k reads a_k.
        debug_assert!(lo > 0 || !weighted);
        let first = lo == 0 && kk == self.k;
        let km1 = self.b.ins().iadd_imm_s(k, -1);
        let old_hi = match top {
            Top::K | Top::Below => km1,
            Top::Degree(d) | Top::BelowDegree(d) => {
                let d = self.b.ins().iconst(types::I64, d as i64);
                self.b.ins().umin(km1, d)
            }
            // Below k for k ≥ 1: no term of it reads order k but j = 0's.
            Top::Half => self.b.ins().ushr_imm_s(km1, 1),
        };
        let from = lo as i64 + i64::from(first);
        let mut sum = self.conv_loop(a, b, from, old_hi, kkv, weighted);
        if first {
            let (x, y) = (self.at0(a), self.load(b, kk));
            let t = self.b.ins().fmul(x, y);
            sum = self.b.ins().fadd(sum, t);
        }
        if let Top::K | Top::Degree(_) = top {
            debug_assert!(kk == self.k);
            let x = self.at_k(a);
            let x = if weighted {
                let kf = self.b.ins().fcvt_from_sint(types::F64, k);
                self.b.ins().fmul(kf, x)
            } else {
                x
            };
            let y = self.at0(b);
            let t = self.b.ins().fmul(x, y);
            let with = self.b.ins().fadd(sum, t);
            sum = match top {
                Top::Degree(d) => {
                    let reached = self.b.ins().icmp_imm_s(
                        condcodes::IntCC::UnsignedLessThanOrEqual,
                        k,
                        d as i64,
                    );
                    self.b.ins().select(reached, with, sum)
                }
                _ => with,
            };
        }
        sum
    }

    /// Σⱼ₌ₗₒ..ₕᵢ [j] aⱼ b_(kk − j) in the lanes and order of [`conv`](super::taylor): a loop
    /// over four terms at a time, then one at a time into lane 0, each block carrying (count,
    /// &aⱼ, &b_(kk−j), j as a float, the lanes).
    pub(crate) fn conv_loop(
        &mut self,
        a: usize,
        b: usize,
        lo: i64,
        hi: Value,
        kk: Value,
        weighted: bool,
    ) -> Value {
        let (pa, pb) = (self.row(a), self.row(b));
        self.conv_loop_at(pa, pb, lo, hi, kk, weighted)
    }

    /// [`SeriesEmitter::conv_loop`] on two series from their coefficient 0 at `pa` and `pb`
    /// (rows of the table or of q̈).
    pub(crate) fn conv_loop_at(
        &mut self,
        pa: Value,
        pb: Value,
        lo: i64,
        hi: Value,
        kk: Value,
        weighted: bool,
    ) -> Value {
        let pa = self.b.ins().iadd_imm_s(pa, 8 * lo);
        let kk8 = self.b.ins().ishl_imm_s(kk, 3);
        let pb = self.b.ins().iadd(pb, kk8);
        let pb = self.b.ins().iadd_imm_s(pb, -8 * lo);
        let count = self.b.ins().iadd_imm_s(hi, 1 - lo);
        let zero = self.f64(0.0);
        let jf = self.f64(lo as f64);
        let blocks = [(); 4].map(|_| self.b.create_block());
        let [quad, quad_body, single, single_body] = blocks;
        for block in blocks {
            for t in [types::I64, types::I64, types::I64, types::F64] {
                self.b.append_block_param(block, t);
            }
            for _ in 0..LANES {
                self.b.append_block_param(block, types::F64);
            }
        }
        let exit = self.b.create_block();
        for _ in 0..LANES {
            self.b.append_block_param(exit, types::F64);
        }
        let args = |v: &[Value]| v.iter().map(|&x| BlockArg::Value(x)).collect::<Vec<_>>();
        let start = [count, pa, pb, jf, zero, zero, zero, zero];
        self.b.ins().jump(quad, &args(&start));
        // Four terms at a time while four are left.
        self.b.switch_to_block(quad);
        let p = self.b.block_params(quad).to_vec();
        let more = self.b.ins().icmp_imm_s(
            condcodes::IntCC::SignedGreaterThanOrEqual,
            p[0],
            LANES as i64,
        );
        self.b
            .ins()
            .brif(more, quad_body, &args(&p), single, &args(&p));
        self.b.switch_to_block(quad_body);
        self.b.seal_block(quad_body);
        let mut p = self.b.block_params(quad_body).to_vec();
        for i in 0..LANES {
            let t = self.loop_term(p[1], p[2], p[3], i as i64, weighted);
            p[4 + i] = self.b.ins().fadd(p[4 + i], t);
        }
        p[0] = self.b.ins().iadd_imm_s(p[0], -(LANES as i64));
        p[1] = self.b.ins().iadd_imm_s(p[1], 8 * LANES as i64);
        p[2] = self.b.ins().iadd_imm_s(p[2], -8 * LANES as i64);
        let step = self.f64(LANES as f64);
        p[3] = self.b.ins().fadd(p[3], step);
        self.b.ins().jump(quad, &args(&p));
        self.b.seal_block(quad);
        // The rest one at a time, into lane 0.
        self.b.switch_to_block(single);
        let p = self.b.block_params(single).to_vec();
        let more = self
            .b
            .ins()
            .icmp_imm_s(condcodes::IntCC::SignedGreaterThan, p[0], 0);
        self.b
            .ins()
            .brif(more, single_body, &args(&p), exit, &args(&p[4..]));
        self.b.switch_to_block(single_body);
        self.b.seal_block(single_body);
        let mut p = self.b.block_params(single_body).to_vec();
        let t = self.loop_term(p[1], p[2], p[3], 0, weighted);
        p[4] = self.b.ins().fadd(p[4], t);
        p[0] = self.b.ins().iadd_imm_s(p[0], -1);
        p[1] = self.b.ins().iadd_imm_s(p[1], 8);
        p[2] = self.b.ins().iadd_imm_s(p[2], -8);
        let one = self.f64(1.0);
        p[3] = self.b.ins().fadd(p[3], one);
        self.b.ins().jump(single, &args(&p));
        self.b.seal_block(single);
        self.b.switch_to_block(exit);
        self.b.seal_block(exit);
        let l = self.b.block_params(exit).to_vec();
        let low = self.b.ins().fadd(l[0], l[1]);
        let high = self.b.ins().fadd(l[2], l[3]);
        self.b.ins().fadd(low, high)
    }

    /// A square's coefficient k from twice its half sum ([`SeriesOp::Square`](super::series::SeriesOp::Square)): plus a²ₖ/₂ where k is
    /// even.
    pub(crate) fn square_middle(&mut self, a: usize, twice: Value) -> Value {
        match self.k {
            Ix::Fixed(k) if k.is_multiple_of(2) => {
                let mid = self.load(a, Ix::Fixed(k / 2));
                let sq = self.b.ins().fmul(mid, mid);
                self.b.ins().fadd(twice, sq)
            }
            Ix::Fixed(_) => twice,
            Ix::Var(k) => {
                let m = self.b.ins().ushr_imm_s(k, 1);
                let mid = self.load(a, Ix::Var(m));
                let sq = self.b.ins().fmul(mid, mid);
                let with = self.b.ins().fadd(twice, sq);
                let odd = self.b.ins().band_imm_s(k, 1);
                self.b.ins().select(odd, twice, with)
            }
        }
    }

    /// Term j + i of a convolution: [(j + i)] a_(j+i) b_(kk−j−i), with `pa` at aⱼ, `pb` at
    /// b_(kk−j) and `jf` = j.
    pub(crate) fn loop_term(
        &mut self,
        pa: Value,
        pb: Value,
        jf: Value,
        i: i64,
        weighted: bool,
    ) -> Value {
        let x = self
            .b
            .ins()
            .load(types::F64, Self::flags(), pa, (8 * i) as i32);
        let x = if weighted {
            let di = self.f64(i as f64);
            let j = if i == 0 {
                jf
            } else {
                self.b.ins().fadd(jf, di)
            };
            self.b.ins().fmul(j, x)
        } else {
            x
        };
        let y = self
            .b
            .ins()
            .load(types::F64, Self::flags(), pb, (-8 * i) as i32);
        self.b.ins().fmul(x, y)
    }

    /// Call the imported maths function `name` on `args`.
    pub(crate) fn call(&mut self, name: &str, args: &[Value]) -> Value {
        let f = self
            .libm
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, f)| f)
            .expect("order 0's functions are imported before its code is generated");
        let call = self.b.ins().call(f, args);
        self.b.inst_results(call)[0]
    }
}
