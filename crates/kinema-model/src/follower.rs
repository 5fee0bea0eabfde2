//! Extra generalized coordinates, body-fixed curves and the follower
//! constraints built on them (Haug §3.4: point-follower, cam-follower,
//! flat-faced follower).
//!
//! - `coord alpha { guess: 0.3 }` (or `coord alpha;`, guess 0) declares a
//!   scalar coordinate that belongs to no body. Such coordinates join q
//!   after every body's `(x, y, phi)`, in declaration order; in
//!   expressions the bare name `alpha` is the coordinate, so it can be
//!   driven (`driver d: alpha == 2 * t;`) or constrained like any other.
//! - `curve B.slot(u) = (R * cos(u), R * sin(u));` declares a curve fixed
//!   in body `B` (or `ground`): its local coordinates as a vector
//!   expression of params and its parameter `u` (only there `u` is a name).
//!   A follower constraint substitutes a declared coordinate for `u`; the
//!   tangent is the engine's derivative of the curve with respect to that
//!   coordinate, never written by hand.
//!
//! This module holds the syntax of both items and the rows of the follower
//! constraints; their checks are in `check/coord.rs`.

use kinema_expr::{Arena, ExprId};
use syn::parse::ParseStream;
use syn::{Token, braced, parenthesized};

use crate::algebra::{Vec2, VecAlgebra};
use crate::check::{BodyRef, CheckedModel, Comp, LibArg, LibKind};
use crate::idx;
use crate::lower::Lowerer;
use crate::syntax::{Expr, Item, expect, expected, kw, name};

/// `coord name { guess: expr }` or `coord name;`
#[derive(Clone, Debug)]
pub struct CoordDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The coordinate's name.
    pub name: crate::syntax::Name,
    /// The initial guess (a constant expression of params), if written.
    pub guess: Option<Expr>,
}

/// `curve body.name(u) = expr;`
#[derive(Clone, Debug)]
pub struct CurveDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The body the curve is fixed in.
    pub body: crate::syntax::Name,
    /// The curve's name.
    pub name: crate::syntax::Name,
    /// The curve's parameter, a name bound in `value` only.
    pub param: crate::syntax::Name,
    /// Its local coordinates: a vector expression of params and `param`.
    pub value: Expr,
}

