//! Rules of the dynamics part of the language: a body's `mass` and
//! `inertia`, `gravity`, `force` elements, and velocities `B.x_dot` (in
//! forces only).
//!
//! | call | generalized force |
//! |---|---|
//! | `point_force(P, F)` | F (global) at P: Q += (∂P/∂q)ᵀ F |
//! | `point_force_local(P, F)` | F in the frame of P's body: Q += (∂P/∂q)ᵀ A F |
//! | `torque(B, T)` | Q_φB += T |
//! | `rsda(Bi, Bj, k, c, theta0[, f])` | n = k(φj − φi − θ0) + c(φ̇j − φ̇i) + f; Q_φi += n, Q_φj −= n |
//! | `tsda(Pi, Pj, k, c, L0[, f])` | d = Pj − Pi, l = ‖d‖, n = k(l − L0) + c l̇ + f; n d/l on Pi, −n d/l on Pj |
//!
//! F, T, f are expressions of coordinates, velocities, params and `t`;
//! k, c, θ0, L0 constants of params. `ground` as Bi of `rsda` makes it a
//! one-body spring to ground (simEngine2D's RSDA1).

use std::collections::HashMap;

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;
use crate::span::Span;
use crate::syntax::{self, ExprKind, Item};

use super::decls::{check_constant, expect_ty, finite_vector};
use super::eval::eval_vector;
use super::expr::{Node, check_expr};
use super::model::{BodyRef, Comp, LibArg, TExpr, TNode, Ty};
use super::{Deps, Names, plural_args};

/// A body's inertia: mass and polar moment about its frame's origin (the
/// centroid).
#[derive(Clone, Debug)]
pub struct Inertia {
    /// The mass at the default params.
    pub mass: f64,
    /// The polar moment of inertia at the default params.
    pub inertia: f64,
    pub(crate) mass_expr: TExpr,
    pub(crate) inertia_expr: TExpr,
}

/// Which force element.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ForceKind {
    /// `point_force(P, F)`: a global force at a point.
    PointForce,
    /// `point_force_local(P, F)`: a force in the body's frame at a point.
    PointForceLocal,
    /// `torque(B, T)`.
    Torque,
    /// `rsda(Bi, Bj, k, c, theta0[, f])`: rotational spring-damper-actuator.
    Rsda,
    /// `tsda(Pi, Pj, k, c, L0[, f])`: translational spring-damper-actuator.
    Tsda,
}

/// An argument's kind in a force element.
#[derive(Clone, Copy, PartialEq, Eq)]
enum FArg {
    Point,
    Body,
    /// A vector expression of q, q̇, t and params.
    Vector,
    /// A scalar expression of q, q̇, t and params.
    Scalar,
    /// A constant of params.
    Constant,
}

struct ForceSpec {
    name: &'static str,
    signature: &'static str,
    kind: ForceKind,
    args: &'static [FArg],
    /// Whether a last scalar argument (the actuation f) may follow.
    actuation: bool,
}

const FORCES: &[ForceSpec] = &[
    ForceSpec {
        name: "point_force",
        signature: "point_force(P, F)",
        kind: ForceKind::PointForce,
        args: &[FArg::Point, FArg::Vector],
        actuation: false,
    },
    ForceSpec {
        name: "point_force_local",
        signature: "point_force_local(P, F)",
        kind: ForceKind::PointForceLocal,
        args: &[FArg::Point, FArg::Vector],
        actuation: false,
    },
    ForceSpec {
        name: "torque",
        signature: "torque(B, T)",
        kind: ForceKind::Torque,
        args: &[FArg::Body, FArg::Scalar],
        actuation: false,
    },
    ForceSpec {
        name: "rsda",
        signature: "rsda(Bi, Bj, k, c, theta0[, f])",
        kind: ForceKind::Rsda,
        args: &[
            FArg::Body,
            FArg::Body,
            FArg::Constant,
            FArg::Constant,
            FArg::Constant,
        ],
        actuation: true,
    },
    ForceSpec {
        name: "tsda",
        signature: "tsda(Pi, Pj, k, c, L0[, f])",
        kind: ForceKind::Tsda,
        args: &[
            FArg::Point,
            FArg::Point,
            FArg::Constant,
            FArg::Constant,
            FArg::Constant,
        ],
        actuation: true,
    },
];

