//! [`Method::Auto`]: the choice of a method from the system's structure, the options and the
//! initial state, with the reason recorded in the statistics.

use super::method::Method;
use super::options::Options;
use super::{stiffness, taylor};
use crate::derived::eom_program::EomFunction;
use crate::dynamics::Dynamics;

/// Choose a method from the system's structure, the options and the initial state (the rule
/// is documented on [`Method::Auto`]); the reason goes to the statistics.
pub(super) fn choose<S: Dynamics + ?Sized>(
    system: &S,
    t0: f64,
    q0: &[f64],
    qd0: &[f64],
    t_end: f64,
    options: &Options,
) -> (Method, String) {
    if let Some(c) = system.constraints() {
        let rows = c.holonomic_rows() + c.velocity_rows();
        let s = system.structure();
        if options.dt.is_some() && s.conservative() && s.separable && c.velocity_rows() == 0 {
            return (
                Method::Yoshida4,
                format!(
                    "constrained ({rows} holonomic rows), separable (constant M, U(q)) and \
                     conservative, with a fixed dt: yoshida4 as a composition of RATTLE steps \
                     stays on the constraints to round-off and, symplectic on the constraint \
                     manifold, keeps the energy error bounded over long runs"
                ),
            );
        }
        let (method, why) = choose_for(system, t0, q0, qd0, t_end, options, false);
        return (
            method,
            format!(
                "constrained ({rows} rows): a method whose steps are projected back onto the \
                 constraints (RATTLE serves only conservative separable systems with holonomic \
                 rows at a fixed dt, and Taylor does not take constraints); {why}"
            ),
        );
    }
    choose_for(system, t0, q0, qd0, t_end, options, true)
}

/// [`choose`] among every method (`symplectic`), or among the projected ones.
fn choose_for<S: Dynamics + ?Sized>(
    system: &S,
    t0: f64,
    q0: &[f64],
    qd0: &[f64],
    t_end: f64,
    options: &Options,
    symplectic: bool,
) -> (Method, String) {
    let s = system.structure();
    if symplectic && options.dt.is_some() && s.conservative() {
        return if s.separable {
            (
                Method::BlanesMoan4,
                "separable (constant M, U(q)) and conservative, with a fixed dt: the symplectic \
                 Blanes–Moan SRKN of order 4 keeps the energy error bounded over long runs"
                    .into(),
            )
        } else {
            (
                Method::Gauss4,
                "conservative but not separable (M depends on q, or gyroscopic or \
                 velocity-dependent terms), with a fixed dt: Gauss–Legendre of order 4 on (q, p) \
                 is symplectic for any Lagrangian and keeps the energy error bounded"
                    .into(),
            )
        };
    }
    let stiffness = stiffness::estimate_stiffness(system, t0, q0, qd0, t_end - t0);
    if let Some(est) = stiffness.filter(|e| e.stiff()) {
        return (
            Method::Radau5,
            format!(
                "stiff: at the initial state the fastest decaying mode (|λ| ≈ {:.3e}) is {:.0} \
                 times faster than every mode the solution must follow (|λ| ≈ {:.3e}, at least \
                 1/span), so an explicit step would be limited by stability; Radau IIA of order \
                 5 is L-stable",
                est.fastest,
                est.ratio(),
                est.resolved
            ),
        );
    }
    let mut taylor_note = String::new();
    let not_stiff = match stiffness {
        Some(est) => format!(
            "not stiff (fastest mode |λ| ≈ {:.3e}, {:.0} times the slowest one to follow)",
            est.fastest,
            est.ratio()
        ),
        None => "not tested for stiffness (over 64 coordinates, or no Jacobian at the initial \
                 state)"
            .into(),
    };
    // Taylor has no stiffness detection of its own: only where the test ran and found none.
    if options.dt.is_none()
        && stiffness.is_some()
        && let Some(estimate) = TaylorEstimate::new(system, options)
    {
        if estimate.ratio() < 1.0 {
            return (
                Method::Taylor,
                format!(
                    "no fixed dt, {not_stiff}, and the model is an analytic expression graph: \
                     taylor (order {}) is estimated at {:.2} times DOP853's cost at this \
                     tolerance ({}); its error follows the tolerance down to round-off",
                    estimate.order,
                    estimate.ratio(),
                    estimate.detail()
                ),
            );
        }
        taylor_note = format!(
            "; taylor (order {}) was estimated at {:.2} times its cost ({})",
            estimate.order,
            estimate.ratio(),
            estimate.detail()
        );
    }
    let why = match options.dt {
        Some(_) => format!(
            "fixed dt on a system that is forced, dissipative or time-dependent, {not_stiff}: \
             DOP853 (order 8) at that step"
        ),
        None if s.conservative() && symplectic => format!(
            "no fixed dt (adaptive steps to rtol and atol), {not_stiff}: DOP853 with error \
             control, dense output and stiffness detection (the symplectic methods, {}, need a \
             fixed dt)",
            if s.separable {
                "blanes_moan4"
            } else {
                "gauss4"
            }
        ),
        None => format!(
            "no fixed dt (adaptive steps to rtol and atol), {not_stiff}: DOP853 with error \
             control, dense output and stiffness detection"
        ),
    };
    (Method::Dop853, why + &taylor_note)
}

