//! Radau IIA of order 5 for stiff problems: three-stage collocation at the Radau points,
//! L-stable, with the AD Jacobian of the first-order system (no finite differences), after
//! Hairer & Wanner, *Solving ODEs II*, 2nd ed., §IV.8 (code `radau5.f`) in the form of SciPy's
//! `Radau` (`scipy/integrate/_ivp/radau.py`).
//!
//! On y = (q, q̇), ẏ = f(t, y) = (q̇, q̈), a step solves for the stage increments Z (3 × 2n) by
//! simplified Newton. The Radau matrix A is diagonalised once, T⁻¹A⁻¹T = diag(μ_r, α ± iβ), so
//! an iteration needs one real and one complex linear system, (μ_r/h − J) and
//! ((α − iβ)/h − J), instead of one of size 6n. J = [[0, I], [∂q̈/∂q, ∂q̈/∂q̇]] comes from
//! [`Dynamics::accelerations_into`] on dual numbers, and its structure reduces each system to
//! size n: with γ the shift, (γ − J)(x_q, x_v) = (r_q, r_v) is
//! (γ − ∂q̈/∂q̇ − ∂q̈/∂q / γ) x_v = r_v + ∂q̈/∂q r_q / γ, x_q = (r_q + x_v)/γ.
//!
//! The error estimate is the embedded order-3 one filtered by (μ_r/h − J)⁻¹ (refined with one
//! more evaluation after a rejection), the step size follows Gustafsson's predictive
//! controller, and J and the factorizations are kept across steps while the step size changes
//! by less than 20 % and Newton converges fast (Hairer's strategy). Dense output is the quintic
//! Hermite interpolant through (y, f) at both ends of the step; the cubic collocation polynomial
//! gives the starting values of the next step.
//!
//! With a fixed `dt` the steps are equal (halved on Newton failure like the other implicit
//! methods) and `rtol`/`atol` still set the Newton tolerance.

use super::dense::{Ends, Interpolant};
use super::implicit::{FixedSteps, ImplicitStep};
use super::run::{Flow, Integrator, Run, SegmentStepper};
use crate::dynamics::Dynamics;
use crate::dynamics::acceleration_jacobian;
use crate::error::{Error, Result};
use crate::nonlinear::{Convergence, Lu, same_step};
use nalgebra::{Complex, DMatrix};
use num_dual::Dual64;

type C64 = Complex<f64>;

/// Stage nodes (4 ∓ √6)/10 and 1.
const C: [f64; 3] = [0.155_051_025_721_682_2, 0.644_948_974_278_317_8, 1.0];
/// Error-estimate weights (−13 ∓ 7√6)/3 and −1/3.
const E: [f64; 3] = [-10.048_809_399_827_414, 1.382_142_733_160_748, -1.0 / 3.0];
/// The real eigenvalue of A⁻¹: 3 + 3^⅔ − 3^⅓.
const MU_REAL: f64 = 3.637_834_252_744_496;
/// The complex eigenvalue α − iβ of A⁻¹.
const MU_COMPLEX: (f64, f64) = (2.681_082_873_627_752_3, -3.050_430_199_247_411);
/// Eigenvectors of A⁻¹ (T) and their inverse (T⁻¹), from `radau.py`.
const T: [[f64; 3]; 3] = [
    [
        0.094_438_762_488_975_24,
        -0.141_255_295_020_954_2,
        0.030_029_194_105_147_42,
    ],
    [
        0.250_213_122_965_333_3,
        0.204_129_352_293_799_94,
        -0.382_942_112_757_261_9,
    ],
    [1.0, 1.0, 0.0],
];
const TI: [[f64; 3]; 3] = [
    [
        4.178_718_591_551_904,
        0.327_682_820_761_062_4,
        0.523_376_445_499_449_5,
    ],
    [
        -4.178_718_591_551_904,
        -0.327_682_820_761_062_4,
        0.476_623_554_500_550_44,
    ],
    [
        0.502_872_634_945_786_8,
        -2.571_926_949_855_605,
        0.596_039_204_828_224_9,
    ],
];
/// The collocation polynomial: y(t + θh) = y + Σₖ (Σⱼ Zⱼ Pⱼₖ) θ^{k+1}.
const P: [[f64; 3]; 3] = [
    [
        10.048_809_399_827_414,
        -25.629_591_447_076_64,
        15.580_782_047_249_224,
    ],
    [
        -1.382_142_733_160_748,
        10.296_258_113_743_303,
        -8.914_115_380_582_556,
    ],
    [1.0 / 3.0, -8.0 / 3.0, 10.0 / 3.0],
];
/// Newton iterations per attempt (Hairer's NIT) with step-size control.
const NEWTON_MAXITER: usize = 6;
/// Newton iterations per attempt with a fixed step, which cannot shrink to help convergence.
const NEWTON_MAXITER_FIXED: usize = 20;
/// Limits of the step-size factor.
const MIN_FACTOR: f64 = 0.2;
const MAX_FACTOR: f64 = 10.0;

