//! Rules on the constants of declarations: params' values, points' local
//! coordinates, bodies' initial guesses.

use crate::ctxt::Ctxt;
use crate::span::Span;
use crate::syntax;

use super::eval::{eval_scalar, eval_vector};
use super::expr::check_expr;
use super::model::{Body, BodyRef, InitialVelocity, Param, Point, TExpr, TNode, Ty};
use super::{Names, Typed, show_nonfinite, ty_name};

/// Rule: a param's value is a constant expression of earlier params and
/// `pi`, and it is finite.
///   error: param `b` is used before its declaration
///   error: param `k` has no value: expected `param k = <expression>;`
///   error: the value of param `x` is NaN: expected a finite number
///
/// Returns the params and their values (NaN for one in error).
pub(super) fn check_params(
    cx: &mut Ctxt,
    names: &Names<'_>,
    params: &[&syntax::ParamDecl],
) -> (Vec<Param>, Vec<f64>) {
    let mut out = Vec::with_capacity(params.len());
    let mut values: Vec<f64> = Vec::with_capacity(params.len());
    for (i, p) in params.iter().enumerate() {
        let name = p.name.to_string();
        let span = p.name.span();
        let value = match &p.value {
            None => {
                cx.error(
                    span,
                    format!("param `{name}` has no value: expected `param {name} = <expression>;`"),
                );
                f64::NAN
            }
            Some(e) => {
                let place = (e, e.root);
                check_constant(cx, names, place, i, Ty::Scalar, "the value of a param").map_or(
                    f64::NAN,
                    |t| {
                        let what = format!("the value of param `{name}`");
                        finite_scalar(cx, &t, &values, e.span(), &what)
                    },
                )
            }
        };
        values.push(value);
        out.push(Param {
            name,
            span,
            docs: p.docs.clone(),
            value,
        });
    }
    (out, values)
}

/// Rule: points' local coordinates are finite constant vectors of params.
///   error: time `t` cannot appear in the local coordinates of a point: …
pub(super) fn check_points(
    cx: &mut Ctxt,
    names: &Names<'_>,
    items: &[(&syntax::PointDecl, BodyRef)],
    values: &[f64],
) -> Vec<Point> {
    let mut out = Vec::with_capacity(items.len());
    for (p, body) in items {
        let place = (&p.value, p.value.root);
        let what = "the local coordinates of a point";
        let t = check_constant(cx, names, place, values.len(), Ty::Vector, what);
        let (local, local_value) = match t {
            Some(t) => {
                let v = eval_vector(&t, values);
                finite_vector(cx, v, p.value.span(), &t, values);
                (t, v)
            }
            None => (vector_const(0.0, 0.0), [0.0, 0.0]),
        };
        out.push(Point {
            name: p.name.to_string(),
            body: *body,
            span: p.name.span(),
            docs: p.docs.clone(),
            local_value,
            local,
        });
    }
    out
}

/// Rule: bodies' initial guesses and initial velocities are finite
/// constant scalars of params.
///   error: this initial guess is NaN: expected a finite number
pub(super) fn check_guesses(
    cx: &mut Ctxt,
    names: &Names<'_>,
    bodies: &[&syntax::BodyDecl],
    values: &[f64],
) -> Vec<Body> {
    let params = values;
    let mut out = Vec::with_capacity(bodies.len());
    for b in bodies {
        let mut guess = [scalar_const(0.0), scalar_const(0.0), scalar_const(0.0)];
        let mut guess_value = [0.0; 3];
        for (k, g) in b.guess.iter().flatten().enumerate().take(3) {
            let place = (g, g.root);
            let t = check_constant(
                cx,
                names,
                place,
                values.len(),
                Ty::Scalar,
                "an initial guess",
            );
            if let Some(t) = t {
                guess_value[k] = finite_scalar(cx, &t, values, g.span(), "this initial guess");
                guess[k] = t;
            }
        }
        let velocity = b.velocity.as_ref().map(|v| {
            let mut exprs = [scalar_const(0.0), scalar_const(0.0), scalar_const(0.0)];
            let mut values = [0.0; 3];
            for (k, e) in v.value.iter().enumerate() {
                let place = (e, e.root);
                let what = "an initial velocity";
                // error: time `t` cannot appear in an initial velocity: expected a constant expression of params
                if let Some(t) = check_constant(cx, names, place, params.len(), Ty::Scalar, what) {
                    values[k] = finite_scalar(cx, &t, params, e.span(), "this initial velocity");
                    exprs[k] = t;
                }
            }
            InitialVelocity {
                keyword: v.keyword,
                value: values,
                exprs,
            }
        });
        out.push(Body {
            name: b.name.to_string(),
            span: b.name.span(),
            docs: b.docs.clone(),
            guess_value,
            guess,
            velocity,
        });
    }
    out
}

