//! Taylor coefficients of the motion by series arithmetic on the expression graph (issue 16).
//!
//! Lagrange's equations are implicit in q̈: M(t, q) q̈ = f(t, q, q̇) (eq. 55, derived on the graph
//! by [`eom_graph`](super::eom_graph)). The normalized Taylor coefficients xₖ = x⁽ᵏ⁾(t₀)/k! of
//! the solution through (t₀, q₀, q̇₀) follow order by order: at order k the coefficients of q
//! and q̇ are known (qₖ = q̇ₖ₋₁/k, q̇ₖ = q̈ₖ₋₁/k), so every node of M and f gets its coefficient k
//! from the standard recurrences of truncated power series (products by convolution, quotients,
//! exp, log, sin and cos together, …), and q̈'s coefficient k from one solve with M₀ = M(t₀, q₀),
//! factored once per expansion:
//!
//! M₀ q̈ₖ = fₖ − Σⱼ₌₁..ₖ Mⱼ q̈ₖ₋ⱼ.
//!
//! No symbolic inverse of M is formed, so the cost is a few evaluations of the graph per order
//! at any number of coordinates. Each node keeps its whole series (and the auxiliary series its
//! recurrence needs: cos beside sin, 1 + tan² beside tan, ln a and b ln a beside aᵇ, …).

use std::sync::Arc;

use super::eom_program::EomGraph;
use super::graph::{Binary, Graph, Node, Unary};
use crate::eom;
use crate::error::{Error, Result};

/// The part of a graph that M and f need, renumbered, ready to expand.
#[derive(Debug, Clone)]
pub struct TaylorProgram {
    dof: usize,
    nodes: Vec<Node>,
    /// M's upper triangle and f, as indices into `nodes`.
    mass: Vec<usize>,
    force: Vec<usize>,
}

/// Where a node's auxiliary series start in [`Expansion::aux`], and how many it has.
fn aux_count(node: &Node) -> usize {
    match node {
        Node::Unary(Unary::Sin | Unary::Cos | Unary::Sinh | Unary::Cosh, _) => 1,
        Node::Unary(Unary::Tan | Unary::Tanh, _) => 1,
        Node::Binary(Binary::Pow, _, _) => 2,
        Node::Binary(Binary::Atan2, _, _) => 3,
        Node::PowI(_, n) => n.unsigned_abs() as usize,
        _ => 0,
    }
}

impl TaylorProgram {
    /// The nodes of `graph` that `eom`'s M and f read, in topological order.
    pub fn new(graph: &Graph, eom: &EomGraph) -> Self {
        let all = graph.nodes();
        let mut needed = vec![false; all.len()];
        for &o in eom.mass.iter().chain(&eom.force) {
            needed[o] = true;
        }
        for k in (0..all.len()).rev() {
            if !needed[k] {
                continue;
            }
            match all[k] {
                Node::Unary(_, a) | Node::PowI(a, _) => needed[a] = true,
                Node::Binary(_, a, b) => {
                    needed[a] = true;
                    needed[b] = true;
                }
                _ => {}
            }
        }
        let mut index = vec![usize::MAX; all.len()];
        let mut nodes = Vec::new();
        for (k, node) in all.iter().enumerate() {
            if !needed[k] {
                continue;
            }
            index[k] = nodes.len();
            nodes.push(match *node {
                Node::Unary(f, a) => Node::Unary(f, index[a]),
                Node::Binary(f, a, b) => Node::Binary(f, index[a], index[b]),
                Node::PowI(a, n) => Node::PowI(index[a], n),
                other => other,
            });
        }
        Self {
            dof: eom.dof,
            mass: eom.mass.iter().map(|&o| index[o]).collect(),
            force: eom.force.iter().map(|&o| index[o]).collect(),
            nodes,
        }
    }

    /// Number of coordinates.
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// Work space for expansions up to `order` with these parameter values.
    pub fn expansion(self: &Arc<Self>, params: &[f64], order: usize) -> Expansion {
        let width = order + 1;
        let aux: usize = self.nodes.iter().map(aux_count).sum();
        Expansion {
            program: self.clone(),
            params: params.to_vec(),
            order,
            series: vec![0.0; self.nodes.len() * width],
            aux: vec![0.0; aux * width],
            aux_start: self
                .nodes
                .iter()
                .scan(0, |next, node| {
                    let start = *next;
                    *next += aux_count(node);
                    Some(start)
                })
                .collect(),
            q: vec![0.0; self.dof * (width + 1)],
            v: vec![0.0; self.dof * (width + 1)],
            m0: vec![0.0; self.dof * self.dof],
            rhs: vec![0.0; self.dof],
        }
    }
}

