//! Inverse dynamics of a fully driven system (NDOF = 0): after position,
//! velocity and acceleration analysis at a time, the Lagrange multipliers
//! of M q̈ + Φ_qᵀ λ = Q_A(q, q̇, t),
//!
//! ```text
//! Φ_qᵀ λ = Q_A − M q̈
//! ```
//!
//! solved with the transposed factorization of Φ_q the step already made
//! ([`LinearSolver::solve_transpose_in_place`]); then each element's
//! reaction on each of its bodies, [F; (B s'P)ᵀF + T] = −Φ_q,bᵀ λ_c, as the
//! force F (global) and the torque T about the element's point P on that
//! body, and each driving row's effort −λ. The conventions are those of
//! simEngine2D's `calcReaction` (docs/src/dynamics.md, "Inverse dynamics").
//!
//! [`LinearSolver::solve_transpose_in_place`]: crate::linalg::LinearSolver::solve_transpose_in_place

use kinema_index::{Axis, Body, Coord};

use crate::error::{Error, Quantity};
use crate::linalg::{LinearSolver, scale_and_finite};
use crate::solver::Solver;
use crate::system::System;

/// Rows `start..end` of Φ: the rows of one element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowRange {
    /// The first row.
    pub start: u32,
    /// One past the last row.
    pub end: u32,
}

impl RowRange {
    /// Whether `row` is one of these rows.
    #[inline]
    #[must_use]
    pub fn contains(self, row: u32) -> bool {
        (self.start..self.end).contains(&row)
    }
}

/// One reaction a [`Dynamics`] system reports: one body of one element of Φ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReactionSpec {
    /// The element's rows of Φ.
    pub rows: RowRange,
    /// The body.
    pub body: Body,
}

/// A [`System`] with inertia and applied forces.
pub trait Dynamics: System {
    /// The reactions reported, in output order.
    fn reactions(&self) -> &[ReactionSpec];

    /// Length of [`dynamics`](Self::dynamics)'s output: 2 n + 2 ×
    /// reactions.
    fn dynamics_len(&self) -> usize {
        2 * self.len() + 2 * self.reactions().len()
    }

    /// Writes diag M (n entries), Q_A(q, q̇, t) (n entries), then for each
    /// reaction the arm A(φ) s'P from its body's origin to the element's
    /// point (2 entries). A slice of the wrong length gives NaN outputs.
    fn dynamics(&self, scratch: &mut Self::Scratch, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]);

    /// The first driving row: rows from it on are drivers, whose efforts
    /// [`InverseDynamics::efforts`] reports.
    fn driving_start(&self) -> usize;

    /// Every reaction and driving effort at once, as straight-line code:
    /// from the Jacobian's values `jac` (in [`System::jacobian_pattern`]
    /// order), λ and the arms (the last 2 × reactions outputs of
    /// [`dynamics`](Self::dynamics)), writes each reaction's
    /// [F; T about its point] = −Φ_q,bᵀ λ_c (the arm's moment removed) and
    /// each driving row's effort −λ, with the operations of
    /// [`Solver::inverse_dynamics`]'s sum over the pattern (terms that are
    /// structurally zero left out: the same values up to the sign of a
    /// zero). Returns the sum of every reaction component — finite only if
    /// each is, so one test covers them all — or `None`, having written
    /// nothing, when the system does not provide it (the default) or a
    /// length is wrong: the runtime then sums over the pattern.
    fn reactions_and_efforts(
        &self,
        _jac: &[f64],
        _lambda: &[f64],
        _arms: &[f64],
        _reactions: &mut [[f64; 3]],
        _efforts: &mut [f64],
    ) -> Option<f64> {
        None
    }
}

/// The results of inverse dynamics at one state, and the buffers that make
/// the computation allocation-free.
#[derive(Debug, Clone)]
pub struct InverseDynamics {
    lambda: Vec<f64>,
    reactions: Vec<[f64; 3]>,
    efforts: Vec<f64>,
    values: Vec<f64>,
    /// Every reaction's Jacobian entries (in its rows and its body's
    /// columns), in one flat list: one pass computes all reactions.
    entries: Vec<ReactionEntry>,
}

/// One term of a reaction: reaction `reaction`'s component `coord` (x, y or
/// the torque about the body's origin) gets −Φ_q[k] λ[row].
#[derive(Debug, Clone, Copy)]
struct ReactionEntry {
    /// Index of the entry in the Jacobian pattern.
    k: u32,
    /// Its row of Φ.
    row: u32,
    /// The reaction it belongs to.
    reaction: u32,
    /// Which coordinate of the body.
    coord: Axis,
}