/// Radau IIA of order 5.
pub(crate) struct Radau;

/// The root mean square of x / scale over the components in `ranges`.
fn rms(x: &[f64], scale: &[f64], ranges: &[std::ops::Range<usize>; 2]) -> f64 {
    let m = ranges.iter().map(ExactSizeIterator::len).sum::<usize>() as f64;
    (ranges
        .iter()
        .flat_map(|r| x[r.clone()].iter().zip(&scale[r.clone()]))
        .map(|(x, s)| (x / s) * (x / s))
        .sum::<f64>()
        / m)
        .sqrt()
}

/// How the Newton iteration of a step ended.
struct Newton {
    converged: bool,
    iterations: usize,
    rate: f64,
    last: f64,
    /// The quantity that was not finite and its time, when that ended the iteration.
    non_finite: Option<(&'static str, f64)>,
}

impl Newton {
    /// The failed iteration as the shared record, whose `failure` is the typed error.
    fn record(&self) -> Convergence {
        Convergence::failed(self.iterations, self.last, self.non_finite)
    }
}

struct Stepper {
    n: usize,
    rtol: f64,
    atol: f64,
    newton_tol: f64,
    max_iter: usize,
    y: Vec<f64>,
    f: Vec<f64>,
    y_new: Vec<f64>,
    f_new: Vec<f64>,
    /// Stage increments Z, transformed W = T⁻¹Z, stage derivatives F, increments ΔW.
    z: [Vec<f64>; 3],
    w: [Vec<f64>; 3],
    fz: [Vec<f64>; 3],
    dw: [Vec<f64>; 3],
    stage: Vec<f64>,
    scale: Vec<f64>,
    /// The components the error estimate reads (`Options::error_ranges`); Newton's
    /// convergence test reads every component.
    ranges: [std::ops::Range<usize>; 2],
    err: Vec<f64>,
    rhs_r: Vec<f64>,
    rhs_c: Vec<C64>,
    tmp_c: Vec<C64>,
    /// ∂q̈/∂(q, q̇) (n × 2n), whether it is at the current state, and its dual work space.
    jac: DMatrix<f64>,
    current_jac: bool,
    xd: Vec<Dual64>,
    fd: Vec<Dual64>,
    /// The two factorizations and the h they are for (NaN: none).
    lu_r: Lu<f64>,
    lu_c: Lu<C64>,
    lu_h: f64,
    /// The last accepted step's collocation polynomial (coefficients of θ, θ², θ³), its start
    /// state and length; `None` before the first step.
    poly: [Vec<f64>; 3],
    poly_y: Vec<f64>,
    poly_h: Option<f64>,
}

impl Stepper {
    fn new<S: Dynamics + ?Sized>(run: &Run<'_, S>) -> Self {
        let n = run.n;
        let m = 2 * n;
        let rtol = run.options.rtol.max(100.0 * f64::EPSILON);
        let v = || vec![0.0; m];
        let zero = Dual64::from_re(0.0);
        Self {
            n,
            rtol,
            atol: run.options.atol,
            newton_tol: (10.0 * f64::EPSILON / rtol).max(0.03_f64.min(rtol.sqrt())),
            max_iter: if run.options.dt.is_some() {
                NEWTON_MAXITER_FIXED
            } else {
                NEWTON_MAXITER
            },
            y: run.y0.clone(),
            f: v(),
            y_new: v(),
            f_new: v(),
            z: [v(), v(), v()],
            w: [v(), v(), v()],
            fz: [v(), v(), v()],
            dw: [v(), v(), v()],
            stage: v(),
            scale: v(),
            ranges: run.options.error_ranges(m),
            err: v(),
            rhs_r: v(),
            rhs_c: vec![C64::new(0.0, 0.0); m],
            tmp_c: vec![C64::new(0.0, 0.0); n],
            jac: DMatrix::zeros(n, m),
            current_jac: false,
            xd: vec![zero; m],
            fd: vec![zero; n],
            lu_r: Lu::new(n),
            lu_c: Lu::new(n),
            lu_h: f64::NAN,
            poly: [v(), v(), v()],
            poly_y: v(),
            poly_h: None,
        }
    }

