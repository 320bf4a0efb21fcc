//! [`EnergyModel`]: a model stated at run time by its energies, with the accelerations from the
//! eq. 55 program derived on its expression graph when it has one
//! ([`EnergyModel::with_program`]), otherwise from one fused derivative pass of T.

use crate::checks::check_lengths;
use crate::derived::eom_program::EomFunction;
use crate::dynamics::Dynamics;
use crate::energies::KineticEnergy;
use crate::eom::Forces;
use crate::error::{Error, Result};
use crate::program::compile::Input;
use crate::program::eval::Function;
use crate::program::jet::{Chain, Jet, Lagrange};
use crate::routes::System;
use crate::scalar::Scalar;

/// The [`System`] of tape functions an [`EnergyModel`] wraps.
pub type TapeSystem = System<Function, Option<Function>, Option<Function>, Option<Function>>;

/// Largest number of coordinates the fused pass handles (larger models use [`System`]'s passes).
const FUSED_MAX: usize = 4;

/// A model stated by its energies as tapes: T, and optionally U, Rayleigh's Φ and Q″.
///
/// It is the [`System`] of those [`Function`]s — every derivative pass and every integrator
/// works on it unchanged — except for the accelerations, the integrators' hot path:
/// - with the eq. 55 program derived from the expression graph ([`EnergyModel::with_program`],
///   what the Python module builds), at `f64` states one run of that program (machine code
///   where Cranelift serves the host; for up to 16 coordinates with the solve unrolled in
///   it, otherwise M and the force vector then the LDLᵀ tail), and over dual numbers (the
///   integrators' Jacobians) the same program interpreted over them;
/// - otherwise, for up to four coordinates whose T depends on q or t, one pass of T over a jet
///   that carries M, the mixed terms (∂²T/∂q̇∂q) q̇ + ∂²T/∂q̇∂t and ∂T/∂q together, instead of a
///   gradient pass and a hyper-dual pass (an interpreted tape pays per instruction).
#[derive(Debug, Clone)]
pub struct EnergyModel {
    system: TapeSystem,
    fused: bool,
    program: Option<EomFunction>,
}

impl EnergyModel {
    /// A model of `dof` coordinates.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when a tape is not made for `dof` coordinates, the kinetic
    /// energy, potential or dissipation has not exactly one output, the potential reads
    /// velocities, or the forces have not one output per coordinate.
    pub fn new(
        dof: usize,
        kinetic: Function,
        potential: Option<Function>,
        dissipation: Option<Function>,
        forces: Option<Function>,
    ) -> Result<Self> {
        let bad = |why: String| Err(Error::InvalidInput { what: "model", why });
        if dof == 0 {
            return bad("a model needs at least one coordinate".into());
        }
        let parts = [
            ("kinetic energy", Some(&kinetic), 1),
            ("potential", potential.as_ref(), 1),
            ("dissipation function", dissipation.as_ref(), 1),
            ("generalized forces", forces.as_ref(), dof),
        ];
        for (what, f, outputs) in parts {
            let Some(f) = f else { continue };
            let tape = f.tape();
            if tape.inputs().dof != dof {
                return bad(format!(
                    "the {what} is made for {} coordinates, the model has {dof}",
                    tape.inputs().dof
                ));
            }
            if tape.outputs() != outputs {
                return bad(format!(
                    "the {what} has {} outputs, expected {outputs}",
                    tape.outputs()
                ));
            }
        }
        if potential
            .as_ref()
            .is_some_and(|u| u.tape().depends_on_velocity())
        {
            return bad("the potential may not depend on the velocities".into());
        }
        let fused = dof <= FUSED_MAX
            && (kinetic.depends_on_position()
                || KineticEnergy::depends_on_time(&kinetic)
                || !kinetic.constant_mass_matrix());
        let system = System::new(dof, kinetic)
            .with_potential(potential)
            .with_dissipation(dissipation)
            .with_forces(forces);
        Ok(Self {
            system,
            fused,
            program: None,
        })
    }

