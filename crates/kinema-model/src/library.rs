//! The constraint library (docs/src/constraints.md), written on the same vector
//! algebra a user has ([`crate::algebra`]). Each constraint is only its Φ:
//! no derivative is written by hand anywhere; the engine derives Φ_q, ν, γ.
//!
//! Notation as in docs/src/constraints.md: a point P on body i is `r_i + A_i s'`,
//! `d = r_j^P − r_i^P`, `A` rotates by the body angle, `perp` is `R`.

use kinema_expr::{Arena, ExprId};

use crate::algebra::{Vec2, VecAlgebra};
use crate::check::lower::Lowerer;
use crate::check::{BodyRef, LibArg, LibKind};

/// A lowered library argument.
#[derive(Clone, Copy)]
enum Arg {
    /// A point: its body, its global position.
    Point(BodyRef, Vec2),
    Body(BodyRef),
    Vector(Vec2),
    Scalar(ExprId),
}

/// The lowered arguments of one call, read by position; a missing or
/// mistyped one (the checker's types rule both out) reads as ground or 0.
struct Args<'l, 'm> {
    lo: &'l Lowerer<'m>,
    list: Vec<Arg>,
    zero: ExprId,
}

impl Args<'_, '_> {
    fn point(&self, k: usize) -> Vec2 {
        match self.list.get(k) {
            Some(Arg::Point(_, p)) => *p,
            _ => Vec2::new(self.zero, self.zero),
        }
    }

    fn body(&self, k: usize) -> BodyRef {
        match self.list.get(k) {
            Some(Arg::Body(b) | Arg::Point(b, _)) => *b,
            _ => BodyRef::Ground,
        }
    }

    fn vector(&self, k: usize) -> Vec2 {
        match self.list.get(k) {
            Some(Arg::Vector(v)) => *v,
            _ => Vec2::new(self.zero, self.zero),
        }
    }

    fn scalar(&self, k: usize) -> ExprId {
        match self.list.get(k) {
            Some(Arg::Scalar(s)) => *s,
            _ => self.zero,
        }
    }

    /// d_ij = r_j^P − r_i^P for the points in arguments i and j.
    fn d(&self, arena: &mut Arena, i: usize, j: usize) -> Vec2 {
        arena.vsub(self.point(j), self.point(i))
    }

    /// φ of the body of argument k (0 for ground).
    fn angle(&self, arena: &mut Arena, k: usize) -> ExprId {
        self.lo.angle(arena, self.body(k))
    }

    /// A_k v: the vector `v` in the frame of the body of argument k.
    fn rotate(&self, arena: &mut Arena, k: usize, v: Vec2) -> Vec2 {
        self.lo.rotate(arena, self.body(k), v)
    }
}

/// The rows of one library constraint.
pub(crate) fn rows(
    lo: &Lowerer<'_>,
    arena: &mut Arena,
    kind: LibKind,
    args: &[LibArg],
) -> Vec<ExprId> {
    if let Some(rows) = crate::follower::rows(lo, arena, kind, args) {
        return rows;
    }
    let list: Vec<Arg> = args
        .iter()
        .map(|a| match a {
            LibArg::Point(b, local) => {
                let s = lo.vector(arena, local);
                Arg::Point(*b, lo.global(arena, *b, s))
            }
            LibArg::Body(b) => Arg::Body(*b),
            LibArg::Vector(v) => Arg::Vector(lo.vector(arena, v)),
            LibArg::Scalar(s) => Arg::Scalar(lo.scalar(arena, s)),
            // The followers' (crate::follower::rows).
            LibArg::Curve(b, _) => Arg::Body(*b),
            LibArg::Coord(_) => Arg::Body(BodyRef::Ground),
        })
        .collect();
    let zero = arena.num(0.0);
    let a = Args { lo, list, zero };
    match kind {
        LibKind::AbsX
        | LibKind::AbsY
        | LibKind::AbsAngle
        | LibKind::AbsDistance
        | LibKind::RelX
        | LibKind::RelY
        | LibKind::RelAngle
        | LibKind::RelDistance
        | LibKind::RevoluteRevolute
        | LibKind::D => vec![absolute_or_relative(arena, kind, &a)],
        LibKind::Revolute
        | LibKind::Translational
        | LibKind::RevoluteTranslational
        | LibKind::TranslationalDistance => joint(arena, kind, &a),
        LibKind::Gear => vec![gear(arena, &a)],
        LibKind::RackPinion => rack_pinion(arena, &a),
        LibKind::Dp1 | LibKind::Dp2 | LibKind::Cd => vec![dot_product(arena, kind, &a)],
        // Built by crate::follower::rows above.
        LibKind::PointFollower | LibKind::CamFollower | LibKind::FlatFollower => Vec::new(),
    }
}

/// The one-row constraints on a point, an angle or a distance (Φ = g − f):
///
/// - AX, AY: Φ = x (y) of P − f; AA: Φ = φ_i − f;
/// - AD: h = r^P − c, Φ = hᵀh − C²;
/// - RX, RY: Φ = e_xᵀd − f (e_y); RA: Φ = φ_j − φ_i − f;
/// - RD, RR: Φ = dᵀd − C²; D: Φ = dᵀd − f.
fn absolute_or_relative(arena: &mut Arena, kind: LibKind, a: &Args<'_, '_>) -> ExprId {
    let (g, f) = match kind {
        LibKind::AbsX => (a.point(0).x, a.scalar(1)),
        LibKind::AbsY => (a.point(0).y, a.scalar(1)),
        LibKind::AbsAngle => (a.angle(arena, 0), a.scalar(1)),
        LibKind::AbsDistance => {
            let h = arena.vsub(a.point(0), a.vector(1));
            let hh = arena.dot(h, h);
            (hh, arena.powi(a.scalar(2), 2))
        }
        LibKind::RelX => (a.d(arena, 0, 1).x, a.scalar(2)),
        LibKind::RelY => (a.d(arena, 0, 1).y, a.scalar(2)),
        LibKind::RelAngle => {
            let pi = a.angle(arena, 0);
            let pj = a.angle(arena, 1);
            (arena.sub(pj, pi), a.scalar(2))
        }
        LibKind::RelDistance | LibKind::RevoluteRevolute => {
            let d = a.d(arena, 0, 1);
            let dd = arena.dot(d, d);
            (dd, arena.powi(a.scalar(2), 2))
        }
        // D
        _ => {
            let d = a.d(arena, 0, 1);
            (arena.dot(d, d), a.scalar(2))
        }
    };
    arena.sub(g, f)
}

