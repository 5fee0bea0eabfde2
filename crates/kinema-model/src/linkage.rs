//! The linkage description of a model made only of revolute joints and
//! driven angles ([`LinkageDesc`]): what a closed-form position solution
//! (the runtime's `Linkage`) is planned from.

use std::collections::HashMap;

use kinema_expr::{Arena, ExprId, SparseMatrix, SymKind};

use crate::check::lower::Lowerer;
use crate::check::{BodyRef, CheckedModel, Form, LibArg, LibKind};

/// A revolute joint of a [`LinkageDesc`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkagePin {
    /// Its two bodies (`None`: ground).
    pub bodies: [Option<u32>; 2],
    /// Its local coordinates (x, y) on each body (on ground, global):
    /// expressions of the parameters alone.
    pub local: [[ExprId; 2]; 2],
}

/// A driven angle of a [`LinkageDesc`]: φ of `body` minus φ of
/// `relative_to` (0 for ground) is `angle`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkageAngle {
    /// The driven body.
    pub body: u32,
    /// The body it is measured from (`None`: ground).
    pub relative_to: Option<u32>,
    /// The angle: an expression of time and the parameters.
    pub angle: ExprId,
}

/// A model whose every equation is a `revolute` joint, an `abs_x` and
/// `abs_y` pair holding one body point at a fixed place (a pin to ground),
/// or a row that fixes one body's angle (or the difference of two bodies'
/// angles) as a function of time: `abs_angle`, `rel_angle`,
/// `B.phi == f(t)`, and the like. Whether it decomposes into cranks and dyads is the runtime's to
/// find.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LinkageDesc {
    /// The revolute joints, in declaration order.
    pub pins: Vec<LinkagePin>,
    /// The driven angles, in the order of their rows.
    pub angles: Vec<LinkageAngle>,
}

/// The description of `model`, whose Φ (rows `phi`, from equations
/// `source`) and Φ_q are given; `None` if a row is neither a revolute's
/// nor a driven angle's, or the model has coordinates of its own.
pub(crate) fn describe(
    arena: &mut Arena,
    lo: &Lowerer<'_>,
    model: &CheckedModel,
    phi: &[ExprId],
    phi_q: &SparseMatrix,
    source: &[usize],
) -> Option<LinkageDesc> {
    let bodies = model.bodies.len();
    if !model.coords.is_empty() || phi_q.cols != 3 * bodies || phi.len() != phi_q.cols {
        return None;
    }
    let mut desc = LinkageDesc::default();
    // `abs_x` and `abs_y` of one body point at fixed values, waiting for
    // their partner (by kind, body and local coordinates): together a pin
    // to ground.
    let mut half: HashMap<(LibKind, Option<u32>, [ExprId; 2]), ExprId> = HashMap::new();
    // Each equation's rows (contiguous, kinematic equations' first).
    let mut rows_of: Vec<Vec<usize>> = vec![Vec::new(); model.equations.len()];
    for (row, &eq) in source.iter().enumerate() {
        rows_of.get_mut(eq)?.push(row);
    }
    for (eq, e) in model.equations.iter().enumerate() {
        match &e.form {
            Form::Library(LibKind::Revolute, args) => {
                desc.pins.push(pin(arena, lo, args)?);
                continue;
            }
            Form::Library(kind @ (LibKind::AbsX | LibKind::AbsY), args) => {
                if let Some((body, local, at)) = fixed_coordinate(arena, lo, args) {
                    let other = if *kind == LibKind::AbsX {
                        LibKind::AbsY
                    } else {
                        LibKind::AbsX
                    };
                    match half.remove(&(other, body, local)) {
                        Some(other_at) => {
                            let ground = if other == LibKind::AbsX {
                                [other_at, at]
                            } else {
                                [at, other_at]
                            };
                            desc.pins.push(LinkagePin {
                                bodies: [body, None],
                                local: [local, ground],
                            });
                        }
                        // A second abs_x of the same point: not a pin.
                        None => {
                            if half.insert((*kind, body, local), at).is_some() {
                                return None;
                            }
                        }
                    }
                    continue;
                }
            }
            _ => {}
        }
        for &row in &rows_of[eq] {
            desc.angles
                .push(angle(arena, lo, phi[row], row_entries(phi_q, row))?);
        }
    }
    half.is_empty().then_some(desc)
}

