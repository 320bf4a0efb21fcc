//! [`Tape::new`]: the part of a [`Graph`] that some outputs need, compiled in named steps —
//! reachability, analysis (`analysis.rs`), constant folding into the `f64` parameter program,
//! instruction selection, and slot allocation with lowering to [`Ins`].

use super::analysis::{Flags, analyse};
use super::inputs::Inputs;
use super::ins::{Ins, InsOp, lower};
use crate::error::{Error, Result};
use crate::expr::graph::{Graph, Node, Unary};

/// A node of the `f64` program that computes the constants from the parameters; operands index
/// earlier constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ConstOp {
    Lit(f64),
    Param(usize),
    Unary(Unary, usize),
    Binary(crate::expr::graph::Binary, usize, usize),
    PowI(usize, i32),
}

/// An input of a tape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Input {
    Time,
    Coord(usize),
    Velocity(usize),
}

/// Where an output is read from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Out {
    Slot(u32),
    Const(u32),
}

/// A compiled expression with one or more outputs, not yet bound to parameter values.
#[derive(Debug, Clone, PartialEq)]
pub struct Tape {
    pub(crate) inputs: Inputs,
    /// The slot each input that appears is written to.
    pub(crate) input_slots: Vec<(u32, Input)>,
    pub(crate) consts: Vec<ConstOp>,
    pub(crate) code: Vec<Ins>,
    pub(crate) slots: usize,
    pub(crate) outputs: Vec<Out>,
    pub(crate) flags: Flags,
}

/// No node (an unused destination or operand of a selected instruction).
const NONE: usize = usize::MAX;

/// An instruction on node ids: (op, destination nodes, operand nodes).
type Selected = (InsOp, [usize; 2], [usize; 2]);

/// The code and slots of [`allocate`].
struct Lowered {
    input_slots: Vec<(u32, Input)>,
    code: Vec<Ins>,
    slots: u32,
    slot_of: Vec<u32>,
}

impl Tape {
    /// Compile the nodes of `graph` that `outputs` need. `what` names the expression in error
    /// messages ("potential", "force on coordinate 2", …).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when an output is not a node of the graph, or the expression reads
    /// something `inputs` does not allow (a velocity in a potential, a coordinate beyond `dof`,
    /// an unknown parameter).
    pub fn new(graph: &Graph, outputs: &[usize], inputs: Inputs, what: &str) -> Result<Self> {
        let nodes = graph.nodes();
        if let Some(&o) = outputs.iter().find(|&&o| o >= nodes.len()) {
            return Err(Error::InvalidInput {
                what: "expression",
                why: format!("{what}: output {o} is not a node of the graph"),
            });
        }
        let live = reachable(nodes, outputs);
        let analysis = analyse(nodes, &live, outputs, inputs, what)?;
        let is_const = &analysis.is_const;
        let (consts, const_of) = constant_program(nodes, &live, is_const);
        let selected = select(graph, &live, is_const, &const_of);
        let lowered = allocate(nodes, &live, &selected, outputs);
        let outputs = outputs
            .iter()
            .map(|&o| {
                if is_const[o] {
                    Out::Const(const_of[o] as u32)
                } else {
                    Out::Slot(lowered.slot_of[o])
                }
            })
            .collect();
        Ok(Self {
            inputs,
            input_slots: lowered.input_slots,
            consts,
            code: lowered.code,
            slots: lowered.slots as usize,
            outputs,
            flags: analysis.flags,
        })
    }

    /// Number of outputs.
    pub fn outputs(&self) -> usize {
        self.outputs.len()
    }

    /// What the tape may read.
    pub fn inputs(&self) -> Inputs {
        self.inputs
    }

    /// Number of instructions evaluated per call (constants excluded).
    pub fn instructions(&self) -> usize {
        self.code.len()
    }

    /// Whether t appears.
    pub fn depends_on_time(&self) -> bool {
        self.flags.time
    }

    /// Whether a coordinate appears.
    pub fn depends_on_position(&self) -> bool {
        self.flags.position
    }

    /// Whether a velocity appears.
    pub fn depends_on_velocity(&self) -> bool {
        self.flags.velocity
    }

    /// Whether every output is a polynomial of degree ≤ 2 in q̇ whose quadratic part has
    /// constant coefficients: for a kinetic energy, M = ∂²T/∂q̇² is then constant.
    pub fn constant_mass_matrix(&self) -> bool {
        self.flags.constant_hessian
    }
}

/// The nodes the outputs need (operands always precede their node).
fn reachable(nodes: &[Node], outputs: &[usize]) -> Vec<bool> {
    let mut live = vec![false; nodes.len()];
    for &o in outputs {
        live[o] = true;
    }
    for i in (0..nodes.len()).rev() {
        if !live[i] {
            continue;
        }
        match nodes[i] {
            Node::Unary(_, a) | Node::PowI(a, _) => live[a] = true,
            Node::Binary(_, a, b) => {
                live[a] = true;
                live[b] = true;
            }
            _ => {}
        }
    }
    live
}

