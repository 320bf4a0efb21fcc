//! The forward-mode derivative passes behind the equations of motion.
//!
//! Each term of eq. 55 gets only the pass it needs (the design is described in
//! docs/ARCHITECTURE.md and docs/site/crate.rst, "How the derivatives are taken"):
//! - [`gradient`]: one first-order vector-dual pass (∂U/∂q, ∂Φ/∂q̇, p = ∂T/∂q̇);
//! - [`inertia`]: everything T contributes, M = ∂²T/∂q̇² and the kinetic terms
//!   ∂T/∂q − (∂²T/∂q̇∂q) q̇ − ∂²T/∂q̇∂t, from one hyper-dual pass whose first directions are q̇ and
//!   whose second directions are q̇ and q: its mixed part holds M and ∂²T/∂q̇∂q, its second
//!   first-order part ∂T/∂q. T (and every sine in it) is evaluated once; no full Hessian of L.
//!   For one or two coordinates the same pass evaluates L = T − U rather than T, so it also gives
//!   −∂U/∂q (U has no q̇, so it leaves M and ∂²T/∂q̇∂q alone) and U needs no pass of its own.
//!   A T with explicit time dependence gets one more small pass for ∂²T/∂q̇∂t.
//!
//! Up to [`CHUNK`](crate::scalar::CHUNK) coordinates are seeded in one pass (the const `C` equals the number of
//! coordinates, so nothing is wasted); larger systems are seeded in chunks of [`CHUNK`](crate::scalar::CHUNK), the way
//! ForwardDiff.jl does, with M by blocks and the kinetic terms from a gradient pass and one
//! hyper-dual pass per chunk along the motion (q, q̇, t) ↦ (q̇, 0, 1). The const `C2` is always
//! `2 C` (stable Rust cannot write `2 * C` in a type).

use crate::energies::{KineticEnergy, Potential};
use crate::scalar::Scalar;
use crate::scalar::{
    Grad, Hyper, grad_const, grad_part, grad_seed, hyper, hyper_eps2, hyper_mixed, with_buf,
};
use nalgebra::{SMatrix, SVector};

/// The largest number of coordinates for which the one-pass scheme also evaluates U. Up to two,
/// its hyper-dual numbers (≤ 15 components) stay in registers and U rides along for free; from
/// three on (28 and 45 components) their operations are out-of-line calls, and U's own
/// first-order pass is cheaper (both measured in benches/eom.rs, on the double pendulum and the
/// 4-pendulum).
const FOLD_POTENTIAL_MAX: usize = 2;

/// Which argument a gradient pass differentiates.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Wrt {
    /// The coordinates q.
    Position,
    /// The velocities q̇.
    Velocity,
}

/// `out[i] += sign · ∂f/∂x_i`, with x = q or q̇ as `wrt` says, in chunks of `C`.
#[inline]
pub(crate) fn gradient<const C: usize, D: Scalar, F>(
    t: D,
    q: &[D],
    qd: &[D],
    wrt: Wrt,
    sign: f64,
    f: F,
    out: &mut [D],
) where
    F: Fn(Grad<D, C>, &[Grad<D, C>], &[Grad<D, C>]) -> Grad<D, C>,
{
    with_len::<C, _>(
        q.len(),
        #[inline(always)]
        |n| {
            let (q, qd, out) = (&q[..n], &qd[..n], &mut out[..n]);
            let tt = grad_const::<D, C>(t);
            let zero = grad_const::<D, C>(D::zero());
            with_buf::<_, C, _>(
                n,
                zero,
                #[inline(always)]
                |qs| {
                    with_buf::<_, C, _>(
                        n,
                        zero,
                        #[inline(always)]
                        |qds| {
                            let (seeded, fixed, x_fixed, x_seeded) = match wrt {
                                Wrt::Position => (qs, qds, qd, q),
                                Wrt::Velocity => (qds, qs, q, qd),
                            };
                            for (l, &x) in fixed.iter_mut().zip(x_fixed) {
                                *l = grad_const(x);
                            }
                            for start in (0..n).step_by(C) {
                                let end = (start + C).min(n);
                                for (i, (l, &x)) in seeded.iter_mut().zip(x_seeded).enumerate() {
                                    *l = if (start..end).contains(&i) {
                                        grad_seed(x, i - start)
                                    } else {
                                        grad_const(x)
                                    };
                                }
                                let v = match wrt {
                                    Wrt::Position => f(tt, seeded, fixed),
                                    Wrt::Velocity => f(tt, fixed, seeded),
                                };
                                for i in start..end {
                                    out[i] += grad_part(&v, i - start) * sign;
                                }
                            }
                        },
                    )
                },
            )
        },
    )
}