    /// J at (t, y) by AD; the factorizations are then stale.
    fn jacobian<S: Dynamics + ?Sized>(&mut self, run: &mut Run<'_, S>, t: f64) -> Result<()> {
        acceleration_jacobian(
            run.system,
            t,
            &self.y,
            &mut self.xd,
            &mut self.fd,
            &mut self.jac,
        )?;
        run.stats.jacobian_evaluations += 1;
        self.current_jac = true;
        self.lu_h = f64::NAN;
        Ok(())
    }

    /// Factor γ − ∂q̈/∂q̇ − ∂q̈/∂q / γ for γ = μ_r/h and (α − iβ)/h; `false` if singular.
    fn factor<S: Dynamics + ?Sized>(&mut self, run: &mut Run<'_, S>, h: f64) -> bool {
        let n = self.n;
        let gr = MU_REAL / h;
        let gc = C64::new(MU_COMPLEX.0, MU_COMPLEX.1) / h;
        let (kr, kc) = (self.lu_r.matrix(), self.lu_c.matrix());
        for i in 0..n {
            for j in 0..n {
                let (aq, av) = (self.jac[(i, j)], self.jac[(i, n + j)]);
                let d = if i == j { 1.0 } else { 0.0 };
                kr[(i, j)] = d * gr - av - aq / gr;
                kc[(i, j)] = gc * d - av - C64::new(aq, 0.0) / gc;
            }
        }
        run.stats.factorizations += 2;
        let ok = self.lu_r.factor() && self.lu_c.factor();
        self.lu_h = if ok { h } else { f64::NAN };
        ok
    }

    /// Solve (μ_r/h − J) x = r in place (r has length 2n).
    fn solve_real(&self, h: f64, r: &mut [f64]) {
        let n = self.n;
        let g = MU_REAL / h;
        let (rq, rv) = r.split_at_mut(n);
        for i in 0..n {
            let mut s = 0.0;
            for j in 0..n {
                s += self.jac[(i, j)] * rq[j];
            }
            rv[i] += s / g;
        }
        self.lu_r.solve(rv);
        for (q, v) in rq.iter_mut().zip(rv.iter()) {
            *q = (*q + v) / g;
        }
    }

    /// Solve ((α − iβ)/h − J) x = r in place on `rhs_c` (length 2n).
    fn solve_complex(&mut self, h: f64) {
        let n = self.n;
        let g = C64::new(MU_COMPLEX.0, MU_COMPLEX.1) / h;
        let (rq, rv) = self.rhs_c.split_at_mut(n);
        for i in 0..n {
            let mut s = C64::new(0.0, 0.0);
            for j in 0..n {
                s += rq[j] * self.jac[(i, j)];
            }
            self.tmp_c[i] = s;
        }
        for (v, s) in rv.iter_mut().zip(&self.tmp_c) {
            *v += s / g;
        }
        self.lu_c.solve(rv);
        for (q, v) in rq.iter_mut().zip(rv.iter()) {
            *q = (*q + v) / g;
        }
    }

