//! Phase 2: validation. Each rule of the language is one `check_*`
//! function with a comment showing what the user sees; this module runs
//! them in order. The output is a [`CheckedModel`]: names resolved,
//! expressions typed (scalar or vector), spans kept; everything the
//! derivation needs so that it cannot fail.
//!
//! | module | rules |
//! |---|---|
//! | `names` | declarations: unique names, reserved words, points' bodies |
//! | `decls` | params, points' local coordinates, initial guesses (constants) |
//! | `expr` | expressions: names, fields, operators, types |
//! | `call` | function calls (`sin(x)`, `dot(a, b)`, …) |
//! | `coord` | coordinates of their own, curves, the followers' curve and coordinate arguments |
//! | `equation` | equations and library constraints |
//! | `count` | counts (NDOF) and undefined parts |
//! | `output` | measures (`output NAME: EXPR;`) and the columns they add |
//! | `lower` | not a rule: checked expressions into the engine's arena, for the rules on constants' values and undefined parts, and for the derivation |
//!
//! All independent errors are collected (in a `Ctxt`); an error inside an
//! expression does not cascade into its parents, and a rejected
//! declaration stays registered as a *poisoned* name, so that its uses are
//! silent instead of "unknown" errors about a name the user did declare.

mod call;
mod coord;
mod count;
mod decls;
mod dynamics;
mod equation;
mod eval;
mod expr;
mod library;
pub(crate) mod lower;
mod model;
mod names;
mod output;

use std::collections::HashMap;

use crate::ctxt::Ctxt;
use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::idx;
use crate::span::Span;
use crate::syntax::{self, ExprKind};

pub use coord::{Coord, Curve};
pub use dynamics::{Dynamics, Force, ForceKind, Inertia};
pub use library::LibKind;
pub use model::{
    Body, BodyRef, CheckedModel, Comp, DofReport, Equation, InitialVelocity, Param, Point, Ty,
};
pub(crate) use model::{Form, LibArg, TExpr, TNode};
pub use names::may_declare;
pub use output::Output;
pub(crate) use output::point_columns;

pub(crate) use eval::eval_vector;

/// What a name declared at mechanism level stands for.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Decl {
    Param(u32),
    Body(u32),
    /// A coordinate of its own (`coord`).
    Coord(u32),
    /// A declaration that was rejected (a duplicate, a body named like a
    /// function): its uses say nothing, the declaration's error said it.
    Poisoned,
}

/// Per-node facts gathered while typing: the first token that makes the
/// node depend on time, and on coordinates.
#[derive(Clone, Copy, Default)]
struct Deps {
    time: Option<Span>,
    coord: Option<Span>,
}

impl Deps {
    fn or(self, other: Deps) -> Deps {
        Deps {
            time: self.time.or(other.time),
            coord: self.coord.or(other.coord),
        }
    }
}

/// A typed subexpression and its dependencies.
struct Typed {
    expr: TExpr,
    deps: Deps,
}

/// How a name in a body's place resolves.
enum BodyName {
    /// `ground` or a declared body.
    Body(BodyRef),
    /// A rejected declaration: the use is silent.
    Poisoned,
    /// Not a body.
    Unknown,
}

/// The names seen by expressions.
struct Names<'a> {
    decls: HashMap<String, Decl>,
    /// Every body's name, in declaration order.
    bodies: Vec<String>,
    /// The names of the bodies that were accepted, for "expected one of".
    accepted: Vec<String>,
    points: HashMap<(BodyRef, String), u32>,
    point_decls: &'a [Point],
    /// Whether velocities (`B.x_dot`) may appear: in forces only.
    velocities: bool,
    /// The declared curves.
    curves: coord::CurveNames,
    /// The parameter of the curve being checked: a name only there.
    curve_arg: Option<String>,
}

impl Names<'_> {
    fn new(decls: HashMap<String, Decl>, bodies: Vec<String>) -> Self {
        let accepted = bodies
            .iter()
            .enumerate()
            .filter(|(k, n)| decls.get(*n) == Some(&Decl::Body(idx(*k))))
            .map(|(_, n)| n.clone())
            .collect();
        Names {
            decls,
            bodies,
            accepted,
            points: HashMap::new(),
            point_decls: &[],
            velocities: false,
            curves: coord::CurveNames::new(),
            curve_arg: None,
        }
    }

    /// Resolves a name in a body's place (`B.x`, `B(sx, sy)`, `point B.p`).
    fn body(&self, name: &str) -> BodyName {
        if name == "ground" {
            return BodyName::Body(BodyRef::Ground);
        }
        match self.decls.get(name) {
            Some(Decl::Body(k)) => BodyName::Body(BodyRef::Body(*k)),
            Some(Decl::Poisoned) => BodyName::Poisoned,
            _ => BodyName::Unknown,
        }
    }

    /// The name of a body, for messages.
    fn body_name(&self, b: BodyRef) -> String {
        match b {
            BodyRef::Ground => "ground".to_string(),
            BodyRef::Body(k) => self.bodies.get(k as usize).cloned().unwrap_or_default(),
        }
    }
}

