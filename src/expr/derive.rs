//! Forward-mode derivatives on the expression [`Graph`] itself: a tangent sweep turns nodes into
//! the nodes of their directional derivatives, so that derivatives are expressions too — shared
//! with the expressions they come from through the graph's hash-consing, simplified as they are
//! built, and compiled once into a tape instead of re-derived by dual numbers at every call.
//!
//! A sweep is seeded by the tangents of the inputs ([`Seeds`]: q̇ⱼ ↦ 1 for ∂/∂q̇ⱼ, or qⱼ ↦ q̇ⱼ and
//! t ↦ 1 for the derivative along the motion, or a parameter ↦ 1 for ∂/∂pᵢ). A node none of whose operands has a tangent has
//! none either (`None`, an exact zero), so a subgraph that does not read a seeded input costs
//! nothing. Construction simplifies 0·x, 1·x, x ± 0, −(−x) and operations on numbers; parameters
//! stay symbolic (they are bound later, by [`Function::new`](crate::tape::Function::new)).
//!
//! |x| has the derivative sign(x)·ẋ ([`Unary::Sign`]: the dual numbers' slope, finite at x = 0).

use super::functions::unary_functions;
use super::graph::{Binary, Graph, Node, Unary};
use crate::error::Result;

/// The tangents of the inputs for one sweep; inputs without a seed have tangent zero.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Seeds {
    seeds: Vec<(Node, usize)>,
}

impl Seeds {
    /// No seed.
    pub fn new() -> Self {
        Self::default()
    }

    /// t ↦ `tangent` (a node).
    pub fn time(mut self, tangent: usize) -> Self {
        self.seeds.push((Node::Time, tangent));
        self
    }

    /// qᵢ ↦ `tangent` (a node).
    pub fn coord(mut self, i: usize, tangent: usize) -> Self {
        self.seeds.push((Node::Coord(i), tangent));
        self
    }

    /// q̇ᵢ ↦ `tangent` (a node).
    pub fn velocity(mut self, i: usize, tangent: usize) -> Self {
        self.seeds.push((Node::Velocity(i), tangent));
        self
    }

    /// Parameter i ↦ `tangent` (a node): derivatives with respect to a parameter, such as the
    /// input matrix B of a linearization ([`input_matrix`](crate::tape::input_matrix)).
    pub fn param(mut self, i: usize, tangent: usize) -> Self {
        self.seeds.push((Node::Param(i), tangent));
        self
    }

    fn of(&self, leaf: Node) -> Option<usize> {
        self.seeds.iter().find(|(n, _)| *n == leaf).map(|&(_, t)| t)
    }
}

/// The tangent of `node` for `seeds`, as a node (a zero tangent is the number 0).
///
/// # Errors
/// [`Error::InvalidInput`](crate::Error::InvalidInput) when `node` or a seed is not a node of
/// the graph.
pub fn tangent(graph: &mut Graph, node: usize, seeds: &Seeds) -> Result<usize> {
    Ok(match tangents(graph, &[node], seeds)?[0] {
        Some(d) => d,
        None => graph.constant(0.0),
    })
}

/// The tangents of several `roots` in one sweep (intermediate tangents are computed once and
/// shared); `None` is an exact zero (the root does not read a seeded input).
///
/// # Errors
/// As [`tangent`].
pub fn tangents(graph: &mut Graph, roots: &[usize], seeds: &Seeds) -> Result<Vec<Option<usize>>> {
    let len = graph.len();
    let bad = |i: usize| crate::error::Error::InvalidInput {
        what: "expression",
        why: format!("node {i} is not a node of the graph"),
    };
    if let Some(&r) = roots.iter().find(|&&r| r >= len) {
        return Err(bad(r));
    }
    if let Some(&(_, s)) = seeds.seeds.iter().find(|(_, s)| *s >= len) {
        return Err(bad(s));
    }
    let Some(&top) = roots.iter().max() else {
        return Ok(Vec::new());
    };
    // Only the nodes the roots read.
    let mut live = vec![false; top + 1];
    for &r in roots {
        live[r] = true;
    }
    for i in (0..=top).rev() {
        if !live[i] {
            continue;
        }
        match graph.nodes()[i] {
            Node::Unary(_, a) | Node::PowI(a, _) => live[a] = true,
            Node::Binary(_, a, b) => {
                live[a] = true;
                live[b] = true;
            }
            _ => {}
        }
    }
    let mut d: Vec<Option<usize>> = vec![None; top + 1];
    let mut s = Simplify(graph);
    for i in (0..=top).filter(|&i| live[i]) {
        let node = s.0.nodes()[i];
        d[i] = match node {
            Node::Const(_) => None,
            Node::Param(_) | Node::Time | Node::Coord(_) | Node::Velocity(_) => seeds.of(node),
            Node::Unary(f, a) => match d[a] {
                None => None,
                Some(da) => s.unary_tangent(f, a, i, da)?,
            },
            Node::PowI(a, k) => match d[a] {
                None => None,
                Some(da) => {
                    // k aᵏ⁻¹ ȧ
                    let p = s.powi(a, k - 1)?;
                    let kc = s.0.constant(f64::from(k));
                    let kp = s.mul(kc, p)?;
                    s.mul_opt(Some(da), kp)?
                }
            },
            Node::Binary(f, a, b) => match (d[a], d[b]) {
                (None, None) => None,
                (da, db) => s.binary_tangent(f, a, b, i, da, db)?,
            },
        };
    }
    Ok(roots.iter().map(|&r| d[r]).collect())
}

