//! Rules over the whole model: the counts (NDOF) and the parts of
//! equations that have no value whatever the coordinates.

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;

use super::model::{CheckedModel, Form, LibArg, TExpr};

/// Rule: the mechanism is kinematically determined, NDOF = 0.
///   error: mechanism `M` has NDOF = 1, expected 0: nc = 9, kinematic equations = 7, drivers = 1, KDOF = 2
///   = help: add 1 driving or kinematic equation
pub(super) fn check_dof(cx: &mut Ctxt, model: &CheckedModel) {
    let dof = model.dof();
    if dof.coordinates == 0 {
        check_not_empty(cx, model);
        return;
    }
    let n = dof.ndof();
    // A model with inertia may have free degrees of freedom: its static
    // equilibrium (`kinema run --equilibrium`) needs no driver, and forward
    // dynamics runs it. It may also count more equations than coordinates:
    // redundant constraints (a parallelogram with a third crank), which
    // only the rank of Φ_q at its assembled configuration tells from
    // contradictory ones; `kinema run` decides there (forward dynamics, a
    // prescribed motion with minimum-norm multipliers, or an error naming
    // the equations).
    if n == 0 || model.dynamics.is_some() {
        return;
    }
    let help = if n > 0 {
        format!("add {n} driving or kinematic equation{}", plural(n))
    } else {
        format!("remove {} equation{}, or add a body", -n, plural(n))
    };
    cx.push(
        Diagnostic::error(
            model.span,
            format!(
                "mechanism `{}` has NDOF = {n}, expected 0: nc = {}, kinematic equations = {}, drivers = {}, KDOF = {}",
                model.name,
                dof.coordinates,
                dof.kinematic,
                dof.driving,
                dof.kdof()
            ),
        )
        .with_help(help),
    );
}

/// Rule: the mechanism has coordinates. Without one there is nothing to
/// solve (Φ_q is 0 × 0) and no motion to write; the model is a mistake, not
/// a degenerate mechanism.
///   error: mechanism `Empty` has no coordinates: there is nothing to analyse
///   = help: declare a body (`body b { guess: (0, 0, 0) }`), the joints that connect it and the drivers that move it
fn check_not_empty(cx: &mut Ctxt, model: &CheckedModel) {
    let equations = model.equations.len();
    let message = if equations == 0 {
        format!(
            "mechanism `{}` has no coordinates: there is nothing to analyse",
            model.name
        )
    } else {
        format!(
            "mechanism `{}` has no coordinates for its {equations} equation{} to place",
            model.name,
            plural(i64::try_from(equations).unwrap_or(i64::MAX))
        )
    };
    cx.push(Diagnostic::error(model.span, message).with_help(
        "declare a body (`body b { guess: (0, 0, 0) }`), the joints that connect it and the \
         drivers that move it",
    ));
}

fn plural(n: i64) -> &'static str {
    if n.abs() == 1 { "" } else { "s" }
}

/// Rule: no part of an equation is undefined whatever the coordinates and
/// time, once simplified: a divisor that is identically zero (`(B.x − B.x)`)
/// or a function of one (`ln(B.y − B.y)`). The engine's constructors keep
/// such parts undefined (NaN) instead of simplifying them away
/// ([`kinema_expr::Arena::is_undefined`]); this reports each at its span.
///   error: division by zero: this divisor is identically zero
///   error: division overflows: 1 divided by this number is beyond f64's range
pub(super) fn check_undefined_parts(cx: &mut Ctxt, model: &CheckedModel) {
    let mut arena = kinema_expr::Arena::new();
    let lo = super::lower::Lowerer::new(&mut arena, model);
    super::coord::check_undefined_curves(cx, model, &lo, &mut arena);
    for eq in &model.equations {
        let exprs: Vec<&TExpr> = match &eq.form {
            Form::User { lhs, rhs } => vec![lhs, rhs],
            Form::Library(_, args) => args
                .iter()
                .filter_map(|a| match a {
                    LibArg::Point(_, t) | LibArg::Vector(t) | LibArg::Scalar(t) => Some(t),
                    LibArg::Body(_) | LibArg::Curve(..) | LibArg::Coord(_) => None,
                })
                .collect(),
        };
        for t in exprs {
            lo.lower_reporting(&mut arena, t, &mut |i, why| {
                let span = t.span(i).unwrap_or(eq.span);
                cx.push(undefined_diagnostic(span, why));
            });
        }
    }
}

/// The error for a divisor that is a number too small to divide by.
pub(super) fn tiny_divisor(span: crate::span::Span) -> Diagnostic {
    Diagnostic::error(
        span,
        "division overflows: 1 divided by this number is beyond f64's range",
    )
    .with_help(
        "a number below about 5.6e-309 in magnitude has no finite reciprocal; \
         rescale the expression so that its numbers stay in range",
    )
}

/// The error for a part of an expression that is undefined whatever the
/// coordinates and time.
pub(super) fn undefined_diagnostic(
    span: crate::span::Span,
    why: super::lower::Undefined,
) -> Diagnostic {
    match why {
        super::lower::Undefined::ZeroDivisor => Diagnostic::error(
            span,
            "division by zero: this divisor is identically zero",
        )
        .with_help("the quotient is undefined whatever the coordinates and time"),
        super::lower::Undefined::TinyDivisor => tiny_divisor(span),
        super::lower::Undefined::Value => Diagnostic::error(
            span,
            "this expression is undefined whatever the coordinates and time",
        )
        .with_help("a function is applied where it has no finite value (such as `ln` of an expression that is identically zero)"),
    }
}