/// Checks a parsed mechanism.
///
/// # Errors
/// Every error found (and the warnings).
pub fn check(mech: &syntax::Mechanism) -> Result<CheckedModel, Diagnostics> {
    if !mech.errors.is_empty() {
        // Parse errors come alone: names missing from a bad item would
        // otherwise show up again as "unknown name" errors.
        return Err(mech.errors.clone());
    }
    let mut cx = Ctxt::default();
    let declared = names::check_names(&mut cx, mech);
    let mut names = Names::new(declared.decls, declared.body_names);
    let (points, point_items) = names::check_point_names(&mut cx, mech, &names);
    names.points = points;
    let (params, values) = decls::check_params(&mut cx, &names, &declared.params);
    let out_points = decls::check_points(&mut cx, &names, &point_items, &values);
    names.point_decls = &out_points;
    let bodies = decls::check_guesses(&mut cx, &names, &declared.bodies, &values);
    let coords = coord::check_coords(&mut cx, &names, &declared.coords, &values);
    let curves = coord::check_curves(&mut cx, &mut names, mech, &values);
    let (equations, rows_known) = equation::check_equations(&mut cx, &names, mech, &values);
    let outputs = output::check_outputs(&mut cx, &names, mech, &bodies, &out_points);
    names.velocities = true;
    let dynamics = dynamics::check_dynamics(&mut cx, &names, mech, &values);
    dynamics::check_velocities_need_inertia(&mut cx, mech);
    let mut model = CheckedModel {
        name: mech.name.to_string(),
        span: mech.name.span(),
        docs: mech.docs.clone(),
        params,
        bodies,
        points: out_points,
        coords,
        curves,
        equations,
        outputs,
        warnings: Diagnostics::new(),
        dynamics,
    };
    coord::check_no_dynamics(&mut cx, &model);
    // Counts over a model with missing or bad declarations would mislead.
    if rows_known && cx.error_count() == 0 {
        count::check_dof(&mut cx, &model);
    }
    if cx.error_count() == 0 {
        count::check_undefined_parts(&mut cx, &model);
        output::check_undefined_outputs(&mut cx, &model);
    }
    let diagnostics = cx.finish();
    if diagnostics.has_errors() {
        return Err(diagnostics);
    }
    model.warnings = diagnostics;
    Ok(model)
}

fn show_nonfinite(v: f64) -> &'static str {
    if v.is_nan() {
        "NaN"
    } else if v > 0.0 {
        "infinite"
    } else {
        "-infinite"
    }
}

fn unknown_body(span: Span, name: &str, bodies: &[String]) -> Diagnostic {
    // error: unknown body `crnk`
    //  = help: the bodies are `crank`, `rod`, `slider`, and `ground`
    // A model may declare thousands of bodies: name a few, count the rest,
    // so that each error costs the same whatever the model's size.
    const SHOWN: usize = 8;
    let mut list: Vec<String> = bodies
        .iter()
        .take(SHOWN)
        .map(|b| format!("`{b}`"))
        .collect();
    if bodies.len() > SHOWN {
        list.push(format!("… ({} more)", bodies.len() - SHOWN));
    }
    list.push("`ground`".to_string());
    Diagnostic::error(span, format!("unknown body `{name}`"))
        .with_help(format!("expected one of: {}", list.join(", ")))
}

/// Reports a name in a body's place that is not a body; silent for a
/// poisoned name. `None` in both cases.
fn resolve_body(cx: &mut Ctxt, names: &Names<'_>, name: &str, span: Span) -> Option<BodyRef> {
    match names.body(name) {
        BodyName::Body(b) => Some(b),
        BodyName::Poisoned => None,
        BodyName::Unknown => {
            cx.push(unknown_body(span, name, &names.accepted));
            None
        }
    }
}

fn ty_name(ty: Ty) -> &'static str {
    match ty {
        Ty::Scalar => "a scalar",
        Ty::Vector => "a vector",
    }
}

fn plural_args(n: usize) -> String {
    if n == 1 {
        "1 argument".to_string()
    } else {
        format!("{n} arguments")
    }
}

/// Describes a syntax node for "found …" messages.
fn describe(expr: &syntax::Expr, i: u32, ty: Ty) -> String {
    let what = match &expr.node(i).kind {
        ExprKind::Field(b, f) => match &expr.node(*b).kind {
            ExprKind::Ident(body) => format!(" (point `{body}.{f}`)"),
            _ => String::new(),
        },
        ExprKind::Call(f, _) => format!(" (`{f}(…)`)"),
        ExprKind::Tuple(_) => " (a vector literal)".to_string(),
        ExprKind::Ident(n) => format!(" (`{n}`)"),
        _ => String::new(),
    };
    format!("{}{what}", ty_name(ty))
}
