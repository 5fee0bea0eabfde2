//! Rules on expressions: names, fields, operators and types. An
//! expression is typed bottom-up over its flat syntax; a node whose child
//! failed fails silently, so one mistake gives one error, and the walk goes
//! on so that independent mistakes are all reported.

use std::collections::{HashMap, HashSet};

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;
use crate::span::Span;
use crate::syntax::{self, BinOp, ExprKind};

use super::call::{Arg, check_call, scalar_arg};
use super::model::{BodyRef, Comp, TExpr, TNode, Ty};
use super::{BodyName, Decl, Deps, Names, Typed, describe, plural_args, show_nonfinite};

/// A typed node about to be pushed: the node, its type, its dependencies.
pub(super) type Node = (TNode, Ty, Deps);

/// Types the subtree of `expr` rooted at `root`. `params_visible`: params
/// with a smaller index may be used. Reports errors; `None` if any.
pub(super) fn check_expr(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    root: u32,
    params_visible: usize,
) -> Option<Typed> {
    let order = expr.subtree(root);
    let mut ck = ExprCheck {
        names,
        expr,
        params_visible,
        body_base: body_bases(names, expr, &order),
        map: HashMap::with_capacity(order.len()),
        out: TExpr {
            nodes: Vec::new(),
            types: Vec::new(),
            spans: Vec::new(),
        },
        folded: Vec::new(),
    };
    let errors_before = cx.error_count();
    let mut failed = false;
    for &i in &order {
        if ck.body_base.contains(&i) {
            continue;
        }
        match ck.check_node(cx, i) {
            Some(n) => ck.push(cx, i, n),
            None => failed = true,
        }
    }
    if cx.error_count() > errors_before || failed {
        return None;
    }
    let (_, deps) = ck.map.get(&root).copied()?;
    // The typed root is the last node (children first): the root has the
    // largest syntax index and nodes are pushed in order.
    Some(Typed { expr: ck.out, deps })
}

/// Field bases that name a body (`crank` in `crank.x`): the field handles
/// them. A poisoned name counts, so that its fields stay silent.
fn body_bases(names: &Names<'_>, expr: &syntax::Expr, order: &[u32]) -> HashSet<u32> {
    let mut out = HashSet::new();
    for &i in order {
        if let ExprKind::Field(b, _) = &expr.node(i).kind
            && let ExprKind::Ident(id) = &expr.node(*b).kind
            && !matches!(names.body(&id.to_string()), BodyName::Unknown)
        {
            out.insert(*b);
        }
    }
    out
}

/// The state of one expression's walk.
pub(super) struct ExprCheck<'a, 'n> {
    pub(super) names: &'a Names<'n>,
    pub(super) expr: &'a syntax::Expr,
    params_visible: usize,
    body_base: HashSet<u32>,
    /// Syntax index → (typed index, deps), for the nodes typed so far.
    map: HashMap<u32, (u32, Deps)>,
    pub(super) out: TExpr,
    /// The value of each typed node that is a constant of numbers and `pi`
    /// alone (what the engine folds), to report a fold that is not finite.
    pub(super) folded: Vec<Option<f64>>,
}

impl ExprCheck<'_, '_> {
    /// The typed child `j`; `None` (silently) if it failed.
    fn child(&self, j: u32) -> Option<(u32, Deps)> {
        self.map.get(&j).copied()
    }

    /// The type of the typed node `k`.
    pub(super) fn ty(&self, k: u32) -> Ty {
        self.out.types[k as usize]
    }

    fn push(&mut self, cx: &mut Ctxt, i: u32, (n, ty, deps): Node) {
        let span = self.expr.node(i).span;
        let value = fold_constant(cx, &n, &self.folded, &self.out, span);
        self.folded.push(value);
        let id = self.out.push_spanned(n, ty, span);
        self.map.insert(i, (id, deps));
    }

