//! A graph-building scalar: a Rust model's generic energies, run on [`Traced`] values, record
//! themselves as an expression graph ([`crate::tape::Graph`]), so that a system written in Rust
//! gets what only the graph gives — eq. 55 derived and compiled ([`EomProgram`]), the Taylor
//! method — without being restated.
//!
//! A [`Traced`] is a number known now (folded as the f64 arithmetic would) or a node of the graph
//! being recorded; the graph lives in a thread-local for the duration of one [`record`], so the
//! value stays `Copy` as [`Scalar`] requires. What a graph cannot hold makes the
//! trace fail with the reason, never a different model: the real part of a node (its value is
//! not known while tracing, so a branch on it, a comparison or `re()` fails), and the functions
//! the graph lacks (`cbrt`, `exp_m1`, `ln_1p`, the inverse hyperbolic functions, `signum`, the
//! spherical Bessel functions, `%`). `asin`, `acos`, `atan`, `log`, `exp2` are recorded through
//! identities with `atan2`, `ln` and `exp`, equal to round-off. Numbers fold, and 0 · x, 1 · x,
//! x ± 0 simplify as the graph's own simplifier does (different from the `f64` code only where
//! x is not finite).
//!
//! [`WithProgram`] pairs a Rust system with its traced eq. 55 program: the system computes as
//! before, and the Taylor method ([`Dynamics::taylor_program`]) gets the program, traced and
//! compiled on its first request. The other methods start on the Rust route; a run through
//! [`FastPath`] (every `simulate` of a Python scene) moves to the same program once it has
//! spent on the Rust route what the trace and compile cost. Why not always: measured
//! through Python (2026-11-28, `--profile ci`, the 2-core machine under load; best of 5),
//! tracing and compiling costs 0.6 ms (damped oscillator), 1.3 ms (Kepler), 2.5 ms (double
//! pendulum) and about 10 ms (a 3-link chain) before a scene's first run — more than a whole
//! run of most scenes (Kepler's `auto` at 1e-9: 0.07 ms, 1.4 ms with the trace), and paid on
//! every run of a sweep that builds the scene per run. Once compiled the program is faster: the
//! double pendulum stated with `lg.Model` (the same program) against the Rust scene over
//! t = 100 (`benches/python_vs_rust.py`) takes 6.7 against 13.6 ms with DOP853 at 1e-10 and 199
//! against 306 ms with Gauss–Legendre 4 at dt = 1e-3, and the program's Jacobians made
//! Gauss–Legendre 6 1.4–3.3 times faster on the scenes (Radau IIA the same). So a long run would
//! gain from the program and a short one lose; routing by history (the program once some run
//! made it) would change results at round-off from one run to the next. So the switch
//! of [`FastPath`] counts the run's own evaluations: a run repeated gives the same numbers.
//!
//! ```
//! use lagrangian::integrators::{Method, Options, solve};
//! use lagrangian::scenes::DoublePendulum;
//! use lagrangian::trace::WithProgram;
//! let system = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81).system();
//! let model = WithProgram::new(system, "double pendulum");
//! let options = Options::adaptive(1e-12, 1e-12);
//! let taylor = solve(&model, &[1.0, 0.5], &[0.0, 0.0], (0.0, 2.0), Method::Taylor, &options)?;
//! let dop853 = solve(&model, &[1.0, 0.5], &[0.0, 0.0], (0.0, 2.0), Method::Dop853, &options)?;
//! let (a, b) = (taylor.last().unwrap().1, dop853.last().unwrap().1);
//! assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
//! # Ok::<(), lagrangian::Error>(())
//! ```
//!
//! [`Scalar`]: crate::scalar::Scalar

use crate::derived::eom_program::{Energies, EomFunction, EomProgram, particle_kinetic};
use crate::dynamics::Dynamics;
use crate::energies::{Dissipation, GeneralizedForces, KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::expr::functions::unary_functions;
use crate::expr::graph::{Binary, Graph, Node, Unary};
use crate::routes::{BodySystem, CartesianForces, ParticleSystem, Particles, RigidBodies, System};
use crate::scalar::Scalar;
use num_dual::{DualNum, DualStruct, Mappable};
use num_traits::{FromPrimitive, Inv, Num, One, Signed, Zero};
use std::cell::RefCell;
use std::cmp::Ordering;
use std::fmt;
use std::iter::{Product, Sum};
use std::ops::{
    Add, AddAssign, Deref, Div, DivAssign, Mul, MulAssign, Neg, Rem, RemAssign, Sub, SubAssign,
};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering as AtomicOrdering};

