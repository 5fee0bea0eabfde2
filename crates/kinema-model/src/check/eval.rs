//! Values of constant expressions (param values, guesses, local coordinates).

use super::model::{TExpr, TNode};

/// Numeric value of a node: scalar or vector.
#[derive(Clone, Copy)]
enum Val {
    S(f64),
    V(f64, f64),
}

/// Evaluates a constant expression (numbers, `pi`, params) forward.
fn eval(t: &TExpr, params: &[f64]) -> Val {
    let mut v: Vec<Val> = Vec::with_capacity(t.nodes.len());
    let s = |v: &Vec<Val>, i: u32| match v.get(i as usize) {
        Some(Val::S(x)) => *x,
        _ => f64::NAN,
    };
    let w = |v: &Vec<Val>, i: u32| match v.get(i as usize) {
        Some(Val::V(x, y)) => (*x, *y),
        _ => (f64::NAN, f64::NAN),
    };
    for n in &t.nodes {
        let val = match *n {
            TNode::Num(x) => Val::S(x),
            TNode::Pi => Val::S(std::f64::consts::PI),
            TNode::Param(i) => Val::S(params.get(i as usize).copied().unwrap_or(f64::NAN)),
            // Not constant: never evaluated here (checked before).
            TNode::Time | TNode::Coord(..) => Val::S(f64::NAN),
            TNode::Point(..) | TNode::NamedPoint(_) => Val::V(f64::NAN, f64::NAN),
            TNode::Vec(a, b) => Val::V(s(&v, a), s(&v, b)),
            TNode::X(a) => Val::S(w(&v, a).0),
            TNode::Y(a) => Val::S(w(&v, a).1),
            TNode::Neg(a) => match v.get(a as usize) {
                Some(Val::V(x, y)) => Val::V(-x, -y),
                _ => Val::S(-s(&v, a)),
            },
            TNode::Add(a, b) | TNode::Sub(a, b) => {
                let sign = if matches!(n, TNode::Add(..)) {
                    1.0
                } else {
                    -1.0
                };
                match (v.get(a as usize), v.get(b as usize)) {
                    (Some(Val::V(x1, y1)), Some(Val::V(x2, y2))) => {
                        Val::V(x1 + sign * x2, y1 + sign * y2)
                    }
                    _ => Val::S(s(&v, a) + sign * s(&v, b)),
                }
            }
            TNode::Mul(a, b) => match (v.get(a as usize), v.get(b as usize)) {
                (Some(Val::V(x, y)), Some(Val::S(c))) | (Some(Val::S(c)), Some(Val::V(x, y))) => {
                    Val::V(c * x, c * y)
                }
                _ => Val::S(s(&v, a) * s(&v, b)),
            },
            TNode::Div(a, b) => match v.get(a as usize) {
                Some(Val::V(x, y)) => Val::V(x / s(&v, b), y / s(&v, b)),
                _ => Val::S(s(&v, a) / s(&v, b)),
            },
            TNode::F1(f, a) => Val::S(f.apply(s(&v, a))),
            TNode::Sqrt(a) => Val::S(s(&v, a).sqrt()),
            TNode::Atan2(a, b) => Val::S(s(&v, a).atan2(s(&v, b))),
            TNode::Pow(a, b) => Val::S(s(&v, a).powf(s(&v, b))),
            TNode::Powi(a, k) => Val::S(s(&v, a).powi(k)),
            TNode::Step([x, x0, h0, x1, h1]) => {
                let (x, x0, h0, x1, h1) = (s(&v, x), s(&v, x0), s(&v, h0), s(&v, x1), s(&v, h1));
                Val::S(h0 + (h1 - h0) * kinema_expr::smooth(0, (x - x0) / (x1 - x0)))
            }
            TNode::Dot(a, b) => {
                let (p, q) = (w(&v, a), w(&v, b));
                Val::S(p.0 * q.0 + p.1 * q.1)
            }
            TNode::Cross(a, b) => {
                let (p, q) = (w(&v, a), w(&v, b));
                Val::S(p.0 * q.1 - p.1 * q.0)
            }
            TNode::Norm(a) => {
                let p = w(&v, a);
                Val::S(p.0.hypot(p.1))
            }
            TNode::Rot(a, b) => {
                let (c, sn) = (s(&v, a).cos(), s(&v, a).sin());
                let p = w(&v, b);
                Val::V(c * p.0 - sn * p.1, sn * p.0 + c * p.1)
            }
            TNode::Perp(a) => {
                let p = w(&v, a);
                Val::V(-p.1, p.0)
            }
        };
        v.push(val);
    }
    v.last().copied().unwrap_or(Val::S(f64::NAN))
}

pub(super) fn eval_scalar(t: &TExpr, params: &[f64]) -> f64 {
    match eval(t, params) {
        Val::S(x) => x,
        Val::V(..) => f64::NAN,
    }
}

pub(crate) fn eval_vector(t: &TExpr, params: &[f64]) -> [f64; 2] {
    match eval(t, params) {
        Val::V(x, y) => [x, y],
        Val::S(_) => [f64::NAN, f64::NAN],
    }
}

/// The value of the typed node `n` when its children's values are known
/// scalars (`folded`; `None` for a child that is not such a constant): the
/// constant folds of numbers and `pi` the expression engine makes.
pub(super) fn fold(n: &TNode, folded: &[Option<f64>]) -> Option<f64> {
    let v = |i: u32| folded.get(i as usize).copied().flatten();
    match *n {
        TNode::Num(x) => Some(x),
        TNode::Pi => Some(std::f64::consts::PI),
        TNode::Neg(a) => v(a).map(|x| -x),
        TNode::Add(a, b) => v(a).zip(v(b)).map(|(x, y)| x + y),
        TNode::Sub(a, b) => v(a).zip(v(b)).map(|(x, y)| x - y),
        TNode::Mul(a, b) => v(a).zip(v(b)).map(|(x, y)| x * y),
        TNode::Div(a, b) => v(a).zip(v(b)).map(|(x, y)| x / y),
        TNode::F1(f, a) => v(a).map(|x| f.apply(x)),
        TNode::Sqrt(a) => v(a).map(f64::sqrt),
        TNode::Atan2(a, b) => v(a).zip(v(b)).map(|(y, x)| y.atan2(x)),
        TNode::Pow(a, b) => v(a).zip(v(b)).map(|(x, y)| x.powf(y)),
        TNode::Powi(a, k) => v(a).map(|x| x.powi(k)),
        _ => None,
    }
}
