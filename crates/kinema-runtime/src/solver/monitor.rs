//! The monitor and the branch test, run after every solve: the LU's
//! pivots read for det Φ_q's sign and the pivot ratio (a small ratio
//! confirmed by the SVD), whether a step is quiet or stays on the branch
//! (else it is refined), and the commit that records the singular
//! configurations a new state reveals (see "Singular configurations" on
//! [`Solver`]).

use super::{PIVOT_GATE, Solver};
use crate::diagnose::{MAX_DENSE_DIAGNOSIS, rank};
use crate::error::Error;
use crate::linalg::LinearSolver;
use crate::newton::{Travel, inf_norm};
use crate::system::System;

/// A step is accepted when its position differs from the Taylor prediction
/// by at most this fraction of the predicted motion, and its velocity from
/// q̇ + h q̈ by at most this fraction of ‖q̇‖ + ‖h q̈‖; else it is refined.
const CONSISTENCY: f64 = 0.3;

/// More Newton updates than this make a step be refined.
pub(super) const MAX_UPDATES_UNREFINED: usize = 8;

/// A step is quiet (see [`Solver::quiet`]) when Newton's later updates sum
/// to at most this fraction of its first: Newton contracted from its first
/// iterate, so the solution it found is the one solution within a few
/// ‖Δq₁‖ of its start, where the branch's own lies (the start is the branch's
/// Taylor prediction, or q0 with a first update that predicts the motion to
/// first order). The branch test's own fraction, [`CONSISTENCY`].
const CONTRACTED: f64 = CONSISTENCY;

