//! Rules on coordinates of their own (`coord`) and body-fixed curves
//! (`curve`), and on the curve and coordinate arguments of the follower
//! constraints (see [`crate::follower`]).

use std::collections::HashMap;

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;
use crate::span::Span;
use crate::syntax::{self, ExprKind, Item};
use crate::syntax::{CoordDecl, CurveDecl};

use super::decls::{check_constant, finite_scalar};
use super::library::LibSpec;
use super::model::{BodyRef, TExpr, TNode, Ty};
use super::{Decl, Names, idx, resolve_body};

/// A generalized coordinate of its own (`coord name { guess: … }`).
#[derive(Clone, Debug)]
pub struct Coord {
    /// Its name.
    pub name: String,
    /// Span of its name.
    pub span: Span,
    /// Doc comments.
    pub docs: Vec<String>,
    /// The initial guess at the default params.
    pub guess_value: f64,
    pub(crate) guess: TExpr,
}

/// A body-fixed curve (`curve B.name(u) = (x(u), y(u));`).
#[derive(Clone, Debug)]
pub struct Curve {
    /// Its name (without the body).
    pub name: String,
    /// The body it is fixed in.
    pub body: BodyRef,
    /// Span of the declaration's name.
    pub span: Span,
    /// Doc comments.
    pub docs: Vec<String>,
    /// The name of its parameter.
    pub param: String,
    /// Local coordinates: a vector of params and the parameter
    /// ([`TNode::CurveArg`]).
    pub(crate) local: TExpr,
}

/// The declared curves: (body, name) → index, for library arguments.
pub(super) type CurveNames = HashMap<(BodyRef, String), u32>;

/// Rule: a coordinate's guess is a finite constant of params.
///   error: this initial guess is NaN: expected a finite number
pub(super) fn check_coords(
    cx: &mut Ctxt,
    names: &Names<'_>,
    coords: &[&CoordDecl],
    values: &[f64],
) -> Vec<Coord> {
    let mut out = Vec::with_capacity(coords.len());
    for c in coords {
        let mut guess = TExpr {
            nodes: vec![TNode::Num(0.0)],
            types: vec![Ty::Scalar],
            spans: Vec::new(),
        };
        let mut guess_value = 0.0;
        if let Some(g) = &c.guess {
            let what = "an initial guess";
            if let Some(t) = check_constant(cx, names, (g, g.root), values.len(), Ty::Scalar, what)
            {
                guess_value = finite_scalar(cx, &t, values, g.span(), "this initial guess");
                guess = t;
            }
        }
        out.push(Coord {
            name: c.name.to_string(),
            span: c.name.span(),
            docs: c.docs.clone(),
            guess_value,
            guess,
        });
    }
    out
}

/// Rules: a curve is declared on a body (or `ground`), its name is unique
/// on that body, and its local coordinates are a vector of params and its
/// parameter (no time, no coordinates).
///   error: unknown body `yok`
///   error: duplicate curve `yoke.slot`
///   error: unknown name `v` (help: … the curve's parameter `u`)
///   error: time `t` cannot appear in a curve: expected a constant expression of params
///
/// Registers the accepted curves in `names` (a rejected one stays
/// registered when its body is known, so that its uses are silent).
pub(super) fn check_curves(
    cx: &mut Ctxt,
    names: &mut Names<'_>,
    mech: &syntax::Mechanism,
    values: &[f64],
) -> Vec<Curve> {
    let mut out = Vec::new();
    for item in &mech.items {
        let Item::Curve(c) = item else { continue };
        let bn = c.body.to_string();
        let Some(body) = resolve_body(cx, names, &bn, c.body.span()) else {
            continue;
        };
        let name = c.name.to_string();
        if names.curves.contains_key(&(body, name.clone())) {
            cx.error(c.name.span(), format!("duplicate curve `{bn}.{name}`"));
            continue;
        }
        let local = check_curve_value(cx, names, c, values.len());
        names.curves.insert((body, name.clone()), idx(out.len()));
        out.push(Curve {
            name,
            body,
            span: c.name.span(),
            docs: c.docs.clone(),
            param: c.param.to_string(),
            local: local.unwrap_or_else(|| TExpr {
                nodes: vec![TNode::Num(f64::NAN), TNode::Num(f64::NAN), TNode::Vec(0, 1)],
                types: vec![Ty::Scalar, Ty::Scalar, Ty::Vector],
                spans: Vec::new(),
            }),
        });
    }
    out
}

fn check_curve_value(
    cx: &mut Ctxt,
    names: &mut Names<'_>,
    c: &CurveDecl,
    params: usize,
) -> Option<TExpr> {
    let param = c.param.to_string();
    if matches!(param.as_str(), "pi" | "t" | "ground") {
        // error: `t` cannot be a curve's parameter: it is time
        cx.error(
            c.param.span(),
            format!("`{param}` cannot be a curve's parameter: it has a built-in meaning"),
        );
        return None;
    }
    names.curve_arg = Some(param);
    let what = "a curve (a vector of params and the curve's parameter)";
    let t = check_constant(
        cx,
        names,
        (&c.value, c.value.root),
        params,
        Ty::Vector,
        what,
    );
    names.curve_arg = None;
    let t = t?;
    if !t.nodes.iter().any(|n| matches!(n, TNode::CurveArg)) {
        // error: curve `yoke.slot` does not depend on its parameter `u`
        cx.push(
            Diagnostic::error(
                c.value.span(),
                format!(
                    "curve `{}.{}` does not depend on its parameter `{}`",
                    c.body, c.name, c.param
                ),
            )
            .with_help("a curve is a point moving with its parameter: it would make Φ_q singular"),
        );
        return None;
    }
    Some(t)
}