impl ForceKind {
    /// The element's name in the language.
    #[must_use]
    pub fn name(self) -> &'static str {
        FORCES
            .iter()
            .find(|s| s.kind == self)
            .map_or("", |s| s.name)
    }
}

/// One applied force element.
#[derive(Clone, Debug)]
pub struct Force {
    /// Its name.
    pub name: String,
    /// Span of the name.
    pub span: Span,
    /// Doc comments.
    pub docs: Vec<String>,
    /// Which element.
    pub kind: ForceKind,
    /// The arguments (the actuation, if any, last).
    pub(crate) args: Vec<LibArg>,
}

/// Inertia, gravity and forces of a model.
#[derive(Clone, Debug)]
pub struct Dynamics {
    /// Per body, in declaration order (zero for a model that declares
    /// forces but no inertia: a massless, quasi-static mechanism).
    pub inertia: Vec<Inertia>,
    /// Gravity at the default params ((0, 0) when not declared).
    pub gravity: [f64; 2],
    pub(crate) gravity_expr: Option<TExpr>,
    /// Force elements in declaration order.
    pub forces: Vec<Force>,
}

/// `B.x_dot`, `B.y_dot`, `B.phi_dot`: `Some` when `field` names a velocity
/// (the node, or `None` after an error), `None` otherwise.
///   error: velocities (`crank.phi_dot`) may appear only in forces
pub(super) fn check_velocity(
    cx: &mut Ctxt,
    names: &Names<'_>,
    body: BodyRef,
    field: &str,
    span: Span,
) -> Option<Option<Node>> {
    let comp = match field {
        "x_dot" => Comp::X,
        "y_dot" => Comp::Y,
        "phi_dot" => Comp::Phi,
        _ => return None,
    };
    let BodyRef::Body(k) = body else {
        cx.error(span, "`ground` has no velocities: it is fixed");
        return Some(None);
    };
    if !names.velocities {
        cx.push(
            Diagnostic::error(span, "velocities may appear only in forces")
                .with_help("constraints are equations of coordinates and time"),
        );
        return Some(None);
    }
    let deps = Deps {
        time: None,
        coord: Some(span),
    };
    Some(Some((TNode::Vel(k, comp), Ty::Scalar, deps)))
}

/// Checks inertia, gravity and forces; `None` when the model has none.
pub(super) fn check_dynamics(
    cx: &mut Ctxt,
    names: &Names<'_>,
    mech: &syntax::Mechanism,
    values: &[f64],
) -> Option<Dynamics> {
    let bodies: Vec<&syntax::BodyDecl> = mech
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Body(b) => Some(b),
            _ => None,
        })
        .collect();
    let gravities: Vec<&syntax::GravityDecl> = mech
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Gravity(g) => Some(g),
            _ => None,
        })
        .collect();
    let forces: Vec<&syntax::ForceDecl> = mech
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Force(f) => Some(f),
            _ => None,
        })
        .collect();
    let any_inertia = bodies
        .iter()
        .any(|b| b.mass.is_some() || b.inertia.is_some());
    if !any_inertia && gravities.is_empty() && forces.is_empty() {
        return None;
    }
    let inertia = check_inertia(cx, names, &bodies, values, any_inertia);
    let (gravity, gravity_expr) = check_gravity(cx, names, &gravities, values);
    let mut out = Vec::new();
    let mut first: HashMap<String, Span> = HashMap::new();
    for f in forces {
        let name = f.name.to_string();
        let span = f.name.span();
        if let Some(s) = first.get(&name) {
            let s = s.start();
            // error: duplicate force name `spring`
            cx.push(
                Diagnostic::error(span, format!("duplicate force name `{name}`")).with_help(
                    format!("`{name}` is first declared at {}:{}", s.line, s.column + 1),
                ),
            );
            continue;
        }
        first.insert(name.clone(), span);
        if let Some((kind, args)) = check_force(cx, names, &f.call, values) {
            out.push(Force {
                name,
                span,
                docs: f.docs.clone(),
                kind,
                args,
            });
        }
    }
    Some(Dynamics {
        inertia,
        gravity,
        gravity_expr,
        forces: out,
    })
}