    /// Starting values Z⁰ for a step (t, t + h): the last collocation polynomial, or zero.
    fn predict(&mut self, h: f64) {
        match self.poly_h {
            Some(hp) => {
                for (j, zj) in self.z.iter_mut().enumerate() {
                    // θ measured on the previous step, which ended at the current t.
                    let theta = 1.0 + C[j] * h / hp;
                    for (i, z) in zj.iter_mut().enumerate() {
                        let mut acc = 0.0;
                        let mut pw = 1.0;
                        for k in 0..3 {
                            pw *= theta;
                            acc += self.poly[k][i] * pw;
                        }
                        *z = self.poly_y[i] + acc - self.y[i];
                    }
                }
            }
            None => {
                for zj in &mut self.z {
                    zj.fill(0.0);
                }
            }
        }
    }

    /// The simplified Newton iteration on the collocation system (`radau.py`'s
    /// `solve_collocation_system`). A stage that leaves the model's domain stops it unconverged.
    fn collocation<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
    ) -> Result<Newton> {
        let m = 2 * self.n;
        let gr = MU_REAL / h;
        let gc = C64::new(MU_COMPLEX.0, MU_COMPLEX.1) / h;
        for k in 0..3 {
            for i in 0..m {
                self.w[k][i] = (0..3).map(|j| TI[k][j] * self.z[j][i]).sum();
            }
        }
        let mut out = Newton {
            converged: false,
            iterations: 0,
            rate: f64::NAN,
            last: f64::INFINITY,
            non_finite: None,
        };
        let mut dw_norm_old: Option<f64> = None;
        for k in 0..self.max_iter {
            out.iterations = k + 1;
            for j in 0..3 {
                for i in 0..m {
                    self.stage[i] = self.y[i] + self.z[j][i];
                }
                let tj = t + C[j] * h;
                if !self.stage.iter().all(|x| x.is_finite()) {
                    out.non_finite = Some(("stage state", tj));
                    return Ok(out);
                }
                match run.rhs(tj, &self.stage, &mut self.fz[j]) {
                    Ok(()) => {}
                    Err(Error::NonFinite { what, t }) => {
                        out.non_finite = Some((what, t));
                        return Ok(out);
                    }
                    Err(e) => return Err(e),
                }
                if !self.fz[j].iter().all(|x| x.is_finite()) {
                    out.non_finite = Some(("accelerations", tj));
                    return Ok(out);
                }
            }
            for i in 0..m {
                let (f0, f1, f2) = (self.fz[0][i], self.fz[1][i], self.fz[2][i]);
                self.rhs_r[i] = TI[0][0] * f0 + TI[0][1] * f1 + TI[0][2] * f2 - gr * self.w[0][i];
                let re = TI[1][0] * f0 + TI[1][1] * f1 + TI[1][2] * f2;
                let im = TI[2][0] * f0 + TI[2][1] * f1 + TI[2][2] * f2;
                self.rhs_c[i] = C64::new(re, im) - gc * C64::new(self.w[1][i], self.w[2][i]);
            }
            let mut rhs_r = std::mem::take(&mut self.rhs_r);
            self.solve_real(h, &mut rhs_r);
            self.rhs_r = rhs_r;
            self.solve_complex(h);
            for i in 0..m {
                self.dw[0][i] = self.rhs_r[i];
                self.dw[1][i] = self.rhs_c[i].re;
                self.dw[2][i] = self.rhs_c[i].im;
            }
            let dw_norm = {
                let s: f64 = (0..3)
                    .map(|j| {
                        self.dw[j]
                            .iter()
                            .zip(&self.scale)
                            .map(|(d, s)| (d / s) * (d / s))
                            .sum::<f64>()
                    })
                    .sum();
                (s / (3 * m) as f64).sqrt()
            };
            out.last = dw_norm;
            let rate = dw_norm_old.map(|old| dw_norm / old);
            if let Some(r) = rate {
                out.rate = r;
                if r >= 1.0
                    || r.powi((self.max_iter - k) as i32) / (1.0 - r) * dw_norm > self.newton_tol
                {
                    return Ok(out);
                }
            }
            if !dw_norm.is_finite() {
                return Ok(out);
            }
            for j in 0..3 {
                for i in 0..m {
                    self.w[j][i] += self.dw[j][i];
                }
            }
            for j in 0..3 {
                for i in 0..m {
                    self.z[j][i] =
                        T[j][0] * self.w[0][i] + T[j][1] * self.w[1][i] + T[j][2] * self.w[2][i];
                }
            }
            if dw_norm == 0.0 || rate.is_some_and(|r| r / (1.0 - r) * dw_norm < self.newton_tol) {
                out.converged = true;
                return Ok(out);
            }
            dw_norm_old = Some(dw_norm);
        }
        Ok(out)
    }

