//! Evaluating a [`Tape`]: the constant program on parameter values, the instructions over any
//! [`Scalar`] — with the dual numbers of the engine's derivative passes on `f64` states
//! evaluated as plain-array jets (`jet.rs`) — and [`Function`], a tape bound to parameter values,
//! which is a kinetic energy, potential, dissipation function or set of generalized forces.

use super::compile::{ConstOp, Input, Out, Tape};
use super::ins::step;
use super::jet::{Arith, Convert, First, Jet, Num, Second};
use crate::energies::{Dissipation, GeneralizedForces, KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::scalar::CHUNK;
use crate::scalar::Scalar;
use crate::scalar::{Grad, Hyper, with_buf};
use std::sync::Arc;

/// Calls `$then!` with the chunk sizes of the derivative passes (`eom/passes.rs`): (C, 2C) for
/// C = 1..=[`CHUNK`]. The passes on `f64` states take dual numbers of these shapes, and
/// [`Tape::eval`] evaluates each of them as a jet.
macro_rules! pass_chunks {
    ($then:ident) => {
        $then! { (1, 2), (2, 4), (3, 6), (4, 8) }
    };
}

/// Fails to compile unless `pass_chunks!` lists exactly C = 1..=CHUNK with C2 = 2C.
macro_rules! assert_pass_chunks {
    ($(($c:literal, $c2:literal)),*) => {
        const _: () = {
            let chunks: &[(usize, usize)] = &[$(($c, $c2)),*];
            assert!(chunks.len() == CHUNK, "pass_chunks! must list C = 1..=CHUNK");
            let mut i = 0;
            while i < chunks.len() {
                assert!(chunks[i].0 == i + 1 && chunks[i].1 == 2 * (i + 1));
                i += 1;
            }
        };
    };
}
pass_chunks!(assert_pass_chunks);

impl Tape {
    /// Run the constant program on parameter values.
    pub(crate) fn constants(&self, params: &[f64]) -> Result<Vec<f64>> {
        if params.len() != self.inputs.params {
            return Err(Error::DimensionMismatch {
                what: "parameters",
                expected: self.inputs.params,
                got: params.len(),
            });
        }
        if let Some(p) = params.iter().find(|p| !p.is_finite()) {
            return Err(Error::InvalidInput {
                what: "parameters",
                why: format!("the value {p} is not finite"),
            });
        }
        let mut c: Vec<f64> = Vec::with_capacity(self.consts.len());
        for op in &self.consts {
            let x = match *op {
                ConstOp::Lit(x) => x,
                ConstOp::Param(k) => params[k],
                ConstOp::Unary(f, a) => f.apply(c[a]),
                ConstOp::Binary(f, a, b) => f.apply(c[a], c[b]),
                ConstOp::PowI(a, k) => c[a].powi(k),
            };
            c.push(x);
        }
        if c.iter().any(|x| !x.is_finite()) {
            return Err(Error::InvalidInput {
                what: "parameters",
                why: "a subexpression of numbers and parameters is not finite with these values \
                      (a division by zero, the log or square root of a negative number?)"
                    .into(),
            });
        }
        Ok(c)
    }

    /// Evaluate on (t, q, q̇) with the constants `consts`, handing each output to `emit`.
    ///
    /// The dual numbers of the engine's derivative passes on `f64` states (the shapes of
    /// `pass_chunks!`) are evaluated as plain-array jets (see [`jet`]); every other scalar
    /// with its own arithmetic.
    #[inline]
    pub(crate) fn eval<D: Scalar>(
        &self,
        consts: &[f64],
        t: D,
        q: &[D],
        qd: &[D],
        mut emit: impl FnMut(usize, D),
    ) {
        let dof = self.inputs.dof;
        assert!(
            (!self.flags.position || q.len() >= dof) && (!self.flags.velocity || qd.len() >= dof),
            "a tape of {dof} coordinates evaluated with {} coordinates and {} velocities",
            q.len(),
            qd.len()
        );
        macro_rules! via_jet {
            ($dual:ty => $jet:ty) => {
                if crate::scalar::is::<D, $dual>() {
                    #[cfg(test)]
                    path::record::<D>(true);
                    // SAFETY: D is $dual (same TypeId), so these are identity casts.
                    let (t, q, qd) = unsafe {
                        (
                            crate::scalar::cast::<D, $dual>(&t),
                            crate::scalar::cast_slice::<D, $dual>(q),
                            crate::scalar::cast_slice::<D, $dual>(qd),
                        )
                    };
                    // SAFETY: as above, $dual is D.
                    let mut emit =
                        |k, v: $dual| emit(k, unsafe { crate::scalar::uncast::<$dual, D>(v) });
                    return self.run_converted::<$dual, $jet>(consts, t, q, qd, &mut emit);
                }
            };
        }
        macro_rules! via_jets {
            ($(($c:literal, $c2:literal)),*) => {$(
                // Gradient passes and the particle route's Jacobians.
                via_jet!(Grad<f64, $c> => Jet<First<$c>>);
                // The one-pass inertia scheme (n = C).
                via_jet!(Hyper<f64, $c, $c2> => Jet<Second<$c, $c2>>);
                // M by blocks.
                via_jet!(Hyper<f64, $c, $c> => Jet<Second<$c, $c>>);
                // Passes along the motion or the time.
                via_jet!(Hyper<f64, $c, 1> => Jet<Second<$c, 1>>);
            )*};
        }
        pass_chunks!(via_jets);
        #[cfg(test)]
        path::record::<D>(false);
        let input = |i: Input| match i {
            Input::Time => Num(t),
            Input::Coord(k) => Num(q[k]),
            Input::Velocity(k) => Num(qd[k]),
        };
        self.run(consts, input, |k, v: Num<D>| emit(k, v.0))
    }

    /// Evaluate with the jet `J` standing for the dual type `T`.
    ///
    /// Not inlined and `emit` behind `dyn`: one copy of the interpreter per jet shape, not one
    /// per shape in every instance of [`Tape::eval`] (it holds all of them, whatever `D` is).
    #[inline(never)]
    fn run_converted<T, J: Convert<T>>(
        &self,
        consts: &[f64],
        t: &T,
        q: &[T],
        qd: &[T],
        emit: &mut dyn FnMut(usize, T),
    ) {
        let input = |i: Input| match i {
            Input::Time => J::from_dual(t),
            Input::Coord(k) => J::from_dual(&q[k]),
            Input::Velocity(k) => J::from_dual(&qd[k]),
        };
        self.run(consts, input, |k, v: J| emit(k, v.into_dual()))
    }

    /// Run the instructions with the arithmetic `A`, the inputs from `input`.
    ///
    /// # Panics
    /// If `consts` are not this tape's constants.
    #[inline(always)]
    pub(crate) fn run<A: Arith>(
        &self,
        consts: &[f64],
        input: impl Fn(Input) -> A,
        mut emit: impl FnMut(usize, A),
    ) {
        // `step` reads the constants unchecked: this is the bound it relies on.
        assert!(
            consts.len() == self.consts.len(),
            "constants of another tape"
        );
        with_buf::<A, 48, _>(self.slots, A::zero(), |s| {
            for &(slot, i) in &self.input_slots {
                s[slot as usize] = input(i);
            }
            let mut acc = A::zero();
            for ins in &self.code {
                step(ins, consts, s, &mut acc);
            }
            for (k, out) in self.outputs.iter().enumerate() {
                emit(
                    k,
                    match *out {
                        Out::Slot(i) => s[i as usize],
                        Out::Const(i) => A::cst(consts[i as usize]),
                    },
                );
            }
        })
    }
}

/// Which path each evaluation took (tests only): the scalar types that fell back to the generic
/// path although they carry derivative parts as `Option`s, and the number of jet evaluations.
#[cfg(test)]
pub(crate) mod path {
    use num_dual::{Dual2_64, Dual64};
    use std::cell::RefCell;

    thread_local! {
        static SEEN: RefCell<(Vec<&'static str>, usize)> = const { RefCell::new((Vec::new(), 0)) };
    }

    /// Scalars whose own arithmetic has no `Option` parts, so the generic path is theirs.
    fn plain<D: 'static>() -> bool {
        crate::scalar::is::<D, f64>()
            || crate::scalar::is::<D, Dual64>()
            || crate::scalar::is::<D, Dual2_64>()
    }

    pub(crate) fn record<D: 'static>(jet: bool) {
        SEEN.with(|s| {
            let mut s = s.borrow_mut();
            if jet {
                s.1 += 1;
            } else if !plain::<D>() {
                let name = std::any::type_name::<D>();
                if !s.0.contains(&name) {
                    s.0.push(name);
                }
            }
        })
    }

    /// The fallbacks and jet evaluations recorded on this thread since the last call.
    pub(crate) fn take() -> (Vec<&'static str>, usize) {
        SEEN.with(|s| std::mem::take(&mut *s.borrow_mut()))
    }
}

