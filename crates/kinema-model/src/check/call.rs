//! Rules on function calls: the function exists, its arguments are as many
//! as its signature says and of the types it needs.

use kinema_expr::{FUNCTIONS, Function, FunctionKind, FunctionKind as K};

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;
use crate::span::Span;
use crate::syntax::ExprKind;

use super::expr::{ExprCheck, Node};
use super::library::library;
use super::model::{TNode, Ty};
use super::{Deps, describe, plural_args};

/// One argument of a call: its syntax node, its typed node, its deps.
#[derive(Clone, Copy)]
pub(super) struct Arg {
    pub(super) syn: u32,
    pub(super) typed: u32,
    pub(super) deps: Deps,
}

impl From<(&u32, (u32, Deps))> for Arg {
    fn from((&syn, (typed, deps)): (&u32, (u32, Deps))) -> Self {
        Arg { syn, typed, deps }
    }
}

/// True for the name of a function of the language.
pub(super) fn is_function(name: &str) -> bool {
    kinema_expr::function(name).is_some()
}

fn function_names() -> String {
    FUNCTIONS
        .iter()
        .map(|f| format!("`{}`", f.name))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Types a function call `f(args…)`: `fspan` is the name's span, `span` the
/// call's.
pub(super) fn check_call(
    cx: &mut Ctxt,
    ck: &ExprCheck<'_, '_>,
    f: &str,
    fspan: Span,
    span: Span,
    args: &[Arg],
) -> Option<Node> {
    let function = known_function(cx, f, fspan)?;
    // Rule: argument counts match the signature.
    //   error: wrong number of arguments: expected `atan2(y, x)`, found 1 argument
    if args.len() != function.arity {
        cx.error(
            span,
            format!(
                "wrong number of arguments: expected `{}`, found {}",
                function.signature,
                plural_args(args.len())
            ),
        );
        return None;
    }
    let deps = args.iter().fold(Deps::default(), |d, a| d.or(a.deps));
    let a = |k: usize| args[k].typed;
    let vector = |cx: &mut Ctxt, k: usize| vector_arg(cx, ck, args[k].syn, a(k));
    let scalar = |cx: &mut Ctxt, k: usize| scalar_arg(cx, ck, args[k].syn, a(k));
    let (node, ty) = match function.kind {
        K::Dot if vector(cx, 0) & vector(cx, 1) => (TNode::Dot(a(0), a(1)), Ty::Scalar),
        K::Cross if vector(cx, 0) & vector(cx, 1) => (TNode::Cross(a(0), a(1)), Ty::Scalar),
        K::Norm if vector(cx, 0) => (TNode::Norm(a(0)), Ty::Scalar),
        K::Perp if vector(cx, 0) => (TNode::Perp(a(0)), Ty::Vector),
        K::Rot if scalar(cx, 0) & vector(cx, 1) => (TNode::Rot(a(0), a(1)), Ty::Vector),
        K::Powi if scalar(cx, 0) => {
            let n = powi_exponent(cx, ck, args[1].syn)?;
            (TNode::Powi(a(0), n), Ty::Scalar)
        }
        K::Dot | K::Cross | K::Norm | K::Perp | K::Rot | K::Powi => return None,
        kind if (0..args.len()).fold(true, |ok, k| scalar(cx, k) & ok) => {
            (scalar_function(kind, args)?, Ty::Scalar)
        }
        _ => return None,
    };
    Some((node, ty, deps))
}

/// Rule: functions are known.
///   error: unknown function `sine`
fn known_function(cx: &mut Ctxt, f: &str, fspan: Span) -> Option<&'static Function> {
    if let Some(function) = kinema_expr::function(f) {
        return Some(function);
    }
    let help = match library(f) {
        Some(spec) => format!(
            "`{f}` is a library constraint: it is a whole equation, as in `joint j: {};`",
            spec.signature
        ),
        None => format!(
            "expected a body (for a point `B(sx, sy)`) or one of: {}",
            function_names()
        ),
    };
    cx.push(Diagnostic::error(fspan, format!("unknown function `{f}`")).with_help(help));
    None
}

/// The node of a function of scalars only.
fn scalar_function(kind: FunctionKind, args: &[Arg]) -> Option<TNode> {
    let a = |k: usize| args[k].typed;
    Some(match kind {
        FunctionKind::Unary(op) => TNode::F1(op, a(0)),
        FunctionKind::Sqrt => TNode::Sqrt(a(0)),
        FunctionKind::Atan2 => TNode::Atan2(a(0), a(1)),
        FunctionKind::Pow => TNode::Pow(a(0), a(1)),
        FunctionKind::Step => TNode::Step([a(0), a(1), a(2), a(3), a(4)]),
        _ => return None,
    })
}

/// Rule: the exponent of `powi` is an integer literal.
///   error: expected an integer exponent for `powi` (such as `2` or `-1`)
fn powi_exponent(cx: &mut Ctxt, ck: &ExprCheck<'_, '_>, syn: u32) -> Option<i32> {
    let n = integer_literal(ck.expr, syn);
    if n.is_none() {
        cx.error(ck.expr.node(syn).span, "expected an integer exponent for `powi` (such as `2` or `-1`); use `pow(x, y)` for other exponents");
    }
    n
}

/// `n` or `-n` with n an integer literal without suffix.
fn integer_literal(expr: &crate::syntax::Expr, i: u32) -> Option<i32> {
    let (neg, j) = match &expr.node(i).kind {
        ExprKind::Neg(j) => (true, *j),
        _ => (false, i),
    };
    match &expr.node(j).kind {
        ExprKind::Num { value, suffix }
            if suffix.is_empty() && value.fract() == 0.0 && value.abs() <= 1e6 =>
        {
            // Checked range above: the cast is exact.
            #[allow(clippy::cast_possible_truncation)]
            let n = *value as i32;
            Some(if neg { -n } else { n })
        }
        _ => None,
    }
}

/// Rule: a scalar is needed here.
///   error: expected a scalar, found a vector (point `crank.o`)
pub(super) fn scalar_arg(cx: &mut Ctxt, ck: &ExprCheck<'_, '_>, syn: u32, typed: u32) -> bool {
    expect_arg(cx, ck, syn, typed, Ty::Scalar)
}

/// Rule: a vector is needed here.
///   error: expected a vector, found a scalar
fn vector_arg(cx: &mut Ctxt, ck: &ExprCheck<'_, '_>, syn: u32, typed: u32) -> bool {
    expect_arg(cx, ck, syn, typed, Ty::Vector)
}

fn expect_arg(cx: &mut Ctxt, ck: &ExprCheck<'_, '_>, syn: u32, typed: u32, want: Ty) -> bool {
    let ty = ck.ty(typed);
    if ty == want {
        return true;
    }
    cx.error(
        ck.expr.node(syn).span,
        format!(
            "expected {}, found {}",
            super::ty_name(want),
            describe(ck.expr, syn, ty)
        ),
    );
    false
}