/// The Taylor coefficients of one expansion and their work space.
#[derive(Debug, Clone)]
pub struct Expansion {
    program: Arc<TaylorProgram>,
    params: Vec<f64>,
    order: usize,
    /// Node i's coefficient k at `i * (order + 1) + k`.
    series: Vec<f64>,
    aux: Vec<f64>,
    aux_start: Vec<usize>,
    /// Coefficients of q and q̇: order k of coordinate i at `k * dof + i`, k = 0..=order + 1.
    q: Vec<f64>,
    v: Vec<f64>,
    m0: Vec<f64>,
    rhs: Vec<f64>,
}

impl Expansion {
    /// The highest order computed.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Coefficient k of q (k = 0..=order).
    pub fn q(&self, k: usize) -> &[f64] {
        let n = self.program.dof;
        &self.q[k * n..(k + 1) * n]
    }

    /// Coefficient k of q̇ (k = 0..=order).
    pub fn qd(&self, k: usize) -> &[f64] {
        let n = self.program.dof;
        &self.v[k * n..(k + 1) * n]
    }

    /// Expand the motion through (t₀, q₀, q̇₀) to `order` (given at creation).
    ///
    /// # Errors
    /// [`Error::SingularMassMatrix`] when M(t₀, q₀) cannot be factored, [`Error::NonFinite`]
    /// when a coefficient is not finite (a singularity of the model within reach, or a
    /// function at a point where its series does not exist, such as √x at x = 0).
    pub fn expand(&mut self, t0: f64, q0: &[f64], qd0: &[f64]) -> Result<()> {
        let n = self.program.dof;
        self.q[..n].copy_from_slice(q0);
        self.v[..n].copy_from_slice(qd0);
        for k in 0..=self.order {
            // q and q̇ of order k are known; every node's coefficient k follows.
            for i in 0..self.program.nodes.len() {
                let c = self.coefficient(i, k, t0);
                self.series[i * (self.order + 1) + k] = c;
            }
            if k == 0 {
                self.mass_at(0);
                let q = q0.to_vec();
                eom::factor(&mut self.m0, n, t0, &q)?;
            }
            if k == self.order {
                break;
            }
            // M₀ q̈ₖ = fₖ − Σⱼ₌₁..ₖ Mⱼ q̈ₖ₋ⱼ, with q̈ₖ₋ⱼ = (k − j + 1) q̇ₖ₋ⱼ₊₁.
            for r in 0..n {
                let mut s = self.at(self.program.force[r], k);
                for j in 1..=k {
                    for c in 0..n {
                        let a = (k - j + 1) as f64 * self.v[(k - j + 1) * n + c];
                        s -= self.mass_entry(r, c, j) * a;
                    }
                }
                self.rhs[r] = s;
            }
            eom::solve(&self.m0, n, t0, &mut self.rhs)?;
            let next = (k + 1) as f64;
            for i in 0..n {
                self.q[(k + 1) * n + i] = self.v[k * n + i] / next;
                self.v[(k + 1) * n + i] = self.rhs[i] / next;
            }
            if !self.rhs.iter().all(|x| x.is_finite()) {
                return Err(Error::NonFinite {
                    what: "Taylor coefficient",
                    t: t0,
                });
            }
        }
        Ok(())
    }

    /// y(t₀ + h) = Σₖ (q, q̇)ₖ hᵏ by Horner's rule, into `out` = (q, q̇).
    pub fn eval(&self, h: f64, out: &mut [f64]) {
        let n = self.program.dof;
        for i in 0..n {
            let (mut q, mut v) = (0.0, 0.0);
            for k in (0..=self.order).rev() {
                q = q * h + self.q[k * n + i];
                v = v * h + self.v[k * n + i];
            }
            out[i] = q;
            out[n + i] = v;
        }
    }

    fn at(&self, node: usize, k: usize) -> f64 {
        self.series[node * (self.order + 1) + k]
    }

    fn aux_at(&self, node: usize, which: usize, k: usize) -> f64 {
        self.aux[(self.aux_start[node] + which) * (self.order + 1) + k]
    }

    fn set_aux(&mut self, node: usize, which: usize, k: usize, x: f64) {
        let w = self.order + 1;
        self.aux[(self.aux_start[node] + which) * w + k] = x;
    }

