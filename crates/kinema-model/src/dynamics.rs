//! The dynamics derivation: the mass matrix M (diagonal), the generalized
//! applied force Q_A(q, q̇, t) assembled from gravity and the force elements
//! (see [`crate::check::ForceKind`]), its derivatives ∂Q_A/∂q and ∂Q_A/∂q̇
//! by the expression engine, and for each element of Φ and each of its
//! bodies the lever arm that turns the element's Lagrange multipliers into
//! a reaction force and torque (docs/src/dynamics.md, "Inverse dynamics").
//!
//! Nothing is derived by hand: a force F at a point P(q) contributes
//! (∂P/∂q)ᵀ F, with ∂P/∂q from the engine; a spring's rate l̇ is the
//! directional derivative of its length along q̇.

use kinema_expr::{Arena, Columns, ExprId, SeedsId, SparseMatrix, SymId};

use crate::algebra::{Vec2, VecAlgebra};
use crate::check::lower::Lowerer;
use crate::check::{BodyRef, CheckedModel, Dynamics, ForceKind, Form, LibArg};

/// Where a reaction is reported: one body of one element of Φ.
#[derive(Clone, Debug)]
pub struct Reaction {
    /// The element (the declared equation's name).
    pub element: String,
    /// The body (index in declaration order).
    pub body: usize,
    /// The body's position among the element's body arguments, ground
    /// counted (0 for the first): simEngine2D's `body1`/`body2`.
    pub slot: usize,
    /// The element's rows of Φ.
    pub rows: std::ops::Range<usize>,
    /// A(φ) s'P: from the body's origin to the element's point on it
    /// (zero when the element has none on this body), global.
    pub arm: [ExprId; 2],
}

/// Mass matrix, applied forces and their derivatives, reactions.
#[derive(Clone, Debug)]
pub struct DynamicsDerivation {
    /// diag M: (m, m, J) per body.
    pub mass: Vec<ExprId>,
    /// Q_A(q, q̇, t), one entry per coordinate.
    pub applied: Vec<ExprId>,
    /// ∂Q_A/∂q, sparse (nc × nc).
    pub applied_q: SparseMatrix,
    /// ∂Q_A/∂q̇, sparse (nc × nc).
    pub applied_qd: SparseMatrix,
    /// Gravity (gx, gy).
    pub gravity: [ExprId; 2],
    /// The force elements' names, in declaration order.
    pub forces: Vec<String>,
    /// One per (element of Φ, moving body of it), elements in row order.
    pub reactions: Vec<Reaction>,
}

/// Builds the dynamics derivation of a model that has one.
pub(crate) fn derive(
    lo: &Lowerer<'_>,
    arena: &mut Arena,
    model: &CheckedModel,
    dynamics: &Dynamics,
    rows: &[crate::derive::Row],
    phi_q: &SparseMatrix,
    seeds: SeedsId,
) -> DynamicsDerivation {
    let nb = model.bodies.len();
    let nc = 3 * nb;
    let zero = arena.num(0.0);
    let mut mass = Vec::with_capacity(nc);
    for i in &dynamics.inertia {
        let m = lo.scalar(arena, &i.mass_expr);
        let j = lo.scalar(arena, &i.inertia_expr);
        mass.extend([m, m, j]);
    }
    mass.resize(nc, zero);
    let gravity = match &dynamics.gravity_expr {
        Some(g) => {
            let v = lo.vector(arena, g);
            [v.x, v.y]
        }
        None => [zero, zero],
    };
    // Terms of each Q_A entry, summed once at the end.
    let mut terms: Vec<Vec<ExprId>> = vec![Vec::new(); nc];
    for (k, m) in mass.chunks(3).enumerate() {
        let (mx, my) = (arena.mul(m[0], gravity[0]), arena.mul(m[1], gravity[1]));
        terms[3 * k].push(mx);
        terms[3 * k + 1].push(my);
    }
    for f in &dynamics.forces {
        add_force(lo, arena, f.kind, &f.args, seeds, &mut terms);
    }
    let applied: Vec<ExprId> = terms.iter().map(|t| arena.sum(t)).collect();
    let q_syms: Vec<SymId> = lo
        .coords
        .iter()
        .flatten()
        .filter_map(|&e| arena.symbol_of(e))
        .collect();
    let qd_syms: Vec<SymId> = lo
        .velocities
        .iter()
        .flatten()
        .filter_map(|&e| arena.symbol_of(e))
        .collect();
    let applied_q = arena.jacobian_by(&applied, &Columns::new(&q_syms));
    let applied_qd = arena.jacobian_by(&applied, &Columns::new(&qd_syms));
    let reactions = reactions(lo, arena, model, rows, phi_q);
    DynamicsDerivation {
        mass,
        applied,
        applied_q,
        applied_qd,
        gravity,
        forces: dynamics.forces.iter().map(|f| f.name.clone()).collect(),
        reactions,
    }
}

