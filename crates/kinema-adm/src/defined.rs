//! Whether a `fun` expression is undefined whatever `t` is: kinema's rule for
//! model equations (`Arena::is_undefined` of kinema-expr: a divisor that is
//! identically zero once simplified, a constant that folds to ±∞ or NaN, a
//! function applied where it has no finite value), applied to the `fun`
//! string itself so that the reader refuses it at the ADM field, in the
//! user's own text, rather than importing a model that the `.kin` checker
//! would then refuse at text the user never wrote.
//!
//! Its t-free parts are also evaluated as the engine and the `.kin`
//! checker's constant folder do (IEEE, left to right): a constant that is
//! not finite there (`ln(5e-324^pi)`: the power flushes to 0), or a divisor
//! that is 0 there, is refused too.
//!
//! The expression is built in the arena as [`Expr::to_kin`] prints it
//! (`log10` as `ln(x) / ln(10)`, an integer power as `powi`), so the verdict
//! is the one the imported model would get. A forward loop over the flat
//! node list: no recursion.

use kinema_expr::{Arena, ExprId};

use crate::fun::{BinOp, Expr, Func, Func2, Node};

/// Largest integer exponent printed as `powi` (as [`Expr::to_kin`] does).
const MAX_POWI: f64 = 1e6;

/// The first place where a `fun` becomes undefined whatever `t` is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Undefined {
    /// 0-based character offset into the `fun` string (the operator, name or
    /// number of the offending node).
    pub(crate) offset: usize,
    /// What is undefined there, for the message.
    pub(crate) what: &'static str,
}

/// The first node (children before parents) whose value is undefined whatever
/// `t` is while its operands' values are not; `None` if the expression is
/// defined for some `t`.
pub(crate) fn first_undefined(e: &Expr) -> Option<Undefined> {
    let mut arena = Arena::new();
    let t = arena.time();
    // Per node: its arena expression and whether it mentions t.
    let mut ids: Vec<(ExprId, bool)> = Vec::with_capacity(e.nodes().len());
    // Per node: its value in IEEE arithmetic when it does not mention t, as
    // the engine and the `.kin` checker's constant folder compute it.
    let mut consts: Vec<Option<f64>> = Vec::with_capacity(e.nodes().len());
    for (i, &node) in e.nodes().iter().enumerate() {
        // Children precede their parents (the parser's invariant); an index
        // out of range is read as an undefined operand and reported nowhere.
        let get = |k: u32| ids.get(k as usize).copied();
        let (id, has_t, operands) = build(&mut arena, t, node, get)?;
        let constant = constant_value(node, |k| consts.get(k as usize).copied().flatten());
        let finite_children = node_children(node).iter().flatten().all(|&k| {
            consts
                .get(k as usize)
                .copied()
                .flatten()
                .is_none_or(f64::is_finite)
        });
        let zero_divisor = matches!(node, Node::Bin(BinOp::Div, _, b)
            if consts.get(b as usize).copied().flatten() == Some(0.0));
        if zero_divisor || (constant.is_some_and(|v| !v.is_finite()) && finite_children) {
            return Some(Undefined {
                offset: e.offset_of(i),
                what: if zero_divisor {
                    "division by zero: this divisor is zero"
                } else {
                    "this constant is not a finite number"
                },
            });
        }
        consts.push(constant);
        if arena.is_undefined(id) && operands.iter().flatten().all(|&o| !arena.is_undefined(o)) {
            let what = match node {
                Node::Bin(BinOp::Div, _, b) if get(b).is_some_and(|(d, _)| arena.is_zero(d)) => {
                    "division by zero: this divisor is identically zero"
                }
                Node::Num(_) | Node::Pi | Node::T => "this number is not finite",
                _ if !has_t => "this constant is not a finite number",
                _ => "a function or power is applied where it has no finite value",
            };
            return Some(Undefined {
                offset: e.offset_of(i),
                what,
            });
        }
        ids.push((id, has_t));
    }
    None
}

/// The operands of a node.
fn node_children(node: Node) -> [Option<u32>; 2] {
    match node {
        Node::Num(_) | Node::Pi | Node::T => [None, None],
        Node::Neg(a) | Node::Call(_, a) => [Some(a), None],
        Node::Bin(_, a, b) | Node::Call2(_, a, b) => [Some(a), Some(b)],
    }
}