    fn set_scale(&mut self) {
        for (s, y) in self.scale.iter_mut().zip(&self.y) {
            *s = self.atol + self.rtol * y.abs();
        }
    }

    /// Solve the collocation system of the step (t, t + h), refreshing J once if a stale one
    /// fails; the factorizations are built as needed. A failure followed by a retry is counted
    /// here, the final one by the caller.
    fn solve_step<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
    ) -> Result<std::result::Result<Newton, Newton>> {
        loop {
            let result = if !same_step(self.lu_h, h) && !self.factor(run, h) {
                let jacobian_finite = self.jac.iter().all(|x| x.is_finite());
                Newton {
                    converged: false,
                    iterations: 0,
                    rate: f64::NAN,
                    last: f64::INFINITY,
                    non_finite: (!jacobian_finite).then_some(("Jacobian", t)),
                }
            } else {
                self.predict(h);
                self.collocation(run, t, h)?
            };
            if result.converged {
                return Ok(Ok(result));
            }
            if self.current_jac {
                return Ok(Err(result));
            }
            run.stats.newton_failures += 1;
            self.jacobian(run, t)?;
        }
    }

    /// After an accepted step from t with length h: the collocation polynomial for the next
    /// starting values.
    fn keep_polynomial(&mut self, h: f64) {
        let m = 2 * self.n;
        for k in 0..3 {
            for i in 0..m {
                self.poly[k][i] = (0..3).map(|j| self.z[j][i] * P[j][k]).sum();
            }
        }
        self.poly_y.copy_from_slice(&self.y);
        self.poly_h = Some(h);
    }

    /// The error estimate (μ_r/h − J)⁻¹ (f + Σ Eⱼ Zⱼ / h) in the scaled RMS norm, refined with
    /// one more evaluation after a rejection.
    fn error_norm<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
        rejected: bool,
    ) -> Result<f64> {
        let m = 2 * self.n;
        for i in 0..m {
            let ze = (E[0] * self.z[0][i] + E[1] * self.z[1][i] + E[2] * self.z[2][i]) / h;
            self.err[i] = self.f[i] + ze;
            self.scale[i] = self.atol + self.rtol * self.y[i].abs().max(self.y_new[i].abs());
        }
        let mut err = std::mem::take(&mut self.err);
        self.solve_real(h, &mut err);
        let mut norm = rms(&err, &self.scale, &self.ranges);
        if rejected && norm > 1.0 {
            for i in 0..m {
                self.stage[i] = self.y[i] + err[i];
            }
            match run.rhs(t, &self.stage, &mut self.f_new) {
                Ok(()) => {
                    for i in 0..m {
                        let ze =
                            (E[0] * self.z[0][i] + E[1] * self.z[1][i] + E[2] * self.z[2][i]) / h;
                        err[i] = self.f_new[i] + ze;
                    }
                    self.solve_real(h, &mut err);
                    norm = rms(&err, &self.scale, &self.ranges);
                }
                Err(Error::NonFinite { .. }) => norm = f64::INFINITY,
                Err(e) => return Err(e),
            }
        }
        self.err = err;
        Ok(if norm.is_nan() { f64::INFINITY } else { norm })
    }

    /// Accept the step of length h to y_new = y + Z₃.
    fn accept(&mut self, h: f64) {
        self.keep_polynomial(h);
        std::mem::swap(&mut self.y, &mut self.y_new);
    }

    fn new_state(&mut self) {
        for i in 0..2 * self.n {
            self.y_new[i] = self.y[i] + self.z[2][i];
        }
    }

    /// Scipy's `select_initial_step` for the order-3 error estimate.
    fn initial_step<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        span: f64,
    ) -> Result<f64> {
        let m = 2 * self.n;
        self.set_scale();
        let d0 = rms(&self.y, &self.scale, &self.ranges);
        let d1 = rms(&self.f, &self.scale, &self.ranges);
        let h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        }
        .min(span);
        let dir = run.dir();
        for i in 0..m {
            self.stage[i] = self.y[i] + dir * h0 * self.f[i];
        }
        run.rhs(run.t0 + dir * h0, &self.stage, &mut self.f_new)?;
        for i in 0..m {
            self.err[i] = self.f_new[i] - self.f[i];
        }
        let d2 = rms(&self.err, &self.scale, &self.ranges) / h0;
        let h1 = if d1 <= 1e-15 && d2 <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / d1.max(d2)).powf(0.25)
        };
        Ok((100.0 * h0).min(h1).min(span))
    }

    /// Gustafsson's predictive step-size factor (Hairer & Wanner §IV.8, eq. 8.25).
    fn predict_factor(h: f64, h_old: Option<f64>, err: f64, err_old: Option<f64>) -> f64 {
        let multiplier = match (h_old, err_old) {
            (Some(ho), Some(eo)) if err != 0.0 => h / ho * (eo / err).powf(0.25),
            _ => 1.0,
        };
        multiplier.min(1.0) * err.powf(-0.25)
    }

    /// The step-size control of a run starting at `run.t0` (f there already evaluated): the
    /// largest and the first step, and the Jacobian at the start.
    fn control<S: Dynamics + ?Sized>(&mut self, run: &mut Run<'_, S>) -> Result<Control> {
        let opts = run.options;
        let span = (run.t_end - run.t0).abs();
        let h_max = opts.max_step.unwrap_or(span).min(span);
        let h_abs = match opts.initial_step {
            Some(h0) => h0.min(h_max),
            None => self.initial_step(run, span)?.min(h_max),
        };
        self.jacobian(run, run.t0)?;
        Ok(Control {
            t: run.t0,
            h_abs,
            h_abs_old: None,
            err_old: None,
            h_max,
        })
    }

    /// One accepted step of error-controlled size from `control.t`, rejected trials retried.
    fn adaptive_step<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        control: &mut Control,
    ) -> Result<Flow> {
        let opts = run.options;
        let dir = run.dir();
        let Control {
            t,
            mut h_abs,
            mut h_abs_old,
            mut err_old,
            h_max,
        } = *control;
        let n = self.n;
        {
            let floor = opts.min_step.max(10.0 * f64::EPSILON * t.abs());
            if h_abs > h_max {
                h_abs = h_max;
                h_abs_old = None;
                err_old = None;
            }
            let mut rejected = false;
            // Why the step shrank last: a Newton failure, or an end point where the model is
            // not finite, is reported as such at the floor.
            let mut newton_failure: Option<Newton> = None;
            let mut non_finite: Option<Error> = None;
            let (t_new, h, result, err) = loop {
                let attempts = run.stats.accepted_steps + run.stats.rejected_steps;
                if attempts >= opts.max_steps {
                    return Err(Error::TooManySteps {
                        t,
                        steps: attempts,
                        needed: None,
                    });
                }
                if h_abs < floor {
                    return Err(match (newton_failure, non_finite) {
                        (Some(nf), _) => nf.record().failure(t),
                        (None, Some(e)) => e,
                        (None, None) => Error::StepSizeTooSmall { t, h: h_abs },
                    });
                }
                let mut t_new = t + dir * h_abs;
                if (t_new - run.t_end) * dir >= 0.0 {
                    t_new = run.t_end;
                }
                let h = t_new - t;
                h_abs = h.abs();
                self.set_scale();
                match self.solve_step(run, t, h)? {
                    Err(nf) => {
                        run.stats.newton_failures += 1;
                        run.stats.rejected_steps += 1;
                        newton_failure = Some(nf);
                        non_finite = None;
                        h_abs *= 0.5;
                        self.lu_h = f64::NAN;
                        continue;
                    }
                    Ok(result) => {
                        self.new_state();
                        let err = self.error_norm(run, t, h, rejected)?;
                        if err > 1.0 {
                            let safety = 0.9 * (2 * NEWTON_MAXITER + 1) as f64
                                / (2 * NEWTON_MAXITER + result.iterations) as f64;
                            let factor = Self::predict_factor(h_abs, h_abs_old, err, err_old);
                            h_abs *= MIN_FACTOR.max(safety * factor);
                            self.lu_h = f64::NAN;
                            rejected = true;
                            newton_failure = None;
                            non_finite = None;
                            run.stats.rejected_steps += 1;
                            continue;
                        }
                        // No drift: the end back onto a constrained system's constraints,
                        // before its derivative is taken.
                        run.project(t_new, &mut self.y_new)?;
                        match run.rhs(t_new, &self.y_new, &mut self.f_new) {
                            Ok(()) => {}
                            Err(e @ Error::NonFinite { .. }) => {
                                // The end point left the model's domain: back off.
                                newton_failure = None;
                                non_finite = Some(e);
                                h_abs *= 0.5;
                                self.lu_h = f64::NAN;
                                rejected = true;
                                run.stats.rejected_steps += 1;
                                continue;
                            }
                            Err(e) => return Err(e),
                        }
                        break (t_new, h, result, err);
                    }
                }
            };
            let safety = 0.9 * (2 * NEWTON_MAXITER + 1) as f64
                / (2 * NEWTON_MAXITER + result.iterations) as f64;
            let recompute_jac = result.iterations > 2 && result.rate > 1e-3;
            let mut factor =
                (safety * Self::predict_factor(h_abs, h_abs_old, err, err_old)).min(MAX_FACTOR);
            if !recompute_jac && factor < 1.2 {
                factor = 1.0;
            } else {
                self.lu_h = f64::NAN;
            }
            run.stats.accepted_steps += 1;
            let last = t_new == run.t_end;
            let step = run.needs_interpolant(t_new).then(|| Interpolant::Hermite {
                t,
                h,
                ends: Ends {
                    q0: &self.y[..n],
                    v0: &self.y[n..],
                    a0: &self.f[n..],
                    q1: &self.y_new[..n],
                    v1: &self.y_new[n..],
                    a1: &self.f_new[n..],
                },
            });
            let flow = run.accept(t, t_new, &self.y_new, last, step.as_ref())?;
            self.accept(h);
            std::mem::swap(&mut self.f, &mut self.f_new);
            if flow != Flow::Continue {
                return Ok(flow);
            }
            if recompute_jac {
                self.jacobian(run, t_new)?;
            } else {
                self.current_jac = false;
            }
            *control = Control {
                t: t_new,
                h_abs: h_abs * factor,
                h_abs_old: Some(h_abs),
                err_old: Some(err),
                h_max,
            };
            Ok(Flow::Continue)
        }
    }
}

