//! Rules on equations (`joint`, `constraint`, `driver`): user-written
//! `lhs == rhs` and calls of library constraints.

use std::collections::HashMap;

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;
use crate::span::Span;
use crate::syntax::{self, EquationKeyword, ExprKind, Item};

use super::decls::{check_constant, expect_ty, finite_vector};
use super::eval::eval_vector;
use super::expr::check_expr;
use super::library::{ArgKind, LIBRARY, LibKind, LibSpec, library};
use super::model::{BodyRef, Equation, Form, LibArg, TExpr, TNode, Ty};
use super::{BodyName, Deps, Names, describe, idx, plural_args, resolve_body, ty_name};

/// A checked equation: its form, dependencies, library kind and rows.
type Checked = (Form, Deps, Option<LibKind>, usize);

/// Checks every equation. Returns them and whether every row count is
/// known (else the DOF rule stays quiet).
pub(super) fn check_equations(
    cx: &mut Ctxt,
    names: &Names<'_>,
    mech: &syntax::Mechanism,
    values: &[f64],
) -> (Vec<Equation>, bool) {
    let mut out = Vec::new();
    let mut first: HashMap<String, Span> = HashMap::new();
    let mut rows_known = true;
    for item in &mech.items {
        let Item::Equation(e) = item else { continue };
        let name = e.name.to_string();
        let span = e.name.span();
        check_unique(cx, &mut first, &name, span);
        let Some((form, deps, library, rows)) = check_equation(cx, names, e, values) else {
            rows_known = false;
            continue;
        };
        check_dependencies(cx, e, &name, span, deps);
        out.push(Equation {
            name,
            span,
            docs: e.docs.clone(),
            keyword: e.keyword,
            rows,
            library,
            form,
        });
    }
    (out, rows_known)
}

/// Rule: equation names are unique.
///   error: duplicate equation name `pin`
fn check_unique(cx: &mut Ctxt, first: &mut HashMap<String, Span>, name: &str, span: Span) {
    if let Some(f) = first.get(name) {
        let s = f.start();
        cx.push(
            Diagnostic::error(span, format!("duplicate equation name `{name}`")).with_help(
                format!("`{name}` is first declared at {}:{}", s.line, s.column + 1),
            ),
        );
    } else {
        first.insert(name.to_string(), span);
    }
}

/// Rules on what an equation depends on.
fn check_dependencies(cx: &mut Ctxt, e: &syntax::EquationDecl, name: &str, span: Span, deps: Deps) {
    let keyword = e.keyword.as_str();
    // Rule: an equation constrains at least one body (a row without
    // coordinates makes Φ_q singular).
    //   error: constraint `c` does not depend on any coordinate
    if deps.coord.is_none() {
        cx.push(
            Diagnostic::error(
                span,
                format!("{keyword} `{name}` does not depend on any coordinate"),
            )
            .with_help("expected an equation in coordinates (`B.x`, `B.y`, `B.phi`) or points of a moving body; it would make Φ_q singular"),
        );
    }
    match (e.keyword, deps.time) {
        // Rule: kinematic constraints do not depend on time.
        //   error: joint `on_axis` is kinematic and cannot depend on time `t`
        //   = help: declare it with `driver` if it drives the mechanism
        (EquationKeyword::Driver, Some(_)) => {}
        (_, Some(t)) => cx.push(
            Diagnostic::error(
                t,
                format!("{keyword} `{name}` is kinematic and cannot depend on time `t`"),
            )
            .with_help("declare it with `driver` if it drives the mechanism"),
        ),
        // Rule (warning): a driver that does not depend on time is a
        // constant constraint.
        //   warning: driver `lock` does not depend on time `t`
        (EquationKeyword::Driver, None) => cx.push(
            Diagnostic::warning(span, format!("driver `{name}` does not depend on time `t`"))
                .with_help("it holds a constant value; `constraint` says so"),
        ),
        _ => {}
    }
}

