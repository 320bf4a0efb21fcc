//! The registry: each [`Method`] to its integrator (one arm per method; the compiler checks
//! that none is missing), and what the methods' integrators say of themselves. It sits above the
//! methods' files and below the solver and the choice of [`Method::Auto`].

use super::gauss::{Gauss, GaussTableau};
use super::method::Method;
use super::radau::Radau;
use super::run::{Integrator, Run, SegmentStepper};
use super::runge_kutta::{self, ExplicitRk};
use super::symplectic::{Splitting, SymplecticTableau};
use super::taylor;
use super::variational::Variational;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};

/// A generic operation on the integrator behind a [`Method`].
trait Visit {
    type Out;
    fn visit<I: Integrator>(self, integrator: I) -> Self::Out;
}

impl Method {
    /// `v` applied to the method's integrator; `None` for [`Method::Auto`].
    fn visit<V: Visit>(self, v: V) -> Option<V::Out> {
        match self {
            Method::Auto => None,
            Method::Rk4 => Some(v.visit(ExplicitRk::new(&runge_kutta::RK4))),
            Method::Dopri5 => Some(v.visit(ExplicitRk::new(&runge_kutta::DOPRI5))),
            Method::Dop853 => Some(v.visit(ExplicitRk::new(&runge_kutta::DOP853))),
            Method::StormerVerlet => {
                Some(v.visit(Splitting::new(SymplecticTableau::stormer_verlet())))
            }
            Method::Yoshida4 => Some(v.visit(Splitting::new(SymplecticTableau::yoshida4()))),
            Method::Yoshida6 => Some(v.visit(Splitting::new(SymplecticTableau::yoshida6()))),
            Method::Yoshida8 => Some(v.visit(Splitting::new(SymplecticTableau::yoshida8()))),
            Method::BlanesMoan4 => Some(v.visit(Splitting::new(SymplecticTableau::blanes_moan4()))),
            Method::Midpoint => Some(v.visit(Variational)),
            Method::Gauss4 => Some(v.visit(Gauss::new(GaussTableau::gauss4()))),
            Method::Gauss6 => Some(v.visit(Gauss::new(GaussTableau::gauss6()))),
            Method::Radau5 => Some(v.visit(Radau)),
            Method::Taylor => Some(v.visit(taylor::Taylor)),
        }
    }

    /// Set up the integration of the run's current segment with this method; `None` for
    /// [`Method::Auto`], which the solver resolves first.
    pub(crate) fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Option<Result<Box<dyn SegmentStepper<S>>>> {
        self.visit(Start(run))
    }
}

struct Info;
impl Visit for Info {
    type Out = (usize, bool, bool);
    fn visit<I: Integrator>(self, i: I) -> (usize, bool, bool) {
        (i.order(), i.adaptive(), i.explicit())
    }
}

impl Method {
    /// Order of convergence; `None` for [`Method::Auto`].
    pub fn order(self) -> Option<usize> {
        self.visit(Info).map(|(order, _, _)| order)
    }

    /// Whether the method controls its step size when no fixed `dt` is given; `None` for
    /// [`Method::Auto`].
    pub fn is_adaptive(self) -> Option<bool> {
        self.visit(Info).map(|(_, adaptive, _)| adaptive)
    }

    /// Whether the method is explicit (its fixed steps have a stability limit); `None` for
    /// [`Method::Auto`].
    pub fn is_explicit(self) -> Option<bool> {
        self.visit(Info).map(|(_, _, explicit)| explicit)
    }

    /// The methods that can integrate `system` from this state: every method except the
    /// explicit splittings serves any system with an invertible mass matrix; those need a
    /// separable one without velocity-dependent forces.
    pub fn fitting<S: Dynamics + ?Sized>(
        system: &S,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
    ) -> Vec<Method> {
        Method::ALL
            .iter()
            .copied()
            .filter(|m| {
                matches!(
                    m.visit(Fits {
                        system,
                        t0,
                        q0,
                        qd0
                    }),
                    Some(Ok(()))
                )
            })
            .collect()
    }

    /// Whether this method can integrate `system` from this state ([`Method::Auto`] always
    /// can).
    ///
    /// # Errors
    /// [`Error::UnsupportedMethod`]: why not, and the methods that can.
    pub fn check_fits<S: Dynamics + ?Sized>(
        self,
        system: &S,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
    ) -> Result<()> {
        match self.visit(Fits {
            system,
            t0,
            q0,
            qd0,
        }) {
            Some(Err(why)) => Err(Error::UnsupportedMethod {
                method: self.name(),
                why,
                fits: Method::fitting(system, t0, q0, qd0)
                    .iter()
                    .map(|m| m.name())
                    .collect(),
            }),
            _ => Ok(()),
        }
    }
}

struct Fits<'a, S: ?Sized> {
    system: &'a S,
    t0: f64,
    q0: &'a [f64],
    qd0: &'a [f64],
}
impl<S: Dynamics + ?Sized> Visit for Fits<'_, S> {
    type Out = std::result::Result<(), String>;
    fn visit<I: Integrator>(self, i: I) -> Self::Out {
        i.fits(self.system, self.t0, self.q0, self.qd0)
    }
}

struct Start<'r, 'a, S: ?Sized>(&'r mut Run<'a, S>);
impl<S: Dynamics + ?Sized> Visit for Start<'_, '_, S> {
    type Out = Result<Box<dyn SegmentStepper<S>>>;
    fn visit<I: Integrator>(self, i: I) -> Self::Out {
        i.start(self.0)
    }
}