/// The state of Radau's step-size control between accepted steps.
#[derive(Debug, Clone, Copy)]
struct Control {
    /// Time of the current state.
    t: f64,
    /// Next trial step size, and the last accepted one.
    h_abs: f64,
    h_abs_old: Option<f64>,
    /// The last accepted step's error norm.
    err_old: Option<f64>,
    h_max: f64,
}

/// Where an adaptive Radau run stands between steps.
struct Adaptive {
    stepper: Stepper,
    control: Control,
}

impl<S: Dynamics + ?Sized> SegmentStepper<S> for Adaptive {
    fn step(&mut self, run: &mut Run<'_, S>) -> Result<Flow> {
        self.stepper.adaptive_step(run, &mut self.control)
    }
}

impl<S: Dynamics + ?Sized> ImplicitStep<S> for Stepper {
    fn attempt(&mut self, run: &mut Run<'_, S>, t: f64, h: f64) -> Result<Option<Convergence>> {
        self.set_scale();
        match self.solve_step(run, t, h)? {
            Err(nf) => {
                self.lu_h = f64::NAN;
                Ok(Some(nf.record()))
            }
            Ok(result) => {
                self.new_state();
                if !self.y_new.iter().all(|x| x.is_finite()) {
                    return Err(Error::NonFinite {
                        what: "state",
                        t: t + h,
                    });
                }
                self.accept(h);
                if result.iterations > 2 && result.rate > 1e-3 {
                    self.jacobian(run, t + h)?;
                } else {
                    self.current_jac = false;
                }
                Ok(None)
            }
        }
    }

