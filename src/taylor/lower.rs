//! The lowering of M's and f's nodes to recurrences ([`Recurrences`]): a row per node and the
//! auxiliary rows some recurrences need, the rows fixed by the parameters apart from those the
//! state sets, and the folds that make a product or quotient by a number a scaling.

use super::series::SeriesOp;
use crate::expr::functions::unary_functions;
use crate::expr::graph::{Binary, Graph, Node, Unary};
use crate::linalg;
use std::collections::{HashMap, HashSet};

/// The Taylor recurrence a function of one argument is lowered to: its row's `series` in the
/// table of `expr/functions.rs`, each a dedicated [`SeriesOp`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Recurrence {
    /// [`SeriesOp::Neg`].
    Neg,
    /// One of the pair [`SeriesOp::SinCos`] computes together (`sine`: the first).
    SinCos { hyperbolic: bool, sine: bool },
    /// [`SeriesOp::Tan`], whose order 0 calls the function's own maths-library function.
    Tan { hyperbolic: bool },
    /// [`SeriesOp::Exp`].
    Exp,
    /// [`SeriesOp::Ln`].
    Ln,
    /// [`SeriesOp::Sqrt`].
    Sqrt,
    /// [`SeriesOp::Abs`].
    Abs,
    /// [`SeriesOp::Sign`] (order 0 only).
    Sign,
}

/// `recurrence(f)`: each function's row's `series`.
macro_rules! recurrences {
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
        /// The recurrence `f` is lowered to.
        pub(crate) fn recurrence(f: Unary) -> Recurrence {
            match f {
                $(Unary::$name => $series,)*
            }
        }
    };
}

unary_functions!(recurrences);

/// The part of a graph that M and f need, lowered to recurrences: the plain data that the
/// interpreter runs and the kernels compile.
#[derive(Debug, Clone)]
pub(crate) struct Recurrences {
    pub(crate) dof: usize,
    /// Rows in the table: one per node, then the auxiliary rows.
    pub(crate) rows: usize,
    /// The recurrences of the rows fixed by the parameters: run once per binding.
    pub(crate) fixed: Vec<SeriesOp>,
    /// The recurrences of the rows the state sets: what order 0 runs.
    pub(crate) order0: Vec<SeriesOp>,
    /// The recurrences of the nodes that depend on t, q or q̇: what orders ≥ 1 run.
    pub(crate) varying: Vec<SeriesOp>,
    /// Rows of the numbers and parameters (index into the parameters), written at binding.
    pub(crate) numbers: Vec<(usize, f64)>,
    pub(crate) params: Vec<(usize, usize)>,
    /// Rows of t and of each qᵢ, q̇ᵢ the model reads.
    pub(crate) time: Option<usize>,
    pub(crate) coords: Vec<Option<usize>>,
    pub(crate) velocities: Vec<Option<usize>>,
    /// Rows of f.
    pub(crate) force: Vec<usize>,
    /// Row of M(r, c) at r·n + c.
    pub(crate) mass_full: Vec<usize>,
    /// Whether M(r, c) (at r·n + c) depends on t or q: the entries that do not have Mⱼ = 0 for
    /// j ≥ 1 and no terms in Σⱼ Mⱼ q̈ₖ₋ⱼ (the diagonal of a chain's M, all of a constant M).
    pub(crate) mass_varying: Vec<bool>,
    /// Whether M depends on the parameters alone (then M₀ is factored once per expansion's
    /// work space).
    pub(crate) mass_constant: bool,
    /// Which entries of M₀'s factor L (at r·n + c, below the diagonal) may be nonzero, when
    /// M's zeros by structure make some zero ([`linalg::ldlt_pattern`]; `None`: none do): the
    /// solves skip those (a diagonal M: the ball, Kepler in polar coordinates, the forced
    /// two-mass).
    pub(crate) factor_nonzero: Option<Vec<bool>>,
}

/// How far a row's series reaches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Reach {
    /// A number fixed by the parameters: computed once per binding.
    Fixed,
    /// Set by the state at order 0, nothing beyond (sign(q), and what only scales it).
    Order0,
    /// A series in t.
    Varying,
}

/// Builds the recurrences, allocating auxiliary rows after the node rows.
struct Lowering {
    rows: usize,
    fixed: Vec<SeriesOp>,
    order0: Vec<SeriesOp>,
    varying: Vec<SeriesOp>,
}

