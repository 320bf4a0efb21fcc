//! What a compiled expression reads and how it depends on q̇, read off the graph.
//!
//! Each live node is checked against the [`Inputs`] the tape may read, classified as constant (a
//! function of numbers and parameters only, for the `f64` program) or not, and given its shape
//! as a polynomial in q̇. From the outputs' shapes follows whether T is of degree ≤ 2 in q̇ with
//! constant quadratic coefficients (then M = ∂²T/∂q̇² is constant and factored once). The
//! analysis is conservative: m l² (cos²θ + sin²θ) θ̇² is reported as not constant.

use super::inputs::Inputs;
use crate::error::{Error, Result};
use crate::expr::graph::{Binary, Node, Unary};

/// Structure read off a compiled expression.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Flags {
    pub(crate) time: bool,
    pub(crate) position: bool,
    pub(crate) velocity: bool,
    /// A polynomial of degree ≤ 2 in q̇ whose quadratic coefficients are constant.
    pub(crate) constant_hessian: bool,
}

/// The result of [`analyse`].
pub(crate) struct Analysis {
    pub(crate) flags: Flags,
    /// Per node: whether it is a function of numbers and parameters only.
    pub(crate) is_const: Vec<bool>,
}

/// The shape of a node as a polynomial in q̇: for each degree 0, 1, 2 whether such terms exist
/// and whether their coefficients depend on (t, q); `None` when it is not such a polynomial.
type Poly = Option<[Option<bool>; 3]>;

/// A term of degree 0 whose coefficient depends on (t, q) or not.
const fn scalar(depends: bool) -> Poly {
    Some([Some(depends), None, None])
}

fn poly_merge(a: Poly, b: Poly) -> Poly {
    let (a, b) = (a?, b?);
    let mut out = [None; 3];
    for d in 0..3 {
        out[d] = match (a[d], b[d]) {
            (None, None) => None,
            (x, y) => Some(x.unwrap_or(false) || y.unwrap_or(false)),
        };
    }
    Some(out)
}

fn poly_mul(a: Poly, b: Poly) -> Poly {
    let (a, b) = (a?, b?);
    let mut out = [None; 3];
    for (da, ca) in a.iter().enumerate() {
        for (db, cb) in b.iter().enumerate() {
            if let (Some(ca), Some(cb)) = (ca, cb) {
                if da + db > 2 {
                    return None;
                }
                let prev = out[da + db].unwrap_or(false);
                out[da + db] = Some(prev || *ca || *cb);
            }
        }
    }
    Some(out)
}

/// `Some(depends on (t, q))` when the node is free of q̇.
fn poly_scalar(a: Poly) -> Option<bool> {
    let a = a?;
    if a[1].is_none() && a[2].is_none() {
        Some(a[0].unwrap_or(false))
    } else {
        None
    }
}

/// Check the live nodes against `inputs`, find the constant ones and the structure flags of
/// `outputs`. `what` names the expression in error messages.
///
/// # Errors
/// [`Error::InvalidInput`] when a live node reads something `inputs` does not allow.
pub(crate) fn analyse(
    nodes: &[Node],
    live: &[bool],
    outputs: &[usize],
    inputs: Inputs,
    what: &str,
) -> Result<Analysis> {
    let n = nodes.len();
    let bad = |why: String| Error::InvalidInput {
        what: "expression",
        why,
    };
    let mut flags = Flags {
        time: false,
        position: false,
        velocity: false,
        constant_hessian: true,
    };
    let mut is_const = vec![false; n];
    let mut poly: Vec<Poly> = vec![None; n];
    for i in (0..n).filter(|&i| live[i]) {
        let (c, p) = match nodes[i] {
            Node::Const(_) => (true, scalar(false)),
            Node::Param(k) => {
                if k >= inputs.params {
                    return Err(bad(format!(
                        "{what}: parameter {k} does not exist ({} parameters)",
                        inputs.params
                    )));
                }
                (true, scalar(false))
            }
            Node::Time => {
                if !inputs.time {
                    return Err(bad(format!("{what} may not depend on the time")));
                }
                flags.time = true;
                (false, scalar(true))
            }
            Node::Coord(k) => {
                if !inputs.position {
                    return Err(bad(format!("{what} may not depend on the coordinates")));
                }
                if k >= inputs.dof {
                    return Err(bad(format!(
                        "{what}: coordinate {k} does not exist ({} coordinates)",
                        inputs.dof
                    )));
                }
                flags.position = true;
                (false, scalar(true))
            }
            Node::Velocity(k) => {
                if !inputs.velocity {
                    return Err(bad(format!(
                        "{what} may not depend on the velocities (velocity {k} appears)"
                    )));
                }
                if k >= inputs.dof {
                    return Err(bad(format!(
                        "{what}: velocity {k} does not exist ({} coordinates)",
                        inputs.dof
                    )));
                }
                flags.velocity = true;
                (false, Some([None, Some(false), None]))
            }
            Node::Unary(f, a) => {
                let p = match f {
                    Unary::Neg => poly[a],
                    _ => poly_scalar(poly[a]).and_then(scalar),
                };
                (is_const[a], p)
            }
            Node::Binary(f, a, b) => {
                let p = match f {
                    Binary::Add | Binary::Sub => poly_merge(poly[a], poly[b]),
                    Binary::Mul => poly_mul(poly[a], poly[b]),
                    Binary::Div => {
                        poly_scalar(poly[b]).and_then(|dep| poly_mul(poly[a], scalar(dep)))
                    }
                    Binary::Pow | Binary::Atan2 => {
                        match (poly_scalar(poly[a]), poly_scalar(poly[b])) {
                            (Some(x), Some(y)) => scalar(x || y),
                            _ => None,
                        }
                    }
                };
                (is_const[a] && is_const[b], p)
            }
            Node::PowI(a, k) => {
                let p = match (poly_scalar(poly[a]), k) {
                    (Some(dep), _) => scalar(dep),
                    (None, 0) => scalar(false),
                    (None, 1) => poly[a],
                    (None, 2) => poly_mul(poly[a], poly[a]),
                    _ => None,
                };
                (is_const[a], p)
            }
        };
        is_const[i] = c;
        poly[i] = p;
    }
    flags.constant_hessian = outputs
        .iter()
        .all(|&o| poly[o].is_some_and(|p| p[2] != Some(true)));
    Ok(Analysis { flags, is_const })
}
