//! The expression graph of a model stated at run time ([`Graph`](graph::Graph): nodes in
//! topological order, equal subexpressions shared) and its derivatives as expressions
//! (`derive.rs`: forward tangents and reverse-mode gradients built as nodes). The lowest floor
//! of the run-time models: it names nothing above it.

pub(crate) mod derive;
pub(crate) mod functions;
pub(crate) mod graph;