    fn state(&self) -> &[f64] {
        &self.y
    }
}

impl Integrator for Radau {
    fn order(&self) -> usize {
        5
    }

    fn adaptive(&self) -> bool {
        true
    }

    fn explicit(&self) -> bool {
        false
    }

    fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Result<Box<dyn SegmentStepper<S>>> {
        let mut stepper = Stepper::new(run);
        match run.options.dt {
            Some(dt) => {
                stepper.jacobian(run, run.t0)?;
                Ok(Box::new(FixedSteps::new(run, stepper, dt)?))
            }
            None => {
                let (t0, y0) = (run.t0, run.y0.clone());
                run.rhs(t0, &y0, &mut stepper.f)?;
                let control = stepper.control(run)?;
                Ok(Box::new(Adaptive { stepper, control }))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The Radau IIA matrix (Hairer & Wanner, Table IV.5.6).
    fn radau_a() -> [[f64; 3]; 3] {
        let s6 = 6f64.sqrt();
        [
            [
                (88.0 - 7.0 * s6) / 360.0,
                (296.0 - 169.0 * s6) / 1800.0,
                (-2.0 + 3.0 * s6) / 225.0,
            ],
            [
                (296.0 + 169.0 * s6) / 1800.0,
                (88.0 + 7.0 * s6) / 360.0,
                (-2.0 - 3.0 * s6) / 225.0,
            ],
            [(16.0 - s6) / 36.0, (16.0 + s6) / 36.0, 1.0 / 9.0],
        ]
    }

    fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let mut c = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        c
    }

    /// T⁻¹ is the inverse of T, and T⁻¹ A T = diag(1/μ_r, block of 1/(α ± iβ)): the constants
    /// diagonalise the tableau they are used with.
    #[test]
    fn radau_transformation_diagonalises_a() {
        let id = mul(&T, &TI);
        for i in 0..3 {
            for j in 0..3 {
                assert_relative_eq!(id[i][j], if i == j { 1.0 } else { 0.0 }, epsilon = 1e-15);
            }
        }
        let a = radau_a();
        // Row sums of A are the nodes.
        for i in 0..3 {
            assert_relative_eq!(a[i].iter().sum::<f64>(), C[i], epsilon = 1e-15);
        }
        let d = mul(&TI, &mul(&a, &T));
        assert_relative_eq!(d[0][0], 1.0 / MU_REAL, epsilon = 1e-14);
        for (i, j) in [(0, 1), (0, 2), (1, 0), (2, 0)] {
            assert!(d[i][j].abs() < 1e-14);
        }
        // The 2 × 2 block [[α', β'], [−β', α']] represents 1/(α − iβ).
        let inv = C64::new(1.0, 0.0) / C64::new(MU_COMPLEX.0, MU_COMPLEX.1);
        assert_relative_eq!(d[1][1], inv.re, epsilon = 1e-14);
        assert_relative_eq!(d[2][2], inv.re, epsilon = 1e-14);
        assert_relative_eq!(d[1][2].abs(), inv.im.abs(), epsilon = 1e-14);
        assert_relative_eq!(d[1][2], -d[2][1], epsilon = 1e-14);
    }

    /// The collocation polynomial Σₖ (Σⱼ Zⱼ Pⱼₖ) θ^{k+1} passes through the stage increments:
    /// it returns Zⱼ at θ = cⱼ.
    #[test]
    fn radau_polynomial_interpolates_stages() {
        for z in [[0.3, -1.2, 2.5], [1.0, 0.0, 0.0]] {
            for j in 0..3 {
                let mut acc = 0.0;
                for k in 0..3 {
                    let pk: f64 = (0..3).map(|i| z[i] * P[i][k]).sum();
                    acc += pk * C[j].powi(k as i32 + 1);
                }
                assert_relative_eq!(acc, z[j], epsilon = 1e-13);
            }
        }
    }
}
