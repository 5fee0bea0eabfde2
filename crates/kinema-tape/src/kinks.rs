//! The kink checks' tapes (see [`System::kink`](kinema_runtime::System::kink)
//! and [`TapeSystem::output_kink`](crate::TapeSystem::output_kink)): only
//! the subexpressions that hold a function with a kink, so that a check
//! costs a fraction of an evaluation of the whole.

use kinema_expr::{Arena, ExprId, Tape, TapeInputs};

/// The subexpressions of some roots (Φ's rows, the results' values) that
/// apply a function with a kink, compiled as one tape, and the first root
/// holding each.
#[derive(Clone, Debug)]
pub(crate) struct KinkTape {
    tape: Tape,
    roots: Vec<usize>,
}

/// A kink found: the first root holding it, and the function.
pub(crate) struct Found {
    pub(crate) root: usize,
    pub(crate) function: &'static str,
}

impl KinkTape {
    /// `None` if no root applies a function with a kink. Walks the
    /// expressions once, iteratively (no recursion on deep models).
    pub(crate) fn new(arena: &Arena, roots: &[ExprId]) -> Option<KinkTape> {
        let mut seen = vec![false; arena.len()];
        let (mut nodes, mut owners) = (Vec::new(), Vec::new());
        let mut stack = Vec::new();
        for (r, &root) in roots.iter().enumerate() {
            stack.push(root);
            while let Some(e) = stack.pop() {
                if std::mem::replace(&mut seen[e.index()], true) {
                    continue;
                }
                if arena.applies_kink(e) {
                    nodes.push(e);
                    owners.push(r);
                }
                arena.for_each_child(e, |c| {
                    if !seen[c.index()] {
                        stack.push(c);
                    }
                });
            }
        }
        let tape = Tape::compile(arena, &nodes);
        // The node test is wider than the tape's (any fractional power):
        // the tape decides.
        tape.has_kinks().then_some(KinkTape {
            tape,
            roots: owners,
        })
    }

    /// Registers the check needs (and as many error bounds).
    pub(crate) fn registers(&self) -> usize {
        self.tape.registers()
    }

    /// The first function at its kink at `inputs` (see
    /// [`Tape::kink`]), with `registers` and `errors` of
    /// [`registers`](Self::registers) values each and the system's sin/cos
    /// cache `trig`; `None` on slices of other lengths too.
    pub(crate) fn find(
        &self,
        inputs: &TapeInputs<'_>,
        uncertainty: f64,
        size: f64,
        registers: &mut [f64],
        errors: &mut [f64],
        trig: &mut [f64],
    ) -> Option<Found> {
        let kink = self
            .tape
            .kink(inputs, uncertainty, size, registers, errors, trig)
            .ok()??;
        Some(Found {
            root: *self.roots.get(kink.output?)?,
            function: kink.function,
        })
    }
}
