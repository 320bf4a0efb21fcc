//! Eq. 55 derived on the expression graph and compiled: `eom_program.rs` ([`EomGraph`] — M's
//! entries and one force vector as nodes — [`EomProgram`] and its bound [`EomFunction`], which
//! owns the Taylor program of the same M and f), and `models.rs` (ready-made graphs of a few
//! systems). It sits above the Taylor lowering, which it hands M's and f's nodes.
//! `constraint_program.rs` derives a constrained model's G and γ the same way
//! ([`ConstraintProgram`](constraint_program::ConstraintProgram)), and `variational.rs` the
//! variational equations of eq. 55 (forward sensitivities) as a model of their own.
//!
//! [`EomGraph`]: eom_program::EomGraph
//! [`EomProgram`]: eom_program::EomProgram
//! [`EomFunction`]: eom_program::EomFunction

pub(crate) mod constraint_program;
pub(crate) mod eom_program;
pub mod models;
pub(crate) mod variational;