    /// The model with its accelerations at `f64` states from `program`: eq. 55 derived on the
    /// expression graph of the same energies ([`EomProgram`](crate::tape::EomProgram)), bound to the
    /// same parameter values.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the program is made for another number of coordinates.
    pub fn with_program(self, program: EomFunction) -> Result<Self> {
        if program.program().dof() != self.dof() {
            return Err(Error::InvalidInput {
                what: "model",
                why: format!(
                    "the equations of motion are derived for {} coordinates, the model has {}",
                    program.program().dof(),
                    self.dof()
                ),
            });
        }
        Ok(Self {
            program: Some(program),
            ..self
        })
    }

    /// Whether the accelerations take the fused pass of T (a test hook: the tests check that a
    /// model small enough takes it).
    #[doc(hidden)]
    pub fn is_fused(&self) -> bool {
        self.fused
    }

    /// The derived eq. 55 program, if the model has one.
    pub fn program(&self) -> Option<&EomFunction> {
        self.program.as_ref()
    }

    /// The [`System`] this model is.
    pub fn system(&self) -> &TapeSystem {
        &self.system
    }

    /// The same model with other parameter values (only the tapes' constants are recomputed).
    ///
    /// # Errors
    /// As [`Function::with_parameters`].
    pub fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        let s = &self.system;
        let rebind =
            |f: &Option<Function>| f.as_ref().map(|f| f.with_parameters(params)).transpose();
        let model = Self::new(
            s.dof(),
            s.kinetic.with_parameters(params)?,
            rebind(&s.potential)?,
            rebind(&s.dissipation)?,
            rebind(&s.forces)?,
        )?;
        match &self.program {
            Some(p) => model.with_program(p.with_parameters(params)?),
            None => Ok(model),
        }
    }

    /// Eq. 55 at an `f64` state with one pass of T (see the type's documentation); the rest of
    /// the right-hand side and the LDLᵀ tail are [`crate::eom`]'s, as for every route. U is not folded
    /// into the pass of T as [`System`] does for one or two coordinates: T and U are separate
    /// tapes, so L = T − U would be a second run over the heavier jet, while U's own gradient
    /// pass runs over a first-order one.
    fn fused<const N: usize, const N1: usize>(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        let s = &self.system;
        let parts = Forces::new(&s.potential, &s.dissipation, &s.forces);
        parts.accelerations::<N, f64>(
            t,
            q,
            qd,
            out,
            #[inline(always)]
            |m, rhs| {
                // T: first directions q̇, second directions (q̇, motion), first-order directions q.
                let k = &s.kinetic;
                let seed = |i: Input| {
                    let mut x = Lagrange::<N, N1>::cst(0.0);
                    match i {
                        Input::Time => {
                            x.s.re = t;
                            x.s.e2[N] = 1.0;
                        }
                        Input::Coord(j) => {
                            x.s.re = q[j];
                            x.s.e2[N] = qd[j];
                            x.g[j] = 1.0;
                        }
                        Input::Velocity(j) => {
                            x.s.re = qd[j];
                            x.s.e1[j] = 1.0;
                            x.s.e2[j] = 1.0;
                        }
                    }
                    Jet(x)
                };
                k.tape.run(&k.consts, seed, |_, v: Jet<Lagrange<N, N1>>| {
                    let v = v.0;
                    for i in 0..N {
                        rhs[i] += v.g[i] - v.s.e12[i][N];
                        for j in 0..N {
                            m[i * N + j] = v.s.e12[i][j];
                        }
                    }
                });
                false
            },
        )
    }
}

