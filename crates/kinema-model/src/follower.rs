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
//! Split by phase as the dynamics is: the items' syntax is in
//! `syntax/coord.rs` ([`crate::syntax::CoordDecl`],
//! [`crate::syntax::CurveDecl`]), their checks in `check/coord.rs`; this
//! module is the derivation's part: the coordinates' symbols in q and the
//! rows of the follower constraints.

use kinema_expr::{Arena, ExprId};

use crate::algebra::{Vec2, VecAlgebra};
use crate::check::lower::Lowerer;
use crate::check::{BodyRef, CheckedModel, Comp, LibArg, LibKind};
use crate::idx;

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