/// A scalar that records the operations on it as nodes of an expression graph.
///
/// Made by [`record`] (the leaves t, q, q̇) or from numbers; see the module documentation for
/// what fails a trace.
///
/// # Panics
/// An operation on a node outside the [`record`] that made it panics (a node is an index into
/// that recording's graph).
#[derive(Clone, Copy, Debug)]
pub struct Traced(Value);

#[derive(Clone, Copy, Debug)]
enum Value {
    /// Known now.
    Number(f64),
    /// Node `id` of the recording numbered `trace`.
    Node { id: usize, trace: u64 },
}

/// The graph being recorded and the first operation that could not be.
struct Recording {
    graph: Graph,
    trace: u64,
    failure: Option<String>,
}

thread_local! {
    static RECORDING: RefCell<Option<Recording>> = const { RefCell::new(None) };
}

/// The number of the next recording, unique across threads: a `Traced` node is `Send`, and one
/// carried to another thread must not match that thread's recording.
static TRACES: AtomicU64 = AtomicU64::new(1);

/// Clears the recording when [`record`] ends, also by a panic in the traced code.
struct Finish;

impl Drop for Finish {
    fn drop(&mut self) {
        RECORDING.with_borrow_mut(|r| *r = None);
    }
}

/// Note the first reason the trace cannot stand for the model.
fn fail(why: impl FnOnce() -> String) {
    RECORDING.with_borrow_mut(|r| {
        if let Some(r) = r {
            r.failure.get_or_insert_with(why);
        }
    });
}

/// `f` on the active recording.
fn with_recording<R>(f: impl FnOnce(&mut Recording) -> R) -> R {
    RECORDING.with_borrow_mut(|r| {
        f(r.as_mut()
            .expect("a traced node is used outside the lagrangian::trace::record that made it"))
    })
}

/// Record `f` into a fresh graph: `f` gets the leaves t, q₁…qₙ, q̇₁…q̇ₙ and returns the outputs,
/// whose node ids come back with the graph (a number becomes a constant node).
///
/// # Errors
/// The reason, when `f` read the value of a node, called a function the graph lacks, or traces
/// inside another trace.
pub fn record(
    dof: usize,
    f: impl FnOnce(Traced, &[Traced], &[Traced]) -> Vec<Traced>,
) -> std::result::Result<(Graph, Vec<usize>), String> {
    let trace = TRACES.fetch_add(1, AtomicOrdering::Relaxed);
    let busy = RECORDING.with_borrow_mut(|r| {
        if r.is_some() {
            return true;
        }
        *r = Some(Recording {
            graph: Graph::new(),
            trace,
            failure: None,
        });
        false
    });
    if busy {
        return Err("a trace was started inside another trace".into());
    }
    let _finish = Finish;
    let node = |n: Node| Traced::record(|rec| rec.graph.push(n));
    let t = node(Node::Time);
    let q: Vec<Traced> = (0..dof).map(|i| node(Node::Coord(i))).collect();
    let qd: Vec<Traced> = (0..dof).map(|i| node(Node::Velocity(i))).collect();
    let outputs = f(t, &q, &qd);
    let ids: Vec<Option<usize>> = with_recording(|rec| outputs.iter().map(|x| x.id(rec)).collect());
    let rec = RECORDING
        .with_borrow_mut(Option::take)
        .expect("the recording is cleared only when record ends");
    if let Some(why) = rec.failure {
        return Err(why);
    }
    let ids = ids
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .ok_or("an output is not finite")?;
    Ok((rec.graph, ids))
}

impl Traced {
    /// A number.
    pub fn number(x: f64) -> Self {
        Traced(Value::Number(x))
    }

    /// The number, if this value is one (known without running the graph).
    pub fn as_number(self) -> Option<f64> {
        match self.0 {
            Value::Number(x) => Some(x),
            Value::Node { .. } => None,
        }
    }

    /// The node of `f` pushed on the recording's graph (a failed push fails the trace).
    fn record(f: impl FnOnce(&mut Recording) -> Result<usize>) -> Self {
        with_recording(|rec| match f(rec) {
            Ok(id) => Traced(Value::Node {
                id,
                trace: rec.trace,
            }),
            Err(e) => {
                rec.failure.get_or_insert_with(|| e.to_string());
                Traced(Value::Number(f64::NAN))
            }
        })
    }

