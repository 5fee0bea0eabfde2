//! The constraint library (CONSTRAINTS.md §1–5), written on the same vector
//! algebra a user has ([`crate::algebra`]). Each constraint is only its Φ:
//! no derivative is written by hand anywhere; the engine derives Φ_q, ν, γ.
//!
//! Notation as in CONSTRAINTS.md: a point P on body i is `r_i + A_i s'`,
//! `d = r_j^P − r_i^P`, `A` rotates by the body angle, `perp` is `R`.

use kinema_expr::{Arena, ExprId};

use crate::algebra::{Vec2, VecAlgebra};
use crate::check::{BodyRef, LibArg, LibKind};
use crate::lower::Lowerer;

/// A lowered library argument.
#[derive(Clone, Copy)]
enum Arg {
    /// A point: its body, its global position.
    Point(BodyRef, Vec2),
    Body(BodyRef),
    Vector(Vec2),
    Scalar(ExprId),
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
    let args: Vec<Arg> = args
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
    let point = |k: usize| match args.get(k) {
        Some(Arg::Point(b, p)) => (*b, *p),
        _ => (BodyRef::Ground, Vec2::new(zero, zero)),
    };
    let body = |k: usize| match args.get(k) {
        Some(Arg::Body(b)) | Some(Arg::Point(b, _)) => *b,
        _ => BodyRef::Ground,
    };
    let vector = |k: usize| match args.get(k) {
        Some(Arg::Vector(v)) => *v,
        _ => Vec2::new(zero, zero),
    };
    let scalar = |k: usize| match args.get(k) {
        Some(Arg::Scalar(s)) => *s,
        _ => zero,
    };
    // d_ij = r_j^P − r_i^P for points in arguments i and j.
    let d = |arena: &mut Arena, i: usize, j: usize| {
        let (_, pi) = point(i);
        let (_, pj) = point(j);
        arena.vsub(pj, pi)
    };
    // Φ = g − f
    let minus = |arena: &mut Arena, g: ExprId, f: ExprId| arena.sub(g, f);
    let square = |arena: &mut Arena, c: ExprId| arena.powi(c, 2);