/// The `f64` program of the live constant nodes, and the index of each node's constant in it.
fn constant_program(
    nodes: &[Node],
    live: &[bool],
    is_const: &[bool],
) -> (Vec<ConstOp>, Vec<usize>) {
    let mut const_of = vec![usize::MAX; nodes.len()];
    let mut consts = Vec::new();
    for i in (0..nodes.len()).filter(|&i| live[i] && is_const[i]) {
        let op = match nodes[i] {
            Node::Const(x) => ConstOp::Lit(x),
            Node::Param(k) => ConstOp::Param(k),
            Node::Unary(f, a) => ConstOp::Unary(f, const_of[a]),
            Node::Binary(f, a, b) => ConstOp::Binary(f, const_of[a], const_of[b]),
            Node::PowI(a, k) => ConstOp::PowI(const_of[a], k),
            Node::Time | Node::Coord(_) | Node::Velocity(_) => {
                unreachable!("inputs are never constant")
            }
        };
        const_of[i] = consts.len();
        consts.push(op);
    }
    (consts, const_of)
}

/// The instructions of the live variable nodes, on node ids: `x op constant` forms so that a
/// parameter never becomes a dual number, `x**2` as a square, and `sin x`, `cos x` of the same
/// `x` as one `sin_cos`.
fn select(graph: &Graph, live: &[bool], is_const: &[bool], const_of: &[usize]) -> Vec<Selected> {
    let nodes = graph.nodes();
    let n = nodes.len();
    let mut selected = Vec::new();
    let mut emitted = vec![false; n];
    for i in (0..n).filter(|&i| live[i] && !is_const[i]) {
        if emitted[i] {
            continue;
        }
        emitted[i] = true;
        let c = |k: usize| const_of[k] as u32;
        let item = match nodes[i] {
            Node::Time | Node::Coord(_) | Node::Velocity(_) => continue,
            Node::Unary(f, a) => {
                // sin and cos of one argument: one sin_cos.
                let partner = match f {
                    Unary::Sin => Some(Node::Unary(Unary::Cos, a)),
                    Unary::Cos => Some(Node::Unary(Unary::Sin, a)),
                    _ => None,
                }
                .and_then(|node| graph.find(node))
                .filter(|&j| live[j] && !emitted[j]);
                match (partner, f) {
                    (Some(j), Unary::Sin) => {
                        emitted[j] = true;
                        (InsOp::SinCos, [i, j], [a, NONE])
                    }
                    (Some(j), _) => {
                        emitted[j] = true;
                        (InsOp::SinCos, [j, i], [a, NONE])
                    }
                    (None, _) => (InsOp::Un(f), [i, NONE], [a, NONE]),
                }
            }
            Node::PowI(a, 2) => (InsOp::Sqr, [i, NONE], [a, NONE]),
            Node::PowI(a, k) => (InsOp::PowI(k), [i, NONE], [a, NONE]),
            Node::Binary(f, a, b) => match (is_const[a], is_const[b]) {
                (false, false) => (InsOp::Bin(f), [i, NONE], [a, b]),
                (false, true) => (InsOp::BinVC(f, c(b)), [i, NONE], [a, NONE]),
                (true, false) => (InsOp::BinCV(f, c(a)), [i, NONE], [b, NONE]),
                (true, true) => unreachable!("constant nodes are in the constant program"),
            },
            Node::Const(_) | Node::Param(_) => unreachable!("constants are not emitted"),
        };
        selected.push(item);
    }
    selected
}