/// Checks one equation: a user-written `lhs == rhs`, or a library call.
/// A call without `==` whose name is a library constraint's is that
/// constraint (even if a body has the same name); with `==`, a call of a
/// body's name is a point.
fn check_equation(
    cx: &mut Ctxt,
    names: &Names<'_>,
    e: &syntax::EquationDecl,
    values: &[f64],
) -> Option<Checked> {
    let lhs_root = e.lhs.node(e.lhs.root);
    let lib = match &lhs_root.kind {
        ExprKind::Call(f, args) => library(&f.to_string()).map(|s| (s, f, args)),
        _ => None,
    };
    let lib = lib.filter(|(_, f, _)| {
        e.rhs.is_none() || matches!(names.body(&f.to_string()), BodyName::Unknown)
    });
    match (&e.rhs, lib) {
        (Some(rhs), None) => check_user_equation(cx, names, &e.lhs, rhs, values.len()),
        (Some(_), Some((spec, f, _))) => {
            // error: `revolute` is a library constraint, a whole equation: it cannot be compared with `==`
            cx.push(
                Diagnostic::error(f.span(), format!("`{}` is a library constraint, a whole equation: it cannot be compared with `==`", spec.name))
                    .with_help(format!("write `{} {}: {};`", e.keyword.as_str(), e.name, spec.signature)),
            );
            None
        }
        (None, None) => {
            not_an_equation(cx, &e.lhs);
            None
        }
        (None, Some((spec, _, args))) => check_library(cx, names, &e.lhs, spec, args, values),
    }
}

/// Rule: an equation is `lhs == rhs` or a library constraint.
///   error: expected a library constraint or an equation `lhs == rhs`, found an expression without `==`
fn not_an_equation(cx: &mut Ctxt, lhs: &syntax::Expr) {
    let (found, span) = match &lhs.node(lhs.root).kind {
        ExprKind::Call(f, _) => (format!("unknown library constraint `{f}`"), f.span()),
        _ => ("an expression without `==`".to_string(), lhs.span()),
    };
    let all = LIBRARY
        .iter()
        .map(|s| format!("`{}`", s.name))
        .collect::<Vec<_>>()
        .join(", ");
    cx.push(
        Diagnostic::error(
            span,
            format!("expected a library constraint or an equation `lhs == rhs`, found {found}"),
        )
        .with_help(format!("the library constraints are {all}")),
    );
}

/// Rule: both sides of `==` have the same type.
///   error: expected a scalar, found a vector
fn check_user_equation(
    cx: &mut Ctxt,
    names: &Names<'_>,
    lhs: &syntax::Expr,
    rhs: &syntax::Expr,
    all_params: usize,
) -> Option<Checked> {
    let l = check_expr(cx, names, lhs, lhs.root, all_params);
    let r = check_expr(cx, names, rhs, rhs.root, all_params);
    let (l, r) = (l?, r?);
    if l.expr.ty() != r.expr.ty() {
        cx.push(
            Diagnostic::error(
                rhs.span(),
                format!(
                    "expected {}, found {}",
                    ty_name(l.expr.ty()),
                    describe(rhs, rhs.root, r.expr.ty())
                ),
            )
            .with_label(format!("the left side is {}", ty_name(l.expr.ty()))),
        );
        return None;
    }
    let rows = if l.expr.ty() == Ty::Vector { 2 } else { 1 };
    let deps = l.deps.or(r.deps);
    let form = Form::User {
        lhs: l.expr,
        rhs: r.expr,
    };
    Some((form, deps, None, rows))
}

/// Rules on a library call: its argument count, each argument's kind, and
/// two different bodies for a joint.
///   error: wrong number of arguments: expected `revolute(Pi, Pj)`, found 3 arguments
fn check_library(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    spec: &LibSpec,
    args: &[u32],
    values: &[f64],
) -> Option<Checked> {
    if args.len() != spec.args.len() {
        cx.error(
            expr.span(),
            format!(
                "wrong number of arguments: expected `{}`, found {}",
                spec.signature,
                plural_args(args.len())
            ),
        );
        return None;
    }
    let mut out = Vec::new();
    let mut deps = Deps::default();
    let mut bodies: Vec<Option<BodyRef>> = Vec::new();
    for (k, (&a, &kind)) in args.iter().zip(spec.args).enumerate() {
        // An argument's errors say which parameter it is and what the call
        // takes (issue 42: a newcomer needs the signature).
        let mark = cx.mark();
        let arg = check_lib_arg(cx, names, expr, a, kind, spec, values);
        cx.help_since(mark, || spec.argument_help(k));
        if let Some((_, d)) = &arg {
            deps = deps.or(*d);
        }
        let arg = arg.map(|(arg, _)| arg);
        bodies.push(arg.as_ref().and_then(|a| match a {
            LibArg::Point(b, _) | LibArg::Body(b) | LibArg::Curve(b, _) => Some(*b),
            _ => None,
        }));
        out.push(arg);
    }
    let distinct = check_distinct_bodies(cx, names, expr, spec, &bodies);
    let out: Vec<LibArg> = out.into_iter().collect::<Option<_>>()?;
    if !distinct {
        return None;
    }
    // A library constraint depends on coordinates through its points and bodies.
    // and through the coordinates of its own it is given.
    let own = out.iter().any(|a| matches!(a, LibArg::Coord(_)));
    if own || bodies.iter().any(|b| matches!(b, Some(BodyRef::Body(_)))) {
        deps.coord = Some(expr.span());
    }
    Some((
        Form::Library(spec.kind, out),
        deps,
        Some(spec.kind),
        spec.rows,
    ))
}

