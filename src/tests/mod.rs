//! Tests of crate-private parts that need floors above their own (a model derived on the
//! graph, a route, an integrator): here, in a room above every other, so that no file draws an
//! arrow up to reach them.

mod eval_paths;
mod expr_constraints;
mod taylor;