    /// This value as a node of the active recording (a number becomes a constant).
    fn id(self, rec: &mut Recording) -> Option<usize> {
        match self.0 {
            Value::Number(x) if x.is_finite() => Some(rec.graph.constant(x)),
            Value::Number(x) => {
                rec.failure
                    .get_or_insert_with(|| format!("the number {x} is not finite"));
                None
            }
            Value::Node { id, trace } if trace == rec.trace => Some(id),
            Value::Node { .. } => {
                rec.failure
                    .get_or_insert_with(|| "a value of another trace is used".into());
                None
            }
        }
    }

    fn unary(self, f: Unary, fold: fn(f64) -> f64) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(fold(x)),
            Value::Node { .. } => Self::record(|rec| {
                let a = self.id(rec).ok_or_else(not_recorded)?;
                rec.graph.unary(f, a)
            }),
        }
    }

    fn binary(self, f: Binary, other: Self) -> Self {
        use Value::Number as N;
        let zero = |v: Value| matches!(v, N(x) if x == 0.0);
        let one = |v: Value| matches!(v, N(x) if x == 1.0);
        match (f, self.0, other.0) {
            (_, N(a), N(b)) => Self::number(fold(f, a, b)),
            // The identities the graph's own simplifier applies, so that the dual numbers' zero
            // and unit parts leave no nodes.
            (Binary::Add, a, _) if zero(a) => other,
            (Binary::Add | Binary::Sub, _, b) if zero(b) => self,
            (Binary::Sub, a, _) if zero(a) => -other,
            (Binary::Mul, a, b) if zero(a) || zero(b) => Self::number(0.0),
            (Binary::Mul, a, _) if one(a) => other,
            (Binary::Mul | Binary::Div, _, b) if one(b) => self,
            _ => Self::record(|rec| {
                let (a, b) = (self.id(rec), other.id(rec));
                let (a, b) = a.zip(b).ok_or_else(not_recorded)?;
                rec.graph.binary(f, a, b)
            }),
        }
    }

    fn powi_node(self, n: i32) -> Self {
        match (self.0, n) {
            (Value::Number(x), _) => Self::number(x.powi(n)),
            (_, 0) => Self::number(1.0),
            (_, 1) => self,
            _ => Self::record(|rec| {
                let a = self.id(rec).ok_or_else(not_recorded)?;
                rec.graph.powi(a, n)
            }),
        }
    }

    /// The value of a node is not known while tracing: fail the trace with `what` and give NaN.
    fn unknown(self, what: &str) -> Option<f64> {
        match self.0 {
            Value::Number(x) => Some(x),
            Value::Node { .. } => {
                fail(|| {
                    format!(
                        "it {what}, whose value is not known while tracing (a branch on the \
                         state has no expression graph)"
                    )
                });
                None
            }
        }
    }

    /// A function the graph lacks: fold a number, fail the trace for a node.
    fn lacking(self, name: &str, f: fn(f64) -> f64) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(f(x)),
            Value::Node { .. } => {
                fail(|| format!("it calls {name}, which the expression graph lacks"));
                Self::number(f64::NAN)
            }
        }
    }
}

fn not_recorded() -> Error {
    Error::InvalidInput {
        what: "trace",
        why: "an operand was not recorded".into(),
    }
}

fn fold(f: Binary, a: f64, b: f64) -> f64 {
    match f {
        Binary::Add => a + b,
        Binary::Sub => a - b,
        Binary::Mul => a * b,
        Binary::Div => a / b,
        Binary::Pow => a.powf(b),
        Binary::Atan2 => a.atan2(b),
    }
}

impl From<f64> for Traced {
    fn from(x: f64) -> Self {
        Self::number(x)
    }
}

impl fmt::Display for Traced {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Value::Number(x) => write!(f, "{x}"),
            Value::Node { id, .. } => write!(f, "node {id}"),
        }
    }
}

impl PartialEq for Traced {
    /// Numbers compare as numbers and a node equals itself (equal nodes are stored once);
    /// anything else needs a value and fails the trace.
    fn eq(&self, other: &Self) -> bool {
        match (self.0, other.0) {
            (Value::Number(a), Value::Number(b)) => a == b,
            (Value::Node { id: a, trace: s }, Value::Node { id: b, trace: t })
                if a == b && s == t =>
            {
                true
            }
            _ => {
                fail(|| {
                    "it compares traced values, whose values are not known while tracing".into()
                });
                false
            }
        }
    }
}