impl Lowering {
    fn row(&mut self) -> usize {
        self.rows += 1;
        self.rows - 1
    }

    fn push(&mut self, op: SeriesOp, reach: Reach) {
        match reach {
            Reach::Fixed => self.fixed.push(op),
            Reach::Order0 => self.order0.push(op),
            Reach::Varying => {
                self.order0.push(op);
                self.varying.push(op);
            }
        }
    }
}

impl Lowering {
    /// Take the negations off every order where that changes no bit: a negation −a read by a
    /// sum or a difference becomes its sign (x + (−a) = x − a and x − (−a) = x + a exactly),
    /// one squared goes ((−a)² = a², every product of its sum exactly),
    /// read by a scaling it moves onto the constant ((−a) c = a (−c) exactly, −c computed once
    /// per binding); one left unread (and not M or f, which `outside` holds) is dropped. The
    /// derivatives of energies are full of them (∂U/∂q of −m g l cos θ, the signs of eq. 55).
    fn fold_negations(&mut self, outside: &HashSet<usize>) {
        let negated: HashMap<usize, usize> = (self.order0.iter())
            .filter_map(|op| match *op {
                SeriesOp::Neg { out, a } => Some((out, a)),
                _ => None,
            })
            .collect();
        if negated.is_empty() {
            return;
        }
        // The negated constants, as rows fixed at binding (of constants fixed at binding: not
        // of a row set at order 0 by the state, sign(x)).
        let state: HashSet<usize> = self.order0.iter().flat_map(SeriesOp::outputs).collect();
        let mut minus: HashMap<usize, usize> = HashMap::new();
        let mut rewrite = |op: SeriesOp, rows: &mut usize, fixed: &mut Vec<SeriesOp>| -> SeriesOp {
            match op {
                SeriesOp::Add { out, a, b } if negated.contains_key(&b) && a != b => {
                    SeriesOp::Sub {
                        out,
                        a,
                        b: negated[&b],
                    }
                }
                SeriesOp::Add { out, a, b } if negated.contains_key(&a) && a != b => {
                    SeriesOp::Sub {
                        out,
                        a: b,
                        b: negated[&a],
                    }
                }
                SeriesOp::Sub { out, a, b } if negated.contains_key(&b) && a != b => {
                    SeriesOp::Add {
                        out,
                        a,
                        b: negated[&b],
                    }
                }
                SeriesOp::Square { out, a } if negated.contains_key(&a) => SeriesOp::Square {
                    out,
                    a: negated[&a],
                },
                SeriesOp::Scale { out, a, c }
                    if negated.contains_key(&a) && !state.contains(&c) =>
                {
                    let c = *minus.entry(c).or_insert_with(|| {
                        *rows += 1;
                        fixed.push(SeriesOp::Neg {
                            out: *rows - 1,
                            a: c,
                        });
                        *rows - 1
                    });
                    SeriesOp::Scale {
                        out,
                        a: negated[&a],
                        c,
                    }
                }
                op => op,
            }
        };
        // Each operation is in `order0`, and the ones that vary in `varying` too: rewritten
        // alike, by their output.
        let mut rewritten: HashMap<SeriesOp, SeriesOp> = HashMap::new();
        for op in &mut self.order0 {
            let new = rewrite(*op, &mut self.rows, &mut self.fixed);
            rewritten.insert(*op, new);
            *op = new;
        }
        for op in &mut self.varying {
            *op = rewritten[op];
        }
        let read: HashSet<usize> = (self.order0.iter())
            .flat_map(SeriesOp::operands)
            .chain(outside.iter().copied())
            .collect();
        let unread = |op: &SeriesOp| matches!(op, SeriesOp::Neg { out, .. } if !read.contains(out));
        self.order0.retain(|op| !unread(op));
        self.varying.retain(|op| !unread(op));
    }
}

