//! The flat program a graph compiles to and its interpreter: `compile.rs` ([`Tape`] step by
//! step, [`Inputs`]), `analysis.rs` (what a tape reads, its polynomial structure in q̇), `ins.rs`
//! (the instruction set as one table), `eval.rs` ([`Function`], the evaluation over any
//! [`Scalar`](crate::Scalar) and its jet fast path) and `jet.rs` (the jet arithmetic). It reads
//! the expression graph ([`crate::expr`]) and nothing above it.
//!
//! [`Tape`]: compile::Tape
//! [`Inputs`]: inputs::Inputs
//! [`Function`]: eval::Function

pub(crate) mod analysis;
pub(crate) mod compile;
pub(crate) mod eval;
pub(crate) mod inputs;
pub(crate) mod ins;
pub(crate) mod jet;