/// Adds (∂P/∂q)ᵀ F to the terms of the coordinates of P's body.
fn add_point_force(
    lo: &Lowerer<'_>,
    arena: &mut Arena,
    body: BodyRef,
    p: Vec2,
    f: Vec2,
    terms: &mut [Vec<ExprId>],
) {
    let BodyRef::Body(k) = body else { return };
    let k = k as usize;
    for (c, &q) in lo.coords[k].iter().enumerate() {
        let Some(s) = arena.symbol_of(q) else {
            continue;
        };
        let dx = arena.diff(p.x, s);
        let dy = arena.diff(p.y, s);
        let a = arena.mul(dx, f.x);
        let b = arena.mul(dy, f.y);
        let term = arena.add(a, b);
        if !arena.is_zero(term) {
            terms[3 * k + c].push(term);
        }
    }
}

/// Adds `t` to the angle entry of a moving body.
fn add_torque(body: BodyRef, t: ExprId, terms: &mut [Vec<ExprId>]) {
    if let BodyRef::Body(k) = body {
        terms[3 * k as usize + 2].push(t);
    }
}

/// The angular velocity of a body (0 for ground).
fn angular_velocity(lo: &Lowerer<'_>, arena: &mut Arena, body: BodyRef) -> ExprId {
    match body {
        BodyRef::Ground => arena.num(0.0),
        BodyRef::Body(k) => lo.velocities[k as usize][2],
    }
}

fn add_force(
    lo: &Lowerer<'_>,
    arena: &mut Arena,
    kind: ForceKind,
    args: &[LibArg],
    seeds: SeedsId,
    terms: &mut [Vec<ExprId>],
) {
    let scalar = |arena: &mut Arena, i: usize| match args.get(i) {
        Some(LibArg::Scalar(t)) => lo.scalar(arena, t),
        _ => arena.num(0.0),
    };
    let point = |arena: &mut Arena, i: usize| match args.get(i) {
        Some(LibArg::Point(b, local)) => {
            let l = lo.vector(arena, local);
            Some((*b, lo.global(arena, *b, l)))
        }
        _ => None,
    };
    let body = |i: usize| match args.get(i) {
        Some(LibArg::Body(b)) => Some(*b),
        _ => None,
    };
    match kind {
        ForceKind::PointForce | ForceKind::PointForceLocal => {
            let (Some((b, p)), Some(LibArg::Vector(f))) = (point(arena, 0), args.get(1)) else {
                return;
            };
            let mut f = lo.vector(arena, f);
            if kind == ForceKind::PointForceLocal {
                f = lo.rotate(arena, b, f);
            }
            add_point_force(lo, arena, b, p, f, terms);
        }
        ForceKind::Torque => {
            let Some(b) = body(0) else { return };
            let t = scalar(arena, 1);
            add_torque(b, t, terms);
        }
        ForceKind::Rsda => {
            let (Some(bi), Some(bj)) = (body(0), body(1)) else {
                return;
            };
            let (k, c, theta0, f) = (
                scalar(arena, 2),
                scalar(arena, 3),
                scalar(arena, 4),
                scalar(arena, 5),
            );
            let (pi, pj) = (lo.angle(arena, bi), lo.angle(arena, bj));
            let (wi, wj) = (
                angular_velocity(lo, arena, bi),
                angular_velocity(lo, arena, bj),
            );
            let rel = arena.sub(pj, pi);
            let stretch = arena.sub(rel, theta0);
            let spring = arena.mul(k, stretch);
            let rate = arena.sub(wj, wi);
            let damper = arena.mul(c, rate);
            let n = arena.sum(&[spring, damper, f]);
            add_torque(bi, n, terms);
            let minus = arena.neg(n);
            add_torque(bj, minus, terms);
        }
        ForceKind::Tsda => {
            let (Some((bi, pi)), Some((bj, pj))) = (point(arena, 0), point(arena, 1)) else {
                return;
            };
            let (k, c, l0, f) = (
                scalar(arena, 2),
                scalar(arena, 3),
                scalar(arena, 4),
                scalar(arena, 5),
            );
            let d = arena.vsub(pj, pi);
            let dd = arena.dot(d, d);
            let l = arena.sqrt(dd);
            let rate = arena.directional(l, seeds);
            let stretch = arena.sub(l, l0);
            let spring = arena.mul(k, stretch);
            let damper = arena.mul(c, rate);
            let n = arena.sum(&[spring, damper, f]);
            // n d / l pulls Pi towards Pj when the spring is stretched.
            let u = arena.vdiv(d, l);
            let on_i = arena.vscale(n, u);
            let on_j = arena.vneg(on_i);
            add_point_force(lo, arena, bi, pi, on_i, terms);
            add_point_force(lo, arena, bj, pj, on_j, terms);
        }
    }
}

