//! Rules on declarations: which names may be declared, and where.
//!
//! Name spaces (README, "Names"):
//! - params, bodies and coordinates of their own (`coord`) share one: all
//!   are read by bare name in expressions (`L`, `crank.x`, `crank(1, 0)`,
//!   `alpha`);
//! - curves live in their body's, as points do (`yoke.slot`);
//! - points live in their body's: `crank.o` and `rod.o` are different;
//! - equations (`joint`, `constraint`, `driver`) have their own: their
//!   names label rows and never appear in expressions;
//! - `pi`, `t` and `ground` are built in and cannot be declared; a body
//!   cannot take a function's name (`sin(…)` would become a point), while
//!   library constraints' names are free (a constraint is only ever a whole
//!   equation).

use std::collections::HashMap;

use crate::ctxt::Ctxt;
use crate::diagnostic::Diagnostic;
use crate::span::Span;
use crate::syntax::{self, Item};

use super::{BodyRef, Decl, Names, idx, resolve_body};

/// The declared points: (body, name) → index among the accepted points.
pub(super) type PointNames = HashMap<(BodyRef, String), u32>;

/// Names with a built-in meaning.
const RESERVED: &[&str] = &["pi", "t", "ground"];

/// Whether a param, body or coordinate may be named `name` (the rules of
/// [`check_names`] on one name): not a built-in name (`pi`, `t`,
/// `ground`) nor, for a body (`body` true), a function's name. Any other
/// identifier is a name, Rust keywords included. For front ends that
/// choose names (the simEngine2D importer).
#[must_use]
pub fn may_declare(name: &str, body: bool) -> bool {
    let function = body && super::call::is_function(name);
    !(RESERVED.contains(&name) || function)
}

/// The declarations of a mechanism, by kind, and what their names mean.
pub(super) struct Declared<'m> {
    pub(super) decls: HashMap<String, Decl>,
    /// Every body's name, in declaration order (indexed by `BodyRef::Body`).
    pub(super) body_names: Vec<String>,
    pub(super) params: Vec<&'m syntax::ParamDecl>,
    pub(super) bodies: Vec<&'m syntax::BodyDecl>,
    pub(super) coords: Vec<&'m syntax::CoordDecl>,
}

/// Rule: names are unique among params and bodies, and none is reserved.
///   error: duplicate name `l1`
///    --> m.kin:4:11
///     = help: `l1` is first declared at 3:11
///   error: `t` is reserved (time) and cannot be declared
///   error: a body cannot be named `sin`: it is the name of a function
///
/// A param and a body of the same name, or a body named like a function,
/// leave the name poisoned: every use of it is silent. (A second param or
/// body of a name leaves the first standing.)
pub(super) fn check_names<'m>(cx: &mut Ctxt, mech: &'m syntax::Mechanism) -> Declared<'m> {
    let mut out = Declared {
        decls: HashMap::new(),
        body_names: Vec::new(),
        params: Vec::new(),
        bodies: Vec::new(),
        coords: Vec::new(),
    };
    let mut first_span: HashMap<String, Span> = HashMap::new();
    for item in &mech.items {
        let (ident, decl) = match item {
            Item::Param(p) => {
                out.params.push(p);
                (&p.name, Decl::Param(idx(out.params.len() - 1)))
            }
            Item::Body(b) => {
                out.bodies.push(b);
                out.body_names.push(b.name.to_string());
                (&b.name, Decl::Body(idx(out.bodies.len() - 1)))
            }
            Item::Coord(c) => {
                out.coords.push(c);
                (&c.name, Decl::Coord(idx(out.coords.len() - 1)))
            }
            _ => continue,
        };
        let name = ident.to_string();
        let span = ident.span();
        let decl = match check_name(cx, &name, decl, span, &first_span) {
            Some(d) => d,
            None if RESERVED.contains(&name.as_str()) => continue,
            // A second declaration of the same kind: the first one stands.
            None if out.decls.get(&name).is_some_and(|d| same_kind(*d, decl)) => continue,
            None => Decl::Poisoned,
        };
        first_span.entry(name.clone()).or_insert(span);
        out.decls.insert(name, decl);
    }
    out
}

/// The rules on one declared name; `None` when it is rejected (reported).
fn check_name(
    cx: &mut Ctxt,
    name: &str,
    decl: Decl,
    span: Span,
    first: &HashMap<String, Span>,
) -> Option<Decl> {
    if RESERVED.contains(&name) {
        cx.error(
            span,
            format!(
                "`{name}` is reserved ({}) and cannot be declared",
                reserved_meaning(name)
            ),
        );
        return None;
    }
    if matches!(decl, Decl::Body(_)) && super::call::is_function(name) {
        cx.error(
            span,
            format!("a body cannot be named `{name}`: it is the name of a function"),
        );
        return None;
    }
    if let Some(first) = first.get(name) {
        let s = first.start();
        cx.push(
            Diagnostic::error(span, format!("duplicate name `{name}`")).with_help(format!(
                "`{name}` is first declared at {}:{}",
                s.line,
                s.column + 1
            )),
        );
        return None;
    }
    Some(decl)
}

fn same_kind(a: Decl, b: Decl) -> bool {
    matches!(
        (a, b),
        (Decl::Param(_), Decl::Param(_))
            | (Decl::Body(_), Decl::Body(_))
            | (Decl::Coord(_), Decl::Coord(_))
    )
}

fn reserved_meaning(name: &str) -> &'static str {
    match name {
        "pi" => "the number π",
        "t" => "time",
        _ => "the fixed body",
    }
}

/// Rule: a point is declared on a body; names are unique per body; `x`,
/// `y`, `phi` are coordinates, not point names.
///   error: unknown body `crnk`
///   error: a point cannot be named `phi`: `crank.phi` is a coordinate
///   error: duplicate point `crank.o`
pub(super) fn check_point_names<'m>(
    cx: &mut Ctxt,
    mech: &'m syntax::Mechanism,
    names: &Names<'_>,
) -> (PointNames, Vec<(&'m syntax::PointDecl, BodyRef)>) {
    let mut points = PointNames::new();
    let mut items = Vec::new();
    for item in &mech.items {
        let Item::Point(p) = item else { continue };
        let body_name = p.body.to_string();
        let Some(body) = resolve_body(cx, names, &body_name, p.body.span()) else {
            continue;
        };
        let name = p.name.to_string();
        if matches!(name.as_str(), "x" | "y" | "phi") {
            cx.error(
                p.name.span(),
                format!("a point cannot be named `{name}`: `{body_name}.{name}` is a coordinate"),
            );
            continue;
        }
        if points.contains_key(&(body, name.clone())) {
            cx.error(
                p.name.span(),
                format!("duplicate point `{body_name}.{name}`"),
            );
            continue;
        }
        points.insert((body, name), idx(items.len()));
        items.push((p, body));
    }
    (points, items)
}