impl PartialOrd for Traced {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        let a = self.unknown("compares a traced value")?;
        let b = other.unknown("compares a traced value")?;
        a.partial_cmp(&b)
    }
}

impl PartialEq<f64> for Traced {
    fn eq(&self, other: &f64) -> bool {
        self.unknown("compares a traced value")
            .is_some_and(|a| a == *other)
    }
}

impl PartialOrd<f64> for Traced {
    fn partial_cmp(&self, other: &f64) -> Option<Ordering> {
        self.unknown("compares a traced value")?.partial_cmp(other)
    }
}

macro_rules! arithmetic {
    ($($trait:ident $method:ident $assign:ident $assign_method:ident $op:expr;)*) => {$(
        impl $trait for Traced {
            type Output = Traced;
            fn $method(self, other: Traced) -> Traced {
                $op(self, other)
            }
        }
        impl $trait<&Traced> for Traced {
            type Output = Traced;
            fn $method(self, other: &Traced) -> Traced {
                $op(self, *other)
            }
        }
        impl $trait<f64> for Traced {
            type Output = Traced;
            fn $method(self, other: f64) -> Traced {
                $op(self, Traced::number(other))
            }
        }
        impl $assign for Traced {
            fn $assign_method(&mut self, other: Traced) {
                *self = $op(*self, other);
            }
        }
        impl $assign<f64> for Traced {
            fn $assign_method(&mut self, other: f64) {
                *self = $op(*self, Traced::number(other));
            }
        }
    )*};
}

arithmetic! {
    Add add AddAssign add_assign |a: Traced, b| a.binary(Binary::Add, b);
    Sub sub SubAssign sub_assign |a: Traced, b| a.binary(Binary::Sub, b);
    Mul mul MulAssign mul_assign |a: Traced, b| a.binary(Binary::Mul, b);
    Div div DivAssign div_assign |a: Traced, b| a.binary(Binary::Div, b);
    Rem rem RemAssign rem_assign |a: Traced, b: Traced| match (a.0, b.0) {
        (Value::Number(x), Value::Number(y)) => Traced::number(x % y),
        _ => {
            fail(|| "it takes a remainder (%), which the expression graph lacks".into());
            Traced::number(f64::NAN)
        }
    };
}

impl Neg for Traced {
    type Output = Traced;
    fn neg(self) -> Traced {
        self.unary(Unary::Neg, |x| -x)
    }
}

impl Zero for Traced {
    fn zero() -> Self {
        Self::number(0.0)
    }
    /// Whether this is the number 0; a node's value is not known, so asking fails the trace.
    fn is_zero(&self) -> bool {
        self.unknown("asks whether a traced value is zero")
            .is_some_and(|x| x == 0.0)
    }
}

impl One for Traced {
    fn one() -> Self {
        Self::number(1.0)
    }
}

impl Num for Traced {
    type FromStrRadixErr = <f64 as Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> std::result::Result<Self, Self::FromStrRadixErr> {
        f64::from_str_radix(s, radix).map(Self::number)
    }
}

impl Signed for Traced {
    fn abs(&self) -> Self {
        self.unary(Unary::Abs, f64::abs)
    }
    fn abs_sub(&self, other: &Self) -> Self {
        (*self - *other).lacking("abs_sub (max(a − b, 0))", |x| x.max(0.0))
    }
    fn signum(&self) -> Self {
        self.lacking("signum", f64::signum)
    }
    fn is_positive(&self) -> bool {
        self.unknown("asks the sign of a traced value")
            .is_some_and(|x| x.is_sign_positive())
    }
    fn is_negative(&self) -> bool {
        self.unknown("asks the sign of a traced value")
            .is_some_and(|x| x.is_sign_negative())
    }
}

impl Inv for Traced {
    type Output = Traced;
    fn inv(self) -> Traced {
        self.recip()
    }
}

impl Sum for Traced {
    fn sum<I: Iterator<Item = Traced>>(iter: I) -> Traced {
        iter.fold(Traced::zero(), |a, b| a + b)
    }
}

impl Product for Traced {
    fn product<I: Iterator<Item = Traced>>(iter: I) -> Traced {
        iter.fold(Traced::one(), |a, b| a * b)
    }
}

