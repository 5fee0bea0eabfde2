//! Deterministic infix printing with minimal parentheses. Iterative.
//!
//! Two forms: [`Arena::display`] prints one expression as a tree (shared
//! subexpressions are printed where they occur), and [`Arena::display_program`]
//! prints several outputs as a straight-line program that names every
//! subexpression used more than once, so that its size stays linear in the
//! size of the DAG however deep or shared it is.

use std::fmt::{self, Write};

use rustc_hash::FxHashMap;

use crate::arena::Arena;
use crate::node::{ExprId, Factor, NodeRef};

const ADD: u8 = 1;
const MUL: u8 = 2;
const POW: u8 = 3;
const ATOM: u8 = 4;

/// Formats a number so that it reads naturally and parses back to the same `f64`.
#[must_use]
pub fn format_number(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e16).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

enum Task {
    Text(&'static str),
    Owned(String),
    Expr(ExprId, u8),
}

/// Printer state: the arena and, for programs, the names of bound nodes.
struct Printer<'a> {
    arena: &'a Arena,
    bound: Option<&'a FxHashMap<ExprId, String>>,
}

impl Printer<'_> {
    fn prec(&self, e: ExprId) -> u8 {
        match self.arena.node(e) {
            NodeRef::Num(v) if v < 0.0 => MUL,
            NodeRef::Num(_) | NodeRef::Sym(_) | NodeRef::Unary(..) | NodeRef::Atan2(..) => ATOM,
            NodeRef::Pow(..) => POW,
            NodeRef::Mul { coeff, factors } => match factors {
                [f] if coeff == 1.0 && f.exp == 0.5 => ATOM,
                [f] if coeff == 1.0 && f.exp > 0.0 => POW,
                _ => MUL,
            },
            NodeRef::Add { .. } => ADD,
        }
    }

    fn write(&self, root: ExprId, out: &mut impl Write) -> fmt::Result {
        let mut stack = vec![Task::Expr(root, 0)];
        let mut parts: Vec<Task> = Vec::new();
        let mut first = true;
        while let Some(task) = stack.pop() {
            match task {
                Task::Text(s) => out.write_str(s)?,
                Task::Owned(s) => out.write_str(&s)?,
                Task::Expr(e, min) => {
                    if !first && let Some(name) = self.bound.and_then(|b| b.get(&e)) {
                        out.write_str(name)?;
                        continue;
                    }
                    first = false;
                    parts.clear();
                    let paren = self.prec(e) < min;
                    if paren {
                        parts.push(Task::Text("("));
                    }
                    self.expand(e, &mut parts);
                    if paren {
                        parts.push(Task::Text(")"));
                    }
                    stack.extend(parts.drain(..).rev());
                }
            }
        }
        Ok(())
    }

    /// Pushes the pieces of one node, in reading order.
    fn expand(&self, e: ExprId, parts: &mut Vec<Task>) {
        let a = self.arena;
        match a.node(e) {
            NodeRef::Num(v) => parts.push(Task::Owned(format_number(v))),
            NodeRef::Sym(s) => parts.push(Task::Owned(a.symbol(s).name.clone())),
            NodeRef::Add { constant, terms } => {
                for (i, t) in terms.iter().enumerate() {
                    let (neg, mag) = (t.coeff < 0.0, t.coeff.abs());
                    parts.push(Task::Text(match (i, neg) {
                        (0, false) => "",
                        (0, true) => "-",
                        (_, false) => " + ",
                        (_, true) => " - ",
                    }));
                    if mag != 1.0 {
                        parts.push(Task::Owned(format_number(mag)));
                        parts.push(Task::Text("*"));
                    }
                    parts.push(Task::Expr(t.expr, MUL));
                }
                if constant != 0.0 {
                    parts.push(Task::Text(if constant < 0.0 { " - " } else { " + " }));
                    parts.push(Task::Owned(format_number(constant.abs())));
                }
            }
            NodeRef::Mul { coeff, factors } => {
                let num: Vec<Factor> = factors.iter().copied().filter(|f| f.exp > 0.0).collect();
                let den: Vec<Factor> = factors
                    .iter()
                    .filter(|f| f.exp < 0.0)
                    .map(|f| Factor {
                        base: f.base,
                        exp: -f.exp,
                    })
                    .collect();
                let mag = coeff.abs();
                if coeff < 0.0 {
                    parts.push(Task::Text("-"));
                }
                let mut wrote = false;
                if mag != 1.0 || num.is_empty() {
                    parts.push(Task::Owned(format_number(mag)));
                    wrote = true;
                }
                for f in &num {
                    if wrote {
                        parts.push(Task::Text("*"));
                    }
                    self.factor(*f, parts);
                    wrote = true;
                }
                if !den.is_empty() {
                    parts.push(Task::Text("/"));
                    let group = den.len() > 1;
                    if group {
                        parts.push(Task::Text("("));
                    }
                    for (i, f) in den.iter().enumerate() {
                        if i > 0 {
                            parts.push(Task::Text("*"));
                        }
                        self.factor(*f, parts);
                    }
                    if group {
                        parts.push(Task::Text(")"));
                    }
                }
            }
            NodeRef::Unary(op, x) => {
                parts.push(Task::Text(op.name()));
                parts.push(Task::Text("("));
                parts.push(Task::Expr(x, 0));
                parts.push(Task::Text(")"));
            }
            NodeRef::Pow(b, x) => {
                parts.push(Task::Expr(b, ATOM));
                parts.push(Task::Text("^"));
                parts.push(Task::Expr(x, ATOM));
            }
            NodeRef::Atan2(y, x) => {
                parts.push(Task::Text("atan2("));
                parts.push(Task::Expr(y, 0));
                parts.push(Task::Text(", "));
                parts.push(Task::Expr(x, 0));
                parts.push(Task::Text(")"));
            }
        }
    }

    fn factor(&self, f: Factor, parts: &mut Vec<Task>) {
        if f.exp == 1.0 {
            parts.push(Task::Expr(f.base, POW));
        } else if f.exp == 0.5 {
            parts.push(Task::Text("sqrt("));
            parts.push(Task::Expr(f.base, 0));
            parts.push(Task::Text(")"));
        } else {
            parts.push(Task::Expr(f.base, ATOM));
            parts.push(Task::Text("^"));
            parts.push(Task::Owned(format_number(f.exp)));
        }
    }
}