/// `body(n)`, with a copy of the body where n is known at compile time for the common n == C
/// case.
#[inline(always)]
fn with_len<const C: usize, R>(n: usize, body: impl FnOnce(usize) -> R) -> R {
    if n == C { body(C) } else { body(n) }
}

/// What [`inertia`] should fill.
pub(crate) struct InertiaOut<'a, D> {
    /// Row-major M = ∂²T/∂q̇², overwritten.
    pub mass: Option<&'a mut [D]>,
    /// ∂T/∂q − (∂²T/∂q̇∂q) q̇ − ∂²T/∂q̇∂t, added in.
    pub kinetic_terms: Option<&'a mut [D]>,
}

/// Mass matrix and kinetic terms of `ke` (see the module docs). Where the one fused pass runs
/// (n = C and kinetic terms requested) and C ≤ [`FOLD_POTENTIAL_MAX`], it differentiates L = T − U
/// instead of T, so −∂U/∂q is added into the kinetic terms at no extra pass; the return value
/// says whether it was.
#[inline(always)]
pub(crate) fn inertia<
    const C: usize,
    const C2: usize,
    D: Scalar,
    K: KineticEnergy,
    P: Potential,
>(
    ke: &K,
    pot: &P,
    t: D,
    q: &[D],
    qd: &[D],
    out: InertiaOut<'_, D>,
) -> bool {
    debug_assert_eq!(C2, 2 * C);
    let InertiaOut {
        mass,
        kinetic_terms,
    } = out;
    let n = q.len();
    match kinetic_terms {
        Some(terms) if n == C => {
            let fold = C <= FOLD_POTENTIAL_MAX && pot.is_present();
            fused::<C, C2, D, K, P>(ke, fold.then_some(pot), t, q, qd, mass, terms);
            if ke.depends_on_time() {
                along::<C, D, K>(ke, t, q, qd, Along::Time, terms);
            }
            fold
        }
        terms => {
            if let Some(m) = mass {
                mass_blocks::<C, D, K>(ke, t, q, qd, m);
            }
            if let Some(terms) = terms {
                let f = |t, q: &[_], qd: &[_]| ke.kinetic(t, q, qd);
                gradient::<C, D, _>(t, q, qd, Wrt::Position, 1.0, f, terms);
                along::<C, D, K>(ke, t, q, qd, Along::Motion, terms);
            }
            false
        }
    }
}

/// M and the kinetic terms but ∂²T/∂q̇∂t in one pass of L = T − U (or of T alone when `pot` is
/// `None`), for n = C: first directions q̇, second directions (q̇, q). U has no q̇ so adds nothing
/// to the mixed part.
#[inline(always)]
fn fused<const C: usize, const C2: usize, D: Scalar, K: KineticEnergy, P: Potential>(
    ke: &K,
    pot: Option<&P>,
    t: D,
    q: &[D],
    qd: &[D],
    mass: Option<&mut [D]>,
    terms: &mut [D],
) {
    // Seeds built whole (not zeros then one store) so no wide load waits on a narrow store.
    let unit = |i: usize| SMatrix::<D, 1, C2>::from_fn(|_, j| D::from((i == j) as u8 as f64));
    let tt = hyper::<D, C, C2>(t, None, None);
    let qs: [Hyper<D, C, C2>; C] = std::array::from_fn(|i| hyper(q[i], None, Some(unit(C + i))));
    let qds: [Hyper<D, C, C2>; C] = std::array::from_fn(|i| {
        let e1 = SVector::<D, C>::from_fn(|k, _| D::from((i == k) as u8 as f64));
        hyper(qd[i], Some(e1), Some(unit(i)))
    });
    let mut v = ke.kinetic(tt, &qs, &qds);
    if let Some(pot) = pot {
        v -= pot.potential(tt, &qs);
    }
    if let Some(m) = mass {
        for i in 0..C {
            for j in 0..C {
                m[i * C + j] = hyper_mixed(&v, i, j);
            }
        }
    }
    for (i, x) in terms.iter_mut().enumerate() {
        let mut s = hyper_eps2(&v, C + i);
        for (j, &w) in qd.iter().enumerate() {
            s -= hyper_mixed(&v, i, C + j) * w;
        }
        *x += s;
    }
}