/// Which inputs a [`gradient`] is taken with respect to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrt {
    /// The coordinates q.
    Position,
    /// The velocities q̇.
    Velocity,
}

/// The gradient of `root` with respect to the `dof` coordinates or velocities, by one reverse
/// sweep on the graph (adjoints as nodes); `None` is an exact zero.
///
/// One reverse sweep instead of `dof` tangent sweeps matters for sums over running sums (a
/// chain's T = Σₖ |Σ_{j≤k} ṙⱼ|²): the adjoints accumulate as shared suffix sums, so the gradient
/// costs O(size of T) nodes where `dof` tangents would cost O(dof · size of T).
///
/// # Errors
/// As [`tangent`].
pub fn gradient(
    graph: &mut Graph,
    root: usize,
    wrt: Wrt,
    dof: usize,
) -> Result<Vec<Option<usize>>> {
    if root >= graph.len() {
        return Err(crate::error::Error::InvalidInput {
            what: "expression",
            why: format!("node {root} is not a node of the graph"),
        });
    }
    let bit = match wrt {
        Wrt::Position => POSITION,
        Wrt::Velocity => VELOCITY,
    };
    let r = reads(graph);
    let mut adj: Vec<Option<usize>> = vec![None; root + 1];
    let mut out = vec![None; dof];
    adj[root] = Some(graph.constant(1.0));
    let one = graph.constant(1.0);
    let mut s = Simplify(graph);
    for i in (0..=root).rev() {
        let Some(a) = adj[i] else { continue };
        let node = s.0.nodes()[i];
        let mut push = |s: &mut Simplify, x: usize, partial: Option<usize>| -> Result<()> {
            if r[x] & bit == 0 {
                return Ok(());
            }
            let Some(p) = partial else { return Ok(()) };
            let term = s.mul(a, p)?;
            adj[x] = s.sum(adj[x], Some(term))?;
            Ok(())
        };
        match node {
            Node::Coord(k) if wrt == Wrt::Position && k < dof => out[k] = Some(a),
            Node::Velocity(k) if wrt == Wrt::Velocity && k < dof => out[k] = Some(a),
            Node::Const(_) | Node::Param(_) | Node::Time | Node::Coord(_) | Node::Velocity(_) => {}
            Node::Unary(f, x) => {
                let p = s.unary_tangent(f, x, i, one)?;
                push(&mut s, x, p)?;
            }
            Node::PowI(x, k) => {
                let p = s.powi(x, k - 1)?;
                let kc = s.0.constant(f64::from(k));
                let kp = s.mul(kc, p)?;
                push(&mut s, x, Some(kp))?;
            }
            Node::Binary(f, x, y) => {
                if x == y {
                    // Both partials in one: the tangent with ẋ = 1.
                    let p = s.binary_tangent(f, x, y, i, Some(one), Some(one))?;
                    push(&mut s, x, p)?;
                } else {
                    if r[x] & bit != 0 {
                        let p = s.binary_tangent(f, x, y, i, Some(one), None)?;
                        push(&mut s, x, p)?;
                    }
                    if r[y] & bit != 0 {
                        let p = s.binary_tangent(f, x, y, i, None, Some(one))?;
                        push(&mut s, y, p)?;
                    }
                }
            }
        }
    }
    Ok(out)
}

/// Node construction with the simplifications of a derivative: 0·x = 0, 1·x = x, x ± 0 = x,
/// −(−x) = x, operations on numbers folded, and operands of + and · in a canonical order so that
/// a + b and b + a are one node.
pub(crate) struct Simplify<'g>(pub(crate) &'g mut Graph);