impl InverseDynamics {
    /// Buffers for `system` (allocates; once).
    #[must_use]
    pub fn new<S: Dynamics>(system: &S) -> Self {
        Self::with_rows(system, system.len())
    }

    /// Buffers for `system` with `rows` rows of Φ, for
    /// [`of_multipliers`](Self::of_multipliers) (forward dynamics and
    /// equilibrium, where Φ need not be square; allocates, once).
    #[must_use]
    pub fn with_rows<S: Dynamics>(system: &S, rows: usize) -> Self {
        let n = rows;
        let pattern = system.jacobian_pattern();
        let mut entries = Vec::new();
        for (reaction, r) in (0u32..).zip(system.reactions()) {
            for (k, &(row, col)) in (0u32..).zip(pattern) {
                let col = Coord::of_index(col as usize);
                if r.rows.contains(row) && col.body == r.body {
                    entries.push(ReactionEntry {
                        k,
                        row,
                        reaction,
                        coord: col.axis,
                    });
                }
            }
        }
        let driving_start = system.driving_start().min(n);
        InverseDynamics {
            lambda: vec![0.0; n],
            reactions: vec![[0.0; 3]; system.reactions().len()],
            efforts: vec![0.0; n - driving_start],
            values: vec![0.0; system.dynamics_len()],
            entries,
        }
    }

    /// λ, one per row of Φ.
    #[must_use]
    pub fn lambda(&self) -> &[f64] {
        &self.lambda
    }

    /// Per reaction (in [`Dynamics::reactions`] order): Fx, Fy (global) and
    /// the torque T about the element's point, applied by the element on
    /// the body.
    #[must_use]
    pub fn reactions(&self) -> &[[f64; 3]] {
        &self.reactions
    }

    /// The effort of each driving row (−λ): the force or torque the driver
    /// supplies along its coordinate.
    #[must_use]
    pub fn efforts(&self) -> &[f64] {
        &self.efforts
    }

    /// The reactions and driving efforts of given multipliers `lambda`
    /// (one per row of Φ, as [`with_rows`](Self::with_rows) was told) at
    /// (t, q, q̇): where λ comes from forward dynamics or an equilibrium
    /// instead of this solve. λ is kept, the arms and Φ_q (into `jac`, in
    /// [`System::jacobian_pattern`] order) evaluated, and the reactions
    /// and efforts summed as [`Solver::inverse_dynamics`] sums them. No
    /// allocation.
    ///
    /// # Errors
    /// A slice of the wrong length; a non-finite M, Q_A or arm (named).
    pub fn of_multipliers<S: Dynamics>(
        &mut self,
        system: &S,
        scratch: &mut S::Scratch,
        (t, q, qd): (f64, &[f64], &[f64]),
        lambda: &[f64],
        jac: &mut [f64],
    ) -> Result<(), Error> {
        let n = system.len();
        let lengths = [
            (lambda.len(), self.lambda.len()),
            (jac.len(), system.jacobian_pattern().len()),
            (q.len(), n),
            (qd.len(), n),
        ];
        if let Some(&(got, want)) = lengths.iter().find(|(got, want)| got != want) {
            return Err(Error::Setup(crate::linalg::LinalgError::Dimension {
                what: "an argument of inverse dynamics of given multipliers",
                expected: want,
                found: got,
            }));
        }
        self.lambda.copy_from_slice(lambda);
        system.dynamics(scratch, q, qd, t, &mut self.values);
        system.jacobian(scratch, q, t, jac);
        let arms = self.values.get(2 * n..).unwrap_or(&[]);
        if system
            .reactions_and_efforts(jac, lambda, arms, &mut self.reactions, &mut self.efforts)
            .is_none()
        {
            sum_reactions(
                &self.entries,
                lambda,
                (jac, arms),
                &mut self.reactions,
                &mut self.efforts,
            );
        }
        if !scale_and_finite(self.reactions.as_flattened()).1 || !scale_and_finite(&self.values).1 {
            return Err(non_finite_value(system, t, n, &self.values));
        }
        Ok(())
    }

    /// diag M, Q_A and the arms, as last evaluated (see
    /// [`Dynamics::dynamics`]).
    #[must_use]
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}