    /// Types syntax node `i`, its children typed; `None` if it fails.
    fn check_node(&mut self, cx: &mut Ctxt, i: u32) -> Option<Node> {
        let node = self.expr.node(i);
        let span = node.span;
        match &node.kind {
            ExprKind::Num { value, suffix } => check_number(cx, *value, suffix, span),
            ExprKind::Ident(id) => self.check_ident(cx, &id.to_string(), span),
            ExprKind::Field(b, field) if self.body_base.contains(b) => {
                let ExprKind::Ident(body) = &self.expr.node(*b).kind else {
                    return None;
                };
                self.check_coordinate(cx, &body.to_string(), field, span)
            }
            ExprKind::Field(b, field) => self.check_vector_field(cx, *b, field),
            ExprKind::Tuple(items) => self.check_tuple(cx, items, span),
            ExprKind::Neg(a) => {
                let (a, da) = self.child(*a)?;
                Some((TNode::Neg(a), self.ty(a), da))
            }
            ExprKind::Binary(op, a, b) => self.check_binary(cx, *op, *a, *b),
            ExprKind::Call(f, args) => {
                let typed: Vec<(u32, Deps)> =
                    args.iter().map(|&a| self.child(a)).collect::<Option<_>>()?;
                let args: Vec<Arg> = args.iter().zip(typed).map(Arg::from).collect();
                self.check_call_or_point(cx, f, span, &args)
            }
        }
    }

    /// A name alone: `pi`, `t` or a param.
    fn check_ident(&self, cx: &mut Ctxt, n: &str, span: Span) -> Option<Node> {
        match n {
            "pi" => return Some((TNode::Pi, Ty::Scalar, Deps::default())),
            "t" => {
                let deps = Deps {
                    time: Some(span),
                    coord: None,
                };
                return Some((TNode::Time, Ty::Scalar, deps));
            }
            _ if self.names.curve_arg.as_deref() == Some(n) => {
                return Some((TNode::CurveArg, Ty::Scalar, Deps::default()));
            }
            _ => {}
        }
        match (n, self.names.decls.get(n)) {
            (_, Some(Decl::Coord(k))) => {
                let deps = Deps {
                    time: None,
                    coord: Some(span),
                };
                Some((TNode::Coord(*k, Comp::Extra), Ty::Scalar, deps))
            }
            (_, Some(Decl::Param(p))) if (*p as usize) < self.params_visible => {
                Some((TNode::Param(*p), Ty::Scalar, Deps::default()))
            }
            (_, Some(Decl::Param(_))) => {
                // error: param `b` is used before its value is known
                cx.error(span, format!("param `{n}` is used before its value is known: a param may use only params declared before it"));
                None
            }
            (_, Some(Decl::Poisoned)) => None,
            ("ground", _) | (_, Some(Decl::Body(_))) => {
                // error: expected a scalar, found the body `crank`
                let help = if n == "ground" {
                    "a point on ground is `ground(x, y)`".to_string()
                } else {
                    format!(
                        "use a coordinate (`{n}.x`, `{n}.y`, `{n}.phi`) or a point (`{n}(sx, sy)`)"
                    )
                };
                cx.push(
                    Diagnostic::error(span, format!("expected a scalar, found the body `{n}`"))
                        .with_help(help),
                );
                None
            }
            (_, None) => {
                // error: unknown name `l3`
                let help = match &self.names.curve_arg {
                    // In a curve: `curve B.c(u) = (cos(v), …)`.
                    Some(u) => format!("expected a param, `pi`, or the curve's parameter `{u}`"),
                    None => {
                        "expected a param, `pi`, `t`, or a coordinate such as `body.x`".to_string()
                    }
                };
                cx.push(Diagnostic::error(span, format!("unknown name `{n}`")).with_help(help));
                None
            }
        }
    }

    /// `body.x`, `body.y`, `body.phi` or a declared point `body.name`.
    fn check_coordinate(
        &self,
        cx: &mut Ctxt,
        bn: &str,
        field: &crate::syntax::Name,
        span: Span,
    ) -> Option<Node> {
        let BodyName::Body(body) = self.names.body(bn) else {
            return None; // poisoned
        };
        let f = field.to_string();
        if let Some(node) = super::dynamics::check_velocity(cx, self.names, body, &f, span) {
            return node;
        }
        let comp = match f.as_str() {
            "x" => Some(Comp::X),
            "y" => Some(Comp::Y),
            "phi" => Some(Comp::Phi),
            _ => None,
        };
        match (comp, body) {
            (Some(_), BodyRef::Ground) => {
                // error: `ground` has no coordinates
                cx.error(span, "`ground` has no coordinates: it is fixed");
                None
            }
            (Some(c), BodyRef::Body(k)) => {
                let deps = Deps {
                    time: None,
                    coord: Some(span),
                };
                Some((TNode::Coord(k, c), Ty::Scalar, deps))
            }
            (None, _) => match self.names.points.get(&(body, f.clone())) {
                Some(p) => {
                    let deps = Deps {
                        time: None,
                        coord: (body != BodyRef::Ground).then_some(span),
                    };
                    Some((TNode::NamedPoint(*p), Ty::Vector, deps))
                }
                None => {
                    // error: body `crank` has no point `q`
                    cx.push(
                        Diagnostic::error(
                            field.span(),
                            format!("body `{bn}` has no point `{f}`"),
                        )
                        .with_help(format!(
                            "expected `x`, `y`, `phi` or a point declared with `point {bn}.{f} = (sx, sy);`"
                        )),
                    );
                    None
                }
            },
        }
    }

