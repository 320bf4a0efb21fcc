//! [`forward_dynamics!`]: the [`Dynamics`](super::Dynamics) methods a wrapper passes on unchanged
//! to the system inside it, written once for every wrapper (a Python model's enum over systems,
//! a traced Rust system, an energy model over its system, a constrained system, a model with
//! loads).

/// Writes, inside an `impl Dynamics for …`, the methods named, each passing the call on
/// unchanged to the system inside: `forward_dynamics!(system: dof, structure, …)` to the field
/// `self.system`, `forward_dynamics!(each!: …)` through a dispatch macro called as
/// `each!(self, s => s.method(…))` (an enum over systems). The impl writes the methods it
/// changes itself.
///
/// A method is forwarded only when named: a wrapper that changes the equations must not pass on
/// [`derived_program`](super::Dynamics::derived_program) or
/// [`taylor_program`](super::Dynamics::taylor_program), so nothing is passed on by default.
macro_rules! forward_dynamics {
    ($field:ident: $($method:ident),+ $(,)?) => {
        $($crate::dynamics::forward_dynamics!(@method [field $field] $method);)+
    };
    ($dispatch:ident!: $($method:ident),+ $(,)?) => {
        $($crate::dynamics::forward_dynamics!(@method [via $dispatch] $method);)+
    };
    (@method $to:tt dof) => {
        fn dof(&self) -> usize {
            $crate::dynamics::forward_dynamics!(@call self $to dof())
        }
    };
    (@method $to:tt structure) => {
        fn structure(&self) -> $crate::dynamics::Structure {
            $crate::dynamics::forward_dynamics!(@call self $to structure())
        }
    };
    (@method $to:tt kinetic_energy) => {
        #[inline]
        fn kinetic_energy<D: $crate::scalar::Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
            $crate::dynamics::forward_dynamics!(@call self $to kinetic_energy(t, q, qd))
        }
    };
    (@method $to:tt potential_energy) => {
        #[inline]
        fn potential_energy<D: $crate::scalar::Scalar>(&self, t: D, q: &[D]) -> D {
            $crate::dynamics::forward_dynamics!(@call self $to potential_energy(t, q))
        }
    };
    (@method $to:tt potential_gradient_into) => {
        #[inline]
        fn potential_gradient_into<D: $crate::scalar::Scalar>(
            &self,
            t: D,
            q: &[D],
            out: &mut [D],
        ) {
            $crate::dynamics::forward_dynamics!(@call self $to potential_gradient_into(t, q, out))
        }
    };
    (@method $to:tt lagrangian) => {
        #[inline]
        fn lagrangian<D: $crate::scalar::Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
            $crate::dynamics::forward_dynamics!(@call self $to lagrangian(t, q, qd))
        }
    };
    (@method $to:tt accelerations_into) => {
        #[inline]
        fn accelerations_into<D: $crate::scalar::Scalar>(
            &self,
            t: D,
            q: &[D],
            qd: &[D],
            out: &mut [D],
        ) -> $crate::error::Result<()> {
            $crate::dynamics::forward_dynamics!(@call self $to accelerations_into(t, q, qd, out))
        }
    };
    (@method $to:tt energy) => {
        fn energy(&self, t: f64, q: &[f64], qd: &[f64]) -> $crate::error::Result<f64> {
            $crate::dynamics::forward_dynamics!(@call self $to energy(t, q, qd))
        }
    };
    (@method $to:tt derived_program) => {
        fn derived_program(&self) -> Option<&dyn $crate::dynamics::DerivedProgram> {
            $crate::dynamics::forward_dynamics!(@call self $to derived_program())
        }
    };
    (@method $to:tt taylor_program) => {
        fn taylor_program(
            &self,
        ) -> std::result::Result<&dyn $crate::dynamics::DerivedProgram, String> {
            $crate::dynamics::forward_dynamics!(@call self $to taylor_program())
        }
    };
    // By the trait: a `Constrained` system has an inherent `constraints` (its rows) as well.
    (@method [field $field:ident] constraints) => {
        fn constraints(&self) -> Option<&dyn $crate::dynamics::ConstraintAccess> {
            $crate::dynamics::Dynamics::constraints(&self.$field)
        }
    };
    (@method [via $dispatch:ident] constraints) => {
        fn constraints(&self) -> Option<&dyn $crate::dynamics::ConstraintAccess> {
            $dispatch!(self, s => $crate::dynamics::Dynamics::constraints(s))
        }
    };
    // The rest write a state's vector or matrix, (t, q, q̇) into `out`: generalized_forces_into,
    // dissipative_forces_into, momenta_into, mass_matrix_into.
    (@method $to:tt $method:ident) => {
        #[inline]
        fn $method<D: $crate::scalar::Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
            $crate::dynamics::forward_dynamics!(@call self $to $method(t, q, qd, out))
        }
    };
    (@call $self:ident [field $field:ident] $method:ident($($arg:ident),*)) => {
        $self.$field.$method($($arg),*)
    };
    (@call $self:ident [via $dispatch:ident] $method:ident($($arg:ident),*)) => {
        $dispatch!($self, s => s.$method($($arg),*))
    };
}

pub(crate) use forward_dynamics;