/// M by blocks of C × C (upper blocks mirrored).
fn mass_blocks<const C: usize, D: Scalar, K: KineticEnergy>(
    ke: &K,
    t: D,
    q: &[D],
    qd: &[D],
    m: &mut [D],
) {
    let n = q.len();
    let tt = hyper::<D, C, C>(t, None, None);
    let qs: Vec<Hyper<D, C, C>> = q.iter().map(|&x| hyper(x, None, None)).collect();
    let mut qds: Vec<Hyper<D, C, C>> = Vec::with_capacity(n);
    for bi in (0..n).step_by(C) {
        for bj in (bi..n).step_by(C) {
            qds.clear();
            qds.extend(qd.iter().enumerate().map(|(i, &x)| {
                let e1 = (bi..bi + C).contains(&i).then(|| {
                    let mut e = SVector::<D, C>::zeros();
                    e[i - bi] = D::one();
                    e
                });
                let e2 = (bj..bj + C).contains(&i).then(|| {
                    let mut e = SMatrix::<D, 1, C>::zeros();
                    e[i - bj] = D::one();
                    e
                });
                hyper(x, e1, e2)
            }));
            let v = ke.kinetic(tt, &qs, &qds);
            for i in bi..(bi + C).min(n) {
                for j in bj..(bj + C).min(n) {
                    let mij = hyper_mixed(&v, i - bi, j - bj);
                    m[i * n + j] = mij;
                    m[j * n + i] = mij;
                }
            }
        }
    }
}

/// The one second direction of [`along`].
#[derive(Clone, Copy)]
enum Along {
    /// (q, q̇, t) ↦ (q̇, 0, 1): the mixed part is (∂²T/∂q̇∂q) q̇ + ∂²T/∂q̇∂t.
    Motion,
    /// (q, q̇, t) ↦ (0, 0, 1): the mixed part is ∂²T/∂q̇∂t.
    Time,
}

/// `terms −= ∂/∂q̇ of the derivative of T along one second direction`, by chunks of C first
/// directions.
fn along<const C: usize, D: Scalar, K: KineticEnergy>(
    ke: &K,
    t: D,
    q: &[D],
    qd: &[D],
    direction: Along,
    terms: &mut [D],
) {
    let n = q.len();
    let one = |x: D| Some(SMatrix::<D, 1, 1>::new(x));
    let tt = hyper::<D, C, 1>(t, None, one(D::one()));
    let qs: Vec<Hyper<D, C, 1>> = match direction {
        Along::Motion => q
            .iter()
            .zip(qd)
            .map(|(&x, &v)| hyper(x, None, one(v)))
            .collect(),
        Along::Time => q.iter().map(|&x| hyper(x, None, None)).collect(),
    };
    let mut qds: Vec<Hyper<D, C, 1>> = Vec::with_capacity(n);
    for bi in (0..n).step_by(C) {
        qds.clear();
        qds.extend(qd.iter().enumerate().map(|(i, &x)| {
            let e1 = (bi..bi + C).contains(&i).then(|| {
                let mut e = SVector::<D, C>::zeros();
                e[i - bi] = D::one();
                e
            });
            hyper(x, e1, None)
        }));
        let v = ke.kinetic(tt, &qs, &qds);
        for i in bi..(bi + C).min(n) {
            terms[i] -= hyper_mixed(&v, i - bi, 0);
        }
    }
}