    match kind {
        // AX: Φ = x of P − f
        LibKind::AbsX => vec![minus(arena, point(0).1.x, scalar(1))],
        // AY: Φ = y of P − f
        LibKind::AbsY => vec![minus(arena, point(0).1.y, scalar(1))],
        // AA: Φ = φ_i − f
        LibKind::AbsAngle => {
            let phi = lo.angle(arena, body(0));
            vec![minus(arena, phi, scalar(1))]
        }
        // AD: h = r^P − c, Φ = hᵀh − C²
        LibKind::AbsDistance => {
            let h = arena.vsub(point(0).1, vector(1));
            let hh = arena.dot(h, h);
            let c2 = square(arena, scalar(2));
            vec![minus(arena, hh, c2)]
        }
        // RX, RY: Φ = e_xᵀd − f (e_y)
        LibKind::RelX => {
            let d = d(arena, 0, 1);
            vec![minus(arena, d.x, scalar(2))]
        }
        LibKind::RelY => {
            let d = d(arena, 0, 1);
            vec![minus(arena, d.y, scalar(2))]
        }
        // RA: Φ = φ_j − φ_i − f
        LibKind::RelAngle => {
            let pi = lo.angle(arena, body(0));
            let pj = lo.angle(arena, body(1));
            let rel = arena.sub(pj, pi);
            vec![minus(arena, rel, scalar(2))]
        }
        // RD, RR: Φ = dᵀd − C²
        LibKind::RelDistance | LibKind::RevoluteRevolute => {
            let d = d(arena, 0, 1);
            let dd = arena.dot(d, d);
            let c2 = square(arena, scalar(2));
            vec![minus(arena, dd, c2)]
        }
        // D: Φ = dᵀd − f
        LibKind::D => {
            let d = d(arena, 0, 1);
            let dd = arena.dot(d, d);
            vec![minus(arena, dd, scalar(2))]
        }
        // REV: Φ = r_i^P − r_j^P (i minus j), two rows x, y
        LibKind::Revolute => {
            let r = arena.vsub(point(0).1, point(1).1);
            vec![r.x, r.y]
        }
        // TRA: u_i = A_i v'_i, n_i = R u_i, u_j = A_j v'_j; Φ = [n_iᵀd; n_iᵀu_j]
        LibKind::Translational => {
            let ui = lo.rotate(arena, body(0), vector(1));
            let ni = arena.perp(ui);
            let uj = lo.rotate(arena, body(2), vector(3));
            let d = d(arena, 0, 2);
            vec![arena.dot(ni, d), arena.dot(ni, uj)]
        }
        // RT: n̂_i = R A_i v̂'_i; Φ = n̂_iᵀd − c
        LibKind::RevoluteTranslational => {
            let v = arena.unit(vector(1));
            let ui = lo.rotate(arena, body(0), v);
            let ni = arena.perp(ui);
            let d = d(arena, 0, 2);
            let nd = arena.dot(ni, d);
            vec![minus(arena, nd, scalar(3))]
        }
        // TD (translational-distance, §5): Φ = û_iᵀd − C
        LibKind::TranslationalDistance => {
            let v = arena.unit(vector(1));
            let ui = lo.rotate(arena, body(0), v);
            let d = d(arena, 0, 2);
            let ud = arena.dot(ui, d);
            vec![minus(arena, ud, scalar(3))]
        }
        // GEAR: k_i = R_i/(R_i + R_j), α = k_i(φ_i + θ_i) + k_j(φ_j + θ_j),
        // e⊥ = (−sin α, cos α); Φ = e⊥ᵀd
        LibKind::Gear => {
            let (ri, rj) = (scalar(2), scalar(3));
            let sum = arena.add(ri, rj);
            let ki = arena.div(ri, sum);
            let kj = arena.div(rj, sum);
            let phi_i = lo.angle(arena, body(0));
            let phi_j = lo.angle(arena, body(1));
            let ai = arena.add(phi_i, scalar(4));
            let aj = arena.add(phi_j, scalar(5));
            let ti = arena.mul(ki, ai);
            let tj = arena.mul(kj, aj);
            let alpha = arena.add(ti, tj);
            let one = arena.num(1.0);
            let e = arena.rot(alpha, Vec2::new(one, zero));
            let e_perp = arena.perp(e);
            let d = d(arena, 0, 1);
            vec![arena.dot(e_perp, d)]
        }
        // RP: û = A_i v̂'_i, n̂ = R û;
        // Φ = [n̂ᵀd − R_p; ûᵀd + R_p(φ_j − φ_i) − c₀]
        LibKind::RackPinion => {
            let v = arena.unit(vector(1));
            let u = lo.rotate(arena, body(0), v);
            let n = arena.perp(u);
            let d = d(arena, 0, 2);
            let rp = scalar(3);
            let nd = arena.dot(n, d);
            let row1 = minus(arena, nd, rp);
            let ud = arena.dot(u, d);
            let phi_i = lo.angle(arena, body(0));
            let phi_j = lo.angle(arena, body(2));
            let rel = arena.sub(phi_j, phi_i);
            let roll = arena.mul(rp, rel);
            let lhs = arena.add(ud, roll);
            let row2 = minus(arena, lhs, scalar(4));
            vec![row1, row2]
        }
        // DP1: a_i = A_i a'_i, a_j = A_j a'_j; Φ = a_iᵀa_j − f
        LibKind::Dp1 => {
            let ai = lo.rotate(arena, body(0), vector(1));
            let aj = lo.rotate(arena, body(2), vector(3));
            let dot = arena.dot(ai, aj);
            vec![minus(arena, dot, scalar(4))]
        }
        // DP2: Φ = a_iᵀd − f, a'_i in the frame of the body of P_i
        LibKind::Dp2 => {
            let ai = lo.rotate(arena, body(0), vector(1));
            let d = d(arena, 0, 2);
            let ad = arena.dot(ai, d);
            vec![minus(arena, ad, scalar(3))]
        }
        // CD: Φ = cᵀd − f, c a constant global vector
        LibKind::Cd => {
            let d = d(arena, 1, 2);
            let cd = arena.dot(vector(0), d);
            vec![minus(arena, cd, scalar(3))]
        }
        // Built by crate::follower::rows above.
        LibKind::PointFollower | LibKind::CamFollower | LibKind::FlatFollower => Vec::new(),
    }
}
