//! The stability limit of a fixed step: the linear stability check of fixed-step explicit
//! methods.
//!
//! An explicit method at a fixed `dt` is stable only while every mode λ of the linearised
//! equations has dt·λ inside its stability region; beyond that the numbers grow geometrically and
//! the answer is garbage long before it overflows — the silent wrong answer of a stiff spring
//! under Störmer–Verlet or RK4. Before such a run the modes at the initial state (eigenvalues of
//! the AD Jacobian of (q̇, q̈)) are checked against the method itself: one step of the method on
//! the damped oscillator ẍ + c ẋ + k x = 0 whose characteristic roots are λ and λ̄ gives the
//! one-step propagator, whose spectral radius must not exceed 1. Testing the method rather than a
//! table of stability intervals keeps the check true for every method of the registry.

use super::method::Method;
use super::options::{Options, Output};
use super::run::{Flow, Run};
use super::stiffness;
use crate::dynamics::{Dynamics, Structure};
use crate::error::{Error, Result};
use crate::scalar::Scalar;
use nalgebra::Complex;

/// Amplification per step above this counts as unstable (round-off in the propagator of a
/// critically damped test mode is ~1e-8).
const GROWTH_TOLERANCE: f64 = 1e-6;

/// `Err(Error::UnstableStep)` when `dt` is beyond `method`'s stability limit for a decaying or
/// oscillating mode of the system linearised at (t₀, q₀, q̇₀). Growing modes (a pendulum above
/// its pivot) are physical and not checked; nor are systems too large for the eigenvalue test.
pub(super) fn check<S: Dynamics + ?Sized>(
    system: &S,
    t0: f64,
    q0: &[f64],
    qd0: &[f64],
    dt: f64,
    method: Method,
) -> Result<()> {
    let Some(modes) = stiffness::jacobian_spectrum(system, t0, q0, qd0) else {
        return Ok(());
    };
    let mut worst: Option<(Complex<f64>, f64)> = None;
    for lambda in modes {
        if lambda.im < 0.0 || lambda.norm() == 0.0 || lambda.re > 1e-9 * lambda.norm() {
            continue;
        }
        if let Some(rho) = amplification(method, dt, lambda)
            && rho > 1.0 + GROWTH_TOLERANCE
            && worst.is_none_or(|(w, _)| lambda.norm() > w.norm())
        {
            worst = Some((lambda, rho));
        }
    }
    let Some((lambda, growth)) = worst else {
        return Ok(());
    };
    // Bisect the largest stable step for that mode (for the message).
    let (mut lo, mut hi) = (0.0, dt);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        match amplification(method, mid, lambda) {
            Some(rho) if rho <= 1.0 + GROWTH_TOLERANCE => lo = mid,
            _ => hi = mid,
        }
    }
    Err(Error::UnstableStep {
        method: method.name(),
        dt,
        t: t0,
        mode: lambda.norm(),
        growth,
        limit: lo,
    })
}

/// The spectral radius of one step of `method` at `dt` on the test oscillator with roots λ, λ̄
/// (a critically damped one, double root λ, for a real λ); `None` when the method cannot run it
/// (a splitting method on a damped test mode).
fn amplification(method: Method, dt: f64, lambda: Complex<f64>) -> Option<f64> {
    let (k, c) = if lambda.im > 0.0 {
        (lambda.norm_sqr(), -2.0 * lambda.re)
    } else {
        (lambda.re * lambda.re, -2.0 * lambda.re)
    };
    let test = TestMode { k, c };
    let options = Options::fixed(dt).with_output(Output::Every(usize::MAX));
    method.check_fits(&test, 0.0, &[1.0], &[0.0]).ok()?;
    options.check_method(method).ok()?;
    let mut columns = [[0.0; 2]; 2];
    for (column, (x0, v0)) in columns.iter_mut().zip([(1.0, 0.0), (0.0, 1.0)]) {
        // One step of the method, as the solver takes it (without this check).
        let mut run = Run::new(
            &test,
            &[x0],
            &[v0],
            (0.0, dt),
            method,
            None,
            &options,
            None,
            &[],
        )
        .ok()?;
        run.batched = true;
        let mut stepper = method.start(&mut run)?.ok()?;
        loop {
            match stepper.step(&mut run).ok()? {
                Flow::Continue => {}
                Flow::End => break,
                Flow::Stop => return None,
            }
        }
        let (_, y) = run.out.last();
        *column = [y[0], y[1]];
    }
    // Eigenvalues of the 2×2 propagator [[a, b], [c, d]] (columns = images of the unit states).
    let (a, b, c, d) = (columns[0][0], columns[1][0], columns[0][1], columns[1][1]);
    let half_trace = 0.5 * (a + d);
    let disc = half_trace * half_trace - (a * d - b * c);
    let rho = if disc >= 0.0 {
        half_trace.abs() + disc.sqrt()
    } else {
        (a * d - b * c).abs().sqrt()
    };
    rho.is_finite().then_some(rho)
}

/// The test oscillator ẍ + c ẋ + k x = 0 in closed form: T = ½ ẋ², U = ½ k x², Φ = ½ c ẋ².
/// With c = 0 it is separable and undamped, so the splitting methods accept it.
#[derive(Clone, Copy)]
struct TestMode {
    k: f64,
    c: f64,
}

impl Dynamics for TestMode {
    fn dof(&self) -> usize {
        1
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: 1,
            time_dependent: false,
            constant_mass: true,
            separable: true,
            dissipative: self.c != 0.0,
            forced: false,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, _q: &[D], v: &[D]) -> D {
        v[0] * v[0] * 0.5
    }
    fn potential_energy<D: Scalar>(&self, _t: D, x: &[D]) -> D {
        x[0] * x[0] * (0.5 * self.k)
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, x: &[D], out: &mut [D]) {
        out[0] = x[0] * self.k;
    }
    fn generalized_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _v: &[D], out: &mut [D]) {
        out[0] = D::zero();
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], v: &[D], out: &mut [D]) {
        out[0] = -v[0] * self.c;
    }
    fn momenta_into<D: Scalar>(&self, _t: D, _q: &[D], v: &[D], out: &mut [D]) {
        out[0] = v[0];
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, _q: &[D], _v: &[D], out: &mut [D]) {
        out[0] = D::one();
    }
    fn accelerations_into<D: Scalar>(&self, _t: D, x: &[D], v: &[D], out: &mut [D]) -> Result<()> {
        out[0] = -(x[0] * self.k + v[0] * self.c);
        Ok(())
    }
}