/// A [`Tape`] bound to parameter values: a function of (t, q, q̇) with one or more outputs.
///
/// It is a kinetic energy, potential, dissipation function (first output) or set of
/// generalized forces (one output per coordinate), with structure flags read off the tape. As a
/// potential it is evaluated with q̇ = 0 (compile potentials with
/// [`Inputs::potential`](crate::tape::Inputs::potential), which rejects velocities). Cloning shares the
/// tape.
#[derive(Debug, Clone, PartialEq)]
pub struct Function {
    pub(crate) tape: Arc<Tape>,
    pub(crate) consts: Arc<[f64]>,
}

impl Function {
    /// Bind `tape` to parameter values.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] for the wrong number of values, [`Error::InvalidInput`] when
    /// a value, or a subexpression of values and numbers, is not finite.
    pub fn new(tape: Arc<Tape>, params: &[f64]) -> Result<Self> {
        let consts = tape.constants(params)?.into();
        Ok(Self { tape, consts })
    }

    /// The same tape with other parameter values (only the constants are recomputed).
    ///
    /// # Errors
    /// As [`Function::new`].
    pub fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        Self::new(self.tape.clone(), params)
    }

    /// The compiled tape.
    pub fn tape(&self) -> &Tape {
        &self.tape
    }

    /// Write the outputs at (t, q, q̇) to `out`.
    ///
    /// # Panics
    /// If `q` or `qd` is shorter than the tape's `dof` (when it reads them) or `out` is shorter
    /// than the number of outputs.
    pub fn eval_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.tape.eval(&self.consts, t, q, qd, |k, v| out[k] = v)
    }

    /// The first output at (t, q, q̇).
    #[inline]
    pub fn eval<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        let mut value = D::zero();
        self.tape.eval(&self.consts, t, q, qd, |k, v| {
            if k == 0 {
                value = v
            }
        });
        value
    }

    /// The outputs of a tape that reads no input (masses, say), in `f64`.
    pub fn constant_values(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.tape.outputs()];
        let zeros = vec![0.0; self.tape.inputs().dof];
        self.eval_into(0.0, &zeros, &zeros, &mut out);
        out
    }
}