    /// `v.x`, `v.y` of a vector expression.
    fn check_vector_field(
        &self,
        cx: &mut Ctxt,
        b: u32,
        field: &crate::syntax::Name,
    ) -> Option<Node> {
        let (a, da) = self.child(b)?;
        let ta = self.ty(a);
        let f = field.to_string();
        match f.as_str() {
            "x" | "y" if ta == Ty::Vector => {
                let n = if f == "x" { TNode::X(a) } else { TNode::Y(a) };
                Some((n, Ty::Scalar, da))
            }
            "x" | "y" => {
                cx.error(
                    self.expr.node(b).span,
                    format!(
                        "expected a vector before `.{f}`, found {}",
                        describe(self.expr, b, ta)
                    ),
                );
                None
            }
            _ => {
                // error: unknown field `z`: expected `x` or `y`
                cx.error(
                    field.span(),
                    format!("unknown field `{f}`: expected `x` or `y` (or a body before the `.`)"),
                );
                None
            }
        }
    }

    /// A vector literal `(a, b)`.
    fn check_tuple(&self, cx: &mut Ctxt, items: &[u32], span: Span) -> Option<Node> {
        if items.len() != 2 {
            cx.error(
                span,
                format!(
                    "expected a vector `(a, b)`, found a tuple of {} elements",
                    items.len()
                ),
            );
            return None;
        }
        let (a, da) = self.child(items[0])?;
        let (b, db) = self.child(items[1])?;
        let ok_a = scalar_arg(cx, self, items[0], a);
        let ok_b = scalar_arg(cx, self, items[1], b);
        (ok_a && ok_b).then(|| (TNode::Vec(a, b), Ty::Vector, da.or(db)))
    }

    /// `a + b`, `a - b`, `a * b`, `a / b`: the types of the operands.
    fn check_binary(&self, cx: &mut Ctxt, op: BinOp, a: u32, b: u32) -> Option<Node> {
        let (x, dx) = self.child(a)?;
        let (y, dy) = self.child(b)?;
        let (tx, ty) = (self.ty(x), self.ty(y));
        let deps = dx.or(dy);
        match (op, tx, ty) {
            (BinOp::Add, _, _) if tx == ty => Some((TNode::Add(x, y), tx, deps)),
            (BinOp::Sub, _, _) if tx == ty => Some((TNode::Sub(x, y), tx, deps)),
            (BinOp::Add | BinOp::Sub, _, _) => {
                self.mixed_sum(cx, op, a, b, tx);
                None
            }
            (BinOp::Mul, Ty::Vector, Ty::Vector) => {
                cx.push(Diagnostic::error(self.expr.node(b).span, format!("expected a scalar, found {}", describe(self.expr, b, ty)))
                    .with_help("a vector may be multiplied by a scalar only; use `dot(a, b)` or `cross(a, b)` for products of vectors"));
                None
            }
            (BinOp::Mul, _, _) => {
                let t = if tx == Ty::Vector || ty == Ty::Vector {
                    Ty::Vector
                } else {
                    Ty::Scalar
                };
                Some((TNode::Mul(x, y), t, deps))
            }
            (BinOp::Div, _, Ty::Vector) => {
                cx.error(
                    self.expr.node(b).span,
                    format!(
                        "expected a scalar divisor, found {}",
                        describe(self.expr, b, ty)
                    ),
                );
                None
            }
            (BinOp::Div, _, _) => Some((TNode::Div(x, y), tx, deps)),
        }
    }

    /// Rule: a vector is not added to a scalar.
    ///   error: expected a scalar, found a vector (point `crank.o`)
    fn mixed_sum(&self, cx: &mut Ctxt, op: BinOp, a: u32, b: u32, tx: Ty) {
        let (v, other) = if tx == Ty::Vector { (a, b) } else { (b, a) };
        let verb = if op == BinOp::Add {
            "added to"
        } else {
            "subtracted from"
        };
        let other_name = match &self.expr.node(other).kind {
            ExprKind::Ident(n) => format!(" (`{n}`)"),
            _ => String::new(),
        };
        cx.push(
            Diagnostic::error(
                self.expr.node(v).span,
                format!(
                    "expected a scalar, found {}",
                    describe(self.expr, v, Ty::Vector)
                ),
            )
            .with_label(format!("a vector cannot be {verb} a scalar"))
            .with_help(format!("the other operand is a scalar{other_name}")),
        );
    }