/// Rule: a body's `velocity` is an initial condition of forward dynamics,
/// so a model that states one has inertia. Without it the velocity could
/// only be ignored (a kinematic run takes q̇ from its drivers), which would
/// hide a mistake: it is an error at each `velocity`.
///   error: body `crank` states a `velocity`, but the model has no inertia: an initial velocity is where forward dynamics starts
pub(super) fn check_velocities_need_inertia(cx: &mut Ctxt, mech: &syntax::Mechanism) {
    let bodies = mech.items.iter().filter_map(|i| match i {
        Item::Body(b) => Some(b),
        _ => None,
    });
    let any_inertia = bodies
        .clone()
        .any(|b| b.mass.is_some() || b.inertia.is_some());
    if any_inertia {
        return;
    }
    for b in bodies {
        if let Some(v) = &b.velocity {
            cx.push(
                Diagnostic::error(
                    v.keyword,
                    format!(
                        "body `{}` states a `velocity`, but the model has no inertia: an initial \
                         velocity is where forward dynamics starts",
                        b.name
                    ),
                )
                .with_help(
                    "give every body a `mass` and an `inertia`, or remove `velocity` (a kinematic \
                     run takes its velocities from the drivers)",
                ),
            );
        }
    }
}

/// Rules: in a model with inertia every body has a `mass` and an
/// `inertia`, finite constants ≥ 0 of params.
///   error: body `rod` has no `mass` and `inertia`: in a model with dynamics every body needs both
fn check_inertia(
    cx: &mut Ctxt,
    names: &Names<'_>,
    bodies: &[&syntax::BodyDecl],
    values: &[f64],
    any: bool,
) -> Vec<Inertia> {
    let mut out = Vec::with_capacity(bodies.len());
    for b in bodies {
        let missing: Vec<&str> = [("mass", &b.mass), ("inertia", &b.inertia)]
            .iter()
            .filter(|(_, e)| e.is_none())
            .map(|(n, _)| *n)
            .collect();
        if any && !missing.is_empty() {
            let what = missing
                .iter()
                .map(|m| format!("`{m}`"))
                .collect::<Vec<_>>()
                .join(" and ");
            cx.push(
                Diagnostic::error(
                    b.name.span(),
                    format!(
                        "body `{}` has no {what}: in a model with dynamics every body needs a mass and an inertia",
                        b.name
                    ),
                )
                .with_help(format!(
                    "write `body {} {{ mass: m, inertia: J, … }}` (J about the body frame's origin, the centroid)",
                    b.name
                )),
            );
        }
        let mut one = |e: &Option<syntax::Expr>, what: &str| -> (f64, TExpr) {
            let zero = TExpr {
                nodes: vec![TNode::Num(0.0)],
                types: vec![Ty::Scalar],
                spans: Vec::new(),
            };
            let Some(e) = e else { return (0.0, zero) };
            let Some(t) = check_constant(cx, names, (e, e.root), values.len(), Ty::Scalar, what)
            else {
                return (0.0, zero);
            };
            let v = eval_vector(&t, values)[0];
            if !(v.is_finite() && v >= 0.0) {
                // error: a mass is -2: expected a finite number ≥ 0
                cx.error(
                    e.span(),
                    format!("{what} is {v}: expected a finite number ≥ 0"),
                );
            }
            (v, t)
        };
        let (mass, mass_expr) = one(&b.mass, "a mass");
        let (inertia, inertia_expr) = one(&b.inertia, "an inertia");
        out.push(Inertia {
            mass,
            inertia,
            mass_expr,
            inertia_expr,
        });
    }
    out
}

/// Rules: at most one `gravity`, a finite constant vector of params.
fn check_gravity(
    cx: &mut Ctxt,
    names: &Names<'_>,
    gravities: &[&syntax::GravityDecl],
    values: &[f64],
) -> ([f64; 2], Option<TExpr>) {
    for g in gravities.iter().skip(1) {
        // error: `gravity` is declared twice
        cx.error(g.keyword, "`gravity` is declared twice");
    }
    let Some(g) = gravities.first() else {
        return ([0.0, 0.0], None);
    };
    let e = &g.value;
    let what = "gravity";
    let Some(t) = check_constant(cx, names, (e, e.root), values.len(), Ty::Vector, what) else {
        return ([0.0, 0.0], None);
    };
    let v = eval_vector(&t, values);
    finite_vector(cx, v, e.span(), &t, values);
    (v, Some(t))
}

