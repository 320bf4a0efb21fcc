//! The expression graph a tape is compiled from: nodes in topological order, equal
//! subexpressions stored once (hash-consing).

use super::functions::unary_functions;
use crate::error::{Error, Result};
use std::collections::HashMap;
use std::hash::{Hash, Hasher};

/// `Some` of a row's optional field, or `None` when the row leaves it out.
macro_rules! optional {
    () => {
        None
    };
    ($e:expr) => {
        Some($e)
    };
}

/// Generates [`Unary`] and its methods from the table of `functions.rs`.
macro_rules! unary_enum {
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
        /// Functions of one argument.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Unary {
            $(#[doc = $doc] $name,)*
        }

        impl Unary {
            /// Every function of one argument (for tests and generators that must cover them
            /// all).
            pub const ALL: [Unary; [$(stringify!($name)),*].len()] = [$(Unary::$name),*];

            /// The function on a number (the constant program's arithmetic).
            pub(crate) fn apply(self, x: f64) -> f64 {
                match self {
                    $(Unary::$name => {
                        let $x = x;
                        $value
                    })*
                }
            }

            /// Its name in the expression language (`lg.<name>`, the operation of the nodes the
            /// Python side sends); `None` for a function only the crate builds.
            pub fn name(self) -> Option<&'static str> {
                match self {
                    $(Unary::$name => optional!($($py)?),)*
                }
            }

            /// The function of this name in the expression language ([`Unary::name`]).
            pub fn from_name(name: &str) -> Option<Unary> {
                Unary::ALL.into_iter().find(|f| f.name() == Some(name))
            }

            /// The maths library's function the compiled code calls for it, by the symbol it is
            /// registered under (`native/mod.rs`); none for a function that is an instruction
            /// of its own.
            pub(crate) fn libm(self) -> &'static [&'static str] {
                match self {
                    $(Unary::$name => &[$(stringify!($sym))?],)*
                }
            }
        }
    };
}

unary_functions!(unary_enum);

/// Functions of two arguments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Binary {
    /// a + b
    Add,
    /// a − b
    Sub,
    /// a · b
    Mul,
    /// a / b
    Div,
    /// aᵇ (a literal integral exponent becomes [`Node::PowI`], a literal ½ a square root)
    Pow,
    /// atan2(a, b), the angle of the point (b, a)
    Atan2,
}

impl Binary {
    /// Every function of two arguments.
    pub const ALL: [Binary; 6] = [
        Binary::Add,
        Binary::Sub,
        Binary::Mul,
        Binary::Div,
        Binary::Pow,
        Binary::Atan2,
    ];
}

/// `Binary::ALL` lists every variant: a new one fails to compile here until it is added there
/// (`Unary::ALL` is generated from the table).
#[allow(dead_code)]
fn every_function_is_listed(b: Binary) {
    match b {
        Binary::Add | Binary::Sub | Binary::Mul | Binary::Div | Binary::Pow | Binary::Atan2 => {}
    }
}

/// One node of a [`Graph`]; operands are indices of earlier nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Node {
    /// A number.
    Const(f64),
    /// Parameter `i`, a number fixed when the tape is bound
    /// ([`Function::new`](crate::tape::Function::new)).
    Param(usize),
    /// The time t.
    Time,
    /// Coordinate qᵢ.
    Coord(usize),
    /// Velocity q̇ᵢ.
    Velocity(usize),
    /// A function of one node.
    Unary(Unary, usize),
    /// A function of two nodes.
    Binary(Binary, usize, usize),
    /// An integer power.
    PowI(usize, i32),
}

/// A node as a hash-consing key: numbers are equal when their bits are.
#[derive(Debug, Clone, Copy)]
struct Key(Node);

impl PartialEq for Key {
    fn eq(&self, other: &Self) -> bool {
        match (self.0, other.0) {
            (Node::Const(x), Node::Const(y)) => x.to_bits() == y.to_bits(),
            (a, b) => a == b,
        }
    }
}

impl Eq for Key {}

impl Hash for Key {
    fn hash<H: Hasher>(&self, h: &mut H) {
        std::mem::discriminant(&self.0).hash(h);
        match self.0 {
            Node::Const(x) => x.to_bits().hash(h),
            Node::Param(i) | Node::Coord(i) | Node::Velocity(i) => i.hash(h),
            Node::Time => {}
            Node::Unary(f, a) => (f, a).hash(h),
            Node::Binary(f, a, b) => (f, a, b).hash(h),
            Node::PowI(a, n) => (a, n).hash(h),
        }
    }
}

/// Largest literal exponent turned into an integer power.
const MAX_POWI: f64 = 1024.0;

