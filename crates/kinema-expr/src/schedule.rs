//! Schedules: the nodes a set of outputs needs, children before parents.

use crate::arena::Arena;
use crate::node::ExprId;

const ABSENT: u32 = u32::MAX;

/// The nodes needed by a set of outputs in evaluation (topological) order,
/// each exactly once, with use counts — what a code generator walks to
/// compute every shared subexpression once.
///
/// The order is deterministic: a depth-first post-order over the outputs in
/// the order given, children in canonical order.
#[derive(Clone, Debug)]
pub struct Schedule {
    nodes: Vec<ExprId>,
    parent_uses: Vec<u32>,
    output_uses: Vec<u32>,
    last_use: Vec<u32>,
    /// Position of each arena node in the schedule (`u32::MAX` if absent).
    position: Vec<u32>,
}

impl Schedule {
    /// The nodes in evaluation order (children before parents), leaves included.
    #[must_use]
    pub fn nodes(&self) -> &[ExprId] {
        &self.nodes
    }

    /// For each node of [`nodes`](Self::nodes): how many scheduled nodes use it as an operand.
    #[must_use]
    pub fn parent_uses(&self) -> &[u32] {
        &self.parent_uses
    }

    /// For each node: how many outputs are that node.
    #[must_use]
    pub fn output_uses(&self) -> &[u32] {
        &self.output_uses
    }

    /// For each node: the position of the last scheduled node that uses it as
    /// an operand (its own position if none does).
    #[must_use]
    pub fn last_use(&self) -> &[u32] {
        &self.last_use
    }

    /// The position of `e` in the schedule, if it is scheduled.
    #[must_use]
    pub fn position(&self, e: ExprId) -> Option<usize> {
        match self.position.get(e.index()) {
            Some(&p) if p != ABSENT => Some(p as usize),
            _ => None,
        }
    }

    /// Number of scheduled nodes.
    #[must_use]
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether nothing is scheduled.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
}

impl Arena {
    /// The schedule of the nodes that `outputs` need.
    #[must_use]
    pub fn schedule(&self, outputs: &[ExprId]) -> Schedule {
        self.schedule_until(outputs, |_| false)
    }

    /// [`schedule`](Self::schedule), not descending below the nodes for
    /// which `stop` holds: they are scheduled as leaves (their value comes
    /// from elsewhere, such as a per-step cache), and their operands are
    /// neither scheduled nor counted as used by them.
    ///
    /// ```
    /// use kinema_expr::Arena;
    /// let mut a = Arena::new();
    /// let x = a.coordinate("x", 0);
    /// let s = a.sin(x);
    /// let e = a.mul(s, s);
    /// assert_eq!(a.schedule(&[e]).len(), 3);
    /// let until = a.schedule_until(&[e], |n| n == s);
    /// assert_eq!(until.nodes(), &[s, e]);
    /// assert_eq!(until.parent_uses(), &[1, 0]);
    /// ```
    #[must_use]
    pub fn schedule_until(&self, outputs: &[ExprId], stop: impl Fn(ExprId) -> bool) -> Schedule {
        let mut position: Vec<u32> = vec![ABSENT; self.len()];
        let mut nodes: Vec<ExprId> = Vec::new();
        let mut stack: Vec<(ExprId, bool)> = Vec::new();
        let mut kids: Vec<ExprId> = Vec::new();
        for &root in outputs {
            stack.push((root, false));
            while let Some((n, expanded)) = stack.pop() {
                if position[n.index()] != ABSENT {
                    continue;
                }
                if expanded || stop(n) {
                    position[n.index()] = nodes.len() as u32;
                    nodes.push(n);
                } else {
                    stack.push((n, true));
                    kids.clear();
                    self.children(n, &mut kids);
                    // Reversed so that the first child is evaluated first.
                    for &c in kids.iter().rev() {
                        if position[c.index()] == ABSENT {
                            stack.push((c, false));
                        }
                    }
                }
            }
        }
        let mut parent_uses = vec![0u32; nodes.len()];
        let mut last_use: Vec<u32> = (0..nodes.len() as u32).collect();
        for (i, &n) in nodes.iter().enumerate() {
            if stop(n) {
                continue;
            }
            kids.clear();
            self.children(n, &mut kids);
            kids.sort_unstable();
            kids.dedup();
            for c in &kids {
                let p = position[c.index()] as usize;
                parent_uses[p] += 1;
                last_use[p] = i as u32;
            }
        }
        let mut output_uses = vec![0u32; nodes.len()];
        for o in outputs {
            output_uses[position[o.index()] as usize] += 1;
        }
        Schedule {
            nodes,
            parent_uses,
            output_uses,
            last_use,
            position,
        }
    }
}