/// A node's value when it and its operands do not mention `t` (`value` of
/// an operand is `None` when it does), in IEEE arithmetic left to right.
fn constant_value(node: Node, value: impl Fn(u32) -> Option<f64>) -> Option<f64> {
    Some(match node {
        Node::Num(x) => x,
        Node::Pi => std::f64::consts::PI,
        Node::T => return None,
        Node::Neg(a) => -value(a)?,
        Node::Call(f, a) => f.apply(value(a)?),
        Node::Bin(op, a, b) => op.apply(value(a)?, value(b)?),
        Node::Call2(Func2::Atan2, a, b) => value(a)?.atan2(value(b)?),
        Node::Call2(Func2::Power, a, b) => value(a)?.powf(value(b)?),
    })
}

/// Builds one node in the arena: its expression, whether it mentions `t`, and
/// its operands' expressions.
fn build(
    arena: &mut Arena,
    t: ExprId,
    node: Node,
    get: impl Fn(u32) -> Option<(ExprId, bool)>,
) -> Option<(ExprId, bool, [Option<ExprId>; 2])> {
    Some(match node {
        Node::Num(x) => (arena.num(x), false, [None, None]),
        Node::Pi => (arena.num(std::f64::consts::PI), false, [None, None]),
        Node::T => (t, true, [None, None]),
        Node::Neg(a) => {
            let (a, ht) = get(a)?;
            (arena.neg(a), ht, [Some(a), None])
        }
        Node::Call(f, a) => {
            let (a, ht) = get(a)?;
            (call(arena, f, a), ht, [Some(a), None])
        }
        Node::Bin(BinOp::Pow, a, b) | Node::Call2(Func2::Power, a, b) => {
            let ((a, ha), (b, hb)) = (get(a)?, get(b)?);
            let integer = arena
                .as_num(b)
                .filter(|v| !hb && v.fract() == 0.0 && v.abs() <= MAX_POWI);
            let id = match integer {
                // |n| ≤ 10⁶: the cast is exact.
                Some(n) => arena.powi(a, n as i32),
                None => arena.pow(a, b),
            };
            (id, ha || hb, [Some(a), Some(b)])
        }
        Node::Bin(op, a, b) => {
            let ((a, ha), (b, hb)) = (get(a)?, get(b)?);
            let id = match op {
                BinOp::Add => arena.add(a, b),
                BinOp::Sub => arena.sub(a, b),
                BinOp::Mul => arena.mul(a, b),
                BinOp::Div | BinOp::Pow => arena.div(a, b),
            };
            (id, ha || hb, [Some(a), Some(b)])
        }
        Node::Call2(Func2::Atan2, a, b) => {
            let ((a, ha), (b, hb)) = (get(a)?, get(b)?);
            (arena.atan2(a, b), ha || hb, [Some(a), Some(b)])
        }
    })
}

fn call(arena: &mut Arena, f: Func, a: ExprId) -> ExprId {
    match f {
        Func::Unary(op) => arena.unary(op, a),
        Func::Sqrt => arena.sqrt(a),
        Func::Log10 => {
            let ln = arena.ln(a);
            let ten = arena.num(10.0);
            let ln10 = arena.ln(ten);
            arena.div(ln, ln10)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn verdict(s: &str) -> Option<Undefined> {
        first_undefined(&Expr::parse(s).expect("parses"))
    }

    #[test]
    fn defined_expressions_pass() {
        for s in [
            "t",
            "sin(t)/t",
            "t/t",
            "log(t)",
            "1e308/10*10 + t",
            "power(t, 2.5)",
            "atan2(t, 0)",
            "log10(t)",
        ] {
            assert_eq!(verdict(s), None, "{s}");
        }
    }

    #[test]
    fn undefined_parts_are_located() {
        // (text, offset of the offending operator or name, message start)
        for (s, offset, what) in [
            ("0/0 + t", 1, "division by zero"),
            // MATLAB evaluates left to right: 1e308*10 is Inf before the
            // division.
            ("1e308*10/1e10 + t", 5, "this constant"),
            ("1e308*1e308 + t", 5, "this constant"),
            ("t + (t - t)/(t - t)", 11, "division by zero"),
            ("t + 0*(1e308*1e308)", 12, "this constant"),
            ("log(t - t) + t", 0, "a function"),
            ("t*(1/0)", 4, "division by zero"),
        ] {
            let u = verdict(s).unwrap_or_else(|| panic!("{s} should be undefined"));
            assert_eq!(u.offset, offset, "{s}: {u:?}");
            assert!(u.what.starts_with(what), "{s}: {u:?}");
        }
    }
}