/// A curve argument `B.name` of a follower constraint.
///   error: expected a curve `B.name` in `point_follower(P, B.curve, alpha)`
///   error: body `crank` has no curve `slot` (help: `slot` is a curve of `yoke`: write `yoke.slot`)
pub(super) fn check_curve_arg(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    a: u32,
    spec: &LibSpec,
) -> Option<(BodyRef, u32)> {
    let node = expr.node(a);
    let (bid, f) = match &node.kind {
        ExprKind::Field(b, f) => match &expr.node(*b).kind {
            ExprKind::Ident(bid) => (bid, f),
            _ => return curve_expected(cx, node.span, spec),
        },
        _ => return curve_expected(cx, node.span, spec),
    };
    let bn = bid.to_string();
    let body = resolve_body(cx, names, &bn, bid.span())?;
    let fname = f.to_string();
    if let Some(&k) = names.curves.get(&(body, fname.clone())) {
        return Some((body, k));
    }
    let mut d = Diagnostic::error(f.span(), format!("body `{bn}` has no curve `{fname}`"));
    // The same name on another body: the likely mistake (a curve belongs
    // to the body it is declared on). Lowest body first, for stable output.
    let elsewhere = names
        .curves
        .keys()
        .filter(|(_, n)| *n == fname)
        .map(|(b, _)| *b)
        .min();
    d = match elsewhere {
        Some(other) => d.with_help(format!(
            "`{fname}` is a curve of `{0}`, not of `{bn}`: write `{0}.{fname}`",
            names.body_name(other)
        )),
        None => d.with_help(format!(
            "expected a curve declared with `curve {bn}.{fname}(u) = (x, y);`"
        )),
    };
    cx.push(d);
    None
}

fn curve_expected<T>(cx: &mut Ctxt, span: Span, spec: &LibSpec) -> Option<T> {
    cx.error(
        span,
        format!(
            "expected a curve `B.name` (declared with `curve`) in `{}`",
            spec.signature
        ),
    );
    None
}

/// A coordinate argument: the name of a `coord` item.
///   error: expected a coordinate declared with `coord` in `point_follower(P, B.curve, alpha)`, found `beta`
pub(super) fn check_coord_arg(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    a: u32,
    spec: &LibSpec,
) -> Option<u32> {
    let node = expr.node(a);
    let found = match &node.kind {
        ExprKind::Ident(id) => {
            let n = id.to_string();
            match names.decls.get(&n) {
                Some(Decl::Coord(k)) => return Some(*k),
                Some(Decl::Poisoned) => return None,
                Some(Decl::Param(_)) => format!("the param `{n}`"),
                Some(Decl::Body(_)) => format!("the body `{n}`"),
                None => format!("`{n}`, which is not declared"),
            }
        }
        _ => "an expression".to_string(),
    };
    cx.push(
        Diagnostic::error(
            node.span,
            format!(
                "expected a coordinate declared with `coord` in `{}`, found {found}",
                spec.signature
            ),
        )
        .with_help("a follower's curve parameter is a coordinate of its own: declare it with `coord alpha { guess: 0 }`"),
    );
    None
}

/// Rule: no part of a curve is undefined whatever its parameter (as for
/// equations, `count::check_undefined_parts`): each curve is lowered with
/// a fresh symbol for its parameter.
///   error: division by zero: this divisor is identically zero
pub(super) fn check_undefined_curves(
    cx: &mut Ctxt,
    model: &super::CheckedModel,
    lo: &super::lower::Lowerer<'_>,
    arena: &mut kinema_expr::Arena,
) {
    // An index past every coordinate: the symbol is the curve's parameter
    // alone.
    let next = 3 * model.bodies.len() + model.coords.len();
    for (k, c) in model.curves.iter().enumerate() {
        let u = arena.coordinate(&c.param, idx(next));
        lo.curve_reporting(arena, idx(k), u, &mut |i, why| {
            let span = c.local.span(i).unwrap_or(c.span);
            cx.push(match why {
                super::lower::Undefined::ZeroDivisor => Diagnostic::error(
                    span,
                    "division by zero: this divisor is identically zero",
                )
                .with_help("the curve is undefined whatever its parameter"),
                super::lower::Undefined::TinyDivisor => super::count::tiny_divisor(span),
                super::lower::Undefined::Value => Diagnostic::error(
                    span,
                    "this expression is undefined whatever the curve's parameter",
                )
                .with_help("a function is applied where it has no finite value (such as `ln` of an expression that is identically zero)"),
            });
        });
    }
}

/// Rule (for now): a model with coordinates of their own has no dynamics.
/// The dynamics (mass matrix, applied forces) is built over the bodies'
/// coordinates only; a massless curve parameter in it is not supported yet.
///   error: a model with coordinates of their own (`coord`) cannot have dynamics yet
pub(super) fn check_no_dynamics(cx: &mut Ctxt, model: &super::CheckedModel) {
    let (Some(c), Some(_)) = (model.coords.first(), &model.dynamics) else {
        return;
    };
    cx.push(
        Diagnostic::error(
            c.span,
            "a model with coordinates of their own (`coord`) cannot have dynamics (mass, inertia, gravity, forces) yet",
        )
        .with_help("the dynamics is built over the bodies' coordinates only; analyse the kinematics of this model, or leave out its dynamics"),
    );
}
