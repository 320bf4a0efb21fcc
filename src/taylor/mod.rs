//! Taylor coefficients of the motion by series arithmetic on the expression graph.
//!
//! Lagrange's equations are implicit in q̈: M(t, q) q̈ = f(t, q, q̇) (eq. 55, derived on the graph
//! by `eom_graph`). The normalized Taylor coefficients xₖ = x⁽ᵏ⁾(t₀)/k! of
//! the solution through (t₀, q₀, q̇₀) follow order by order: at order k the coefficients of q
//! and q̇ are known (qₖ = q̇ₖ₋₁/k, q̇ₖ = q̈ₖ₋₁/k), so every node of M and f gets its coefficient k
//! from the standard recurrences of truncated power series (products by convolution, quotients,
//! exp, log, sin and cos together, …), and q̈'s coefficient k from one solve with M₀ = M(t₀, q₀),
//! factored once per expansion:
//!
//! M₀ q̈ₖ = fₖ − Σⱼ₌₁..ₖ Mⱼ q̈ₖ₋ⱼ.
//!
//! No symbolic inverse of M is formed, so the cost is a few evaluations of the graph per order
//! at any number of coordinates.
//!
//! The graph is lowered once to a list of recurrences ([`SeriesOp`](series::SeriesOp)) over the rows of one table: a row
//! per node and the auxiliary rows some recurrences need (cos beside sin, 1 + tan² beside tan,
//! the squares of a power by squaring, …). Nodes that depend on none of t, q, q̇ have a series
//! with nothing beyond order 0, so they are evaluated once per expansion and skipped at higher
//! orders, and a product or quotient by one of them is a scaling. The recurrences are
//! interpreted here and compiled to machine code by `kernel.rs` and `emit.rs` (feature `jit`), with the
//! same operations in the same order, so both give the same coefficients bit for bit.
//!
//! Where things live, lowest first: `series.rs` (one recurrence, [`SeriesOp`](series::SeriesOp),
//! and the convolution), `lower.rs` (M's and f's nodes lowered to recurrences), `abi.rs` (the
//! `repr(C)` layouts the interpreter and the kernels share), `kernel.rs` and `emit.rs` (the
//! recurrences compiled by Cranelift, feature `jit`), and `expansion.rs` ([`TaylorProgram`],
//! [`Expansion`]: the one place that chooses compiled or interpreted expansion).

mod abi;
#[cfg(feature = "parallel")]
pub(crate) mod batch;
#[cfg(feature = "jit")]
mod emit;
mod expansion;
#[cfg(feature = "jit")]
mod kernel;
mod lower;
pub(crate) mod series;

pub use abi::StepRule;
#[cfg(feature = "jit")]
pub(crate) use expansion::RowEnd;
pub use expansion::{Expansion, TaylorProgram};
pub use series::MAX_TAYLOR_ORDER;