impl FromPrimitive for Traced {
    fn from_i64(n: i64) -> Option<Self> {
        Some(Self::number(n as f64))
    }
    fn from_u64(n: u64) -> Option<Self> {
        Some(Self::number(n as f64))
    }
    fn from_f64(n: f64) -> Option<Self> {
        Some(Self::number(n))
    }
}

impl DualStruct for Traced {
    type Real = f64;
    type Inner = Traced;
    /// The number; a node's value is not known while tracing, so asking fails the trace
    /// (and gives NaN).
    fn re(&self) -> f64 {
        self.unknown("reads the value of a traced quantity (re())")
            .unwrap_or(f64::NAN)
    }
    fn from_inner(inner: &Traced) -> Self {
        *inner
    }
}

impl Mappable<Traced> for Traced {
    type Output<O> = O;
    fn map_dual<M: Fn(Traced) -> O, O>(self, f: M) -> O {
        f(self)
    }
}

/// The `DualNum` methods of the functions of one argument the graph holds (each row of
/// `expr/functions.rs` with a `dual_num` method): a number folds by the row's `value`, a node
/// records the function.
macro_rules! traced_methods {
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
        $($(
            fn $dn(&self) -> Self {
                self.unary(Unary::$name, |$x| $value)
            }
        )?)*
    };
}

impl DualNum for Traced {
    unary_functions!(traced_methods);

    type Primitive = f64;
    const NDERIV: usize = 0;
    type InnerDual = Traced;

    fn from_re(re: Traced) -> Self {
        re
    }
    fn scale(self, factor: &Traced) -> Self {
        self * *factor
    }
    fn recip(&self) -> Self {
        Traced::one() / *self
    }
    fn powi(&self, n: i32) -> Self {
        self.powi_node(n)
    }
    fn powf(&self, n: f64) -> Self {
        self.binary(Binary::Pow, Traced::number(n))
    }
    fn powd(&self, n: Self) -> Self {
        self.binary(Binary::Pow, n)
    }
    fn cbrt(&self) -> Self {
        self.lacking("cbrt", f64::cbrt)
    }
    fn exp2(&self) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(x.exp2()),
            Value::Node { .. } => (*self * std::f64::consts::LN_2).exp(),
        }
    }
    fn exp_m1(&self) -> Self {
        self.lacking(
            "exp_m1 (eˣ − 1 from exp would lose the digits it keeps)",
            f64::exp_m1,
        )
    }
    fn log(&self, base: f64) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(x.log(base)),
            Value::Node { .. } => self.ln() / base.ln(),
        }
    }
    fn log2(&self) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(x.log2()),
            Value::Node { .. } => self.ln() / std::f64::consts::LN_2,
        }
    }
    fn log10(&self) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(x.log10()),
            Value::Node { .. } => self.ln() / std::f64::consts::LN_10,
        }
    }
    fn ln_1p(&self) -> Self {
        self.lacking(
            "ln_1p (ln(1 + x) from ln would lose the digits it keeps)",
            f64::ln_1p,
        )
    }
    fn sin_cos(&self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
    /// asin x = atan2(x, √(1 − x²)), exact on [−1, 1] (NaN outside, as asin).
    fn asin(&self) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(x.asin()),
            Value::Node { .. } => {
                let c = (Traced::one() - *self * *self).sqrt();
                self.atan2(c)
            }
        }
    }
    /// acos x = atan2(√(1 − x²), x), exact on [−1, 1] (NaN outside, as acos).
    fn acos(&self) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(x.acos()),
            Value::Node { .. } => (Traced::one() - *self * *self).sqrt().atan2(*self),
        }
    }
    fn atan(&self) -> Self {
        match self.0 {
            Value::Number(x) => Self::number(x.atan()),
            Value::Node { .. } => self.atan2(Traced::one()),
        }
    }
    fn atan2(&self, other: Self) -> Self {
        self.binary(Binary::Atan2, other)
    }
    fn asinh(&self) -> Self {
        self.lacking("asinh", f64::asinh)
    }
    fn acosh(&self) -> Self {
        self.lacking("acosh", f64::acosh)
    }
    fn atanh(&self) -> Self {
        self.lacking("atanh", f64::atanh)
    }
    fn sph_j0(&self) -> Self {
        self.lacking("a spherical Bessel function", |x| {
            <f64 as DualNum>::sph_j0(&x)
        })
    }
    fn sph_j1(&self) -> Self {
        self.lacking("a spherical Bessel function", |x| {
            <f64 as DualNum>::sph_j1(&x)
        })
    }
    fn sph_j2(&self) -> Self {
        self.lacking("a spherical Bessel function", |x| {
            <f64 as DualNum>::sph_j2(&x)
        })
    }
    fn mul_add(&self, a: Self, b: Self) -> Self {
        match (self.0, a.0, b.0) {
            // f64's mul_add rounds once; so does the fold.
            (Value::Number(x), Value::Number(y), Value::Number(z)) => Self::number(x.mul_add(y, z)),
            _ => *self * a + b,
        }
    }
}