/// `abs_x(P, f)` or `abs_y(P, f)` with f a function of the parameters:
/// P's body, its local coordinates, and f.
fn fixed_coordinate(
    arena: &mut Arena,
    lo: &Lowerer<'_>,
    args: &[LibArg],
) -> Option<(Option<u32>, [ExprId; 2], ExprId)> {
    let [LibArg::Point(BodyRef::Body(b), local), LibArg::Scalar(f)] = args else {
        return None;
    };
    let v = lo.vector(arena, local);
    let f = lo.scalar(arena, f);
    let fixed = [v.x, v.y, f].iter().all(|&e| params_only(arena, e, false));
    fixed.then_some((Some(*b), [v.x, v.y], f))
}

/// The entries of Φ_q's row `row` (row-major).
fn row_entries(m: &SparseMatrix, row: usize) -> &[kinema_expr::Entry] {
    let start = m.entries.partition_point(|e| (e.row as usize) < row);
    let end = m.entries.partition_point(|e| (e.row as usize) <= row);
    &m.entries[start..end]
}

/// A revolute joint's pin, its local coordinates lowered; `None` if they
/// depend on more than the parameters.
fn pin(arena: &mut Arena, lo: &Lowerer<'_>, args: &[LibArg]) -> Option<LinkagePin> {
    let [LibArg::Point(b0, l0), LibArg::Point(b1, l1)] = args else {
        return None;
    };
    let body = |b: &BodyRef| match b {
        BodyRef::Ground => None,
        BodyRef::Body(k) => Some(*k),
    };
    let (v0, v1) = (lo.vector(arena, l0), lo.vector(arena, l1));
    let local = [[v0.x, v0.y], [v1.x, v1.y]];
    let constant = local
        .iter()
        .flatten()
        .all(|&e| params_only(arena, e, false));
    constant.then_some(LinkagePin {
        bodies: [body(b0), body(b1)],
        local,
    })
}

/// Whether `e` depends on nothing but the parameters (and time, if
/// `time`).
fn params_only(arena: &Arena, e: ExprId, time: bool) -> bool {
    arena
        .free_symbols(e)
        .into_iter()
        .all(|s| match arena.symbol(s).kind {
            SymKind::Parameter(_) => true,
            SymKind::Time => time,
            SymKind::Coordinate(_) | SymKind::Velocity(_) => false,
        })
}

/// The driven angle of a row Φ whose Φ_q row is `c` at one body's φ (Φ =
/// c φ_b + g(t)), or `c` and `−c` at two bodies' (Φ = c (φ_j − φ_i) +
/// g(t)), `c` a nonzero number: the angle is φ_b − Φ/c (φ_j − φ_i − Φ/c),
/// which must then depend on time and the parameters alone.
fn angle(
    arena: &mut Arena,
    lo: &Lowerer<'_>,
    phi: ExprId,
    entries: &[kinema_expr::Entry],
) -> Option<LinkageAngle> {
    let angle_column = |col: u32| (col % 3 == 2).then_some(col / 3);
    let (body, relative_to, c) = match entries {
        [e] => (angle_column(e.col)?, None, arena.as_num(e.expr)?),
        [a, b] => {
            let (ca, cb) = (arena.as_num(a.expr)?, arena.as_num(b.expr)?);
            if ca != -cb {
                return None;
            }
            // φ_j with +c, φ_i with −c: the later column is j when cb = c.
            (angle_column(b.col)?, Some(angle_column(a.col)?), cb)
        }
        _ => return None,
    };
    if c == 0.0 || !c.is_finite() {
        return None;
    }
    let own = lo.coords[body as usize][2];
    let difference = match relative_to {
        None => own,
        Some(i) => arena.sub(own, lo.coords[i as usize][2]),
    };
    let c = arena.num(c);
    let scaled = arena.div(phi, c);
    let angle = arena.sub(difference, scaled);
    params_only(arena, angle, true).then_some(LinkageAngle {
        body,
        relative_to,
        angle,
    })
}