impl KineticEnergy for Function {
    #[inline]
    fn kinetic<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.eval(t, q, qd)
    }
    fn depends_on_time(&self) -> bool {
        self.tape.depends_on_time()
    }
    fn depends_on_position(&self) -> bool {
        self.tape.depends_on_position()
    }
    fn constant_mass_matrix(&self) -> bool {
        self.tape.constant_mass_matrix()
    }
}

impl Potential for Function {
    #[inline]
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        if self.tape.depends_on_velocity() {
            with_buf::<D, 8, _>(q.len(), D::zero(), |rest| self.eval(t, q, rest))
        } else {
            self.eval(t, q, &[])
        }
    }
    fn depends_on_time(&self) -> bool {
        self.tape.depends_on_time()
    }
}

impl Dissipation for Function {
    #[inline]
    fn dissipation<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.eval(t, q, qd)
    }
}

impl GeneralizedForces for Function {
    #[inline]
    fn forces<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.tape.eval(&self.consts, t, q, qd, |k, v| out[k] += v)
    }
    fn depends_on_time(&self) -> bool {
        self.tape.depends_on_time()
    }
}

/// An absent part is `None`.
impl Potential for Option<Function> {
    #[inline]
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.as_ref().map_or(D::zero(), |f| f.potential(t, q))
    }
    fn depends_on_time(&self) -> bool {
        self.as_ref().is_some_and(Potential::depends_on_time)
    }
    fn is_present(&self) -> bool {
        self.is_some()
    }
}

/// An absent part is `None`.
impl Dissipation for Option<Function> {
    #[inline]
    fn dissipation<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.as_ref().map_or(D::zero(), |f| f.eval(t, q, qd))
    }
    fn is_present(&self) -> bool {
        self.is_some()
    }
}