/// Parses a `coord` or `curve` item (the next token is one of the keywords).
pub(crate) fn parse_item(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<Item> {
    if input.peek(kw::coord) {
        input.parse::<kw::coord>()?;
        let name = name(input, "the coordinate's name after `coord`")?;
        let lookahead = input.lookahead1();
        let guess = if lookahead.peek(Token![;]) {
            input.parse::<Token![;]>()?;
            None
        } else if lookahead.peek(syn::token::Brace) {
            let content;
            braced!(content in input);
            let mut guess = None;
            if !content.is_empty() {
                expect::<kw::guess>(&content, "`guess` or `}`")?;
                expect::<Token![:]>(&content, "`:` after `guess`")?;
                guess = Some(content.parse::<Expr>()?);
                if content.peek(Token![,]) {
                    content.parse::<Token![,]>()?;
                }
                if !content.is_empty() {
                    // error: expected `}`: a coordinate has only a `guess`, found `x`
                    return Err(expected(&content, "`}`: a coordinate has only a `guess`"));
                }
            }
            guess
        } else {
            // error: expected `;` or `{ guess: value }` after the coordinate's name, found `=`
            return Err(expected(
                input,
                "`;` or `{ guess: value }` after the coordinate's name",
            ));
        };
        return Ok(Item::Coord(CoordDecl { docs, name, guess }));
    }
    input.parse::<kw::curve>()?;
    // curve body.name(u) = (x(u), y(u));
    let body = name(input, "a body's name after `curve`")?;
    expect::<Token![.]>(input, "`.`: a curve is `curve body.name(u) = (x, y);`")?;
    let cname = name(input, "the curve's name after `.`")?;
    if !input.peek(syn::token::Paren) {
        // error: expected `(u)`: the curve's parameter, found `=`
        return Err(expected(
            input,
            "`(u)`: the curve's parameter (a curve is `curve body.name(u) = (x, y);`)",
        ));
    }
    let content;
    parenthesized!(content in input);
    let param = name(&content, "the name of the curve's parameter")?;
    if !content.is_empty() {
        // error: expected `)`: a curve has one parameter, found `,`
        return Err(expected(&content, "`)`: a curve has one parameter"));
    }
    expect::<Token![=]>(input, "`=`: a curve is `curve body.name(u) = (x, y);`")?;
    let value: Expr = input.parse()?;
    expect::<Token![;]>(input, "`;` at the end of the curve")?;
    Ok(Item::Curve(CurveDecl {
        docs,
        body,
        name: cname,
        param,
        value,
    }))
}

/// Appends the coordinates of their own to q (after every body's), in
/// declaration order, with their velocities `name_dot` and guesses.
pub(crate) fn push_coordinates(
    arena: &mut Arena,
    lo: &Lowerer<'_>,
    model: &CheckedModel,
    out: &mut Vec<crate::Coordinate>,
) {
    let base = 3 * model.bodies.len();
    for (k, c) in model.coords.iter().enumerate() {
        let q = lo.extra(arena, idx(k));
        let i = base + k;
        let qd = arena.velocity(&format!("{}_dot", c.name), idx(i));
        let guess = lo.scalar(arena, &c.guess);
        let (Some(sym), Some(velocity)) = (arena.symbol_of(q), arena.symbol_of(qd)) else {
            unreachable!("`Lowerer::new` makes one coordinate symbol per `coord` item")
        };
        out.push(crate::Coordinate {
            name: c.name.clone(),
            // Never a body's index: `bodies.get(body)` is `None`.
            body: model.bodies.len() + k,
            comp: Comp::Extra,
            sym,
            velocity,
            guess,
            guess_value: c.guess_value,
            initial_velocity: None,
            initial_velocity_value: 0.0,
        });
    }
}

/// A curve argument at a coordinate: its global point and its global
/// tangent, the engine's derivative of the local curve with respect to the
/// coordinate (`A g'`, g' = dc'/dα).
fn curve_at(arena: &mut Arena, lo: &Lowerer<'_>, body: BodyRef, k: u32, a: u32) -> (Vec2, Vec2) {
    let alpha = lo.extra(arena, a);
    let local = lo.curve(arena, k, alpha);
    let g = match arena.symbol_of(alpha) {
        Some(s) => Vec2::new(arena.diff(local.x, s), arena.diff(local.y, s)),
        // No such coordinate (the checker's rule): no tangent.
        None => arena.vnum(f64::NAN, f64::NAN),
    };
    (lo.global(arena, body, local), lo.rotate(arena, body, g))
}

/// The rows of a follower constraint, or `None` for another library
/// constraint. Written on the vector algebra; the engine differentiates.
pub(crate) fn rows(
    lo: &Lowerer<'_>,
    arena: &mut Arena,
    kind: LibKind,
    args: &[LibArg],
) -> Option<Vec<ExprId>> {
    use LibArg as A;
    match (kind, args) {
        // PF (Haug 3.4.32): Φ = r_i + A_i s'_i − r_j − A_j c'(α)
        (LibKind::PointFollower, [A::Point(b, s), A::Curve(bc, k), A::Coord(a)]) => {
            let s = lo.vector(arena, s);
            let p = lo.global(arena, *b, s);
            let (c, _) = curve_at(arena, lo, *bc, *k, *a);
            let d = arena.vsub(p, c);
            Some(vec![d.x, d.y])
        }
        // CF (Haug §3.4.4): Φ = [r_i + A_i c'_i − r_j − A_j c'_j; (R t_i)ᵀ t_j]
        (
            LibKind::CamFollower,
            [
                A::Curve(bi, ki),
                A::Coord(ai),
                A::Curve(bj, kj),
                A::Coord(aj),
            ],
        ) => {
            let (pi, ti) = curve_at(arena, lo, *bi, *ki, *ai);
            let (pj, tj) = curve_at(arena, lo, *bj, *kj, *aj);
            let d = arena.vsub(pi, pj);
            let parallel = arena.cross(ti, tj);
            Some(vec![d.x, d.y, parallel])
        }
        // Flat-faced follower: the face is the line through P with
        // direction û = A_f v̂'. Φ = [n̂ᵀ(c − P); (R t)ᵀû], n̂ = R û: the
        // cam's point at α is on the face and its tangent is along it.
        (LibKind::FlatFollower, [A::Curve(bc, k), A::Coord(a), A::Point(bf, s), A::Vector(v)]) => {
            let (c, t) = curve_at(arena, lo, *bc, *k, *a);
            let s = lo.vector(arena, s);
            let p = lo.global(arena, *bf, s);
            let v = lo.vector(arena, v);
            let v = arena.unit(v);
            let u = lo.rotate(arena, *bf, v);
            let n = arena.perp(u);
            let d = arena.vsub(c, p);
            let on_face = arena.dot(n, d);
            let parallel = arena.cross(t, u);
            Some(vec![on_face, parallel])
        }
        _ => None,
    }
}
