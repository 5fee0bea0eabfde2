//! Values of constant expressions (param values, guesses, local
//! coordinates, body-fixed vectors): each is lowered into a scratch arena as
//! equations are, with every param replaced by its value, and evaluated
//! there. The engine's own arithmetic, so a constant has the value the
//! tape and generated code compute from the same expression; no second
//! evaluator of the language.

use kinema_expr::Arena;

use super::lower::{Lowerer, Value};
use super::model::{BodyRef, TExpr, TNode};

/// The value of a constant expression: `[x, y]` of a vector, `[v, v]` of a
/// scalar; NaN where it is not finite.
fn eval(t: &TExpr, params: &[f64]) -> [f64; 2] {
    let mut arena = Arena::new();
    let substituted = TExpr {
        nodes: t
            .nodes
            .iter()
            .map(|n| match *n {
                TNode::Param(i) => TNode::Num(params.get(i as usize).copied().unwrap_or(f64::NAN)),
                // Not constants: absent from a constant, but a caller may
                // evaluate a prefix of an equation's nodes whose last node
                // is one (points.rs); their values are never read.
                TNode::Coord(..) | TNode::Vel(..) => TNode::Num(f64::NAN),
                TNode::Point(_, a) => TNode::Point(BodyRef::Ground, a),
                ref n => n.clone(),
            })
            .collect(),
        types: t.types.clone(),
        spans: Vec::new(),
    };
    let lowerer = Lowerer::constants(&mut arena);
    let (x, y) = match lowerer.lower(&mut arena, &substituted) {
        Value::S(e) => (e, e),
        Value::V(v) => (v.x, v.y),
    };
    // Time is the only symbol left, and a constant does not read it.
    let values = arena.eval_many(&[x, y], |_| f64::NAN);
    [values[0], values[1]]
}

pub(super) fn eval_scalar(t: &TExpr, params: &[f64]) -> f64 {
    eval(t, params)[0]
}

pub(crate) fn eval_vector(t: &TExpr, params: &[f64]) -> [f64; 2] {
    eval(t, params)
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