impl Lowering {
    /// Turn a quotient of a quotient by the same series, (x / b) / b, into one quotient by the
    /// square the program already computes, x / b², and −(x / b) / b into −(x / b²), when the
    /// inner quotient (and the negation) is read nowhere else: a convolution fewer at every
    /// order. Polar coordinates make them: ∂U/∂r of −μ/r is μ/r / r, beside M's r². The
    /// coefficients move by an ulp or so (one quotient by a rounded square for two quotients).
    fn fold_quotients(&mut self, outside: &HashSet<usize>) {
        let mut reads: HashMap<usize, usize> = HashMap::new();
        for r in self.order0.iter().flat_map(SeriesOp::operands) {
            *reads.entry(r).or_insert(0) += 1;
        }
        let once = |r: usize| reads.get(&r) == Some(&1) && !outside.contains(&r);
        let made: HashMap<usize, SeriesOp> = self.order0.iter().map(|op| (op.out(), *op)).collect();
        let varies: HashSet<SeriesOp> = self.varying.iter().copied().collect();
        // The squares the program computes at every order it computes them, by their operand.
        let squares: HashMap<usize, SeriesOp> = (self.order0.iter())
            .filter_map(|op| match *op {
                SeriesOp::Square { a, .. } => Some((a, *op)),
                _ => None,
            })
            .collect();
        // (old outer quotient, the inner ops it replaces, its replacements).
        let mut rewrites: Vec<(SeriesOp, Vec<SeriesOp>, Vec<SeriesOp>)> = Vec::new();
        // The rows of the ops rewritten so far: a rewrite touching one is left out (a quotient
        // of a quotient of a quotient folds its first two).
        let mut touched: HashSet<usize> = HashSet::new();
        for &op in &self.order0 {
            let SeriesOp::Div { out, a, b } = op else {
                continue;
            };
            let Some(&square) = squares.get(&b) else {
                continue;
            };
            // Computed before the quotient, at every order the quotient is.
            let position = |x: SeriesOp| self.order0.iter().position(|&o| o == x);
            if position(square) > position(op) || varies.contains(&op) && !varies.contains(&square)
            {
                continue;
            }
            let inner = |r: usize| match made.get(&r) {
                Some(&SeriesOp::Div { a: x, b: c, .. }) if c == b && once(r) => Some(x),
                _ => None,
            };
            let sq = square.out();
            if let Some(x) = inner(a) {
                let new = SeriesOp::Div { out, a: x, b: sq };
                if ![x, out, a].iter().any(|r| touched.contains(r)) {
                    touched.extend([out, a]);
                    rewrites.push((op, vec![made[&a]], vec![new]));
                }
            } else if let Some(&SeriesOp::Neg { a: m, .. }) = made.get(&a)
                && once(a)
                && let Some(x) = inner(m)
            {
                let quotient = SeriesOp::Div {
                    out: m,
                    a: x,
                    b: sq,
                };
                let negation = SeriesOp::Neg { out, a: m };
                if ![x, out, a, m].iter().any(|r| touched.contains(r)) {
                    touched.extend([out, a, m]);
                    rewrites.push((op, vec![made[&a], made[&m]], vec![quotient, negation]));
                }
            }
        }
        for (old, gone, new) in rewrites {
            for list in [&mut self.order0, &mut self.varying] {
                if let Some(at) = list.iter().position(|&o| o == old) {
                    list.splice(at..=at, new.iter().copied());
                }
                list.retain(|op| !gone.contains(op));
            }
        }
    }
}

impl Lowering {
    /// Fold a scaling of a scaling read nowhere else, (x c₁) c₂, into one, x (c₁ c₂), with
    /// c₁ c₂ a row fixed at binding (of constants fixed at binding): one operation fewer at every
    /// order. The derivatives of quadratic energies are full of them (∂U/∂x of ½ k (x₂ − x₁)²
    /// is (x₂ − x₁) 2 · ½ k). The products round once where they rounded twice: the
    /// coefficients move by an ulp or so, as the same model stated in another order would.
    fn fold_scalings(&mut self, outside: &HashSet<usize>) {
        let state: HashSet<usize> = self.order0.iter().flat_map(SeriesOp::outputs).collect();
        let mut reads: HashMap<usize, usize> = HashMap::new();
        for r in self.order0.iter().flat_map(SeriesOp::operands) {
            *reads.entry(r).or_insert(0) += 1;
        }
        // The scalings read once (and not M or f), by their row: (x, c₁) of x c₁.
        let mut inner: HashMap<usize, (usize, usize)> = (self.order0.iter())
            .filter_map(|op| match *op {
                SeriesOp::Scale { out, a, c }
                    if reads.get(&out) == Some(&1)
                        && !outside.contains(&out)
                        && !state.contains(&c) =>
                {
                    Some((out, (a, c)))
                }
                _ => None,
            })
            .collect();
        // One pass in order (operands come before their readers): a scaling of an inner one
        // becomes x (c₁ c₂), and is itself the inner one of the next, if it is one.
        let mut replaced: HashMap<SeriesOp, SeriesOp> = HashMap::new();
        let mut gone: HashSet<usize> = HashSet::new();
        for at in 0..self.order0.len() {
            let SeriesOp::Scale { out, a: s, c: c2 } = self.order0[at] else {
                continue;
            };
            if state.contains(&c2) {
                continue;
            }
            let Some((x, c1)) = inner.remove(&s) else {
                continue;
            };
            let c12 = self.row();
            self.fixed.push(SeriesOp::Scale {
                out: c12,
                a: c1,
                c: c2,
            });
            let new = SeriesOp::Scale { out, a: x, c: c12 };
            replaced.insert(self.order0[at], new);
            self.order0[at] = new;
            gone.insert(s);
            if let Some(outer) = inner.get_mut(&out) {
                *outer = (x, c12);
            }
        }
        let folded =
            |op: &SeriesOp| matches!(op, SeriesOp::Scale { out, .. } if gone.contains(out));
        self.order0.retain(|op| !folded(op));
        for op in &mut self.varying {
            if let Some(&new) = replaced.get(op) {
                *op = new;
            }
        }
        self.varying.retain(|op| !folded(op));
    }
}