/// A step is quiet only with a pivot ratio at least this (ten times the
/// monitor's gate [`PIVOT_GATE`]).
const WATCH_RATIO: f64 = 0.1;

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// Reads the LU's pivots for `self.next` (Φ_q at its q in `ws.jac`): det sign, pivot ratio, and near-singularity, confirmed by
    /// the equilibrated SVD when the ratio is below the gate.
    pub(super) fn monitor(&mut self) {
        if self.system.is_empty() {
            // Φ_q is 0 × 0: det 1, never singular (nothing to diagnose).
            self.next.stats.pivot_ratio = 1.0;
            self.next.det_sign = 1.0;
            self.next.stats.near_singular = false;
            return;
        }
        let (ratio, sign) = self
            .lu
            .pivot_report()
            .map_or((1.0, 0.0), |r| (r.ratio, r.det_sign));
        self.next.stats.pivot_ratio = ratio;
        self.next.det_sign = sign;
        self.next.stats.near_singular = ratio < PIVOT_GATE && self.confirm_near_singular(ratio);
    }

    /// The SVD's verdict on a small pivot ratio (out of the hot path). When
    /// the equilibrated matrix is well conditioned the ratio came from the
    /// units: the solver switches to equilibrated factorizations.
    #[cold]
    #[inline(never)]
    fn confirm_near_singular(&mut self, ratio: f64) -> bool {
        let tolerance = self.options.singular_tolerance;
        let n = self.system.len();
        let limit = crate::diagnose::near_singular_condition(tolerance);
        // Past the step's budget of dense diagnoses the (equilibrated) pivot
        // ratio decides alone, as for systems too large for the SVD.
        if n > MAX_DENSE_DIAGNOSIS || self.ws.diagnoses_left == 0 {
            return ratio * limit <= 1.0;
        }
        self.ws.diagnoses_left -= 1;
        match rank(n, self.system.jacobian_pattern(), &self.ws.jac, tolerance) {
            Ok(r) if r.near_singular(tolerance) => true,
            Ok(_) => {
                if !self.ws.scaling.active {
                    self.ws
                        .scaling
                        .switch_on(self.system.jacobian_pattern(), &self.ws.jac);
                }
                false
            }
            Err(_) => ratio * limit <= 1.0,
        }
    }

    /// Whether `self.next` is a quiet step, which cannot have left the
    /// branch unseen, so that the branch test ([`acceptable`](Self::acceptable))
    /// is not needed: from a regular, unrefined state, with the monitor's
    /// pivot ratio steady (at least [`WATCH_RATIO`] and at least half the
    /// last state's: the condition is not growing) and Newton contracted from
    /// its start (its later updates sum to at most [`CONTRACTED`] × its
    /// first; a correction large against the step is not quiet). Reads a few
    /// numbers: the per-step price of the monitor.
    pub(super) fn quiet(&self) -> bool {
        let (base, stats) = (&self.state.stats, &self.next.stats);
        let Travel { first, later } = self.travel;
        let newton_quiet = later <= CONTRACTED * first;
        let ratio_steady =
            stats.pivot_ratio >= WATCH_RATIO && stats.pivot_ratio >= 0.5 * base.pivot_ratio;
        let base_regular = base.substeps == 0 && !base.near_singular;
        newton_quiet && ratio_steady && base_regular
    }

    /// Whether `self.next`, a regular solution a step h = t_next − t from
    /// the current state, stays on the branch: few Newton updates, position
    /// within [`CONSISTENCY`] of the predicted motion from the Taylor
    /// prediction q + h q̇ + h²/2 q̈ (recomputed here, bit for bit as
    /// [`predict_into`](super::predict_into) gives it), velocity likewise
    /// from q̇ + h q̈. A non-finite value rejects. Runs on every step: one
    /// pass over the states.
    pub(super) fn acceptable(&self) -> bool {
        if self.next.stats.iterations > MAX_UPDATES_UNREFINED {
            return false;
        }
        let (s, next) = (&self.state, &self.next);
        let h = next.t - s.t;
        let half_h2 = 0.5 * h * h;
        let n = s.q.len();
        let (q0, v0, a0) = (&s.q[..n], &s.qd[..n], &s.qdd[..n]);
        let (q, v) = (&next.q[..n], &next.qd[..n]);
        // The larger of m and x, one instruction (maxsd), blind to a NaN x;
        // the inputs are finite (a committed state, a converged q, solved
        // rates), so only the predictions can be NaN or infinite: their sum
        // is checked.
        let max = |m: f64, x: f64| if x > m { x } else { m };
        // Maxima of |q − p|, |p − q0|, |q̇ − (q̇0 + h q̈0)|, |q̇0| + |h q̈0|.
        let (mut dq, mut sq, mut dv, mut sv) = (0.0, 0.0, 0.0, 0.0);
        // The predictions summed: non-finite if one of them is.
        let mut sum = 0.0;
        for i in 0..n {
            let p = q0[i] + h * v0[i] + half_h2 * a0[i];
            let w = v0[i] + h * a0[i];
            dq = max(dq, (q[i] - p).abs());
            sq = max(sq, (p - q0[i]).abs());
            dv = max(dv, (v[i] - w).abs());
            sv = max(sv, v0[i].abs() + (h * a0[i]).abs());
            sum += p + w;
        }
        let finite = (sum + sv).is_finite();
        let v_ok = dv <= CONSISTENCY * sv + 1e-9 * (1.0 + sv);
        // The absolute floor of the position test, 10⁻⁹ (1 + ‖q0‖∞), only
        // when the relative test alone fails.
        let q_ok = dq <= CONSISTENCY * sq || dq <= CONSISTENCY * sq + 1e-9 * (1.0 + inf_norm(q0));
        finite && q_ok && v_ok
    }

    /// Makes `self.next` (solved at `t`) the current state, after
    /// recording the singular configurations it reveals: a change of sign
    /// of det Φ_q (located by bisection), the start or end of a run of
    /// near-singular states.
    #[inline]
    pub(super) fn commit(&mut self, t: f64) -> Result<(), Error> {
        let sign = self.next.det_sign;
        let near = self.next.stats.near_singular;
        // Near a singular configuration q̇ and q̈ are limits, with only
        // positions asked for they are differences: neither reads Φ_q.
        let kink = if near || self.options.positions_only {
            None
        } else {
            let uncertainty = self.next.stats.residual;
            self.system.kink(
                &mut self.scratch,
                &self.next.q,
                uncertainty,
                self.ws.rows.size(),
                t,
            )
        };
        // Written only when it changes (rarely): a store just before the
        // swap below would be read back by its wider loads, which cannot
        // take a value still in flight (measured: +4 % on the JIT's step).
        if kink != self.next.kink {
            self.next.kink = kink;
        }
        let flipped = self.branch_sign * sign < 0.0;
        // The regular case, every step: nothing to record.
        if !flipped && !near && self.zone.is_none() {
            if sign != 0.0 {
                self.branch_sign = sign;
            }
            std::mem::swap(&mut self.state, &mut self.next);
            self.assembled = true;
            return Ok(());
        }
        self.commit_events(t, sign, near, flipped)
    }

    /// [`commit`](Self::commit) when the state reveals or ends a singular
    /// configuration (off the hot path).
    #[cold]
    #[inline(never)]
    fn commit_events(&mut self, t: f64, sign: f64, near: bool, flipped: bool) -> Result<(), Error> {
        if flipped {
            let event = self.locate_passage(t)?;
            if let Some(zone) = &mut self.zone {
                zone.flipped = true;
            }
            if self.options.stop_at_singular {
                return Err(Error::SingularConfiguration {
                    event: Box::new(event),
                });
            }
            self.events.push(event);
        }
        if sign != 0.0 {
            self.branch_sign = sign;
        }
        // A run of near-singular solutions ends at the first regular state
        // committed after it (solutions seen ahead of a jump count too).
        let past_zone = !near && self.zone.as_ref().is_some_and(|z| t > z.event.t);
        if near {
            self.note_near_singular(t);
        } else if past_zone
            && let Some(zone) = self.zone.take()
            && !zone.flipped
        {
            if self.options.stop_at_singular {
                return Err(Error::SingularConfiguration {
                    event: Box::new(zone.event),
                });
            }
            self.events.push(zone.event);
        }
        std::mem::swap(&mut self.state, &mut self.next);
        self.assembled = true;
        Ok(())
    }
}