/// The joints:
///
/// - REV: Φ = r_i^P − r_j^P (i minus j), two rows x, y;
/// - TRA: u_i = A_i v'_i, n_i = R u_i, u_j = A_j v'_j; Φ = [n_iᵀd; n_iᵀu_j];
/// - RT: n̂_i = R A_i v̂'_i; Φ = n̂_iᵀd − c;
/// - TD (translational-distance, §5): Φ = û_iᵀd − C.
fn joint(arena: &mut Arena, kind: LibKind, a: &Args<'_, '_>) -> Vec<ExprId> {
    match kind {
        LibKind::Revolute => {
            let r = arena.vsub(a.point(0), a.point(1));
            vec![r.x, r.y]
        }
        LibKind::Translational => {
            let ui = a.rotate(arena, 0, a.vector(1));
            let ni = arena.perp(ui);
            let uj = a.rotate(arena, 2, a.vector(3));
            let d = a.d(arena, 0, 2);
            vec![arena.dot(ni, d), arena.dot(ni, uj)]
        }
        LibKind::RevoluteTranslational => {
            let v = arena.unit(a.vector(1));
            let ui = a.rotate(arena, 0, v);
            let ni = arena.perp(ui);
            let d = a.d(arena, 0, 2);
            let nd = arena.dot(ni, d);
            vec![arena.sub(nd, a.scalar(3))]
        }
        // TranslationalDistance
        _ => {
            let v = arena.unit(a.vector(1));
            let ui = a.rotate(arena, 0, v);
            let d = a.d(arena, 0, 2);
            let ud = arena.dot(ui, d);
            vec![arena.sub(ud, a.scalar(3))]
        }
    }
}

/// GEAR: k_i = R_i/(R_i + R_j), α = k_i(φ_i + θ_i) + k_j(φ_j + θ_j),
/// e⊥ = (−sin α, cos α); Φ = e⊥ᵀd.
fn gear(arena: &mut Arena, a: &Args<'_, '_>) -> ExprId {
    let (ri, rj) = (a.scalar(2), a.scalar(3));
    let sum = arena.add(ri, rj);
    let ki = arena.div(ri, sum);
    let kj = arena.div(rj, sum);
    let phi_i = a.angle(arena, 0);
    let phi_j = a.angle(arena, 1);
    let ai = arena.add(phi_i, a.scalar(4));
    let aj = arena.add(phi_j, a.scalar(5));
    let ti = arena.mul(ki, ai);
    let tj = arena.mul(kj, aj);
    let alpha = arena.add(ti, tj);
    let one = arena.num(1.0);
    let e = arena.rot(alpha, Vec2::new(one, a.zero));
    let e_perp = arena.perp(e);
    let d = a.d(arena, 0, 1);
    arena.dot(e_perp, d)
}

/// RP: û = A_i v̂'_i, n̂ = R û;
/// Φ = [n̂ᵀd − R_p; ûᵀd + R_p(φ_j − φ_i) − c₀].
fn rack_pinion(arena: &mut Arena, a: &Args<'_, '_>) -> Vec<ExprId> {
    let v = arena.unit(a.vector(1));
    let u = a.rotate(arena, 0, v);
    let n = arena.perp(u);
    let d = a.d(arena, 0, 2);
    let rp = a.scalar(3);
    let nd = arena.dot(n, d);
    let row1 = arena.sub(nd, rp);
    let ud = arena.dot(u, d);
    let phi_i = a.angle(arena, 0);
    let phi_j = a.angle(arena, 2);
    let rel = arena.sub(phi_j, phi_i);
    let roll = arena.mul(rp, rel);
    let lhs = arena.add(ud, roll);
    let row2 = arena.sub(lhs, a.scalar(4));
    vec![row1, row2]
}

/// The dot products:
///
/// - DP1: a_i = A_i a'_i, a_j = A_j a'_j; Φ = a_iᵀa_j − f;
/// - DP2: Φ = a_iᵀd − f, a'_i in the frame of the body of P_i;
/// - CD: Φ = cᵀd − f, c a constant global vector.
fn dot_product(arena: &mut Arena, kind: LibKind, a: &Args<'_, '_>) -> ExprId {
    let (g, f) = match kind {
        LibKind::Dp1 => {
            let ai = a.rotate(arena, 0, a.vector(1));
            let aj = a.rotate(arena, 2, a.vector(3));
            (arena.dot(ai, aj), a.scalar(4))
        }
        LibKind::Dp2 => {
            let ai = a.rotate(arena, 0, a.vector(1));
            let d = a.d(arena, 0, 2);
            (arena.dot(ai, d), a.scalar(3))
        }
        // Cd
        _ => {
            let d = a.d(arena, 1, 2);
            (arena.dot(a.vector(0), d), a.scalar(3))
        }
    };
    arena.sub(g, f)
}