impl Lowering {
    /// Read the row a copy copies, or a scaling by exactly 1 scales, in place of theirs, and drop
    /// them (in M and f, `outside`, too): no bit changes, and an operation fewer at every order.
    /// Powers make copies (x² is a square, copied into the node's row), and so does sin beside
    /// cos of one argument; the derivatives of ½ m v² scale by ½ · 2. Which numbers are 1 is
    /// known here, where the rows fixed by numbers alone are computed once (`numbers`): a row
    /// that reads a parameter, however far back, is not (sign(p) is ±1 whatever p is).
    fn alias_rows(&mut self, numbers: &[(usize, f64)], outside: [&mut [usize]; 2]) {
        let mut values = vec![0.0; self.rows];
        let mut known = vec![false; self.rows];
        for &(r, x) in numbers {
            (values[r], known[r]) = (x, true);
        }
        for op in &self.fixed {
            if op.operands().iter().all(|&r| known[r]) {
                op.apply(&mut values, 1, 0);
                for r in op.outputs() {
                    known[r] = true;
                }
            }
        }
        let alias: HashMap<usize, usize> = (self.order0.iter())
            .filter_map(|op| match *op {
                SeriesOp::Copy { out, a } => Some((out, a)),
                SeriesOp::Scale { out, a, c } if known[c] && values[c] == 1.0 => Some((out, a)),
                _ => None,
            })
            .collect();
        if alias.is_empty() {
            return;
        }
        // A row an alias reads may be an alias itself (chains end: each reads an earlier row).
        let resolve = |mut r: usize| {
            while let Some(&a) = alias.get(&r) {
                r = a;
            }
            r
        };
        for list in [&mut self.order0, &mut self.varying] {
            list.retain(|op| !alias.contains_key(&op.out()));
            for op in list.iter_mut() {
                for r in op.operands_mut() {
                    *r = resolve(*r);
                }
            }
        }
        for r in outside.into_iter().flatten() {
            *r = resolve(*r);
        }
    }

    /// Drop from the orders above 0 the recurrences whose rows no order above 0 reads there
    /// (nor M and f, `outside`): ω t feeding only sin ω t and cos ω t, which sum ω instead.
    /// Order 0 still computes them; no bit changes, and an operation fewer at every order.
    fn drop_unread_orders(&mut self, outside: &[usize]) {
        let mut read: HashSet<usize> = outside.iter().copied().collect();
        let mut kept = Vec::with_capacity(self.varying.len());
        for op in self.varying.iter().rev() {
            if op.outputs().iter().any(|r| read.contains(r)) {
                read.extend(op.operands_above_zero());
                kept.push(*op);
            }
        }
        kept.reverse();
        self.varying = kept;
    }
}

/// The derivative of a node's series, as a row: d/dt of what it is ([`Derivatives::of`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Derivative {
    /// Zero: a number or a parameter.
    Zero,
    Row(usize),
}

/// Rows for the derivatives a′ of the arguments of sin and cos where they are linear in the
/// velocities and t, so that `SeriesOp::SinCos` sums a′ₘ instead of weighing j aⱼ (made during the
/// lowering, whose state it borrows).
struct Derivatives<'a> {
    all: &'a [Node],
    row: &'a [usize],
    reach: &'a [Reach],
    velocity_rows: &'a [Option<usize>],
    low: &'a mut Lowering,
    numbers: &'a mut Vec<(usize, f64)>,
    velocities: &'a mut Vec<Option<usize>>,
    done: &'a mut HashMap<usize, Option<(Derivative, Reach)>>,
}

