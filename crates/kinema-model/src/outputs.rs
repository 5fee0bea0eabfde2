//! Results beyond the coordinates: the named points and the measures
//! (`output NAME: EXPR;`), with their first and second time derivatives.
//!
//! Each scalar result y(q, t) (a component of a point's global position,
//! a scalar measure, a component of a vector measure) is derived as
//! everything else is, along the velocities:
//!
//! - ẏ = y_q q̇ + y_t: the directional derivative of y along the seeds
//!   {q_k → q̇_k}, plus ∂y/∂t;
//! - ÿ = d/dt ẏ = ẏ_q̇ q̈ + ẏ_q q̇ + ẏ_t = y_q q̈ + c, with c the directional
//!   derivative of ẏ along the same seeds plus ∂ẏ/∂t (ẏ_q̇ = y_q).
//!
//! q̈ appears in ÿ only through y_q, kept sparse ([`OutputColumn::jacobian`]);
//! c ([`OutputColumn::acceleration`]) is a function of q, q̇ and t, so both
//! evaluate on the same symbols as Φ and γ. For a point P of body B this is
//! r_P = r + A s′, ṙ_P = ṙ + B s′ φ̇, r̈_P = r̈ + B s′ φ̈ − A s′ φ̇², without a
//! formula written by hand.
//!
//! Split by phase as the dynamics is: the `output` item's syntax is in
//! `syntax/output.rs` ([`crate::syntax::OutputDecl`]), its checks in
//! `check/output.rs`; this module is the derivation's part.

use kinema_expr::{Arena, Columns, ExprId, SeedsId, SymId};

use crate::check::lower::{Lowerer, Value};
use crate::check::{BodyRef, CheckedModel, point_columns};
use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::span::Span;

/// What a result column measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OutputSource {
    /// Named point `k` of [`CheckedModel::points`].
    Point(usize),
    /// Measure `k` of [`CheckedModel::outputs`].
    Measure(usize),
}

/// One scalar result: a component of a named point or a measure, with its
/// time derivatives.
#[derive(Clone, Debug)]
pub struct OutputColumn {
    /// Column name of the value: `B.name.x`, `NAME`, `NAME.x`; the
    /// derivatives' columns add `_dot` and `_ddot`.
    pub name: String,
    /// The declared point (`B.name`) or measure (`NAME`) it belongs to.
    pub declared: String,
    /// What it measures.
    pub source: OutputSource,
    /// Doc comments of the declaration.
    pub docs: Vec<String>,
    /// y(q, t).
    pub value: ExprId,
    /// ẏ = y_q q̇ + y_t.
    pub velocity: ExprId,
    /// c = (ẏ)_q q̇ + (ẏ)_t: ÿ without its q̈ terms.
    pub acceleration: ExprId,
    /// y_q: the coefficients of q̈ in ÿ, as (coordinate index, expression),
    /// structural nonzeros in increasing index.
    pub jacobian: Vec<(u32, ExprId)>,
}

/// The symbols the derivatives need.
pub(crate) struct Along<'a> {
    pub(crate) seeds: SeedsId,
    pub(crate) columns: &'a Columns,
    pub(crate) time: SymId,
    pub(crate) budget: usize,
}

/// Derives every named point (both components) and every measure, in
/// declaration order: points first, then measures.
///
/// # Errors
/// A result whose derivatives would outgrow the budget, at its name.
pub(crate) fn derive_outputs(
    model: &CheckedModel,
    lo: &Lowerer<'_>,
    arena: &mut Arena,
    along: &Along<'_>,
) -> Result<Vec<OutputColumn>, Diagnostics> {
    let mut out = Vec::new();
    for (k, p) in model.points.iter().enumerate() {
        let limit = arena.size().saturating_add(along.budget);
        arena.set_budget(Some(limit));
        let local = lo.point_locals.get(k).copied();
        let Some(local) = local else { continue };
        let global = lo.global(arena, p.body, local);
        let [cx, cy] = point_columns(&model.bodies, p);
        let declared = match p.body {
            BodyRef::Ground => format!("ground.{}", p.name),
            BodyRef::Body(b) => format!(
                "{}.{}",
                model
                    .bodies
                    .get(b as usize)
                    .map_or("?", |b| b.name.as_str()),
                p.name
            ),
        };
        for (name, y) in [(cx, global.x), (cy, global.y)] {
            let column = derive_one(arena, along, y);
            out.push(OutputColumn {
                name,
                declared: declared.clone(),
                source: OutputSource::Point(k),
                docs: p.docs.clone(),
                ..column
            });
        }
        over_budget(arena, limit, p.span, &declared, along.budget)?;
    }
    for (k, o) in model.outputs.iter().enumerate() {
        let limit = arena.size().saturating_add(along.budget);
        arena.set_budget(Some(limit));
        let values = match lo.lower(arena, &o.expr) {
            Value::S(e) => vec![e],
            Value::V(v) => vec![v.x, v.y],
        };
        for (name, y) in o.column_names().into_iter().zip(values) {
            let column = derive_one(arena, along, y);
            out.push(OutputColumn {
                name,
                declared: o.name.clone(),
                source: OutputSource::Measure(k),
                docs: o.docs.clone(),
                ..column
            });
        }
        over_budget(arena, limit, o.span, &o.name, along.budget)?;
    }
    arena.set_budget(None);
    Ok(out)
}

fn derive_one(arena: &mut Arena, along: &Along<'_>, y: ExprId) -> OutputColumn {
    let yq = arena.directional(y, along.seeds);
    let yt = arena.diff(y, along.time);
    let velocity = arena.add(yq, yt);
    let cq = arena.directional(velocity, along.seeds);
    let ct = arena.diff(velocity, along.time);
    let acceleration = arena.add(cq, ct);
    let jacobian = arena
        .jacobian_by(&[y], along.columns)
        .entries
        .into_iter()
        .map(|en| (en.col, en.expr))
        .collect();
    OutputColumn {
        name: String::new(),
        declared: String::new(),
        source: OutputSource::Measure(0),
        docs: Vec::new(),
        value: y,
        velocity,
        acceleration,
        jacobian,
    }
}

fn over_budget(
    arena: &mut Arena,
    limit: usize,
    span: Span,
    name: &str,
    budget: usize,
) -> Result<(), Diagnostics> {
    if !(arena.budget_exceeded() || arena.size() > limit) {
        return Ok(());
    }
    arena.set_budget(None);
    let mut errors = Diagnostics::new();
    errors.push(
        Diagnostic::error(
            span,
            format!(
                "the derivatives of `{name}` are too large: they would need more than {budget} \
                 expression entries (the limit per equation)"
            ),
        )
        .with_help(
            "write the output with fewer terms or factors, or derive it with a larger budget",
        ),
    );
    Err(errors)
}