/// An expression ready to be formatted; see [`Arena::display`].
pub struct Display<'a> {
    arena: &'a Arena,
    expr: ExprId,
}

impl fmt::Display for Display<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        Printer {
            arena: self.arena,
            bound: None,
        }
        .write(self.expr, f)
    }
}

impl Arena {
    /// Infix form of `e`, deterministic, with minimal parentheses.
    ///
    /// ```
    /// use kinema_expr::Arena;
    /// let mut a = Arena::new();
    /// let x = a.coordinate("x", 0);
    /// let y = a.coordinate("y", 1);
    /// let s = a.add(x, y);
    /// let p = a.powi(s, 2);
    /// let e = a.div(p, x);
    /// assert_eq!(a.display(e).to_string(), "(x + y)^2/x");
    /// ```
    #[must_use]
    pub fn display(&self, e: ExprId) -> Display<'_> {
        Display {
            arena: self,
            expr: e,
        }
    }

    /// For every node of the arena (indexed by [`ExprId::index`]), the
    /// number of nodes [`display`](Self::display) prints for it: its size as
    /// a tree, where a shared subexpression counts at each use (saturating
    /// at `u64::MAX`). One pass over the arena: compare it with the number
    /// of distinct nodes to see when tree printing would blow up.
    #[must_use]
    pub fn tree_sizes(&self) -> Vec<u64> {
        let mut size: Vec<u64> = Vec::with_capacity(self.len());
        for i in 0..self.len() {
            // Children have smaller ids than their parents.
            let mut s: u64 = 1;
            self.for_each_child(crate::ExprId(i as u32), |c| {
                s = s.saturating_add(size[c.index()]);
            });
            size.push(s);
        }
        size
    }

    /// The number of distinct nodes reachable from `roots` (their DAG size).
    #[must_use]
    pub fn dag_size(&self, roots: &[ExprId]) -> usize {
        let mut seen = vec![false; self.len()];
        let mut stack: Vec<ExprId> = roots.to_vec();
        let mut count = 0;
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n.index()], true) {
                continue;
            }
            count += 1;
            self.for_each_child(n, |c| {
                if !seen[c.index()] {
                    stack.push(c);
                }
            });
        }
        count
    }

    /// Prints `outputs` as a straight-line program: every compound
    /// subexpression used more than once gets a `let` binding (`v0`, `v1`, …,
    /// numbered in evaluation order), then each output is printed as
    /// `label = expr`. Linear in the size of the DAG.
    #[must_use]
    pub fn display_program(&self, outputs: &[(&str, ExprId)]) -> String {
        let ids: Vec<ExprId> = outputs.iter().map(|&(_, e)| e).collect();
        let schedule = self.schedule(&ids);
        let mut bound: FxHashMap<ExprId, String> = FxHashMap::default();
        let mut text = String::new();
        for (i, &n) in schedule.nodes().iter().enumerate() {
            let leaf = matches!(self.node(n), NodeRef::Num(_) | NodeRef::Sym(_));
            if leaf || schedule.parent_uses()[i] < 2 {
                continue;
            }
            let name = format!("v{}", bound.len());
            let p = Printer {
                arena: self,
                bound: Some(&bound),
            };
            let _ = write!(text, "let {name} = ");
            let _ = p.write(n, &mut text);
            text.push_str(";\n");
            bound.insert(n, name);
        }
        let p = Printer {
            arena: self,
            bound: Some(&bound),
        };
        for &(label, e) in outputs {
            let _ = write!(text, "{label} = ");
            match bound.get(&e) {
                Some(name) => text.push_str(name),
                None => {
                    let _ = p.write(e, &mut text);
                }
            }
            text.push('\n');
        }
        text
    }
}