/// Types a constant of params with `params_visible` params in scope and
/// the type `ty` (the rules `constant` and `expect_ty`); reports errors.
/// `what` names the place for messages ("an initial guess").
pub(super) fn check_constant(
    cx: &mut Ctxt,
    names: &Names<'_>,
    (expr, root): (&syntax::Expr, u32),
    params_visible: usize,
    ty: Ty,
    what: &str,
) -> Option<TExpr> {
    let t = check_expr(cx, names, expr, root, params_visible)?;
    if !constant(cx, &t, what) {
        return None;
    }
    expect_ty(cx, t, ty, expr.node(root).span).map(|t| t.expr)
}

/// Evaluates a checked scalar constant. Rule: it is finite (unless a bad
/// param, already reported, is the cause).
///   error: the value of param `x` is NaN: expected a finite number
pub(super) fn finite_scalar(
    cx: &mut Ctxt,
    t: &TExpr,
    values: &[f64],
    span: Span,
    what: &str,
) -> f64 {
    let v = eval_scalar(t, values);
    if !v.is_finite() && !uses_bad_param(t, values) {
        cx.error(
            span,
            format!("{what} is {}: expected a finite number", show_nonfinite(v)),
        );
    }
    v
}

/// Rule: constant contexts (param values, guesses, point coordinates,
/// body-fixed vectors) use only numbers, params and `pi`.
///   error: time `t` cannot appear in the value of a param: expected a constant expression of params
fn constant(cx: &mut Ctxt, t: &Typed, what: &str) -> bool {
    let mut ok = true;
    if let Some(s) = t.deps.time {
        cx.error(
            s,
            format!("time `t` cannot appear in {what}: expected a constant expression of params"),
        );
        ok = false;
    }
    if let Some(s) = t.deps.coord {
        cx.error(s, format!("coordinates and points cannot appear in {what}: expected a constant expression of params"));
        ok = false;
    }
    ok
}

/// Rule: an expression has the type its place needs.
///   error: expected a scalar, found a vector
pub(super) fn expect_ty(cx: &mut Ctxt, t: Typed, ty: Ty, span: Span) -> Option<Typed> {
    if t.expr.ty() == ty {
        return Some(t);
    }
    cx.error(
        span,
        format!("expected {}, found {}", ty_name(ty), ty_name(t.expr.ty())),
    );
    None
}

/// True when `t` reads a param whose value is not finite (already reported).
fn uses_bad_param(t: &TExpr, params: &[f64]) -> bool {
    t.nodes.iter().any(|n| match n {
        TNode::Param(i) => !params.get(*i as usize).is_some_and(|v| v.is_finite()),
        _ => false,
    })
}

/// Rule: constant vectors are finite (unless a bad param, already reported,
/// is the cause).
pub(super) fn finite_vector(cx: &mut Ctxt, v: [f64; 2], span: Span, t: &TExpr, params: &[f64]) {
    let finite = v[0].is_finite() && v[1].is_finite();
    if !finite && !uses_bad_param(t, params) {
        cx.error(span, "this vector is not finite: expected finite numbers");
    }
}

fn scalar_const(v: f64) -> TExpr {
    TExpr {
        nodes: vec![TNode::Num(v)],
        types: vec![Ty::Scalar],
        spans: Vec::new(),
    }
}

fn vector_const(a: f64, b: f64) -> TExpr {
    TExpr {
        nodes: vec![TNode::Num(a), TNode::Num(b), TNode::Vec(0, 1)],
        types: vec![Ty::Scalar, Ty::Scalar, Ty::Vector],
        spans: Vec::new(),
    }
}