impl Simplify<'_> {
    fn num(&self, i: usize) -> Option<f64> {
        match self.0.nodes()[i] {
            Node::Const(x) => Some(x),
            _ => None,
        }
    }

    fn is(&self, i: usize, x: f64) -> bool {
        self.num(i) == Some(x)
    }

    /// A folded number, or `None` when it is not finite (then the node stays symbolic).
    fn fold(&mut self, x: f64) -> Option<usize> {
        x.is_finite().then(|| self.0.constant(x))
    }

    pub(crate) fn add(&mut self, a: usize, b: usize) -> Result<usize> {
        if self.is(a, 0.0) {
            return Ok(b);
        }
        if self.is(b, 0.0) {
            return Ok(a);
        }
        if let (Some(x), Some(y)) = (self.num(a), self.num(b))
            && let Some(c) = self.fold(x + y)
        {
            return Ok(c);
        }
        // Like terms: c₁ x + c₂ x = (c₁ + c₂) x. A running sum Σₖ x of one term (the entries of
        // M of a chain whose velocities are running sums) becomes one product, not n additions.
        let (ca, xa) = self.coefficient(a);
        let (cb, xb) = self.coefficient(b);
        if xa == xb {
            let c = self.0.constant(ca + cb);
            return self.mul(c, xa);
        }
        self.0.binary(Binary::Add, a.min(b), a.max(b))
    }

    /// `a` as c · x with c a number (c = 1 when `a` is no such product).
    fn coefficient(&self, a: usize) -> (f64, usize) {
        match self.0.nodes()[a] {
            Node::Binary(Binary::Mul, x, y) => match (self.num(x), self.num(y)) {
                (Some(c), None) => (c, y),
                (None, Some(c)) => (c, x),
                _ => (1.0, a),
            },
            Node::Unary(Unary::Neg, x) => (-1.0, x),
            _ => (1.0, a),
        }
    }

    pub(crate) fn sub(&mut self, a: usize, b: usize) -> Result<usize> {
        if self.is(b, 0.0) {
            return Ok(a);
        }
        if self.is(a, 0.0) {
            return self.neg(b);
        }
        if a == b {
            return Ok(self.0.constant(0.0));
        }
        if let (Some(x), Some(y)) = (self.num(a), self.num(b))
            && let Some(c) = self.fold(x - y)
        {
            return Ok(c);
        }
        // a − (−b) = a + b
        if let Node::Unary(Unary::Neg, nb) = self.0.nodes()[b] {
            return self.add(a, nb);
        }
        self.0.binary(Binary::Sub, a, b)
    }

    pub(crate) fn mul(&mut self, a: usize, b: usize) -> Result<usize> {
        if self.is(a, 0.0) || self.is(b, 0.0) {
            return Ok(self.0.constant(0.0));
        }
        if self.is(a, 1.0) {
            return Ok(b);
        }
        if self.is(b, 1.0) {
            return Ok(a);
        }
        if self.is(a, -1.0) {
            return self.neg(b);
        }
        if self.is(b, -1.0) {
            return self.neg(a);
        }
        if let (Some(x), Some(y)) = (self.num(a), self.num(b))
            && let Some(c) = self.fold(x * y)
        {
            return Ok(c);
        }
        self.0.binary(Binary::Mul, a.min(b), a.max(b))
    }

    pub(crate) fn div(&mut self, a: usize, b: usize) -> Result<usize> {
        if self.is(a, 0.0) {
            return Ok(self.0.constant(0.0));
        }
        if self.is(b, 1.0) {
            return Ok(a);
        }
        if self.is(b, -1.0) {
            return self.neg(a);
        }
        if let (Some(x), Some(y)) = (self.num(a), self.num(b))
            && let Some(c) = self.fold(x / y)
        {
            return Ok(c);
        }
        self.0.binary(Binary::Div, a, b)
    }

    pub(crate) fn neg(&mut self, a: usize) -> Result<usize> {
        match self.0.nodes()[a] {
            Node::Const(x) => Ok(self.0.constant(-x)),
            Node::Unary(Unary::Neg, x) => Ok(x),
            _ => self.0.unary(Unary::Neg, a),
        }
    }

    fn unary(&mut self, f: Unary, a: usize) -> Result<usize> {
        if let Some(x) = self.num(a)
            && let Some(c) = self.fold(f.apply(x))
        {
            return Ok(c);
        }
        if f == Unary::Neg {
            return self.neg(a);
        }
        self.0.unary(f, a)
    }

    fn powi(&mut self, a: usize, k: i32) -> Result<usize> {
        match k {
            0 => Ok(self.0.constant(1.0)),
            1 => Ok(a),
            _ => {
                if let Some(x) = self.num(a)
                    && let Some(c) = self.fold(x.powi(k))
                {
                    return Ok(c);
                }
                self.0.powi(a, k)
            }
        }
    }

    fn pow(&mut self, a: usize, b: usize) -> Result<usize> {
        match self.num(b) {
            Some(0.0) => Ok(self.0.constant(1.0)),
            Some(1.0) => Ok(a),
            Some(y) if y.fract() == 0.0 && y.abs() <= 1024.0 => self.powi(a, y as i32),
            _ => {
                if let (Some(x), Some(y)) = (self.num(a), self.num(b))
                    && let Some(c) = self.fold(x.powf(y))
                {
                    return Ok(c);
                }
                self.0.binary(Binary::Pow, a, b)
            }
        }
    }

    /// `d · x`, with `None` for zero.
    fn mul_opt(&mut self, d: Option<usize>, x: usize) -> Result<Option<usize>> {
        d.map(|d| self.mul(d, x)).transpose()
    }

    /// The tangent of `y = f(a)` (node `y`) with ȧ = `da`: each function's rule is its entry
    /// in the table of `functions.rs`.
    fn unary_tangent(&mut self, f: Unary, a: usize, y: usize, da: usize) -> Result<Option<usize>> {
        macro_rules! tangents {
            ($($name:ident {
                doc: $doc:expr,
                name: $($py:literal)?,
                value: |$x:ident| $value:expr,
                tangent: |$d:ident, $a:ident, $y:ident, $da:ident| $tangent:expr,
                num: |$nx:ident| $num:expr,
                jet: |$jx:ident| $jet:expr,
                series: $series:expr,
                libm: $($sym:ident = $f:ident)?,
                ins: $u:ident, $ua:ident: $m:ident,
                dual_num: $($dn:ident)?,
            })*) => {
                match f {
                    $(Unary::$name => {
                        #[allow(unused_variables)]
                        let ($d, $a, $y, $da) = (&mut *self, a, y, Some(da));
                        $tangent
                    })*
                }
            };
        }
        unary_functions!(tangents)
    }

    /// The tangent of `y = f(a, b)` (node `y`) with ȧ = `da`, ḃ = `db` (`None` for zero).
    fn binary_tangent(
        &mut self,
        f: Binary,
        a: usize,
        b: usize,
        y: usize,
        da: Option<usize>,
        db: Option<usize>,
    ) -> Result<Option<usize>> {
        Ok(match f {
            Binary::Add => match (da, db) {
                (Some(x), Some(z)) => Some(self.add(x, z)?),
                (x, z) => x.or(z),
            },
            Binary::Sub => match (da, db) {
                (Some(x), Some(z)) => Some(self.sub(x, z)?),
                (Some(x), None) => Some(x),
                (None, Some(z)) => Some(self.neg(z)?),
                (None, None) => None,
            },
            Binary::Mul => {
                let l = self.mul_opt(da, b)?;
                let r = self.mul_opt(db, a)?;
                self.sum(l, r)?
            }
            Binary::Div => {
                // (ȧ − y ḃ) / b
                let ydb = self.mul_opt(db, y)?;
                let num = match (da, ydb) {
                    (Some(x), Some(z)) => self.sub(x, z)?,
                    (Some(x), None) => x,
                    (None, Some(z)) => self.neg(z)?,
                    (None, None) => return Ok(None),
                };
                Some(self.div(num, b)?)
            }
            Binary::Pow => {
                // b aᵇ⁻¹ ȧ + aᵇ ln a ḃ
                let l = match da {
                    Some(da) => {
                        let one = self.0.constant(1.0);
                        let bm1 = self.sub(b, one)?;
                        let p = self.pow(a, bm1)?;
                        let k = self.mul(b, p)?;
                        Some(self.mul(da, k)?)
                    }
                    None => None,
                };
                let r = match db {
                    Some(db) => {
                        let ln = self.unary(Unary::Ln, a)?;
                        let k = self.mul(y, ln)?;
                        Some(self.mul(db, k)?)
                    }
                    None => None,
                };
                self.sum(l, r)?
            }
            Binary::Atan2 => {
                // (b ȧ − a ḃ) / (a² + b²)
                let l = self.mul_opt(da, b)?;
                let r = self.mul_opt(db, a)?;
                let num = match (l, r) {
                    (Some(x), Some(z)) => self.sub(x, z)?,
                    (Some(x), None) => x,
                    (None, Some(z)) => self.neg(z)?,
                    (None, None) => return Ok(None),
                };
                let a2 = self.powi(a, 2)?;
                let b2 = self.powi(b, 2)?;
                let r2 = self.add(a2, b2)?;
                Some(self.div(num, r2)?)
            }
        })
    }

    /// `a + b` with `None` for zero.
    pub(crate) fn sum(&mut self, a: Option<usize>, b: Option<usize>) -> Result<Option<usize>> {
        Ok(match (a, b) {
            (Some(x), Some(z)) => Some(self.add(x, z)?),
            (x, z) => x.or(z),
        })
    }

    /// `a − b` with `None` for zero.
    pub(crate) fn diff(&mut self, a: Option<usize>, b: Option<usize>) -> Result<Option<usize>> {
        Ok(match (a, b) {
            (Some(x), Some(z)) => Some(self.sub(x, z)?),
            (x, None) => x,
            (None, Some(z)) => Some(self.neg(z)?),
        })
    }
}