/// The Taylor method's cost against DOP853's at the same tolerance, from the sizes of the model's
/// programs. Fitted to `benches/taylor_choice.py` (2-core machine, release, every model there
/// at rtol = atol = 1e-6 … 1e-15, Taylor's expansions before they are compiled unrolled, so a
/// choice never counts on code it has not compiled): in nanoseconds,
///
/// - a Taylor step ≈ 250 + U/4.8 + 11 O, U the estimated instructions of the expansion to the
///   order ([`TaylorProgram::expansion_instructions`](crate::tape::TaylorProgram)), O the
///   operations of order 0;
/// - a DOP853 step ≈ 620 + 3.5 R + 100 C, R the instructions of one evaluation of the
///   accelerations, C its calls to the maths library (12 evaluations and the stages' vector
///   work per step);
/// - DOP853 takes (10⁻⁹/ε)^(1/9) times as many steps as Taylor at ε = max(rtol, atol) (the
///   tolerance atol + rtol |yᵢ| of a component of order one): Jorba and Zou's step hardly
///   shrinks with ε (the order, set by min(rtol, atol), grows instead), DOP853's like ε^(1/8).
///   Measured: 0.38–0.54 at 1e-6, 0.84–1.40 at 1e-9, 1.7–3.6 at 1e-12, 3.7–10 at 1e-15.
///
/// The fit's per-step costs were within about 45 % of the measured ones. Re-measured on
/// 2026-11-25 with the expansion's cheaper recurrences (which the instruction estimate follows):
/// within about 35 %, and the choice the faster method in 45 of the 48 pairs; the other three
/// keep DOP853 where Taylor was 1–34 % faster (Kepler at 1e-12 a tie). Re-measured on
/// 2026-11-27 (the unrolled step, folded negations and scalings, sin and cos summing their
/// argument's derivative): 44–45 of 48 in two runs, the others keeping DOP853 where Taylor was
/// 9–34 % faster (Kepler and the elastic pendulum at 1e-12 in both runs); after the work
/// spaces kept between runs and the steps taken in a row, 43 of 48, the five others keeping
/// DOP853 where Taylor was 1–35 % faster (Taylor got faster, the estimate was not refitted).
/// Refitted on 2026-11-27 after that: over the 48 pairs Taylor's measured cost ratio was 0.84
/// of the estimate's (median; geometric mean 0.86), so its step's constants were scaled by 0.84
/// (300, U/4, 13 O before). Then, with squares summing half their terms: the faster method in
/// 45 of 48, the other three a tie (the ball at 1e-6) or within the machine's ±0.4 noise (the
/// double pendulum and Hénon–Heiles at 1e-9); with the unrolled step's pairs from the
/// registers, Kepler's quotient by r² and a smaller fixed cost per call (not refitted), 46 of
/// 48, the other two a tie (the ball at 1e-6) or within the noise (Hénon–Heiles at 1e-9). Once
/// compiled unrolled (after 10⁴ expansions, which this estimate never counts on) Taylor is
/// 1.2–25× faster than DOP853 on the small models.
struct TaylorEstimate {
    order: usize,
    /// Estimated nanoseconds per step.
    taylor_step: f64,
    dop853_step: f64,
    /// DOP853's steps per Taylor step.
    steps: f64,
}

impl TaylorEstimate {
    /// The estimate for a model the Taylor method can run: stated as an expression graph
    /// without |x| or sign(x) of the state. The fit is of machine code on both sides; the
    /// interpreter (`backend="interpreter"`, or no `jit` feature) gets the same choice, so
    /// that the backend changes the speed of a run, never its result.
    fn new<S: Dynamics + ?Sized>(system: &S, options: &Options) -> Option<Self> {
        let eom = system.derived_program()?;
        let (program, _) = EomFunction::of(eom).taylor();
        if !program.is_analytic() {
            return None;
        }
        // The order follows the tighter tolerance; the steps of both methods follow the
        // tolerance of components of order one, atol + rtol, which the looser one sets.
        let order = taylor::order_for(options.rtol.min(options.atol));
        let eps = options.rtol.max(options.atol);
        let (operations, calls) = program.order0_operations();
        Some(Self {
            order,
            taylor_step: 250.0
                + program.expansion_instructions(order) as f64 / 4.8
                + 11.0 * operations as f64,
            dop853_step: 620.0
                + 3.5 * eom.acceleration_instructions() as f64
                + 100.0 * calls as f64,
            steps: (1e-9 / eps).powf(1.0 / 9.0),
        })
    }

    /// Taylor's estimated cost over DOP853's for the same span.
    fn ratio(&self) -> f64 {
        self.taylor_step / (self.steps * self.dop853_step)
    }

    fn detail(&self) -> String {
        format!(
            "a Taylor step ≈ {:.1} DOP853 steps' work, DOP853 taking ≈ {:.2} times as many \
             steps; estimates from the programs' sizes, fitted by benches/taylor_choice.py",
            self.taylor_step / self.dop853_step,
            self.steps
        )
    }
}