impl Derivatives<'_> {
    /// d/dt of node k's series and how far the derivative's series reaches: qᵢ′ is q̇ᵢ's row
    /// (made, and written with the other velocities, if the graph reads none), t′ a row of 1,
    /// a number's 0, and sums, differences, negations and products and quotients by constants
    /// follow; `None` for anything else (its series has no row of its derivative).
    fn of(&mut self, k: usize) -> Option<(Derivative, Reach)> {
        if let Some(&known) = self.done.get(&k) {
            return known;
        }
        // Fixed by the parameters (or, sign(x), by the state at order 0): nothing beyond order 0.
        if self.reach[self.row[k]] != Reach::Varying {
            return Some((Derivative::Zero, Reach::Fixed));
        }
        let fixed = |g: &Self, x: usize| g.reach[g.row[x]] != Reach::Varying;
        let derivative = match self.all[k] {
            Node::Const(_) | Node::Param(_) => Some((Derivative::Zero, Reach::Fixed)),
            Node::Coord(i) => {
                let r = match self.velocity_rows[i].or(self.velocities[i]) {
                    Some(r) => r,
                    None => {
                        let r = self.low.row();
                        self.velocities[i] = Some(r);
                        r
                    }
                };
                Some((Derivative::Row(r), Reach::Varying))
            }
            Node::Time => {
                let r = self.low.row();
                self.numbers.push((r, 1.0));
                Some((Derivative::Row(r), Reach::Fixed))
            }
            Node::Unary(Unary::Neg, a) => match self.of(a)? {
                (Derivative::Zero, reach) => Some((Derivative::Zero, reach)),
                (Derivative::Row(a), reach) => {
                    Some(self.push(|out| SeriesOp::Neg { out, a }, reach))
                }
            },
            Node::Binary(f @ (Binary::Add | Binary::Sub), a, b) => {
                match (self.of(a)?, self.of(b)?) {
                    ((Derivative::Zero, _), (Derivative::Zero, _)) => {
                        Some((Derivative::Zero, Reach::Fixed))
                    }
                    (x, (Derivative::Zero, _)) => Some(x),
                    ((Derivative::Zero, _), (Derivative::Row(b), reach)) => match f {
                        Binary::Add => Some((Derivative::Row(b), reach)),
                        _ => Some(self.push(|out| SeriesOp::Neg { out, a: b }, reach)),
                    },
                    ((Derivative::Row(a), ra), (Derivative::Row(b), rb)) => {
                        let reach = ra.max(rb);
                        Some(match f {
                            Binary::Add => self.push(|out| SeriesOp::Add { out, a, b }, reach),
                            _ => self.push(|out| SeriesOp::Sub { out, a, b }, reach),
                        })
                    }
                }
            }
            Node::Binary(Binary::Mul, a, b) if fixed(self, a) || fixed(self, b) => {
                let (x, c) = if fixed(self, a) { (b, a) } else { (a, b) };
                let c = self.row[c];
                match self.of(x)? {
                    (Derivative::Zero, reach) => Some((Derivative::Zero, reach)),
                    (Derivative::Row(a), reach) => {
                        let reach = reach.max(self.reach[c]);
                        Some(self.push(|out| SeriesOp::Scale { out, a, c }, reach))
                    }
                }
            }
            Node::Binary(Binary::Div, a, b) if fixed(self, b) => {
                let c = self.row[b];
                match self.of(a)? {
                    (Derivative::Zero, reach) => Some((Derivative::Zero, reach)),
                    (Derivative::Row(a), reach) => {
                        let reach = reach.max(self.reach[c]);
                        Some(self.push(|out| SeriesOp::DivC { out, a, c }, reach))
                    }
                }
            }
            _ => None,
        };
        self.done.insert(k, derivative);
        derivative
    }

    /// A new row computed by `op`, reaching as far as `reach`.
    fn push(&mut self, op: impl FnOnce(usize) -> SeriesOp, reach: Reach) -> (Derivative, Reach) {
        let out = self.low.row();
        self.low.push(op(out), reach);
        (Derivative::Row(out), reach)
    }
}