/// What each node reads, as bits: [`TIME`], [`POSITION`], [`VELOCITY`].
pub(crate) fn reads(graph: &Graph) -> Vec<u8> {
    let nodes = graph.nodes();
    let mut r = vec![0u8; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        r[i] = match *node {
            Node::Const(_) | Node::Param(_) => 0,
            Node::Time => TIME,
            Node::Coord(_) => POSITION,
            Node::Velocity(_) => VELOCITY,
            Node::Unary(_, a) | Node::PowI(a, _) => r[a],
            Node::Binary(_, a, b) => r[a] | r[b],
        };
    }
    r
}

/// A node reads t.
pub(crate) const TIME: u8 = 1;
/// A node reads a coordinate.
pub(crate) const POSITION: u8 = 2;
/// A node reads a velocity.
pub(crate) const VELOCITY: u8 = 4;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simplify_folds_identities_and_like_terms() {
        let mut g = Graph::new();
        let x = g.coord(0);
        let p = g.param(0);
        let (zero, one, two, three) = (
            g.constant(0.0),
            g.constant(1.0),
            g.constant(2.0),
            g.constant(3.0),
        );
        let mut s = Simplify(&mut g);
        assert_eq!(s.mul(zero, x).unwrap(), zero);
        assert_eq!(s.mul(x, one).unwrap(), x);
        assert_eq!(s.add(x, zero).unwrap(), x);
        assert_eq!(s.sub(x, zero).unwrap(), x);
        let nx = s.neg(x).unwrap();
        assert_eq!(s.neg(nx).unwrap(), x);
        assert_eq!(s.add(two, three).unwrap(), s.0.constant(5.0));
        assert_eq!(s.mul(two, three).unwrap(), s.0.constant(6.0));
        // Parameters stay symbolic.
        let tp = s.mul(two, p).unwrap();
        assert!(matches!(s.0.nodes()[tp], Node::Binary(Binary::Mul, ..)));
        // x + x + x = 3 x, and a + b is b + a.
        let xx = s.add(x, x).unwrap();
        let xxx = s.add(xx, x).unwrap();
        assert_eq!(xxx, s.mul(three, x).unwrap());
        assert_eq!(s.add(x, p).unwrap(), s.add(p, x).unwrap());
        assert_eq!(s.add(x, nx).unwrap(), zero);
    }

    #[test]
    fn tangents_share_one_sweep() {
        // d/dq of sin q and of sin q · q in one sweep: cos q is built once.
        let mut g = Graph::new();
        let q = g.coord(0);
        let s = g.unary(Unary::Sin, q).unwrap();
        let sq = g.binary(Binary::Mul, s, q).unwrap();
        let one = g.constant(1.0);
        let d = tangents(&mut g, &[s, sq], &Seeds::new().coord(0, one)).unwrap();
        let cos = g.find(Node::Unary(Unary::Cos, q)).unwrap();
        assert_eq!(d[0], Some(cos));
        assert!(d[1].is_some());
        let seeds = Seeds::new().velocity(0, one);
        assert_eq!(tangents(&mut g, &[sq], &seeds).unwrap(), vec![None]);
    }

    #[test]
    fn parameter_seeds_differentiate_by_a_parameter() {
        // d/dp of p · sin q is sin q; of q alone, an exact zero; of another parameter, zero.
        let mut g = Graph::new();
        let q = g.coord(0);
        let p = g.param(0);
        let other = g.param(1);
        let s = g.unary(Unary::Sin, q).unwrap();
        let ps = g.binary(Binary::Mul, p, s).unwrap();
        let one = g.constant(1.0);
        let seeds = Seeds::new().param(0, one);
        assert_eq!(
            tangents(&mut g, &[ps, q, other], &seeds).unwrap(),
            vec![Some(s), None, None]
        );
    }
}