    /// `name(args…)`: a point `B(sx, sy)` in a body's frame when `name` is
    /// a body, else a function call.
    fn check_call_or_point(
        &mut self,
        cx: &mut Ctxt,
        fname: &crate::syntax::Name,
        span: Span,
        args: &[Arg],
    ) -> Option<Node> {
        let f = fname.to_string();
        match self.names.body(&f) {
            BodyName::Body(body) => self.check_body_point(cx, &f, body, span, args),
            BodyName::Poisoned if !super::call::is_function(&f) => None,
            _ => check_call(cx, self, &f, fname.span(), span, args),
        }
    }

    /// Rule: a point `B(sx, sy)` has two scalar constant coordinates.
    ///   error: wrong number of arguments: expected `crank(sx, sy)`, found 3 arguments
    ///   error: time `t` cannot appear in the local coordinates of a point: …
    fn check_body_point(
        &mut self,
        cx: &mut Ctxt,
        f: &str,
        body: BodyRef,
        span: Span,
        args: &[Arg],
    ) -> Option<Node> {
        let [x, y] = args else {
            cx.error(span, format!("wrong number of arguments: expected `{f}(sx, sy)` (a point in the body's frame), found {}", plural_args(args.len())));
            return None;
        };
        let mut ok = scalar_arg(cx, self, x.syn, x.typed) & scalar_arg(cx, self, y.syn, y.typed);
        let deps = x.deps.or(y.deps);
        let what = "the local coordinates of a point";
        if let Some(s) = deps.time {
            cx.error(
                s,
                format!(
                    "time `t` cannot appear in {what}: expected a constant expression of params"
                ),
            );
            ok = false;
        }
        if let Some(s) = deps.coord {
            cx.error(s, format!("coordinates and points cannot appear in {what}: expected a constant expression of params"));
            ok = false;
        }
        if !ok {
            return None;
        }
        let v = self
            .out
            .push_spanned(TNode::Vec(x.typed, y.typed), Ty::Vector, span);
        self.folded.push(None);
        let coord = (body != BodyRef::Ground).then_some(span);
        Some((
            TNode::Point(body, v),
            Ty::Vector,
            Deps { time: None, coord },
        ))
    }
}

/// Rule: numbers are written as in maths, and are finite.
///   error: number with a type suffix `f64`: expected a plain number such as `2`, `0.3` or `1e-3`
///   error: number out of range: expected a finite number
fn check_number(cx: &mut Ctxt, value: f64, suffix: &str, span: Span) -> Option<Node> {
    if !suffix.is_empty() {
        cx.error(span, format!("number with a type suffix `{suffix}`: expected a plain number such as `2`, `0.3` or `1e-3`"));
        None
    } else if !value.is_finite() {
        cx.error(span, "number out of range: expected a finite number");
        None
    } else {
        Some((TNode::Num(value), Ty::Scalar, Deps::default()))
    }
}

/// Rules: a constant of numbers and `pi` folds to a finite number, and no
/// divisor is identically zero.
///   error: division by zero: this divisor is zero
///   error: this constant overflows: its value is infinite
///
/// Computes the folded value of the typed node `n` about to be pushed after
/// the nodes whose values are `folded` (None: not such a constant). The
/// first node whose value stops being finite is reported; its parents are
/// then not constants any more, so one mistake gives one error.
fn fold_constant(
    cx: &mut Ctxt,
    n: &TNode,
    folded: &[Option<f64>],
    out: &TExpr,
    span: Span,
) -> Option<f64> {
    if let TNode::Div(_, b) = *n
        && folded.get(b as usize).copied().flatten() == Some(0.0)
    {
        cx.push(
            Diagnostic::error(
                out.span(b).unwrap_or(span),
                "division by zero: this divisor is zero",
            )
            .with_help("the quotient is undefined whatever the coordinates and time"),
        );
        return None;
    }
    match super::eval::fold(n, folded) {
        Some(x) if !x.is_finite() => {
            cx.push(
                Diagnostic::error(
                    span,
                    format!("this constant is {}: expected a finite number", show_nonfinite(x)),
                )
                .with_help("its value overflows or is undefined (such as `1e308 * 1e308`, `ln(0)` or `0 / 0`)"),
            );
            None
        }
        other => other,
    }
}