/// Slots for the inputs that appear (the first slots, written before the instructions run) and
/// for the instructions' results, reusing the slots of dead values, and the lowered code with
/// the accumulator forms where an operand is the previous result.
fn allocate(nodes: &[Node], live: &[bool], selected: &[Selected], outputs: &[usize]) -> Lowered {
    let n = nodes.len();
    // Liveness: the last instruction reading each value; outputs live to the end.
    let mut last_use = vec![0usize; n];
    for (k, (_, _, operands)) in selected.iter().enumerate() {
        for &a in operands.iter().filter(|&&a| a != NONE) {
            last_use[a] = k;
        }
    }
    for &o in outputs {
        last_use[o] = usize::MAX;
    }
    let mut slot_of = vec![u32::MAX; n];
    let mut free: Vec<u32> = Vec::new();
    let mut slots = 0u32;
    let mut input_slots = Vec::new();
    for i in (0..n).filter(|&i| live[i]) {
        let input = match nodes[i] {
            Node::Time => Input::Time,
            Node::Coord(k) => Input::Coord(k),
            Node::Velocity(k) => Input::Velocity(k),
            _ => continue,
        };
        slot_of[i] = slots;
        input_slots.push((slots, input));
        slots += 1;
    }
    let mut code = Vec::with_capacity(selected.len());
    // The node whose value the accumulator holds (none after a two-result sin_cos).
    let mut acc: Option<usize> = None;
    for (k, &(op, dsts, operands)) in selected.iter().enumerate() {
        let slot = |a: usize| if a == NONE { 0 } else { slot_of[a] };
        let (a, b) = (slot(operands[0]), slot(operands[1]));
        let from_acc = match acc {
            Some(p) if operands[0] == p => 1,
            Some(p) if operands[1] == p => 2,
            _ => 0,
        };
        // Operands that die here free their slot before the destination takes one
        // (instructions read their operands before writing).
        for &x in operands.iter().filter(|&&x| x != NONE) {
            if last_use[x] == k && slot_of[x] != u32::MAX {
                free.push(slot_of[x]);
                slot_of[x] = u32::MAX;
            }
        }
        let mut ds = [0u32; 2];
        for (slot, &d) in ds.iter_mut().zip(dsts.iter()).filter(|(_, d)| **d != NONE) {
            *slot = free.pop().unwrap_or_else(|| {
                slots += 1;
                slots - 1
            });
            slot_of[d] = *slot;
        }
        code.push(lower(op, ds, a, b, from_acc));
        acc = (dsts[1] == NONE).then_some(dsts[0]);
    }
    Lowered {
        input_slots,
        code,
        slots,
        slot_of,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::graph::{Binary, Graph, Unary};

    #[test]
    fn tape_finds_mass_matrix_structure() {
        let flags = |build: &dyn Fn(&mut Graph) -> Result<usize>| {
            let mut g = Graph::new();
            let o = build(&mut g).unwrap();
            let t = Tape::new(&g, &[o], Inputs::kinetic(2, 0), "T").unwrap();
            (t.constant_mass_matrix(), t.depends_on_position())
        };
        // ½ q̇₀² + q̇₀ q̇₁ + 3 q̇₁ sin q₀: constant M, depends on q (gyroscopic term).
        assert_eq!(
            flags(&|g| {
                let (v0, v1, q0) = (g.velocity(0), g.velocity(1), g.coord(0));
                let a = g.powi(v0, 2)?;
                let b = g.binary(Binary::Mul, v0, v1)?;
                let s = g.unary(Unary::Sin, q0)?;
                let three = g.constant(3.0);
                let c = g.binary(Binary::Mul, three, v1)?;
                let c = g.binary(Binary::Mul, c, s)?;
                let ab = g.binary(Binary::Add, a, b)?;
                g.binary(Binary::Add, ab, c)
            }),
            (true, true)
        );
        // q̇₀² cos q₁: M depends on q.
        assert_eq!(
            flags(&|g| {
                let (v0, q1) = (g.velocity(0), g.coord(1));
                let a = g.powi(v0, 2)?;
                let c = g.unary(Unary::Cos, q1)?;
                g.binary(Binary::Mul, a, c)
            }),
            (false, true)
        );
        // q̇₀⁴: not quadratic.
        assert_eq!(
            flags(&|g| {
                let v0 = g.velocity(0);
                g.powi(v0, 4)
            }),
            (false, false)
        );
        // (q̇₀ + q̇₁)² / 2: quadratic with constant coefficients.
        assert_eq!(
            flags(&|g| {
                let (v0, v1) = (g.velocity(0), g.velocity(1));
                let s = g.binary(Binary::Add, v0, v1)?;
                let s2 = g.powi(s, 2)?;
                let two = g.constant(2.0);
                g.binary(Binary::Div, s2, two)
            }),
            (true, false)
        );
        // cos(q̇₀): not a polynomial.
        assert_eq!(
            flags(&|g| {
                let v0 = g.velocity(0);
                g.unary(Unary::Cos, v0)
            }),
            (false, false)
        );
    }

    #[test]
    fn tape_rejects_what_inputs_forbid() {
        let mut g = Graph::new();
        let v = g.velocity(0);
        let err = Tape::new(&g, &[v], Inputs::potential(1, 0), "potential").unwrap_err();
        assert!(err.to_string().contains("velocities"), "{err}");
        let x = g.coord(3);
        assert!(Tape::new(&g, &[x], Inputs::kinetic(2, 0), "T").is_err());
        let p = g.param(1);
        assert!(Tape::new(&g, &[p], Inputs::constant(1), "mass").is_err());
        let t = g.time();
        assert!(Tape::new(&g, &[t], Inputs::constant(0), "mass").is_err());
    }
}
