//! The domain check's tape (see
//! [`System::undefined`](kinema_runtime::System::undefined)): the
//! subexpressions of Φ that are functions of time alone (they read t, and
//! no coordinate) and apply a function whose domain can be left — a
//! division, `ln`, `sqrt` and fractional powers, `pow`, `atan2`, `asin`,
//! `acos`, `tan`, and the functions that overflow (`exp`, `sinh`,
//! `cosh`) — compiled as one tape, with the equation holding each.
//!
//! Functions of time alone are what a driver's right-hand side is made of:
//! their value does not depend on the solution, so whether they are
//! defined over a step can be asked before the step, exactly (see
//! [`kinema_expr::Tape::undefined`]).

use kinema_expr::{Arena, ExprId, NodeRef, SymKind, Tape, TapeInputs, TapeUndefined, UnaryOp};

/// See the module's documentation.
#[derive(Clone, Debug)]
pub(crate) struct DomainTape {
    tape: Tape,
    roots: Vec<usize>,
}

/// A function outside its domain: the equation holding it, and what.
pub(crate) struct Found {
    pub(crate) root: usize,
    pub(crate) undefined: TapeUndefined,
}

impl DomainTape {
    /// `None` if no equation applies such a function to a function of time
    /// alone. Walks the expressions once, iteratively.
    pub(crate) fn new(arena: &Arena, roots: &[ExprId]) -> Option<DomainTape> {
        // Every node reachable from the roots, with the first root reaching
        // it; then in index order (children before parents) whether each
        // reads t and whether it reads a coordinate.
        let mut owner = vec![usize::MAX; arena.len()];
        let mut stack = Vec::new();
        let mut reached = Vec::new();
        for (r, &root) in roots.iter().enumerate() {
            stack.push(root);
            while let Some(e) = stack.pop() {
                if owner[e.index()] != usize::MAX {
                    continue;
                }
                owner[e.index()] = r;
                reached.push(e);
                arena.for_each_child(e, |c| {
                    if owner[c.index()] == usize::MAX {
                        stack.push(c);
                    }
                });
            }
        }
        reached.sort_unstable_by_key(|e| e.index());
        // Bit 0: reads t; bit 1: reads a coordinate or a velocity.
        let mut reads = vec![0u8; arena.len()];
        let (mut nodes, mut owners) = (Vec::new(), Vec::new());
        for &e in &reached {
            let mut bits = 0u8;
            if let NodeRef::Sym(s) = arena.node(e) {
                bits = match arena.symbol(s).kind {
                    SymKind::Time => 1,
                    SymKind::Coordinate(_) | SymKind::Velocity(_) => 2,
                    SymKind::Parameter(_) => 0,
                };
            }
            arena.for_each_child(e, |c| bits |= reads[c.index()]);
            reads[e.index()] = bits;
            if bits == 1 && restricted(arena, e) {
                nodes.push(e);
                owners.push(owner[e.index()]);
            }
        }
        if nodes.is_empty() {
            return None;
        }
        Some(DomainTape {
            tape: Tape::compile(arena, &nodes),
            roots: owners,
        })
    }

    /// Registers the check needs (and as many error bounds).
    pub(crate) fn registers(&self) -> usize {
        self.tape.registers()
    }

    /// The first function outside its domain at `inputs` with t uncertain
    /// by `t_error` (see [`Tape::undefined`]); `None` on slices of other
    /// lengths too.
    pub(crate) fn find(
        &self,
        inputs: &TapeInputs<'_>,
        t_error: f64,
        registers: &mut [f64],
        errors: &mut [f64],
    ) -> Option<Found> {
        let undefined = self
            .tape
            .undefined(inputs, t_error, registers, errors, &mut [])
            .ok()??;
        Some(Found {
            root: *self.roots.get(undefined.output?)?,
            undefined,
        })
    }
}

/// Whether node `e` applies a function whose domain can be left (or that
/// can overflow).
fn restricted(arena: &Arena, e: ExprId) -> bool {
    match arena.node(e) {
        NodeRef::Unary(op, _) => matches!(
            op,
            UnaryOp::Ln
                | UnaryOp::Asin
                | UnaryOp::Acos
                | UnaryOp::Tan
                | UnaryOp::Exp
                | UnaryOp::Sinh
                | UnaryOp::Cosh
        ),
        NodeRef::Atan2(..) | NodeRef::Pow(..) => true,
        // A quotient (a negative exponent) or a root (a fractional one).
        NodeRef::Mul { factors, .. } => factors.iter().any(|f| f.exp < 0.0 || f.exp.fract() != 0.0),
        NodeRef::Num(_) | NodeRef::Sym(_) | NodeRef::Add { .. } => false,
    }
}
