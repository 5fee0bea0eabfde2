//! Rules on measures, `output NAME: EXPR;`: the expression is typed like an
//! equation's side (coordinates, params, `t`, points; scalar or vector), and
//! the CSV columns the outputs add are unique.

use std::collections::HashMap;

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;
use crate::span::Span;
use crate::syntax::{self, Item};

use super::expr::check_expr;
use super::model::{Body, CheckedModel, Point, TExpr, Ty};
use super::{Names, count};

/// A measure: `output NAME: EXPR;`, a scalar or vector expression of
/// coordinates, params and time whose value and first and second time
/// derivatives are results of the analysis.
#[derive(Clone, Debug)]
pub struct Output {
    /// Its name (a scalar gives the column `NAME`, a vector `NAME.x`, `NAME.y`).
    pub name: String,
    /// Span of the name.
    pub span: Span,
    /// Doc comments (units, as for params).
    pub docs: Vec<String>,
    /// Scalar or vector.
    pub ty: Ty,
    pub(crate) expr: TExpr,
}

impl Output {
    /// The names of its value columns: `NAME`, or `NAME.x`, `NAME.y`.
    #[must_use]
    pub fn column_names(&self) -> Vec<String> {
        match self.ty {
            Ty::Scalar => vec![self.name.clone()],
            Ty::Vector => vec![format!("{}.x", self.name), format!("{}.y", self.name)],
        }
    }
}

/// The value columns of a named point: `B.name.x`, `B.name.y`.
pub(crate) fn point_columns(bodies: &[Body], p: &Point) -> [String; 2] {
    let body = match p.body {
        super::BodyRef::Ground => "ground",
        super::BodyRef::Body(k) => bodies.get(k as usize).map_or("?", |b| b.name.as_str()),
    };
    [
        format!("{body}.{}.x", p.name),
        format!("{body}.{}.y", p.name),
    ]
}

/// Rule: an output's expression is a scalar or vector expression of
/// coordinates, points, params and `t` (the names resolve as in equations).
///   error: unknown name `crank_angle`
/// Rule: output names are unique.
///   error: duplicate output `angle`
/// Rule: every column an output adds (with its `_dot`, `_ddot` forms) is
/// new: not `t`, a coordinate's, a point's or another output's.
///   error: output `crank` would write the column `crank.x`, which is the coordinate `crank.x`
pub(super) fn check_outputs(
    cx: &mut Ctxt,
    names: &Names<'_>,
    mech: &syntax::Mechanism,
    bodies: &[Body],
    points: &[Point],
) -> Vec<Output> {
    // Every column so far, with what writes it.
    let mut columns: HashMap<String, String> = HashMap::new();
    let add = |columns: &mut HashMap<String, String>, base: &str, what: &str| {
        for suffix in ["", "_dot", "_ddot"] {
            columns
                .entry(format!("{base}{suffix}"))
                .or_insert_with(|| what.to_string());
        }
    };
    columns.insert("t".to_string(), "time".to_string());
    for b in bodies {
        for c in ["x", "y", "phi"] {
            let base = format!("{}.{c}", b.name);
            add(&mut columns, &base, &format!("the coordinate `{base}`"));
        }
    }
    for p in points {
        for base in point_columns(bodies, p) {
            add(
                &mut columns,
                &base,
                &format!("a column of a point (`{base}`)"),
            );
        }
    }
    let mut out = Vec::new();
    let mut first: HashMap<String, Span> = HashMap::new();
    for item in &mech.items {
        let Item::Output(o) = item else { continue };
        let name = o.name.to_string();
        let span = o.name.span();
        if let Some(f) = first.get(&name) {
            // error: duplicate output `angle`
            let s = f.start();
            cx.push(
                Diagnostic::error(span, format!("duplicate output `{name}`")).with_help(format!(
                    "`{name}` is first declared at {}:{}",
                    s.line,
                    s.column + 1
                )),
            );
            continue;
        }
        first.insert(name.clone(), span);
        let typed = check_expr(cx, names, &o.value, o.value.root, usize::MAX);
        let Some(typed) = typed else { continue };
        let output = Output {
            name,
            span,
            docs: o.docs.clone(),
            ty: typed.expr.ty(),
            expr: typed.expr,
        };
        let mut clash = None;
        for base in output.column_names() {
            for suffix in ["", "_dot", "_ddot"] {
                let column = format!("{base}{suffix}");
                if clash.is_none()
                    && let Some(what) = columns.get(&column)
                {
                    clash = Some((column, what.clone()));
                }
            }
        }
        if let Some((column, what)) = clash {
            // error: output `a_dot` would write the column `a_dot`, which is a column of output `a`
            cx.push(
                Diagnostic::error(
                    span,
                    format!(
                        "output `{}` would write the column `{column}`, which is {what}",
                        output.name
                    ),
                )
                .with_help("CSV columns are unique: choose another name for the output"),
            );
            continue;
        }
        for base in output.column_names() {
            add(
                &mut columns,
                &base,
                &format!("a column of output `{}`", output.name),
            );
        }
        out.push(output);
    }
    out
}

/// Rule: no part of an output is undefined whatever the coordinates and
/// time (as for equations, see `count`).
///   error: division by zero: this divisor is identically zero
pub(super) fn check_undefined_outputs(cx: &mut Ctxt, model: &CheckedModel) {
    if model.outputs.is_empty() {
        return;
    }
    let mut arena = kinema_expr::Arena::new();
    let lo = super::lower::Lowerer::new(&mut arena, model);
    for o in &model.outputs {
        lo.lower_reporting(&mut arena, &o.expr, &mut |i, why| {
            let span = o.expr.span(i).unwrap_or(o.span);
            cx.push(count::undefined_diagnostic(span, why));
        });
    }
}