    /// Mⱼ(r, c) from the upper triangle.
    fn mass_entry(&self, r: usize, c: usize, j: usize) -> f64 {
        let n = self.program.dof;
        let (i, l) = if r <= c { (r, c) } else { (c, r) };
        self.at(self.program.mass[i * n - i * (i + 1) / 2 + l], j)
    }

    fn mass_at(&mut self, j: usize) {
        let n = self.program.dof;
        for r in 0..n {
            for c in 0..n {
                self.m0[r * n + c] = self.mass_entry(r, c, j);
            }
        }
    }

    /// Σⱼ₌₁..ₖ j aⱼ bₖ₋ⱼ, the convolution of the recurrences of functions with x′ = g(x) a′.
    fn weighted(&self, a: usize, k: usize, b: impl Fn(usize) -> f64) -> f64 {
        (1..=k).map(|j| j as f64 * self.at(a, j) * b(k - j)).sum()
    }

    /// Coefficient k of node i, its inputs' coefficients up to k and its own below k known.
    fn coefficient(&mut self, i: usize, k: usize, t0: f64) -> f64 {
        let n = self.program.dof;
        let kf = k as f64;
        match self.program.nodes[i] {
            Node::Const(x) => {
                if k == 0 {
                    x
                } else {
                    0.0
                }
            }
            Node::Param(p) => {
                if k == 0 {
                    self.params[p]
                } else {
                    0.0
                }
            }
            Node::Time => match k {
                0 => t0,
                1 => 1.0,
                _ => 0.0,
            },
            Node::Coord(c) => self.q[k * n + c],
            Node::Velocity(c) => self.v[k * n + c],
            Node::Unary(f, a) => {
                let x = |k: usize| self.at(a, k);
                match f {
                    Unary::Neg => -x(k),
                    Unary::Sin | Unary::Cos | Unary::Sinh | Unary::Cosh => {
                        // The node and its partner (cos beside sin, …) together.
                        let (s, c) = if k == 0 {
                            match f {
                                Unary::Sin | Unary::Cos => x(0).sin_cos(),
                                _ => (x(0).sinh(), x(0).cosh()),
                            }
                        } else {
                            let (mine, partner) = (|j| self.at(i, j), |j| self.aux_at(i, 0, j));
                            let (s_of, c_of): (&dyn Fn(usize) -> f64, &dyn Fn(usize) -> f64) =
                                match f {
                                    Unary::Sin | Unary::Sinh => (&mine, &partner),
                                    _ => (&partner, &mine),
                                };
                            let sign = if matches!(f, Unary::Sin | Unary::Cos) {
                                -1.0
                            } else {
                                1.0
                            };
                            (
                                self.weighted(a, k, c_of) / kf,
                                sign * self.weighted(a, k, s_of) / kf,
                            )
                        };
                        let (value, partner) = match f {
                            Unary::Sin | Unary::Sinh => (s, c),
                            _ => (c, s),
                        };
                        self.set_aux(i, 0, k, partner);
                        value
                    }
                    Unary::Tan | Unary::Tanh => {
                        // t′ = w a′ with w = 1 ± t² (aux 0).
                        let sign = if f == Unary::Tan { 1.0 } else { -1.0 };
                        let t = match (k, f) {
                            (0, Unary::Tan) => x(0).tan(),
                            (0, _) => x(0).tanh(),
                            _ => self.weighted(a, k, |j| self.aux_at(i, 0, j)) / kf,
                        };
                        let w = if k == 0 {
                            1.0 + sign * t * t
                        } else {
                            let inner: f64 =
                                (1..k).map(|j| self.at(i, j) * self.at(i, k - j)).sum();
                            sign * (2.0 * self.at(i, 0) * t + inner)
                        };
                        self.set_aux(i, 0, k, w);
                        t
                    }
                    Unary::Exp => {
                        if k == 0 {
                            x(0).exp()
                        } else {
                            self.weighted(a, k, |j| self.at(i, j)) / kf
                        }
                    }
                    Unary::Ln => {
                        if k == 0 {
                            x(0).ln()
                        } else {
                            let s: f64 = (1..k).map(|j| j as f64 * self.at(i, j) * x(k - j)).sum();
                            (x(k) - s / kf) / x(0)
                        }
                    }
                    Unary::Sqrt => {
                        if k == 0 {
                            x(0).sqrt()
                        } else {
                            let s: f64 = (1..k).map(|j| self.at(i, j) * self.at(i, k - j)).sum();
                            (x(k) - s) / (2.0 * self.at(i, 0))
                        }
                    }
                    Unary::Abs => {
                        if x(0) > 0.0 {
                            x(k)
                        } else {
                            -x(k)
                        }
                    }
                    Unary::Sign => {
                        if k > 0 {
                            0.0
                        } else if x(0) > 0.0 {
                            1.0
                        } else {
                            -1.0
                        }
                    }
                }
            }
            Node::Binary(f, a, b) => {
                let (x, y) = (|k: usize| self.at(a, k), |k: usize| self.at(b, k));
                match f {
                    Binary::Add => x(k) + y(k),
                    Binary::Sub => x(k) - y(k),
                    Binary::Mul => (0..=k).map(|j| x(j) * y(k - j)).sum(),
                    Binary::Div => {
                        let s: f64 = (1..=k).map(|j| y(j) * self.at(i, k - j)).sum();
                        (x(k) - s) / y(0)
                    }
                    Binary::Pow => {
                        // aᵇ = exp(m), m = b · ln a: aux 0 is ln a, aux 1 is m.
                        let l = if k == 0 {
                            x(0).ln()
                        } else {
                            let s: f64 = (1..k)
                                .map(|j| j as f64 * self.aux_at(i, 0, j) * x(k - j))
                                .sum();
                            (x(k) - s / kf) / x(0)
                        };
                        let value = x(0).powf(y(0));
                        self.set_aux(i, 0, k, l);
                        let m: f64 = (0..=k)
                            .map(|j| self.at(b, j) * self.aux_at(i, 0, k - j))
                            .sum();
                        self.set_aux(i, 1, k, m);
                        if k == 0 {
                            value
                        } else {
                            (1..=k)
                                .map(|j| j as f64 * self.aux_at(i, 1, j) * self.at(i, k - j))
                                .sum::<f64>()
                                / kf
                        }
                    }
                    Binary::Atan2 => {
                        // θ = atan2(y, x) of the point (x, y) = (b, a): θ′ = N / D with
                        // N = x y′ − y x′, D = x² + y²; aux N, D, R = N / D.
                        let (num, den) = (|j| self.at(a, j), |j| self.at(b, j));
                        let d: f64 = (0..=k)
                            .map(|j| den(j) * den(k - j) + num(j) * num(k - j))
                            .sum();
                        let angle = num(0).atan2(den(0));
                        let m = k.saturating_sub(1);
                        let nm: f64 = (0..=m)
                            .map(|j| {
                                let d = (m - j + 1) as f64;
                                den(j) * d * num(m - j + 1) - num(j) * d * den(m - j + 1)
                            })
                            .sum();
                        self.set_aux(i, 1, k, d);
                        if k == 0 {
                            return angle;
                        }
                        self.set_aux(i, 0, m, nm);
                        let s: f64 = (1..=m)
                            .map(|j| self.aux_at(i, 1, j) * self.aux_at(i, 2, m - j))
                            .sum();
                        let r = (nm - s) / self.aux_at(i, 1, 0);
                        self.set_aux(i, 2, m, r);
                        r / kf
                    }
                }
            }
            Node::PowI(a, p) => {
                // Powers by products: aux j − 1 holds a^(j+1)'s series for j = 1..|p| − 1, the
                // last aux a^|p| (then 1 / a^|p| for p < 0).
                if p == 0 {
                    return if k == 0 { 1.0 } else { 0.0 };
                }
                let m = p.unsigned_abs() as usize;
                let mut prev_value = self.at(a, k);
                for j in 1..m {
                    // a^(j+1) = a · a^j.
                    let v: f64 = (0..=k)
                        .map(|l| {
                            let pj = if j == 1 {
                                self.at(a, k - l)
                            } else {
                                self.aux_at(i, j - 2, k - l)
                            };
                            self.at(a, l) * pj
                        })
                        .sum();
                    self.set_aux(i, j - 1, k, v);
                    prev_value = v;
                }
                if p > 0 {
                    prev_value
                } else {
                    // c = 1 / b with b = a^m: c_k = (δₖ₀ − Σⱼ₌₁..ₖ bⱼ cₖ₋ⱼ) / b₀.
                    let b = |j: usize| {
                        if m == 1 {
                            self.at(a, j)
                        } else {
                            self.aux_at(i, m - 2, j)
                        }
                    };
                    let s: f64 = (1..=k).map(|j| b(j) * self.at(i, k - j)).sum();
                    (if k == 0 { 1.0 } else { 0.0 } - s) / b(0)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::{Method, Options, solve};
    use crate::tape::{Energies, EnergyModel, Function, Inputs, Tape, eom_graph, models};
    use std::sync::Arc;

    /// M, f derived from `parts` on `g`, its expansion program, and the same model through the
    /// tapes' dual numbers (the reference the coefficients are checked against).
    fn setup(
        g: &mut Graph,
        dof: usize,
        parts: &Energies,
        params: &[f64],
    ) -> (TaylorProgram, EnergyModel) {
        let eom = eom_graph(g, dof, parts).unwrap();
        let program = TaylorProgram::new(g, &eom);
        let f = |nodes: &[usize], inputs: Inputs| {
            Function::new(
                Arc::new(Tape::new(g, nodes, inputs, "part").unwrap()),
                params,
            )
            .unwrap()
        };
        let all = Inputs::kinetic(dof, params.len());
        let model = EnergyModel::new(
            dof,
            f(&[parts.kinetic], all),
            parts
                .potential
                .map(|u| f(&[u], Inputs::potential(dof, params.len()))),
            parts.dissipation.map(|r| f(&[r], all)),
            parts.forces.as_ref().map(|q| f(q, all)),
        )
        .unwrap();
        (program, model)
    }

    /// x = cos t from (1, 0) under T = ½ẋ², U = ½x²: xₖ = cos⁽ᵏ⁾(0)/k!.
    #[test]
    fn oscillator_coefficients_are_those_of_cos() {
        let mut g = Graph::new();
        let (x, v, half) = (g.coord(0), g.velocity(0), g.constant(0.5));
        let v2 = g.powi(v, 2).unwrap();
        let x2 = g.powi(x, 2).unwrap();
        let parts = Energies {
            kinetic: g.binary(Binary::Mul, half, v2).unwrap(),
            potential: Some(g.binary(Binary::Mul, half, x2).unwrap()),
            dissipation: None,
            forces: None,
        };
        let (program, _) = setup(&mut g, 1, &parts, &[]);
        let program = Arc::new(program);
        let mut e = program.expansion(&[], 24);
        e.expand(0.0, &[1.0], &[0.0]).unwrap();
        let mut factorial = 1.0;
        for k in 0..=24 {
            if k > 0 {
                factorial *= k as f64;
            }
            let want = match k % 4 {
                0 => 1.0,
                2 => -1.0,
                _ => 0.0,
            } / factorial;
            assert!(
                (e.q(k)[0] - want).abs() <= 4e-16 * want.abs(),
                "{k}: {} vs {want}",
                e.q(k)[0]
            );
        }
    }

    /// The expansion of a model over every function — M depending on q, L on t and q̇,
    /// damping and forces — summed at a step h agrees with a tight DOP853 run to round-off.
    #[test]
    fn expansion_agrees_with_an_integration_for_every_function() {
        let mut g = Graph::new();
        let (x, v, t, p) = (g.coord(0), g.velocity(0), g.time(), g.param(0));
        let c = |g: &mut Graph, k: f64| g.constant(k);
        let mul = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Mul, a, b).unwrap();
        let add = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Add, a, b).unwrap();
        let un = |g: &mut Graph, f: Unary, a: usize| g.unary(f, a).unwrap();
        // T = ½ (2 + ½ sin x) ẋ² + 0.1 t x ẋ
        let s = un(&mut g, Unary::Sin, x);
        let (half, two) = (c(&mut g, 0.5), c(&mut g, 2.0));
        let hs = mul(&mut g, half, s);
        let m = add(&mut g, two, hs);
        let v2 = g.powi(v, 2).unwrap();
        let mv = mul(&mut g, m, v2);
        let kin = mul(&mut g, half, mv);
        let tenth = c(&mut g, 0.1);
        let tx = mul(&mut g, t, x);
        let txv = mul(&mut g, tx, v);
        let gyro = mul(&mut g, tenth, txv);
        let kinetic = add(&mut g, kin, gyro);
        // U = ½ p x² + 0.01 Σ (every function of x)
        let x2 = g.powi(x, 2).unwrap();
        let px2 = mul(&mut g, p, x2);
        let mut u = mul(&mut g, half, px2);
        let mut terms = Vec::new();
        let k03 = c(&mut g, 0.3);
        let x03 = mul(&mut g, k03, x);
        terms.push(un(&mut g, Unary::Tan, x03));
        terms.push(un(&mut g, Unary::Exp, x03));
        let x2p = add(&mut g, two, x);
        terms.push(un(&mut g, Unary::Ln, x2p));
        terms.push(un(&mut g, Unary::Sqrt, x2p));
        terms.push(un(&mut g, Unary::Sinh, x03));
        terms.push(un(&mut g, Unary::Cosh, x03));
        terms.push(un(&mut g, Unary::Tanh, x));
        terms.push(un(&mut g, Unary::Cos, x03));
        let k17 = c(&mut g, 1.7);
        terms.push(g.binary(Binary::Pow, x2p, k17).unwrap());
        terms.push(g.binary(Binary::Pow, x2p, x03).unwrap());
        terms.push(g.binary(Binary::Atan2, x, two).unwrap());
        terms.push(g.binary(Binary::Atan2, two, x2p).unwrap());
        let five = c(&mut g, 5.0);
        let x5 = add(&mut g, x, five);
        terms.push(un(&mut g, Unary::Abs, x5));
        terms.push(g.powi(x2p, -2).unwrap());
        terms.push(g.powi(x, 3).unwrap());
        let ct = un(&mut g, Unary::Cos, t);
        terms.push(mul(&mut g, ct, x));
        terms.push(g.binary(Binary::Div, x, x2p).unwrap());
        let small = c(&mut g, 0.01);
        for term in terms {
            let st = mul(&mut g, small, term);
            u = add(&mut g, u, st);
        }
        // Φ = 0.05 ẋ², Q = 0.2 sin t
        let k005 = c(&mut g, 0.05);
        let dissipation = Some(mul(&mut g, k005, v2));
        let k02 = c(&mut g, 0.2);
        let st = un(&mut g, Unary::Sin, t);
        let forces = Some(vec![mul(&mut g, k02, st)]);
        let parts = Energies {
            kinetic,
            potential: Some(u),
            dissipation,
            forces,
        };
        let params = [1.3];
        let (program, model) = setup(&mut g, 1, &parts, &params);
        let program = Arc::new(program);
        let (t0, q0, v0) = (0.1, [0.3], [0.2]);
        let mut e = program.expansion(&params, 20);
        e.expand(t0, &q0, &v0).unwrap();
        // Order 2 is half the acceleration.
        let mut a = [0.0];
        crate::Dynamics::accelerations_into(&model, t0, &q0, &v0, &mut a).unwrap();
        assert!((2.0 * e.q(2)[0] - a[0]).abs() < 1e-14 * a[0].abs().max(1.0));
        for h in [0.05, -0.05, 0.1] {
            let options = Options::adaptive(1e-14, 1e-15);
            let sol = solve(&model, &q0, &v0, (t0, t0 + h), Method::Dop853, &options).unwrap();
            let (_, q, qd) = sol.last().unwrap();
            let mut y = [0.0; 2];
            e.eval(h, &mut y);
            assert!((y[0] - q[0]).abs() < 2e-13, "h = {h}: {} vs {}", y[0], q[0]);
            assert!(
                (y[1] - qd[0]).abs() < 2e-12,
                "h = {h}: {} vs {}",
                y[1],
                qd[0]
            );
        }
    }

    /// The double pendulum (M(q), two coordinates): the expansion summed at h against DOP853.
    #[test]
    fn double_pendulum_expansion() {
        let mut g = Graph::new();
        let parts = models::double_pendulum(&mut g).unwrap();
        let params = [1.0, 2.0, 1.5, 0.7, 9.81];
        let (program, model) = setup(&mut g, 2, &parts, &params);
        let program = Arc::new(program);
        let (q0, v0) = ([1.0, -0.5], [0.3, 2.0]);
        let mut e = program.expansion(&params, 22);
        e.expand(0.0, &q0, &v0).unwrap();
        let h = 0.05;
        let sol = solve(
            &model,
            &q0,
            &v0,
            (0.0, h),
            Method::Dop853,
            &Options::adaptive(1e-14, 1e-15),
        )
        .unwrap();
        let (_, q, qd) = sol.last().unwrap();
        let mut y = [0.0; 4];
        e.eval(h, &mut y);
        for i in 0..2 {
            assert!((y[i] - q[i]).abs() < 1e-13, "{y:?} vs {q:?}");
            assert!((y[2 + i] - qd[i]).abs() < 1e-12, "{y:?} vs {qd:?}");
        }
    }
}