/// A Rust system whose energies can be traced: its T, U, Φ and Q″ as nodes of one graph (the
/// parameters' values are numbers in it).
pub trait TraceEnergies: Dynamics {
    /// The graph and the energies' nodes.
    ///
    /// # Errors
    /// The reason the energies cannot be traced (see the module documentation).
    fn trace_energies(&self) -> std::result::Result<(Graph, Energies), String>;
}

/// Whether node `id` is the number 0 (an absent part).
fn is_zero(g: &Graph, id: usize) -> bool {
    matches!(g.nodes()[id], Node::Const(x) if x == 0.0)
}

/// The energies from the outputs [U, Φ, Q₁…Qₙ] that follow T (or the positions).
fn energies(g: &Graph, kinetic: usize, rest: &[usize]) -> Energies {
    let part = |id: usize| (!is_zero(g, id)).then_some(id);
    let forces = &rest[2..];
    Energies {
        kinetic,
        potential: part(rest[0]),
        dissipation: part(rest[1]),
        forces: (!forces.iter().all(|&f| is_zero(g, f))).then(|| forces.to_vec()),
    }
}

impl<T, U, R, Q> TraceEnergies for System<T, U, R, Q>
where
    T: KineticEnergy,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    fn trace_energies(&self) -> std::result::Result<(Graph, Energies), String> {
        let n = self.dof();
        let (g, ids) = record(n, |t, q, qd| {
            let mut out = vec![
                self.kinetic.kinetic(t, q, qd),
                self.potential.potential(t, q),
                self.dissipation.dissipation(t, q, qd),
            ];
            let mut forces = vec![Traced::zero(); n];
            self.forces.forces(t, q, qd, &mut forces);
            out.extend(forces);
            out
        })?;
        let parts = energies(&g, ids[0], &ids[1..]);
        Ok((g, parts))
    }
}

/// A system stated by particles: the positions are traced and T = ½ Σ m |ṙ|² derived from them
/// on the graph ([`particle_kinetic`], as for a model stated by particles in Python); U (with
/// gravity) and Q″ (with the Cartesian forces mapped onto the coordinates) are traced through
/// the system's own generic code.
impl<P, U, R, Q, F> TraceEnergies for ParticleSystem<P, U, R, Q, F>
where
    P: Particles,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
    F: CartesianForces,
{
    fn trace_energies(&self) -> std::result::Result<(Graph, Energies), String> {
        let (n, width) = (self.dof(), self.particles.coordinates_len());
        let (mut g, ids) = record(n, |t, q, qd| {
            let mut out = vec![Traced::zero(); width];
            self.particles.positions(t, q, &mut out);
            out.push(self.potential_energy(t, q));
            out.push(self.dissipation.dissipation(t, q, qd));
            let mut forces = vec![Traced::zero(); n];
            self.generalized_forces_into(t, q, qd, &mut forces);
            out.extend(forces);
            out
        })?;
        let masses: Vec<usize> = (0..self.particles.count())
            .map(|j| g.constant(self.particles.mass(j)))
            .collect();
        let (positions, rest) = ids.split_at(width);
        let kinetic = particle_kinetic(&mut g, n, positions, &masses, self.particles.dim())
            .map_err(|e| e.to_string())?;
        let parts = energies(&g, kinetic, rest);
        Ok((g, parts))
    }
}

/// A system of rigid bodies: T (with the quaternions' regularizing terms), U with gravity, Φ
/// and Q″ traced through its energy route's generic code.
impl<B, U, R, Q> TraceEnergies for BodySystem<B, U, R, Q>
where
    B: RigidBodies,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    fn trace_energies(&self) -> std::result::Result<(Graph, Energies), String> {
        self.energy_route().trace_energies()
    }
}