/// The reactions: per element of Φ, its moving bodies with their arms.
fn reactions(
    lo: &Lowerer<'_>,
    arena: &mut Arena,
    model: &CheckedModel,
    rows: &[crate::derive::Row],
    phi_q: &SparseMatrix,
) -> Vec<Reaction> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < rows.len() {
        let name = &rows[start].equation;
        let end = rows[start..]
            .iter()
            .position(|r| &r.equation != name)
            .map_or(rows.len(), |n| start + n);
        let Some(eq) = model.equations.iter().find(|e| &e.name == name) else {
            start = end;
            continue;
        };
        // (slot, body, local point) of each body argument, in order.
        let mut bodies: Vec<(usize, usize, Option<&crate::check::TExpr>)> = Vec::new();
        match &eq.form {
            Form::Library(_, args) => {
                let mut slot = 0;
                for a in args {
                    let (b, local) = match a {
                        LibArg::Point(b, l) => (*b, Some(l)),
                        LibArg::Body(b) => (*b, None),
                        _ => continue,
                    };
                    if let BodyRef::Body(k) = b {
                        match bodies.iter_mut().find(|x| x.1 == k as usize) {
                            // A body named twice (a point, then a vector's
                            // body): its first point stands.
                            Some(x) => {
                                if x.2.is_none() {
                                    x.2 = local;
                                }
                            }
                            None => bodies.push((slot, k as usize, local)),
                        }
                    }
                    slot += 1;
                }
            }
            Form::User { .. } => {
                let mut seen: Vec<usize> = phi_q
                    .entries
                    .iter()
                    .filter(|e| (start..end).contains(&(e.row as usize)))
                    .map(|e| e.col as usize / 3)
                    .collect();
                seen.sort_unstable();
                seen.dedup();
                bodies.extend(seen.into_iter().enumerate().map(|(s, b)| (s, b, None)));
            }
        }
        for (slot, body, local) in bodies {
            let arm = match local {
                Some(t) => {
                    let l = lo.vector(arena, t);
                    let v = lo.rotate(arena, BodyRef::Body(crate::idx(body)), l);
                    [v.x, v.y]
                }
                None => {
                    let z = arena.num(0.0);
                    [z, z]
                }
            };
            out.push(Reaction {
                element: name.clone(),
                body,
                slot,
                rows: start..end,
                arm,
            });
        }
        start = end;
    }
    out
}