impl Dynamics for EnergyModel {
    crate::dynamics::forward_dynamics!(system: dof, structure, kinetic_energy, potential_energy,
        potential_gradient_into, generalized_forces_into, dissipative_forces_into,
        mass_matrix_into, lagrangian);
    #[inline]
    fn momenta_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        if let Some(program) = &self.program
            && crate::scalar::is::<D, f64>()
        {
            // SAFETY: D is f64 (same TypeId), so these are identity casts.
            let (t, q, qd, out) = unsafe {
                (
                    *crate::scalar::cast::<D, f64>(&t),
                    crate::scalar::cast_slice::<D, f64>(q),
                    crate::scalar::cast_slice::<D, f64>(qd),
                    &mut *(out as *mut [D] as *mut [f64]),
                )
            };
            return program.momenta(t, q, qd, out);
        }
        self.system.momenta_into(t, q, qd, out)
    }
    #[inline]
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        if (self.program.is_some() || self.fused) && crate::scalar::is::<D, f64>() {
            // SAFETY: D is f64 (same TypeId), so these are identity casts.
            let (t, q, qd) = unsafe {
                (
                    *crate::scalar::cast::<D, f64>(&t),
                    crate::scalar::cast_slice::<D, f64>(q),
                    crate::scalar::cast_slice::<D, f64>(qd),
                )
            };
            let out = unsafe { &mut *(out as *mut [D] as *mut [f64]) };
            if let Some(program) = &self.program {
                return program.accelerations(t, q, qd, out);
            }
            check_lengths(self.dof(), q, qd, out)?;
            return match self.dof() {
                1 => self.fused::<1, 2>(t, q, qd, out),
                2 => self.fused::<2, 3>(t, q, qd, out),
                3 => self.fused::<3, 4>(t, q, qd, out),
                _ => self.fused::<4, 5>(t, q, qd, out),
            };
        }
        match &self.program {
            Some(program) => program.accelerations_dual(t, q, qd, out),
            None => self.system.accelerations_into(t, q, qd, out),
        }
    }
    fn derived_program(&self) -> Option<&dyn crate::dynamics::DerivedProgram> {
        self.program.as_ref().map(|p| p as _)
    }
    fn energy(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<f64> {
        let Some(program) = &self.program else {
            return crate::dynamics::energy_from_parts(self, t, q, qd);
        };
        crate::checks::check_state(self.dof(), t, q, Some(qd))?;
        let h = program.energy(t, q, qd);
        crate::checks::finite(&[h], "energy", t).map(|()| h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::derived::eom_program::{Energies, EomProgram};
    use crate::expr::graph::{Binary, Graph, Unary};
    use crate::program::compile::Tape;
    use crate::program::inputs::Inputs;
    use crate::routes::ParticleSystem;
    use crate::routes::TapeParticles;
    use approx::assert_relative_eq;
    use std::sync::Arc;

    /// A little expression builder over a [`Graph`] for the tests.
    struct B(Graph);
    impl B {
        fn c(&mut self, x: f64) -> usize {
            self.0.constant(x)
        }
        fn bin(&mut self, f: Binary, a: usize, b: usize) -> usize {
            self.0.binary(f, a, b).unwrap()
        }
        fn un(&mut self, f: Unary, a: usize) -> usize {
            self.0.unary(f, a).unwrap()
        }
        fn mul(&mut self, a: usize, b: usize) -> usize {
            self.bin(Binary::Mul, a, b)
        }
        fn add(&mut self, a: usize, b: usize) -> usize {
            self.bin(Binary::Add, a, b)
        }
        fn sqr(&mut self, a: usize) -> usize {
            self.0.powi(a, 2).unwrap()
        }
        fn sum(&mut self, terms: &[usize]) -> usize {
            terms[1..].iter().fold(terms[0], |s, &x| self.add(s, x))
        }
        fn prod(&mut self, factors: &[usize]) -> usize {
            factors[1..].iter().fold(factors[0], |p, &x| self.mul(p, x))
        }
        fn function(&self, root: usize, inputs: Inputs, params: &[f64]) -> Function {
            self.outputs(&[root], inputs, params)
        }
        fn outputs(&self, roots: &[usize], inputs: Inputs, params: &[f64]) -> Function {
            let tape = Tape::new(&self.0, roots, inputs, "test").unwrap();
            Function::new(Arc::new(tape), params).unwrap()
        }
    }

    #[test]
    fn energy_model_rejects_mismatched_parts() {
        let mut b = B(Graph::new());
        let v = b.0.velocity(0);
        let t2 = b.sqr(v);
        let k = b.function(t2, Inputs::kinetic(1, 0), &[]);
        let k2 = b.function(t2, Inputs::kinetic(2, 0), &[]);
        assert!(EnergyModel::new(2, k.clone(), None, None, None).is_err());
        assert!(EnergyModel::new(0, k.clone(), None, None, None).is_err());
        // A velocity in the potential.
        assert!(EnergyModel::new(1, k.clone(), Some(k.clone()), None, None).is_err());
        // One force for two coordinates.
        assert!(EnergyModel::new(2, k2.clone(), None, None, Some(k2)).is_err());
    }

    /// A particle of mass m at r = (x + A sin ωt, y + b x²) in gravity g (T depends on t and q,
    /// M on q), a spring U = ½ k (x² + y²) + κ x y, Φ = ½ c (ẋ² + ẏ²) + ½ c₂ x² ẏ², and
    /// Q″ = (F cos νt, −d y ẋ): every term of eq. 55. As a model stated by its energies (T
    /// written out, U with gravity), the same with eq. 55 derived on its graph
    /// ([`EnergyModel::with_program`]), and as particles (the positions, gravity, and the same
    /// spring, Φ and Q″).
    fn every_term() -> (
        EnergyModel,
        EnergyModel,
        ParticleSystem<TapeParticles, Function, Function, Function>,
    ) {
        let [m, a, w, bq, g, k, kappa, c, c2, f, nu, d] = [
            1.3, 0.4, 1.7, 0.6, 9.81, 2.5, 0.3, 0.35, 0.2, 0.8, 1.1, 0.45,
        ];
        let mut b = B(Graph::new());
        let (x, y, vx, vy, t) = (
            b.0.coord(0),
            b.0.coord(1),
            b.0.velocity(0),
            b.0.velocity(1),
            b.0.time(),
        );
        let cs: Vec<usize> = [a, w, bq, 2.0 * bq, 0.5 * m, m * g, 0.5 * k, kappa]
            .into_iter()
            .chain([0.5 * c, 0.5 * c2, f, nu, -d])
            .map(|v| b.c(v))
            .collect();
        let [
            ca,
            cw,
            cb,
            c2b,
            chm,
            cmg,
            chk,
            ckap,
            chc,
            chc2,
            cf,
            cnu,
            cmd,
        ] = cs[..]
        else {
            unreachable!()
        };
        let wt = b.prod(&[cw, t]);
        let (swt, cwt) = (b.un(Unary::Sin, wt), b.un(Unary::Cos, wt));
        let (x2, y2, vx2, vy2) = (b.sqr(x), b.sqr(y), b.sqr(vx), b.sqr(vy));
        // r = (x + A sin ωt, y + b x²) and ṙ = (ẋ + A ω cos ωt, ẏ + 2 b x ẋ).
        let moved = [b.prod(&[ca, swt]), b.prod(&[cb, x2])];
        let (rx, ry) = (b.sum(&[x, moved[0]]), b.sum(&[y, moved[1]]));
        let moving = [b.prod(&[ca, cw, cwt]), b.prod(&[c2b, x, vx])];
        let (vrx, vry) = (b.sum(&[vx, moving[0]]), b.sum(&[vy, moving[1]]));
        let speed2 = [b.sqr(vrx), b.sqr(vry)];
        let v2 = b.sum(&speed2);
        let kinetic = b.prod(&[chm, v2]);
        // The spring, and U = m g r_y + spring.
        let parts = [
            b.prod(&[chk, x2]),
            b.prod(&[chk, y2]),
            b.prod(&[ckap, x, y]),
        ];
        let spring = b.sum(&parts);
        let weight = b.prod(&[cmg, ry]);
        let potential = b.sum(&[weight, spring]);
        // Φ and Q″.
        let parts = [
            b.prod(&[chc, vx2]),
            b.prod(&[chc, vy2]),
            b.prod(&[chc2, x2, vy2]),
        ];
        let dissipation = b.sum(&parts);
        let nut = b.prod(&[cnu, t]);
        let cnt = b.un(Unary::Cos, nut);
        let (q0, q1) = (b.prod(&[cf, cnt]), b.prod(&[cmd, y, vx]));
        let (ki, po) = (Inputs::kinetic(2, 0), Inputs::potential(2, 0));
        let (phi, forces) = (
            b.function(dissipation, ki, &[]),
            b.outputs(&[q0, q1], ki, &[]),
        );
        let model = EnergyModel::new(
            2,
            b.function(kinetic, ki, &[]),
            Some(b.function(potential, po, &[])),
            Some(phi.clone()),
            Some(forces.clone()),
        )
        .unwrap();
        let energies = Energies {
            kinetic,
            potential: Some(potential),
            dissipation: Some(dissipation),
            forces: Some(vec![q0, q1]),
        };
        let program = EomProgram::new(&mut b.0, 2, 0, &energies).unwrap();
        let derived = model
            .clone()
            .with_program(program.bind(&[]).unwrap())
            .unwrap();
        let positions = TapeParticles::new(2, 2, b.outputs(&[rx, ry], po, &[]), vec![m]).unwrap();
        let particles = ParticleSystem::new(positions)
            .with_gravity([0.0, -g, 0.0])
            .with_potential(b.function(spring, po, &[]))
            .with_dissipation(phi)
            .with_forces(forces);
        (model, derived, particles)
    }

    /// q̈ from the (q, p) form: ṗ = G with ṗ = ∂p/∂t + (∂p/∂q) q̇ + M q̈, so
    /// q̈ = M⁻¹ (G − ∂p/∂t − (∂p/∂q) q̇), the derivative of p along (1, q̇, 0) by one dual pass.
    fn qp_accelerations<S: Dynamics>(system: &S, t: f64, q: &[f64], qd: &[f64]) -> Vec<f64> {
        use num_dual::Dual64;
        let n = q.len();
        let (mut g, mut tmp) = (vec![0.0; n], vec![0.0; n]);
        crate::dynamics::ForceParts::of(system).force_into(system, t, q, qd, &mut g, &mut tmp);
        let td = Dual64::new(t, 1.0);
        let qdual: Vec<Dual64> = q.iter().zip(qd).map(|(&x, &v)| Dual64::new(x, v)).collect();
        let vdual: Vec<Dual64> = qd.iter().map(|&v| Dual64::from_re(v)).collect();
        let mut p = vec![Dual64::from_re(0.0); n];
        system.momenta_into(td, &qdual, &vdual, &mut p);
        let rhs: Vec<f64> = g.iter().zip(&p).map(|(g, p)| g - p.eps).collect();
        let m = system.mass_matrix(t, q, qd).unwrap();
        m.lu()
            .solve(&nalgebra::DVector::from_vec(rhs))
            .unwrap()
            .as_slice()
            .to_vec()
    }

    /// The four routes of eq. 55 — the energy route (U folded into T's pass), the tape's fused
    /// jet pass, the particle route, and the (q, p) form of each — agree on a system with every
    /// term: T depending on t and q, U, Φ and Q″.
    #[test]
    fn accelerations_every_term_four_routes() {
        let (model, derived, particles) = every_term();
        let energy = particles.energy_route();
        assert!(model.fused);
        let s = model.structure();
        assert!(s.time_dependent && s.dissipative && s.forced && !s.constant_mass);
        for (t, q, qd) in [
            (0.0, [0.3, -0.4], [0.0, 0.0]),
            (0.7, [1.1, 0.5], [0.8, -1.3]),
            (2.9, [-0.6, 1.7], [-2.1, 0.4]),
        ] {
            let want = energy.accelerations(t, &q, &qd).unwrap();
            let routes = [
                ("tape", model.accelerations(t, &q, &qd).unwrap()),
                (
                    "tape, generic",
                    model.system().accelerations(t, &q, &qd).unwrap(),
                ),
                ("particles", particles.accelerations(t, &q, &qd).unwrap()),
                ("derived", derived.accelerations(t, &q, &qd).unwrap()),
            ];
            let qp = [
                ("(q, p) energy", qp_accelerations(&energy, t, &q, &qd)),
                ("(q, p) tape", qp_accelerations(&model, t, &q, &qd)),
                ("(q, p) particles", qp_accelerations(&particles, t, &q, &qd)),
            ];
            let routes = routes
                .into_iter()
                .map(|(name, a)| (name, a.as_slice().to_vec()))
                .chain(qp);
            for (name, got) in routes {
                for i in 0..2 {
                    let tol = 1e-12 * want[i].abs().max(1.0);
                    assert!(
                        (got[i] - want[i]).abs() <= tol,
                        "{name} at t = {t}: q̈{i} = {} vs {}",
                        got[i],
                        want[i]
                    );
                }
            }
        }
    }

    /// The derived program evaluated over dual numbers (what Radau IIA's Newton iteration and
    /// `model.jacobian` use) gives the Jacobian ∂q̈/∂(q, q̇) of the energy route, the particle
    /// route and the tapes' derivative passes on the system with every term.
    #[test]
    fn acceleration_jacobian_derived_program_every_term() {
        use crate::dynamics::acceleration_jacobian;
        use nalgebra::DMatrix;
        use num_dual::Dual64;
        let (model, derived, particles) = every_term();
        let energy = particles.energy_route();
        fn jac<S: Dynamics>(system: &S) -> DMatrix<f64> {
            let (t, y) = (1.3, [0.9, -0.4, 1.3, 0.7]);
            let mut jac = DMatrix::zeros(2, 4);
            let (mut xd, mut fd) = ([Dual64::from_re(0.0); 4], [Dual64::from_re(0.0); 2]);
            acceleration_jacobian(system, t, &y, &mut xd, &mut fd, &mut jac).unwrap();
            jac
        }
        let want = jac(&energy);
        // The derived program over dual numbers, without its compiled Jacobian.
        let program = EomFunction::of(derived.derived_program().unwrap());
        let (t, y) = (1.3, [0.9, -0.4, 1.3, 0.7]);
        let mut dual = DMatrix::zeros(2, 4);
        let (mut xd, mut fd) = ([Dual64::from_re(0.0); 4], [Dual64::from_re(0.0); 2]);
        crate::dynamics::jacobian(&y, &mut xd, &mut fd, &mut dual, |x, out| {
            program.accelerations_dual(Dual64::from_re(t), &x[..2], &x[2..], out)
        })
        .unwrap();
        let mut compiled = DMatrix::zeros(2, 4);
        let has = program.acceleration_jacobian(t, &y[..2], &y[2..], compiled.as_mut_slice());
        assert_eq!(has, cfg!(feature = "jit"), "machine code exactly with jit");
        let routes = [
            ("derived", jac(&derived)),
            ("derived, dual numbers", dual),
            ("tape passes", jac(&model)),
            ("particles", jac(&particles)),
        ];
        assert!(
            want.iter().all(|x| x.abs() > 1e-3),
            "every entry is exercised: {want}"
        );
        for (name, got) in routes {
            for (g, w) in got.iter().zip(want.iter()) {
                assert!(
                    (g - w).abs() <= 1e-12 * w.abs().max(1.0),
                    "{name}: {got} vs {want}"
                );
            }
        }
    }

    /// The (q, p) form of the implicit symplectic methods from the derived program — p and
    /// G = Q″ + ∂L/∂q − ∂Φ/∂q̇ in one run, and their Jacobian ∂(p, G)/∂(q, q̇) as machine code
    /// (with `jit`) — against the energy route's parts and their dual-number Jacobian.
    #[test]
    fn qp_form_derived_program_every_term() {
        use nalgebra::DMatrix;
        use num_dual::Dual64;
        let (_, derived, particles) = every_term();
        let energy = particles.energy_route();
        let parts = crate::dynamics::ForceParts::of(&energy);
        let program = derived.derived_program().unwrap();
        for (t, q, v) in [
            (0.2, [0.5, -1.1], [0.9, 0.3]),
            (3.1, [-0.7, 0.2], [-1.4, 2.2]),
        ] {
            let (mut p, mut g, mut tmp) = ([0.0; 2], [0.0; 2], [0.0; 2]);
            program.qp_form(t, &q, &v, &mut p, &mut g);
            let (mut pw, mut gw) = ([0.0; 2], [0.0; 2]);
            energy.momenta_into(t, &q, &v, &mut pw);
            parts.force_into(&energy, t, &q, &v, &mut gw, &mut tmp);
            for i in 0..2 {
                assert_relative_eq!(p[i], pw[i], max_relative = 1e-13);
                assert_relative_eq!(g[i], gw[i], max_relative = 1e-13);
            }
            let y = [q[0], q[1], v[0], v[1]];
            let mut want = DMatrix::zeros(4, 4);
            let (mut xd, mut fd) = ([Dual64::from_re(0.0); 4], [Dual64::from_re(0.0); 4]);
            let mut tmp = [Dual64::from_re(0.0); 2];
            let td = Dual64::from_re(t);
            crate::dynamics::jacobian(&y, &mut xd, &mut fd, &mut want, |x, out| {
                let (p, g) = out.split_at_mut(2);
                energy.momenta_into(td, &x[..2], &x[2..], p);
                parts.force_into(&energy, td, &x[..2], &x[2..], g, &mut tmp);
                Ok(())
            })
            .unwrap();
            let mut got = DMatrix::zeros(4, 4);
            let has = program.qp_jacobian(t, &q, &v, got.as_mut_slice());
            assert_eq!(has, cfg!(feature = "jit"), "machine code exactly with jit");
            if has {
                assert!(want.iter().filter(|x| x.abs() > 1e-3).count() >= 12);
                for (g, w) in got.iter().zip(want.iter()) {
                    assert!((g - w).abs() <= 1e-13 * w.abs().max(1.0), "{got} vs {want}");
                }
            }
        }
    }

    /// The momenta and the energy function h = q̇·p − L from the derived program's own tapes
    /// (machine code with `jit`) are those of the energy route.
    #[test]
    fn momenta_and_energy_derived_program_every_term() {
        let (_, derived, particles) = every_term();
        let energy = particles.energy_route();
        for (t, q, qd) in [
            (0.2, [0.5, -1.1], [0.9, 0.3]),
            (3.1, [-0.7, 0.2], [-1.4, 2.2]),
        ] {
            let (want, got) = (
                energy.momenta(t, &q, &qd).unwrap(),
                derived.momenta(t, &q, &qd).unwrap(),
            );
            for i in 0..2 {
                assert_relative_eq!(got[i], want[i], max_relative = 1e-13);
            }
            let (want, got) = (
                energy.energy(t, &q, &qd).unwrap(),
                derived.energy(t, &q, &qd).unwrap(),
            );
            assert_relative_eq!(got, want, max_relative = 1e-13);
        }
    }

    /// Like every `*_into`, `potential_gradient_into` overwrites its output, on every route.
    #[test]
    fn potential_gradient_into_overwrites() {
        let (model, _, particles) = every_term();
        let energy = particles.energy_route();
        let (t, q) = (0.4, [0.7, -0.3]);
        // ∂U/∂q of U = m g (y + b x²) + ½ k (x² + y²) + κ x y.
        let (m, bq, g, k, kappa) = (1.3, 0.6, 9.81, 2.5, 0.3);
        let exact = [
            m * g * 2.0 * bq * q[0] + k * q[0] + kappa * q[1],
            m * g + k * q[1] + kappa * q[0],
        ];
        let prefilled = |f: &dyn Fn(&mut [f64])| {
            let mut out = [1e3; 2];
            f(&mut out);
            out
        };
        for got in [
            prefilled(&|out| model.potential_gradient_into(t, &q, out)),
            prefilled(&|out| energy.potential_gradient_into(t, &q, out)),
            prefilled(&|out| particles.potential_gradient_into(t, &q, out)),
        ] {
            for i in 0..2 {
                assert_relative_eq!(got[i], exact[i], max_relative = 1e-14);
            }
        }
    }
}