/// The eq. 55 program of a traced system, compiled and bound as a model stated in Python is
/// ([`EomProgram::new`], [`EomProgram::bind`]; no parameters, their values are in the graph).
///
/// # Errors
/// [`Error::NotTraceable`] naming `what` and the reason, or the program's own errors.
pub fn eom_program<S: TraceEnergies + ?Sized>(system: &S, what: &str) -> Result<EomFunction> {
    let (mut graph, parts) = system.trace_energies().map_err(|why| Error::NotTraceable {
        what: what.to_string(),
        why,
    })?;
    EomProgram::new(&mut graph, system.dof(), 0, &parts)?.bind(&[])
}

/// [`eom_program`] for a system run again and again: its small Taylor expansions compiled
/// unrolled from their first run ([`EomProgram::unroll_small_early`]).
fn eom_program_reused<S: TraceEnergies + ?Sized>(system: &S, what: &str) -> Result<EomFunction> {
    let (mut graph, parts) = system.trace_energies().map_err(|why| Error::NotTraceable {
        what: what.to_string(),
        why,
    })?;
    let program = EomProgram::new(&mut graph, system.dof(), 0, &parts)?;
    program.unroll_small_early().bind(&[])
}

/// A Rust system with its eq. 55 program traced on first request: everything the system
/// computes it still computes ([`Dynamics`] is passed through), and the Taylor method, which
/// needs the expression graph, takes the program ([`Dynamics::taylor_program`]).
#[derive(Debug)]
pub struct WithProgram<S> {
    system: S,
    name: String,
    program: OnceLock<Result<EomFunction>>,
}

impl<S: TraceEnergies> WithProgram<S> {
    /// `system`, named `name` in the errors of its trace.
    pub fn new(system: S, name: impl Into<String>) -> Self {
        Self {
            system,
            name: name.into(),
            program: OnceLock::new(),
        }
    }

    /// The Rust system.
    pub fn system(&self) -> &S {
        &self.system
    }

    /// The traced eq. 55 program, traced and compiled on the first call.
    ///
    /// # Errors
    /// Those of [`eom_program`]; the same error on every call.
    pub fn program(&self) -> Result<&EomFunction> {
        self.program
            .get_or_init(|| eom_program_reused(&self.system, &self.name))
            .as_ref()
            .map_err(Clone::clone)
    }
}

impl<S: TraceEnergies> Dynamics for WithProgram<S> {
    crate::dynamics::forward_dynamics!(system: dof, structure, kinetic_energy, potential_energy,
        potential_gradient_into, generalized_forces_into, dissipative_forces_into, momenta_into,
        mass_matrix_into, accelerations_into, lagrangian, energy);
    /// The traced program, traced and compiled on this first request, or why the system
    /// cannot be traced ([`Error::NotTraceable`]'s message). Only the Taylor method asks:
    /// [`Dynamics::derived_program`] stays `None`, so that every other method starts on the
    /// Rust code, with no trace to pay for on a short run ([`FastPath`] decides when a run
    /// moves to the program; see the module documentation for the measurements).
    fn taylor_program(&self) -> std::result::Result<&dyn crate::dynamics::DerivedProgram, String> {
        self.program().map(|p| p as _).map_err(|e| e.to_string())
    }
}

/// The Rust route's evaluations of a run, times the degrees of freedom, after which
/// [`FastPath`] compiles. Tracing and compiling a scene costs as much as some hundreds to
/// thousands of its dual-number evaluations of q̈, fewer the larger it is (measured through
/// Python, 2026-12-08, `--profile ci`, N-link chains: 2,300 at N = 2, 1,500 at 8, 690 at 16,
/// 100 at 32, where the solve is no longer unrolled and the compile cheaper); this switches at a
/// fifth to two thirds of that, so that a run that switches costs little more than the same
/// system stated by hand (which pays the same compile up front), while a run shorter than the
/// switch keeps the Rust route's head start.
pub const SWITCH_WORK: usize = 3_000;

