//! The generic scalar every model is written over, and the seeding helpers that lift plain
//! values into dual numbers.
//!
//! A model written once as `fn kinetic<D: Scalar>(…) -> D` runs on `f64` (plain evaluation) and on
//! every num-dual type (`Dual64`, `HyperDualVec`, `Dual2`, and nestings of them), which is how the
//! equations of motion get their derivatives without finite differences or symbolic algebra.

use nalgebra::Const;
use num_dual::{Derivative, DualNum, DualSVec, HyperDualVec};
use std::mem::MaybeUninit;

/// A real scalar that models are generic over: `f64` and all of num-dual's (nested) dual numbers.
///
/// Write constants as `x * 0.5` or `D::from(0.5)`; all of `sin`, `cos`, `exp`, `sqrt`, `powi`, … come
/// from [`num_dual::DualNum`].
pub trait Scalar: DualNum<Primitive = f64> + Copy {}

impl<D: DualNum<Primitive = f64> + Copy> Scalar for D {}

/// The real (`f64`) part of any scalar.
#[inline]
pub fn re<D: Scalar>(x: D) -> f64 {
    x.re()
}

/// The largest number of directions one dual-number pass seeds: the passes of eq. 55, the
/// constraints' Jacobian and the programs' jets all differentiate in chunks of this size.
pub(crate) const CHUNK: usize = 4;

/// A first-order vector dual over `K` seeded directions (gradients in chunks of `K`).
pub(crate) type Grad<D, const K: usize> = DualSVec<D, K>;

/// A constant (no derivative part) gradient dual.
#[inline]
pub(crate) fn grad_const<D: Scalar, const K: usize>(x: D) -> Grad<D, K> {
    Grad::<D, K>::from_re(x)
}

/// A gradient dual seeded in direction `k`.
#[inline]
pub(crate) fn grad_seed<D: Scalar, const K: usize>(x: D, k: usize) -> Grad<D, K> {
    let mut eps = nalgebra::SVector::<D, K>::zeros();
    eps[k] = D::one();
    Grad::<D, K>::new(x, Derivative::some(eps))
}

/// The derivative component `k` of a gradient dual (zero when it carries none).
#[inline]
pub(crate) fn grad_part<D: Scalar, const K: usize>(x: &Grad<D, K>, k: usize) -> D {
    x.eps.0.as_ref().map_or(D::zero(), |e| e[k])
}

/// A hyper-dual with `M` first directions and `N` second directions.
pub(crate) type Hyper<D, const M: usize, const N: usize> = HyperDualVec<D, Const<M>, Const<N>>;

/// Build a hyper-dual from its value and optional seeds in the first (`eps1`) and second
/// (`eps2`) direction sets; the mixed part starts at zero.
#[inline]
pub(crate) fn hyper<D: Scalar, const M: usize, const N: usize>(
    x: D,
    eps1: Option<nalgebra::SVector<D, M>>,
    eps2: Option<nalgebra::SMatrix<D, 1, N>>,
) -> Hyper<D, M, N> {
    Hyper::<D, M, N>::new(
        x,
        Derivative::new(eps1),
        Derivative::new(eps2),
        Derivative::none(),
    )
}

/// Component `j` of a hyper-dual's second first-order part (zero when it carries none).
#[inline]
pub(crate) fn hyper_eps2<D: Scalar, const M: usize, const N: usize>(
    x: &Hyper<D, M, N>,
    j: usize,
) -> D {
    x.eps2.0.as_ref().map_or(D::zero(), |e| e[j])
}

/// The `(i, j)` entry of a hyper-dual's mixed part (zero when it carries none).
#[inline]
pub(crate) fn hyper_mixed<D: Scalar, const M: usize, const N: usize>(
    x: &Hyper<D, M, N>,
    i: usize,
    j: usize,
) -> D {
    x.eps1eps2.0.as_ref().map_or(D::zero(), |e| e[(i, j)])
}