/// One force element call.
///   error: unknown force element `spring`
///   error: wrong number of arguments: expected `torque(B, T)`, found 3 arguments
fn check_force(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    values: &[f64],
) -> Option<(ForceKind, Vec<LibArg>)> {
    let all = || {
        FORCES
            .iter()
            .map(|s| format!("`{}`", s.signature))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let ExprKind::Call(f, args) = &expr.node(expr.root).kind else {
        cx.push(
            Diagnostic::error(expr.span(), "expected a force element call")
                .with_help(format!("the force elements are {}", all())),
        );
        return None;
    };
    let fname = f.to_string();
    let Some(spec) = FORCES.iter().find(|s| s.name == fname) else {
        cx.push(
            Diagnostic::error(f.span(), format!("unknown force element `{fname}`"))
                .with_help(format!("the force elements are {}", all())),
        );
        return None;
    };
    let n = spec.args.len();
    if !(args.len() == n || (spec.actuation && args.len() == n + 1)) {
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
    let kinds = spec
        .args
        .iter()
        .copied()
        .chain(std::iter::once(FArg::Scalar));
    let mut out = Vec::new();
    let mut bodies = Vec::new();
    for (&a, kind) in args.iter().zip(kinds) {
        let arg = check_force_arg(cx, names, expr, a, kind, spec, values);
        if let Some(LibArg::Point(b, _) | LibArg::Body(b)) = &arg {
            bodies.push((*b, expr.node(a).span));
        }
        out.push(arg);
    }
    let out: Vec<LibArg> = out.into_iter().collect::<Option<_>>()?;
    // Rules: a force acts on a moving body; a spring joins two different
    // bodies.
    //   error: `torque` acts on `ground`, which does not move
    match (spec.kind, &bodies[..]) {
        (
            ForceKind::PointForce | ForceKind::PointForceLocal | ForceKind::Torque,
            [(BodyRef::Ground, s)],
        ) => {
            cx.error(
                *s,
                format!("`{}` acts on `ground`, which does not move", spec.name),
            );
            return None;
        }
        (ForceKind::Rsda | ForceKind::Tsda, [(a, _), (b, s)]) if a == b => {
            cx.push(
                Diagnostic::error(
                    *s,
                    format!(
                        "`{}` joins the body `{}` to itself",
                        spec.name,
                        names.body_name(*a)
                    ),
                )
                .with_help(
                    "expected two different bodies (`ground` for a spring to the fixed frame)",
                ),
            );
            return None;
        }
        _ => {}
    }
    Some((spec.kind, out))
}

fn check_force_arg(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    a: u32,
    kind: FArg,
    spec: &ForceSpec,
    values: &[f64],
) -> Option<LibArg> {
    let node = expr.node(a);
    match kind {
        FArg::Body => {
            super::equation::check_body_arg(cx, names, expr, a, spec.signature).map(LibArg::Body)
        }
        FArg::Point => {
            let (b, local) =
                super::equation::check_point_arg(cx, names, expr, a, spec.signature, values.len())?;
            let v = eval_vector(&local, values);
            finite_vector(cx, v, node.span, &local, values);
            Some(LibArg::Point(b, local))
        }
        FArg::Constant => {
            let what = "the constants of a spring-damper";
            check_constant(cx, names, (expr, a), values.len(), Ty::Scalar, what).map(LibArg::Scalar)
        }
        FArg::Vector | FArg::Scalar => {
            let ty = if kind == FArg::Vector {
                Ty::Vector
            } else {
                Ty::Scalar
            };
            let t = check_expr(cx, names, expr, a, values.len())?;
            let t = expect_ty(cx, t, ty, node.span)?;
            Some(if ty == Ty::Vector {
                LibArg::Vector(t.expr)
            } else {
                LibArg::Scalar(t.expr)
            })
        }
    }
}