/// One argument of a library call; its deps count for scalars only (points
/// and bodies give the call its coordinates).
fn check_lib_arg(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    a: u32,
    kind: ArgKind,
    spec: &LibSpec,
    values: &[f64],
) -> Option<(LibArg, Deps)> {
    let node = expr.node(a);
    let none = Deps::default();
    match kind {
        ArgKind::Body => {
            check_body_arg(cx, names, expr, a, spec.signature).map(|b| (LibArg::Body(b), none))
        }
        ArgKind::Point => {
            let (b, local) = check_point_arg(cx, names, expr, a, spec.signature, values.len())?;
            let v = eval_vector(&local, values);
            finite_vector(cx, v, node.span, &local, values);
            Some((LibArg::Point(b, local), none))
        }
        ArgKind::Vector => {
            // `cd`'s and `abs_distance`'s vector is a point of the
            // global frame, the others' a direction in a body's frame.
            let what = match spec.kind {
                LibKind::Cd | LibKind::AbsDistance => "a constant vector of the global frame",
                _ => "a body-fixed vector",
            };
            let t = check_constant(cx, names, (expr, a), values.len(), Ty::Vector, what)?;
            let v = eval_vector(&t, values);
            finite_vector(cx, v, node.span, &t, values);
            Some((LibArg::Vector(t), none))
        }
        ArgKind::Scalar => {
            let t = check_expr(cx, names, expr, a, values.len())?;
            if let Some(s) = t.deps.coord {
                // error: coordinates and points cannot appear in the scalar arguments of `gear`
                cx.push(Diagnostic::error(s, format!("coordinates and points cannot appear in the scalar arguments of `{}`: expected an expression of params and `t`", spec.name))
                    .with_help("write the equation by hand (`lhs == rhs`) for anything else"));
                return None;
            }
            let t = expect_ty(cx, t, Ty::Scalar, node.span)?;
            Some((LibArg::Scalar(t.expr), t.deps))
        }
        ArgKind::Curve => super::coord::check_curve_arg(cx, names, expr, a, spec)
            .map(|(b, k)| (LibArg::Curve(b, k), none)),
        ArgKind::Coord => super::coord::check_coord_arg(cx, names, expr, a, spec)
            .map(|k| (LibArg::Coord(k), none)),
    }
}

/// A body argument: a body's name or `ground`.
///   error: expected a body name (or `ground`) in `rel_angle(Bi, Bj, f)`
pub(super) fn check_body_arg(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    a: u32,
    signature: &str,
) -> Option<BodyRef> {
    let node = expr.node(a);
    if let ExprKind::Ident(id) = &node.kind {
        return resolve_body(cx, names, &id.to_string(), node.span);
    }
    cx.error(
        node.span,
        format!("expected a body name (or `ground`) in `{signature}`"),
    );
    None
}

/// Rule: a two-body constraint joins two different bodies.
///   error: `revolute` joins the body `crank` to itself
fn check_distinct_bodies(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    spec: &LibSpec,
    bodies: &[Option<BodyRef>],
) -> bool {
    let Some((i, j)) = spec.pair else { return true };
    let (Some(Some(bi)), Some(Some(bj))) = (bodies.get(i), bodies.get(j)) else {
        return true;
    };
    if bi != bj {
        return true;
    }
    cx.push(
        Diagnostic::error(
            expr.span(),
            format!(
                "`{}` joins the body `{}` to itself",
                spec.name,
                names.body_name(*bi)
            ),
        )
        .with_help("expected two different bodies"),
    );
    false
}