/// An expression graph: nodes in topological order, equal subexpressions stored once.
#[derive(Debug, Clone, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    index: HashMap<Key, usize>,
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of distinct nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the graph has no node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The nodes, in topological order.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Add a node (or find the equal one already there) and return its index.
    ///
    /// A literal integral exponent of [`Binary::Pow`] becomes [`Node::PowI`] and a literal ½ a
    /// square root, so that `x**2` costs a product and M's structure is recognised.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when an operand is not an earlier node, or a number is not
    /// finite.
    pub fn push(&mut self, node: Node) -> Result<usize> {
        let n = self.nodes.len();
        let bad = |why: String| {
            Err(Error::InvalidInput {
                what: "expression",
                why,
            })
        };
        let operands: &[usize] = match &node {
            Node::Unary(_, a) | Node::PowI(a, _) => std::slice::from_ref(a),
            Node::Binary(_, a, b) => &[*a, *b],
            Node::Const(x) if !x.is_finite() => {
                return bad(format!("the number {x} is not finite"));
            }
            _ => &[],
        };
        if let Some(&bad_operand) = operands.iter().find(|&&a| a >= n) {
            return bad(format!(
                "node {n} refers to node {bad_operand}, which is not an earlier node"
            ));
        }
        let node = match node {
            Node::Binary(Binary::Pow, a, b) => match self.nodes[b] {
                Node::Const(x) if x.fract() == 0.0 && x.abs() <= MAX_POWI => {
                    Node::PowI(a, x as i32)
                }
                Node::Const(0.5) => Node::Unary(Unary::Sqrt, a),
                _ => node,
            },
            _ => node,
        };
        let key = Key(node);
        if let Some(&i) = self.index.get(&key) {
            return Ok(i);
        }
        self.nodes.push(node);
        self.index.insert(key, n);
        Ok(n)
    }

    /// A number.
    ///
    /// # Panics
    /// If `x` is not finite.
    pub fn constant(&mut self, x: f64) -> usize {
        assert!(x.is_finite(), "a constant must be finite, got {x}");
        self.push(Node::Const(x)).expect("a leaf has no operands")
    }

    /// Parameter `i`.
    pub fn param(&mut self, i: usize) -> usize {
        self.push(Node::Param(i)).expect("a leaf has no operands")
    }

    /// The time t.
    pub fn time(&mut self) -> usize {
        self.push(Node::Time).expect("a leaf has no operands")
    }

    /// Coordinate qᵢ.
    pub fn coord(&mut self, i: usize) -> usize {
        self.push(Node::Coord(i)).expect("a leaf has no operands")
    }

    /// Velocity q̇ᵢ.
    pub fn velocity(&mut self, i: usize) -> usize {
        self.push(Node::Velocity(i))
            .expect("a leaf has no operands")
    }

    /// `f(a)`; see [`Graph::push`] for the errors.
    pub fn unary(&mut self, f: Unary, a: usize) -> Result<usize> {
        self.push(Node::Unary(f, a))
    }

    /// `f(a, b)`; see [`Graph::push`] for the errors.
    pub fn binary(&mut self, f: Binary, a: usize, b: usize) -> Result<usize> {
        self.push(Node::Binary(f, a, b))
    }

    /// `aⁿ`; see [`Graph::push`] for the errors.
    pub fn powi(&mut self, a: usize, n: i32) -> Result<usize> {
        self.push(Node::PowI(a, n))
    }

    /// The index of `node` if the graph holds it (as stored: no rewriting of powers).
    pub(crate) fn find(&self, node: Node) -> Option<usize> {
        self.index.get(&Key(node)).copied()
    }
}

impl Binary {
    /// The function on numbers (the constant program's arithmetic).
    pub(crate) fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
            Binary::Pow => a.powf(b),
            Binary::Atan2 => a.atan2(b),
        }
    }
}

/// [`Unary::Sign`] on a number.
#[inline(always)]
pub(crate) fn sign(x: f64) -> f64 {
    if x > 0.0 { 1.0 } else { -1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn graph_shares_equal_subexpressions() {
        let mut g = Graph::new();
        let x = g.coord(0);
        let a = g.unary(Unary::Sin, x).unwrap();
        let b = g.unary(Unary::Sin, x).unwrap();
        assert_eq!(a, b);
        assert_eq!(g.len(), 2);
    }

    #[test]
    fn names_of_the_functions_are_distinct_and_found_back() {
        let named: Vec<Unary> = Unary::ALL
            .into_iter()
            .filter(|f| f.name().is_some())
            .collect();
        for &f in &named {
            assert_eq!(Unary::from_name(f.name().unwrap()), Some(f), "{f:?}");
        }
        assert_eq!(
            named.len(),
            Unary::ALL.len() - 1,
            "only Sign is the crate's own"
        );
        assert_eq!(Unary::Sign.name(), None);
        assert_eq!(Unary::from_name("no such function"), None);
        // Ln is `log` in the expression language, as in NumPy and SymPy.
        assert_eq!(Unary::from_name("log"), Some(Unary::Ln));
    }

    #[test]
    fn graph_rejects_forward_references() {
        let mut g = Graph::new();
        assert!(matches!(
            g.push(Node::Unary(Unary::Sin, 0)),
            Err(Error::InvalidInput { .. })
        ));
    }
}