impl Recurrences {
    /// The nodes of `graph` that M (`mass_nodes`, its upper triangle by rows) and f
    /// (`force_nodes`) read, lowered to recurrences.
    pub(crate) fn new(
        graph: &Graph,
        dof: usize,
        mass_nodes: &[usize],
        force_nodes: &[usize],
    ) -> Self {
        let all = graph.nodes();
        let mut needed = vec![false; all.len()];
        for &o in mass_nodes.iter().chain(force_nodes) {
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
        // Node rows first, in topological order.
        let mut row = vec![usize::MAX; all.len()];
        let mut kept = Vec::new();
        for (k, _) in all.iter().enumerate().filter(|&(k, _)| needed[k]) {
            row[k] = kept.len();
            kept.push(k);
        }
        let mut low = Lowering {
            rows: kept.len(),
            fixed: Vec::new(),
            order0: Vec::new(),
            varying: Vec::new(),
        };
        let (mut numbers, mut params) = (Vec::new(), Vec::new());
        let (mut time, mut coords, mut velocities) = (None, vec![None; dof], vec![None; dof]);
        let mut reach = vec![Reach::Fixed; kept.len()];
        // The rows of the velocities the graph reads, and the derivatives of the arguments of sin
        // and cos made so far, by node.
        let velocity_rows: Vec<Option<usize>> = (0..dof)
            .map(|i| (kept.iter()).position(|&k| matches!(all[k], Node::Velocity(j) if j == i)))
            .collect();
        let mut derivatives: HashMap<usize, Option<(Derivative, Reach)>> = HashMap::new();
        // The degree of each node row's series when it is a polynomial in t (numbers 0, t 1),
        // None when it is not (the state's rows, and what they reach).
        let mut degree = vec![Some(0); kept.len()];
        // sin and cos (or sinh and cosh) of a row, computed together: (row, hyperbolic) → (s, c).
        let mut trig: HashMap<(usize, bool), (usize, usize)> = HashMap::new();
        for (out, &k) in kept.iter().enumerate() {
            let at = |r: usize| reach[r];
            let v = |r: usize| reach[r] == Reach::Varying;
            degree[out] = match all[k] {
                Node::Time => Some(1),
                Node::Coord(_) | Node::Velocity(_) => None,
                Node::Unary(_, a) | Node::PowI(a, _) if !v(row[a]) => Some(0),
                Node::Unary(Unary::Neg, a) => degree[row[a]],
                Node::PowI(a, n) if n >= 0 => degree[row[a]].map(|d| d * n.unsigned_abs() as usize),
                Node::Binary(Binary::Add | Binary::Sub, a, b) => {
                    degree[row[a]].zip(degree[row[b]]).map(|(x, y)| x.max(y))
                }
                Node::Binary(Binary::Mul, a, b) => {
                    degree[row[a]].zip(degree[row[b]]).map(|(x, y)| x + y)
                }
                Node::Binary(Binary::Div, a, b) if !v(row[b]) => degree[row[a]],
                Node::Binary(_, a, b) if !v(row[a]) && !v(row[b]) => Some(0),
                Node::Const(_) | Node::Param(_) => Some(0),
                _ => None,
            };
            let (op, var) = match all[k] {
                Node::Const(x) => {
                    numbers.push((out, x));
                    (None, Reach::Fixed)
                }
                Node::Param(p) => {
                    params.push((out, p));
                    (None, Reach::Fixed)
                }
                Node::Time | Node::Coord(_) | Node::Velocity(_) => {
                    match all[k] {
                        Node::Time => time = Some(out),
                        Node::Coord(i) => coords[i] = Some(out),
                        Node::Velocity(i) => velocities[i] = Some(out),
                        _ => unreachable!(),
                    }
                    (None, Reach::Varying)
                }
                Node::Unary(f, a) => {
                    let a = row[a];
                    let op = match recurrence(f) {
                        Recurrence::Neg => SeriesOp::Neg { out, a },
                        Recurrence::SinCos { hyperbolic, sine } => {
                            if let Some(&(s, c)) = trig.get(&(a, hyperbolic)) {
                                // Its partner is computed already (sin(θ₁ − θ₂) beside
                                // cos(θ₁ − θ₂)): a copy, not a second pair of sums.
                                SeriesOp::Copy {
                                    out,
                                    a: if sine { s } else { c },
                                }
                            } else {
                                let partner = low.row();
                                let (s, c) = if sine { (out, partner) } else { (partner, out) };
                                trig.insert((a, hyperbolic), (s, c));
                                let mut d = Derivatives {
                                    all,
                                    row: &row,
                                    reach: &reach,
                                    velocity_rows: &velocity_rows,
                                    low: &mut low,
                                    numbers: &mut numbers,
                                    velocities: &mut velocities,
                                    done: &mut derivatives,
                                };
                                let da = match d.of(kept[a]) {
                                    Some((Derivative::Row(r), _)) => Some(r),
                                    _ => None,
                                };
                                SeriesOp::SinCos {
                                    s,
                                    c,
                                    a,
                                    hyperbolic,
                                    degree: degree[a],
                                    da,
                                }
                            }
                        }
                        Recurrence::Tan { hyperbolic } => SeriesOp::Tan {
                            out,
                            w: low.row(),
                            a,
                            f,
                            hyperbolic,
                        },
                        Recurrence::Exp => SeriesOp::Exp { out, a },
                        Recurrence::Ln => SeriesOp::Ln { out, a },
                        Recurrence::Sqrt => SeriesOp::Sqrt { out, a },
                        Recurrence::Abs => SeriesOp::Abs { out, a },
                        // ±1: nothing beyond order 0.
                        Recurrence::Sign => {
                            let r = at(a).min(Reach::Order0);
                            low.push(SeriesOp::Sign { out, a }, r);
                            reach[out] = r;
                            continue;
                        }
                    };
                    (Some(op), at(a))
                }
                Node::Binary(f, a, b) => {
                    let (a, b) = (row[a], row[b]);
                    let var = at(a).max(at(b));
                    let op = match f {
                        Binary::Add => SeriesOp::Add { out, a, b },
                        Binary::Sub => SeriesOp::Sub { out, a, b },
                        Binary::Mul if !v(a) => SeriesOp::Scale { out, a: b, c: a },
                        Binary::Mul if !v(b) => SeriesOp::Scale { out, a, c: b },
                        Binary::Mul if a == b => SeriesOp::Square { out, a },
                        Binary::Mul => SeriesOp::Mul { out, a, b },
                        Binary::Div if !v(b) => SeriesOp::DivC { out, a, c: b },
                        Binary::Div => SeriesOp::Div { out, a, b },
                        Binary::Pow => {
                            // aᵇ = exp(b ln a).
                            let (l, m) = (low.row(), low.row());
                            low.push(SeriesOp::Ln { out: l, a }, at(a));
                            low.push(SeriesOp::Mul { out: m, a: b, b: l }, var);
                            SeriesOp::Exp { out, a: m }
                        }
                        Binary::Atan2 => SeriesOp::Atan2 {
                            out,
                            y: a,
                            x: b,
                            d: low.row(),
                            r: low.row(),
                        },
                    };
                    (Some(op), var)
                }
                Node::PowI(a, n) => {
                    let a = row[a];
                    if n == 0 {
                        // 1: a number.
                        numbers.push((out, 1.0));
                        reach[out] = Reach::Fixed;
                        continue;
                    }
                    // a^|n| by squaring, each product in a row of its own.
                    let (mut base, mut acc, mut m) = (a, None, n.unsigned_abs());
                    loop {
                        if m & 1 == 1 {
                            acc = Some(match acc {
                                None => base,
                                Some(r) => {
                                    let p = low.row();
                                    low.push(
                                        SeriesOp::Mul {
                                            out: p,
                                            a: r,
                                            b: base,
                                        },
                                        at(a),
                                    );
                                    p
                                }
                            });
                        }
                        m >>= 1;
                        if m == 0 {
                            break;
                        }
                        let sq = low.row();
                        low.push(SeriesOp::Square { out: sq, a: base }, at(a));
                        base = sq;
                    }
                    let power = acc.unwrap_or(a);
                    let op = if n > 0 {
                        SeriesOp::Copy { out, a: power }
                    } else {
                        SeriesOp::Recip { out, b: power }
                    };
                    (Some(op), at(a))
                }
            };
            reach[out] = var;
            if let Some(op) = op {
                low.push(op, var);
            }
        }
        let mut mass: Vec<usize> = mass_nodes.iter().map(|&o| row[o]).collect();
        let mut force: Vec<usize> = force_nodes.iter().map(|&o| row[o]).collect();
        let outside: HashSet<usize> = mass.iter().chain(&force).copied().collect();
        low.fold_quotients(&outside);
        low.fold_negations(&outside);
        low.fold_scalings(&outside);
        // M's reach is its node rows' (the rows they may read through after `alias_rows` are
        // auxiliary rows of the same reach).
        let mass_reach: Vec<Reach> = mass.iter().map(|&r| reach[r]).collect();
        low.alias_rows(&numbers, [&mut mass, &mut force]);
        low.drop_unread_orders(&[&mass[..], &force[..]].concat());
        // Entry of M(r, c) from the upper triangle, row by row.
        let upper = |r: usize, c: usize| {
            let (i, l) = if r <= c { (r, c) } else { (c, r) };
            i * dof - i * (i + 1) / 2 + l
        };
        let entries = (0..dof * dof).map(|e| upper(e / dof, e % dof));
        let mass_varying: Vec<bool> = entries
            .clone()
            .map(|e| mass_reach[e] == Reach::Varying)
            .collect();
        let mass_full: Vec<usize> = entries.map(|e| mass[e]).collect();
        let zero = |e: usize| {
            !mass_varying[e] && numbers.iter().any(|&(r, x)| r == mass_full[e] && x == 0.0)
        };
        let factor_nonzero =
            Some(linalg::ldlt_pattern(dof, zero)).filter(|p| !p.iter().all(|&x| x));
        Self {
            factor_nonzero,
            mass_varying,
            mass_full,
            dof,
            rows: low.rows,
            mass_constant: mass_reach.iter().all(|&r| r == Reach::Fixed),
            force,
            fixed: low.fixed,
            order0: low.order0,
            varying: low.varying,
            numbers,
            params,
            time,
            coords,
            velocities,
        }
    }

    /// [`TaylorProgram::expansion_instructions`](super::TaylorProgram::expansion_instructions).
    pub(crate) fn expansion_instructions(&self, order: usize) -> usize {
        let n = self.dof;
        (1..order)
            .map(|k| {
                let ops: usize = self.varying.iter().map(|op| 3 * op.terms(k) + 4).sum();
                let mass = 4 * self.mass_varying.iter().filter(|&&v| v).count() * k;
                ops + mass + 3 * n * n + 8 * n
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both forms `fold_quotients` rewrites, on a hand-made program: (x/b)/b and −(x/b)/b
    /// become x/b² and −(x/b²), with b² the program's own square, and give the series of the
    /// two quotients to rounding at every order.
    #[test]
    fn quotients_fold_in_both_forms() {
        // Rows: 0 = x, 1 = b, 2 = b², 3 = x/b, 4 = (x/b)/b, 5 = x/b again, 6 = −(x/b),
        // 7 = −(x/b)/b.
        let ops = vec![
            SeriesOp::Square { out: 2, a: 1 },
            SeriesOp::Div { out: 3, a: 0, b: 1 },
            SeriesOp::Div { out: 4, a: 3, b: 1 },
            SeriesOp::Div { out: 5, a: 0, b: 1 },
            SeriesOp::Neg { out: 6, a: 5 },
            SeriesOp::Div { out: 7, a: 6, b: 1 },
        ];
        let mut low = Lowering {
            rows: 8,
            fixed: Vec::new(),
            order0: ops.clone(),
            varying: ops.clone(),
        };
        low.fold_quotients(&HashSet::from([2, 4, 7]));
        let folded = vec![
            SeriesOp::Square { out: 2, a: 1 },
            SeriesOp::Div { out: 4, a: 0, b: 2 },
            SeriesOp::Div { out: 5, a: 0, b: 2 },
            SeriesOp::Neg { out: 7, a: 5 },
        ];
        assert_eq!(low.order0, folded);
        assert_eq!(low.varying, folded);
        let w = 17;
        let run = |ops: &[SeriesOp]| {
            let mut s = vec![0.0; 8 * w];
            for k in 0..w {
                s[k] = ((k * 5 % 7) as f64 - 2.9) / (k + 1) as f64;
                s[w + k] = 1.3 / (k * k + 1) as f64;
            }
            for k in 0..w {
                for op in ops {
                    op.apply(&mut s, w, k);
                }
            }
            s
        };
        let (before, after) = (run(&ops), run(&folded));
        for row in [4, 7] {
            for k in 0..w {
                let (a, b) = (after[row * w + k], before[row * w + k]);
                assert!(
                    (a - b).abs() <= 1e-13 * b.abs().max(1e-3),
                    "row {row} order {k}: {a} {b}"
                );
            }
        }
    }
}