impl<S: Dynamics, L: LinearSolver> Solver<S, L> {
    /// Inverse dynamics at the current state (after [`step`](Self::step)):
    /// fills `out` with λ, the reactions and the driving efforts. One
    /// evaluation of M and Q_A and one transposed solve with the step's
    /// factorization; no allocation.
    ///
    /// # Errors
    /// No state yet; a non-finite M, Q_A or λ (named); a singular Φ_q when
    /// the state needed a new factorization.
    pub fn inverse_dynamics(&mut self, out: &mut InverseDynamics) -> Result<(), Error> {
        let n = self.dim();
        let (system, scratch, state) = self.parts();
        let Some(state) = state else {
            return Err(Error::Setup(crate::linalg::LinalgError::NotFactored));
        };
        let t = state.t();
        // The system's outputs go into `values`; the right-hand side is
        // built in `lambda` and solved in place.
        system.dynamics(scratch, state.q(), state.qd(), t, &mut out.values);
        if out.values.len() < 2 * n {
            return Err(non_finite_value(system, t, n, &out.values));
        }
        let (m, rest) = out.values.split_at(n);
        let (qa, arms) = rest.split_at(n);
        let qdd = state.qdd();
        for (((l, &mi), &qi), &a) in out.lambda.iter_mut().zip(m).zip(qa).zip(qdd) {
            *l = qi - mi * a;
        }
        // A non-finite M or Q_A makes its entry of the right-hand side, and
        // so λ, non-finite (NaN and ∞ survive every operation of a solve):
        // only λ is checked, the culprit named on the error path.
        let (system, jac) = self.solve_transposed_at_state(&mut out.lambda)?;
        // A finite sum: every λ is finite; the exact test only otherwise.
        let lambda_sum: f64 = out.lambda.iter().sum();
        if !lambda_sum.is_finite() && !scale_and_finite(&out.lambda).1 {
            return Err(if scale_and_finite(&out.values).1 {
                let i = out.lambda.iter().position(|v| !v.is_finite()).unwrap_or(0);
                Error::NonFinite {
                    t,
                    quantity: Quantity::Multiplier,
                    name: system.equation_name(i).to_owned(),
                }
            } else {
                non_finite_value(system, t, n, &out.values)
            });
        }
        let sum = system.reactions_and_efforts(
            jac,
            &out.lambda,
            arms,
            &mut out.reactions,
            &mut out.efforts,
        );
        let finite = match sum {
            // A finite sum: every component is finite.
            Some(s) if s.is_finite() => true,
            Some(_) => scale_and_finite(out.reactions.as_flattened()).1,
            None => {
                sum_reactions(
                    &out.entries,
                    &out.lambda,
                    (jac, arms),
                    &mut out.reactions,
                    &mut out.efforts,
                );
                scale_and_finite(out.reactions.as_flattened()).1
            }
        };
        // λ is finite, so a non-finite reaction comes from an arm.
        if !finite {
            return Err(non_finite_value(system, t, n, &out.values));
        }
        Ok(())
    }
}

/// The reactions and efforts by a sum over the Jacobian's pattern (systems
/// without [`Dynamics::reactions_and_efforts`], such as tapes).
fn sum_reactions(
    entries: &[ReactionEntry],
    lambda: &[f64],
    (jac, arms): (&[f64], &[f64]),
    reactions: &mut [[f64; 3]],
    efforts: &mut [f64],
) {
    // [F; T_origin] = −Φ_q,bᵀ λ_c, all reactions in one pass.
    reactions.fill([0.0; 3]);
    for e in entries {
        reactions[e.reaction as usize][e.coord.index()] -=
            jac[e.k as usize] * lambda[e.row as usize];
    }
    // About P: T = T_origin − (B s'P)ᵀ F, B s'P = perp(arm).
    for (r, arm) in reactions.iter_mut().zip(arms.chunks_exact(2)) {
        r[2] -= -arm[1] * r[0] + arm[0] * r[1];
    }
    // The driving rows are the last efforts.len() rows.
    let driving = &lambda[lambda.len() - efforts.len()..];
    for (e, &l) in efforts.iter_mut().zip(driving) {
        *e = -l;
    }
}

/// The error for a non-finite output of [`Dynamics::dynamics`], naming the
/// first: an entry of M, of Q_A, or a reaction's arm (error path only).
#[cold]
fn non_finite_value<S: System>(system: &S, t: f64, n: usize, values: &[f64]) -> Error {
    let k = values.iter().position(|v| !v.is_finite()).unwrap_or(0);
    let name = match k {
        k if k < n => format!("M at {}", system.coordinate_name(k)),
        k if k < 2 * n => format!("Q_A at {}", system.coordinate_name(k - n)),
        k => format!("the arm of reaction {}", (k - 2 * n) / 2),
    };
    Error::NonFinite {
        t,
        quantity: Quantity::AppliedForce,
        name,
    }
}