/// An absent part is `None`.
impl GeneralizedForces for Option<Function> {
    #[inline]
    fn forces<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        if let Some(f) = self {
            f.forces(t, q, qd, out)
        }
    }
    fn depends_on_time(&self) -> bool {
        self.as_ref()
            .is_some_and(GeneralizedForces::depends_on_time)
    }
    fn is_present(&self) -> bool {
        self.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::graph::sign;
    use crate::expr::graph::{Binary, Graph, Unary};
    use crate::program::inputs::Inputs;
    use approx::assert_relative_eq;
    use num_dual::Dual64;

    /// f = sin x cos x + tan y − eˣ ln y + √y + sinh x cosh y − |x − y| + xʸ + atan2(x, y)
    ///     + x^2.5 + 2ˣ + 3/x + (4 − x) + atan2(1, x) + atan2(x, 2) + x⁻³ + y/x + (x − 1)/2
    ///     + Σ_f f(x y) over every function of one argument (`Unary::ALL`)
    fn every_operation(g: &mut Graph) -> Result<usize> {
        let (x, y) = (g.coord(0), g.coord(1));
        let (sx, cx) = (g.unary(Unary::Sin, x)?, g.unary(Unary::Cos, x)?);
        let mut terms = vec![g.binary(Binary::Mul, sx, cx)?, g.unary(Unary::Tan, y)?];
        let (ex, ly) = (g.unary(Unary::Exp, x)?, g.unary(Unary::Ln, y)?);
        let p = g.binary(Binary::Mul, ex, ly)?;
        terms.push(g.unary(Unary::Neg, p)?);
        terms.push(g.unary(Unary::Sqrt, y)?);
        let (shx, chy) = (g.unary(Unary::Sinh, x)?, g.unary(Unary::Cosh, y)?);
        terms.push(g.binary(Binary::Mul, shx, chy)?);
        let d = g.binary(Binary::Sub, x, y)?;
        let a = g.unary(Unary::Abs, d)?;
        terms.push(g.unary(Unary::Neg, a)?);
        terms.push(g.binary(Binary::Pow, x, y)?);
        terms.push(g.binary(Binary::Atan2, x, y)?);
        let e = g.constant(2.5);
        terms.push(g.binary(Binary::Pow, x, e)?);
        let two = g.constant(2.0);
        terms.push(g.binary(Binary::Pow, two, x)?);
        let three = g.constant(3.0);
        terms.push(g.binary(Binary::Div, three, x)?);
        let four = g.constant(4.0);
        terms.push(g.binary(Binary::Sub, four, x)?);
        let one = g.constant(1.0);
        terms.push(g.binary(Binary::Atan2, one, x)?);
        terms.push(g.binary(Binary::Atan2, x, two)?);
        terms.push(g.powi(x, -3)?);
        terms.push(g.binary(Binary::Div, y, x)?);
        let xm1 = g.binary(Binary::Sub, x, one)?;
        terms.push(g.binary(Binary::Div, xm1, two)?);
        let xy = g.binary(Binary::Mul, x, y)?;
        for f in Unary::ALL {
            terms.push(g.unary(f, xy)?);
        }
        let mut sum = terms[0];
        for &t in &terms[1..] {
            sum = g.binary(Binary::Add, sum, t)?;
        }
        Ok(sum)
    }

    /// num-dual's own method of each function of the table (`expr/functions.rs`, the row's
    /// `dual_num`), or the row's `num` where num-dual has none.
    macro_rules! reference {
        ($u:ident; $dn:ident; |$nx:ident| $num:expr) => {
            $u.$dn()
        };
        ($u:ident; ; |$nx:ident| $num:expr) => {{
            let $nx = $u;
            $num
        }};
    }

    /// Σ_f f(u) over the table's functions, in `Unary::ALL`'s order, by [`reference!`].
    macro_rules! reference_sum {
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
            fn every_function_exact<D: Scalar>(u: D, mut sum: D) -> D {
                $(sum += reference!(u; $($dn)?; |$nx| $num);)*
                sum
            }
        };
    }

    crate::expr::functions::unary_functions!(reference_sum);

    /// [`every_operation`] written directly in num-dual.
    fn every_operation_exact<D: Scalar>(x: D, y: D) -> D {
        let sum = x.sin() * x.cos() + y.tan() - x.exp() * y.ln() + y.sqrt() + x.sinh() * y.cosh()
            - if x.re() > y.re() { x - y } else { y - x }
            + x.powd(y)
            + x.atan2(y)
            + x.powf(2.5)
            + (x * 2f64.ln()).exp()
            + x.recip() * 3.0
            + (-x + 4.0)
            + D::one().atan2(x)
            + x.atan2(D::from(2.0))
            + x.powi(-3)
            + y / x
            + (x - 1.0) / 2.0;
        every_function_exact(x * y, sum)
    }

    fn every_operation_function() -> Function {
        let mut g = Graph::new();
        let f = every_operation(&mut g).unwrap();
        let tape = Tape::new(&g, &[f], Inputs::potential(2, 0), "test").unwrap();
        Function::new(tape.into(), &[]).unwrap()
    }

    #[test]
    fn tape_evaluates_every_operation() {
        let f = every_operation_function();
        let (x, y) = (0.7, 1.3);
        for dir in [(1.0, 0.0), (0.0, 1.0)] {
            let q = [Dual64::new(x, dir.0), Dual64::new(y, dir.1)];
            let got = f.eval(Dual64::from(0.0), &q, &[]);
            let want = every_operation_exact(q[0], q[1]);
            assert_relative_eq!(got.re, want.re, max_relative = 1e-14);
            assert_relative_eq!(got.eps, want.eps, max_relative = 1e-13);
        }
    }

    /// The evaluations since the last `path::take` were one, on the jet path.
    fn assert_one_jet(what: &str) {
        assert_eq!(path::take(), (vec![], 1), "{what} not evaluated as a jet");
    }

    #[test]
    fn jets_match_num_dual_first_order() {
        use nalgebra::SVector;
        use num_dual::{Derivative, DualSVec64};
        let f = every_operation_function();
        let seed =
            |x: f64, e: [f64; 2]| DualSVec64::<2>::new(x, Derivative::some(SVector::from(e)));
        let q = [seed(0.7, [1.0, 0.3]), seed(1.3, [-0.4, 1.0])];
        path::take();
        let got = f.eval(DualSVec64::<2>::from(0.0), &q, &[]);
        assert_one_jet("DualSVec64<2>");
        let want = every_operation_exact(q[0], q[1]);
        assert_relative_eq!(got.re, want.re, max_relative = 1e-14);
        let (g, w) = (got.eps.0.unwrap(), want.eps.0.unwrap());
        for i in 0..2 {
            assert_relative_eq!(g[i], w[i], max_relative = 1e-13);
        }
    }

    /// [`every_operation`] over `Hyper<f64, 2, N>` against num-dual, through the jet path.
    fn check_second_order<const N: usize>() {
        use nalgebra::{Const, SMatrix, SVector};
        use num_dual::{Derivative, HyperDualVec64};
        type H<const N: usize> = HyperDualVec64<Const<2>, Const<N>>;
        let f = every_operation_function();
        let seed = |x: f64, e1: [f64; 2], e2: [f64; 4]| {
            H::<N>::new(
                x,
                Derivative::some(SVector::from(e1)),
                Derivative::some(SMatrix::<f64, 1, N>::from_fn(|_, j| e2[j])),
                Derivative::none(),
            )
        };
        let q = [
            seed(0.7, [1.0, 0.2], [1.0, 0.0, 0.5, 0.2]),
            seed(1.3, [0.0, 1.0], [0.3, 1.0, -0.7, 0.4]),
        ];
        path::take();
        let got = f.eval(H::<N>::from(0.0), &q, &[]);
        assert_one_jet(&format!("Hyper<f64, 2, {N}>"));
        let want = every_operation_exact(q[0], q[1]);
        assert_relative_eq!(got.re, want.re, max_relative = 1e-14);
        let (g1, w1) = (got.eps1.0.unwrap(), want.eps1.0.unwrap());
        let (g2, w2) = (got.eps2.0.unwrap(), want.eps2.0.unwrap());
        let (g12, w12) = (got.eps1eps2.0.unwrap(), want.eps1eps2.0.unwrap());
        for i in 0..2 {
            assert_relative_eq!(g1[i], w1[i], max_relative = 1e-13);
        }
        for j in 0..N {
            assert_relative_eq!(g2[j], w2[j], max_relative = 1e-13);
        }
        for i in 0..2 {
            for j in 0..N {
                assert_relative_eq!(g12[(i, j)], w12[(i, j)], max_relative = 1e-12);
            }
        }
    }

    /// The shapes of the passes for two coordinates: one-pass inertia (2, 4), M (2, 2), along
    /// the motion (2, 1).
    #[test]
    fn jets_match_num_dual_second_order() {
        check_second_order::<4>();
        check_second_order::<2>();
        check_second_order::<1>();
    }

    #[test]
    fn function_rejects_non_finite_constants() {
        let mut g = Graph::new();
        let (one, p) = (g.constant(1.0), g.param(0));
        let d = g.binary(Binary::Div, one, p).unwrap();
        let tape = Arc::new(Tape::new(&g, &[d], Inputs::constant(1), "mass").unwrap());
        assert!(Function::new(tape.clone(), &[0.0]).is_err());
        assert!(Function::new(tape.clone(), &[f64::NAN]).is_err());
        assert!(Function::new(tape.clone(), &[]).is_err());
        assert_eq!(
            Function::new(tape, &[4.0]).unwrap().constant_values(),
            vec![0.25]
        );
    }

    /// The check of every pass shape (`src/tests/eval_paths.rs`) can fail: a dual number outside
    /// the passes' shapes is recorded.
    #[test]
    fn eval_records_generic_path() {
        use nalgebra::Const;
        use num_dual::HyperDualVec64;
        let f = every_operation_function();
        path::take();
        let x = HyperDualVec64::<Const<2>, Const<3>>::from(0.7);
        f.eval(x, &[x, x], &[]);
        f.eval(Dual64::from(0.7), &[Dual64::from(0.7); 2], &[]);
        let (fallbacks, jets) = path::take();
        assert_eq!((fallbacks.len(), jets), (1, 0), "{fallbacks:?}");
    }

    /// (From `compile.rs`: the tapes checked by evaluating them.)
    fn graph_of(build: impl FnOnce(&mut Graph) -> Result<Vec<usize>>) -> (Graph, Vec<usize>) {
        let mut g = Graph::new();
        let outs = build(&mut g).unwrap();
        (g, outs)
    }

    #[test]
    fn tape_reuses_slots() {
        // A long chain x + x + … needs two slots however long it is.
        let (g, outs) = graph_of(|g| {
            let x = g.coord(0);
            let mut s = g.unary(Unary::Sin, x)?;
            for k in 0..50 {
                let c = g.constant(k as f64);
                let p = g.binary(Binary::Mul, x, c)?;
                let e = g.unary(Unary::Exp, p)?;
                s = g.binary(Binary::Add, s, e)?;
            }
            Ok(vec![s])
        });
        let tape = Tape::new(&g, &outs, Inputs::potential(1, 0), "test").unwrap();
        assert!(tape.slots <= 3, "{} slots", tape.slots);
        let f = Function::new(tape.into(), &[]).unwrap();
        let want: f64 = 0.1f64.sin() + (0..50).map(|k| (0.1 * k as f64).exp()).sum::<f64>();
        assert_relative_eq!(f.eval(0.0, &[0.1], &[]), want, max_relative = 1e-14);
    }

    #[test]
    fn tape_folds_parameters_into_constants() {
        // T = ½ m l² θ̇²: one square and one product with a constant, whatever m and l are.
        let (g, outs) = graph_of(|g| {
            let (m, l) = (g.param(0), g.param(1));
            let half = g.constant(0.5);
            let l2 = g.powi(l, 2)?;
            let k = g.binary(Binary::Mul, half, m)?;
            let k = g.binary(Binary::Mul, k, l2)?;
            let w = g.velocity(0);
            let w2 = g.powi(w, 2)?;
            Ok(vec![g.binary(Binary::Mul, k, w2)?])
        });
        let tape = Arc::new(Tape::new(&g, &outs, Inputs::kinetic(1, 2), "T").unwrap());
        // The square of q̇ and the product with ½ m l²; the input is no instruction.
        assert_eq!(tape.instructions(), 2);
        assert!(tape.constant_mass_matrix());
        assert!(!tape.depends_on_position() && !tape.depends_on_time());
        let f = Function::new(tape, &[2.0, 3.0]).unwrap();
        assert_relative_eq!(f.eval(0.0, &[0.0], &[0.5]), 0.5 * 2.0 * 9.0 * 0.25);
        let f = f.with_parameters(&[1.0, 1.0]).unwrap();
        assert_relative_eq!(f.eval(0.0, &[0.0], &[0.5]), 0.125);
    }
}