/// One run of a traced system that starts on the Rust route and, once it has spent on it a fair
/// part of what tracing and compiling cost, continues on the compiled eq. 55 program (the one
/// [`WithProgram`] holds, traced and compiled once for every run and the Taylor method; a later
/// run of the same system switches at the same count, though its compile is already paid, so
/// that its numbers do not depend on the runs before it).
///
/// Why this rule: a run cannot know beforehand how many evaluations it will take; paying the
/// compile once the Rust evaluations already spent are a fair part of it (the ski rental's rule)
/// bounds the loss against either route fixed in advance, for short runs and long. The switch
/// counts the `f64` accelerations ([`switch_at`](Self::switch_at) of them, [`SWITCH_WORK`] over
/// n by default), never a clock, so that a run repeated gives the same numbers; a run that switches
/// differs from the Rust route by round-off from the switch on. Only the `f64` accelerations
/// switch (the explicit methods' work): dual-number evaluations (implicit methods' Jacobians)
/// and the other quantities stay on the Rust route. A system that cannot be traced stays on the
/// Rust route, and [`route`](Self::route) says why.
#[derive(Debug)]
pub struct FastPath<P: Deref> {
    system: P,
    program: Program<P::Target>,
    switch_at: usize,
    calls: AtomicUsize,
    compiled: OnceLock<std::result::Result<(), String>>,
}

/// Where [`FastPath`] gets the traced program of its system (traced on the first call, kept).
pub type Program<S> = for<'s> fn(&'s S) -> Result<&'s EomFunction>;

impl<P: Deref<Target: Dynamics>> FastPath<P> {
    /// A run of `system` (a reference or an owner), whose traced program `program` gives,
    /// switching after [`SWITCH_WORK`] / n evaluations.
    pub fn new(system: P, program: Program<P::Target>) -> Self {
        let switch_at = SWITCH_WORK / system.dof().max(1);
        Self::switching_at(system, program, switch_at)
    }

    /// The same, switching after `switch_at` evaluations of the Rust route (0: compiled from
    /// the first; `usize::MAX`: never).
    pub fn switching_at(system: P, program: Program<P::Target>, switch_at: usize) -> Self {
        Self {
            system,
            program,
            switch_at,
            calls: AtomicUsize::new(0),
            compiled: OnceLock::new(),
        }
    }

    /// The evaluations of the Rust route after which the run switches.
    pub fn switch_at(&self) -> usize {
        self.switch_at
    }

    /// What computed the run's `f64` accelerations and why, for `Statistics::scene_path`:
    /// `"rust: …"` or `"compiled: …"`.
    pub fn route(&self) -> String {
        match self.compiled.get() {
            None => format!(
                "rust: fewer evaluations than the {} that pay for compiling",
                self.switch_at
            ),
            Some(Ok(())) => format!(
                "compiled: the traced eq. 55 program after {} evaluations on the Rust route",
                self.switch_at
            ),
            Some(Err(why)) => format!("rust: the system cannot be traced ({why})"),
        }
    }

    /// The program, once the run has switched to it.
    fn compiled(&self) -> Option<&EomFunction> {
        let program = || (self.program)(&self.system);
        match self.compiled.get() {
            Some(Ok(())) => return program().ok(),
            Some(Err(_)) => return None,
            None => {}
        }
        if self.calls.fetch_add(1, AtomicOrdering::Relaxed) < self.switch_at {
            return None;
        }
        let made = self
            .compiled
            .get_or_init(|| program().map(|_| ()).map_err(|e| e.to_string()));
        made.as_ref().ok().and_then(|()| program().ok())
    }
}

impl<P: Deref<Target: Dynamics>> Dynamics for FastPath<P> {
    crate::dynamics::forward_dynamics!(system: dof, structure, kinetic_energy, potential_energy,
        potential_gradient_into, generalized_forces_into, dissipative_forces_into, momenta_into,
        mass_matrix_into, lagrangian, energy, taylor_program);
    /// The Rust route's, or the program's once the run has switched (`f64` only).
    #[inline]
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        if crate::scalar::is::<D, f64>()
            && let Some(program) = self.compiled()
        {
            // SAFETY: D is f64 (same TypeId), so these are identity casts.
            let (t, q, qd) = unsafe {
                (
                    *crate::scalar::cast::<D, f64>(&t),
                    crate::scalar::cast_slice::<D, f64>(q),
                    crate::scalar::cast_slice::<D, f64>(qd),
                )
            };
            let out = unsafe { &mut *(out as *mut [D] as *mut [f64]) };
            return program.accelerations(t, q, qd, out);
        }
        self.system.accelerations_into(t, q, qd, out)
    }
    fn scene_path(&self) -> Option<String> {
        Some(self.route())
    }
}
