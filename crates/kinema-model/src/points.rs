//! The body-fixed points each equation uses, for drawing a mechanism:
//! [`EquationPoint`], [`CheckedModel::equation_points`].
//!
//! A point is a library argument `B(sx, sy)`, `B.name` or `ground(x, y)`, or
//! a point written inside a user equation (`rod.tip.y == …`). Its local
//! coordinates are constants of the params; they are evaluated at the
//! declared values.

use crate::check::{BodyRef, CheckedModel, Form, LibArg, TExpr, TNode, eval_vector};

/// A body-fixed point used by an equation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EquationPoint {
    /// The body it is fixed in (for [`BodyRef::Ground`], `local` is global).
    pub body: BodyRef,
    /// Local coordinates s′ at the declared parameter values.
    pub local: [f64; 2],
}

impl CheckedModel {
    /// The points equation `index` of [`CheckedModel::equations`] uses, in
    /// the order they are written (a point used twice is listed twice);
    /// empty for an index out of range. Points whose local coordinates are
    /// not finite at the declared params are left out.
    #[must_use]
    pub fn equation_points(&self, index: usize) -> Vec<EquationPoint> {
        let Some(equation) = self.equations.get(index) else {
            return Vec::new();
        };
        let params: Vec<f64> = self.params.iter().map(|p| p.value).collect();
        let mut out = Vec::new();
        match &equation.form {
            Form::Library(_, args) => {
                for arg in args {
                    if let LibArg::Point(body, local) = arg {
                        push(&mut out, *body, eval_vector(local, &params));
                    }
                }
            }
            Form::User { lhs, rhs } => {
                for side in [lhs, rhs] {
                    self.user_points(side, &params, &mut out);
                }
            }
        }
        out
    }

    /// Points written inside a user expression: `B(sx, sy)` nodes (whose
    /// local coordinates are the subexpression before them — children
    /// precede parents, so a prefix of the nodes holds it) and named points.
    fn user_points(&self, expr: &TExpr, params: &[f64], out: &mut Vec<EquationPoint>) {
        for node in &expr.nodes {
            match *node {
                TNode::Point(body, local) => {
                    let end = (local as usize + 1).min(expr.nodes.len());
                    let sub = TExpr {
                        nodes: expr.nodes[..end].to_vec(),
                        types: expr.types[..end.min(expr.types.len())].to_vec(),
                        spans: Vec::new(),
                    };
                    push(out, body, eval_vector(&sub, params));
                }
                TNode::NamedPoint(k) => {
                    if let Some(p) = self.points.get(k as usize) {
                        push(out, p.body, p.local_value);
                    }
                }
                _ => {}
            }
        }
    }
}

fn push(out: &mut Vec<EquationPoint>, body: BodyRef, local: [f64; 2]) {
    if local.iter().all(|v| v.is_finite()) {
        out.push(EquationPoint { body, local });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn library_and_user_points() -> Result<(), String> {
        let src = "mechanism M {
            param l = 2;
            body a { guess: (1, 0, 0) }
            body b { guess: (3, 0, 0) }
            point b.tip = (l / 2, 0);
            joint pin: revolute(a(-l / 2, 0), ground(0, 1));
            joint link: revolute(a(1, 0), b(-1, 0));
            constraint slot: b.tip.y == 0.5 * b(0, 0.25).x;
            driver turn: a.phi == t;
        }";
        let checked = crate::check_str(src).map_err(|d| d.render(src, "m.kin"))?;
        let p = |body, x, y| EquationPoint {
            body,
            local: [x, y],
        };
        assert_eq!(
            checked.equation_points(0),
            [p(BodyRef::Body(0), -1.0, 0.0), p(BodyRef::Ground, 0.0, 1.0)]
        );
        assert_eq!(
            checked.equation_points(2),
            [
                p(BodyRef::Body(1), 1.0, 0.0),
                p(BodyRef::Body(1), 0.0, 0.25)
            ]
        );
        assert!(checked.equation_points(3).is_empty());
        assert!(checked.equation_points(9).is_empty());
        Ok(())
    }
}