/// A point argument: `B(sx, sy)`, `B.name` or `ground(x, y)`.
///   error: expected a point (`B(sx, sy)`, `B.name` or `ground(x, y)`) in `revolute(Pi, Pj)`
pub(super) fn check_point_arg(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    a: u32,
    signature: &str,
    all_params: usize,
) -> Option<(BodyRef, TExpr)> {
    let node = expr.node(a);
    match &node.kind {
        ExprKind::Call(b, args) => {
            let bn = b.to_string();
            let body = resolve_body(cx, names, &bn, b.span())?;
            let [x, y] = args[..] else {
                cx.error(node.span, format!("wrong number of arguments: expected `{bn}(sx, sy)` (a point in the body's frame), found {}", plural_args(args.len())));
                return None;
            };
            let what = "the local coordinates of a point";
            let x = check_constant(cx, names, (expr, x), all_params, Ty::Scalar, what);
            let y = check_constant(cx, names, (expr, y), all_params, Ty::Scalar, what);
            Some((body, vector_of(x?, y?)))
        }
        ExprKind::Field(b, f) if matches!(expr.node(*b).kind, ExprKind::Ident(_)) => {
            let ExprKind::Ident(bid) = &expr.node(*b).kind else {
                return None;
            };
            let bn = bid.to_string();
            let body = resolve_body(cx, names, &bn, bid.span())?;
            named_point(cx, names, body, &bn, f)
        }
        _ => {
            cx.error(
                node.span,
                format!(
                    "expected a point (`B(sx, sy)`, `B.name` or `ground(x, y)`) in `{signature}`"
                ),
            );
            None
        }
    }
}

/// Rule: a point `B.name` is declared.
///   error: body `crank` has no point `q`
fn named_point(
    cx: &mut Ctxt,
    names: &Names<'_>,
    body: BodyRef,
    bn: &str,
    f: &crate::syntax::Name,
) -> Option<(BodyRef, TExpr)> {
    let fname = f.to_string();
    if let Some(&p) = names.points.get(&(body, fname.clone())) {
        let point = names.point_decls.get(p as usize)?;
        return Some((body, point.local.clone()));
    }
    cx.push(
        Diagnostic::error(f.span(), format!("body `{bn}` has no point `{fname}`")).with_help(
            format!("expected a point declared with `point {bn}.{fname} = (sx, sy);`"),
        ),
    );
    None
}

/// The vector `(x, y)` of two scalar expressions, as one expression.
fn vector_of(x: TExpr, y: TExpr) -> TExpr {
    let mut local = x;
    let xr = local.root();
    let off = idx(local.nodes.len());
    for (n, ty) in y.nodes.into_iter().zip(y.types) {
        local.push(shift(n, off), ty);
    }
    local.spans.extend(y.spans);
    let yr = local.root();
    local.push(TNode::Vec(xr, yr), Ty::Vector);
    local
}

/// Shifts the child indices of a node by `off`.
fn shift(n: TNode, off: u32) -> TNode {
    use TNode::*;
    match n {
        Num(_) | Pi | Time | Param(_) | Coord(..) | Vel(..) | NamedPoint(_) | CurveArg => n,
        Point(b, a) => Point(b, a + off),
        Vec(a, b) => Vec(a + off, b + off),
        X(a) => X(a + off),
        Y(a) => Y(a + off),
        Neg(a) => Neg(a + off),
        Add(a, b) => Add(a + off, b + off),
        Sub(a, b) => Sub(a + off, b + off),
        Mul(a, b) => Mul(a + off, b + off),
        Div(a, b) => Div(a + off, b + off),
        F1(f, a) => F1(f, a + off),
        Sqrt(a) => Sqrt(a + off),
        Atan2(a, b) => Atan2(a + off, b + off),
        Pow(a, b) => Pow(a + off, b + off),
        Powi(a, k) => Powi(a + off, k),
        Step(s) => Step(s.map(|a| a + off)),
        Dot(a, b) => Dot(a + off, b + off),
        Cross(a, b) => Cross(a + off, b + off),
        Norm(a) => Norm(a + off),
        Rot(a, b) => Rot(a + off, b + off),
        Perp(a) => Perp(a + off),
    }
}