/// Run `f` on a slice of `len` copies of `fill` that lives on the stack when `len <= CAP`, so the
/// hot paths of small systems never touch the allocator; larger systems fall back to the heap.
/// The stack buffer starts zeroed: num-dual's derivative parts are `Option`s, and where a pass is
/// not inlined the compiler computes on the payload of a `None` speculatively. Uninitialised
/// payload bytes are often subnormal as doubles, and each subnormal operation costs ~100 cycles
/// (an out-of-line double-pendulum call in benches/eom.rs measured several times slower
/// with them than zeroed).
#[inline(always)]
pub(crate) fn with_buf<L: Copy, const CAP: usize, R>(
    len: usize,
    fill: L,
    f: impl FnOnce(&mut [L]) -> R,
) -> R {
    let mut stack = [const { MaybeUninit::<L>::zeroed() }; CAP];
    let mut heap = Vec::new();
    // One call site: `f` (a whole derivative pass or tape run) is compiled once, not once per
    // branch, and the rest is instantiated once per buffer type, not once per closure.
    f(fill_buf(&mut stack, &mut heap, len, fill))
}

/// [`with_buf`] for plain `f64` work space, `len` zeros: the stack array is not zeroed first
/// (no dual payloads whose stale bytes could be subnormals), so a generous `CAP` costs nothing
/// beyond the `len` slots used.
#[inline(always)]
pub(crate) fn with_f64_buf<const CAP: usize, R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    let mut stack = [const { MaybeUninit::<f64>::uninit() }; CAP];
    let mut heap = Vec::new();
    f(fill_buf(&mut stack, &mut heap, len, 0.0))
}

/// The first `len` slots of `stack` set to `fill`, or `heap` filled with `len` of them when
/// `len > CAP`.
#[inline(always)]
fn fill_buf<'a, L: Copy, const CAP: usize>(
    stack: &'a mut [MaybeUninit<L>; CAP],
    heap: &'a mut Vec<L>,
    len: usize,
    fill: L,
) -> &'a mut [L] {
    if len <= CAP {
        for slot in &mut stack[..len] {
            slot.write(fill);
        }
        // SAFETY: the first `len` slots were initialised just above, and `L: Copy` has no drop
        // glue, so viewing them as `&mut [L]` is sound.
        unsafe { &mut *(&mut stack[..len] as *mut [MaybeUninit<L>] as *mut [L]) }
    } else {
        *heap = vec![fill; len];
        heap
    }
}

// Dispatch on the scalar type: a generic pass that meets `f64` (or one dual shape) takes its
// plain-array path instead.

/// Whether `D` is exactly `T`.
#[inline(always)]
pub(crate) fn is<D: 'static, T: 'static>() -> bool {
    std::any::TypeId::of::<D>() == std::any::TypeId::of::<T>()
}

/// `x` as a `T`, when [`is::<D, T>`] holds.
///
/// # Safety
/// `D` and `T` must be the same type.
#[inline(always)]
pub(crate) unsafe fn cast<D, T>(x: &D) -> &T {
    // SAFETY: the caller guarantees D == T.
    unsafe { &*(x as *const D as *const T) }
}

/// `x` as a slice of `T`, when [`is::<D, T>`] holds.
///
/// # Safety
/// `D` and `T` must be the same type.
#[inline(always)]
pub(crate) unsafe fn cast_slice<D, T>(x: &[D]) -> &[T] {
    // SAFETY: the caller guarantees D == T.
    unsafe { &*(x as *const [D] as *const [T]) }
}

/// `x` as a `D`, when [`is::<D, T>`] holds.
///
/// # Safety
/// `D` and `T` must be the same type.
#[inline(always)]
pub(crate) unsafe fn uncast<T, D>(x: T) -> D {
    let x = std::mem::ManuallyDrop::new(x);
    // SAFETY: the caller guarantees D == T, so the bits are a valid D; `x` is not dropped twice.
    unsafe { std::mem::transmute_copy::<T, D>(&x) }
}
