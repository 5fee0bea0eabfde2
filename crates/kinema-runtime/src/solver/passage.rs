//! The refinement near singular configurations (see "Singular
//! configurations" on [`Solver`]): internal sub-steps through a passage,
//! the branch's limit at an output time within the threshold, the location
//! of a passage (change of sign of det Φ_q) and of a lock-up (limit point),
//! and a start at a singular configuration. Off the per-step hot path.

use super::monitor::MAX_UPDATES_UNREFINED;
use super::{ROUNDOFF_RATIO, Solver, predict_into};
use crate::diagnose::MAX_DENSE_DIAGNOSIS;
use crate::error::Error;
use crate::event::{SingularEvent, SingularKind};
use crate::linalg::LinearSolver;
use crate::newton::{
    Eval, Factorization, Lu, Took, Travel, check_jacobian, inf_norm, solve_position,
};
use crate::options::Options;
use crate::state::StepStats;
use crate::system::System;

/// Bisections of a failed step when looking for a limit point (2⁻⁶⁰ of the
/// step: below roundoff of t).
const MAX_BISECTIONS: usize = 60;

/// Sub-steps shorter than this fraction of the step end the refinement
/// (a lock-up, diagnosed by bisection).
const MIN_FRACTION: f64 = 1e-13;

/// At most this many successive jumps (each twice as far) over a
/// near-singular neighbourhood.
const MAX_JUMPS: usize = 20;

/// [`Solver::bridge`] gives up after this many probes in a row, each twice
/// as far beyond the output time as the last, where Newton finds no
/// solution.
const MAX_FAILED_PROBES: usize = 6;

/// At most this many internal sub-step attempts per step.
const MAX_SUBSTEPS: usize = 1000;

/// In the bisection of a passage, a solution with a pivot ratio above this
/// may serve as the base of the next prediction.
const BASE_RATIO: f64 = 1e-6;

/// A limit (the Taylor prediction taken where Φ_q is singular) must satisfy
/// ‖Φ‖∞ ≤ this multiple of the residual tolerance.
const LIMIT_RESIDUAL: f64 = 100.0;

/// What a sub-step's solution means for the refinement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// On the branch: the next base.
    Accept,
    /// Within the threshold of a singular configuration: jump over it.
    Jump,
    /// Failed or off the branch: halve.
    Reject,
}

/// How the bisection of a change of sign of det Φ_q ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum End {
    /// The interval is down to roundoff of t.
    Narrowed,
    /// At a singular configuration (Φ_q singular at a time tried).
    Singular,
    /// Newton failed or left the branch at every time tried towards the
    /// left end, or a solution's sign was undecided.
    GaveUp,
    /// [`MAX_BISECTIONS`] rounds spent.
    Rounds,
}

/// A run of near-singular states.
#[derive(Debug, Clone)]
pub(super) struct Zone {
    pub(super) worst_ratio: f64,
    pub(super) event: SingularEvent,
    pub(super) flipped: bool,
}

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// Assembly met a singular Φ_q: perhaps the motion starts at a singular
    /// configuration. The branch that leaves it is assembled a little later,
    /// at t0 + δ (δ the first of 10⁻⁴, 2·10⁻⁴, … (1 + |t0|) where Φ_q is not
    /// near singular), from the initial guess — the user's picture of the
    /// mechanism chooses the branch — and followed back to t0 by its Taylor
    /// expansion (q⃛ from a second solve at t0 + 2δ). If that satisfies
    /// Φ(q, t0) = 0 to √tol, it is the start,
    /// flagged (q̇, q̈ are the branch's limits); otherwise `failure`.
    #[cold]
    pub(super) fn singular_start(&mut self, t0: f64, failure: Error) -> Result<(), Error> {
        let scale = 1.0 + t0.abs();
        let mut delta = 1e-4 * scale;
        let mut found = false;
        for _ in 0..12 {
            self.system.initial_guess(&mut self.next.q);
            if self.solve_inner(t0 + delta).is_ok() {
                self.monitor();
                if !self.next.stats.near_singular {
                    found = true;
                    break;
                }
            }
            delta *= 2.0;
        }
        self.factorization = Factorization::None;
        if !found {
            return Err(failure);
        }
        // Back along the branch from t0 + δ, with q⃛ from a second solve at
        // t0 + 2δ (else 0): q(t0) = q − δ q̇ + δ²/2 q̈ − δ³/6 q⃛,
        // q̇(t0) = q̇ − δ q̈ + δ²/2 q⃛, q̈(t0) = q̈ − δ q⃛.
        std::mem::swap(&mut self.state, &mut self.next);
        let second = self.attempt(t0 + 2.0 * delta).is_ok() && !self.next.stats.near_singular;
        if second && self.options.positions_only {
            // No rates: the slope between the two solves stands for q̇ at
            // t0 + δ (q̈ is zero), which takes q back to t0 to O(δ²).
            let (one, two) = (&mut self.state, &self.next);
            for ((v, &a), &b) in one.qd.iter_mut().zip(&one.q).zip(&two.q) {
                *v = (b - a) / delta;
            }
            // A forward slope: not the quadratic's derivatives the next
            // estimate would read back through h_back.
            one.qdd.fill(0.0);
            one.h_back = f64::NAN;
        }
        self.spare.clone_from(&self.state);
        let (one, two) = (&self.state, &self.next);
        let out = &mut self.spare;
        for i in 0..out.q.len() {
            let jerk = if second {
                (two.qdd[i] - one.qdd[i]) / delta
            } else {
                0.0
            };
            let (q, qd, qdd) = (one.q[i], one.qd[i], one.qdd[i]);
            out.q[i] =
                q - delta * qd + 0.5 * delta * delta * qdd - delta * delta * delta / 6.0 * jerk;
            out.qd[i] = qd - delta * qdd + 0.5 * delta * delta * jerk;
            out.qdd[i] = qdd - delta * jerk;
        }
        out.h_back = f64::NAN;
        std::mem::swap(&mut self.next, &mut self.spare);
        self.system
            .phi(&mut self.scratch, &self.next.q, t0, &mut self.ws.phi);
        let residual = inf_norm(&self.ws.phi);
        let close = self.ws.rows.scaled(&self.ws.phi)
            <= self.options.residual_tolerance.sqrt() * (1.0 + inf_norm(&self.next.q));
        if !close {
            return Err(failure);
        }
        self.next.t = t0;
        self.next.stats = crate::state::StepStats {
            residual,
            pivot_ratio: 0.0,
            near_singular: true,
            ..Default::default()
        };
        self.next.det_sign = 0.0;
        self.factored = 0;
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t0, &mut self.ws.jac);
        Ok(())
    }

    /// The refinement of [`advance`](Self::advance): sub-steps from t0 to
    /// t. A sub-step is halved when it fails or leaves the branch, doubled
    /// after one that succeeds. A sub-step ending within the threshold of a
    /// singular configuration is not a base for the next one: the next
    /// jumps over it (twice as far), predicted from the regular state
    /// before it. If the output time t itself is within the threshold, its
    /// rates are bridged (see [`bridge`](Self::bridge)).
    pub(super) fn substeps(&mut self, t0: f64, t: f64) -> Result<(), Error> {
        let span = t - t0;
        let mut h = 0.5 * span;
        let (mut substeps, mut tries) = (0usize, 0usize);
        let mut jumps = 0usize;
        // Where the last run of jumps started (a near-singular solution).
        let mut zone_at = f64::NAN;
        loop {
            tries += 1;
            let from = self.state.t;
            let remaining = t - from;
            // Never `from` itself: a sub-step shorter than the resolution of
            // t (a step of an ulp, halved) would be accepted without moving,
            // and doubled from 0 forever.
            let t_try = if h >= remaining * (1.0 - 1e-9) {
                t
            } else {
                (from + h).max(from.next_up()).min(t)
            };
            let h_try = t_try - from;
            let attempt = self.attempt(t_try);
            let at_end = t_try >= t;
            let outcome = match &attempt {
                Ok(()) if self.next.stats.near_singular => {
                    self.note_near_singular(t_try);
                    if !at_end {
                        Outcome::Jump
                    } else if self.bridge(t) {
                        Outcome::Accept
                    } else {
                        Outcome::Reject
                    }
                }
                Ok(()) if self.acceptable() => Outcome::Accept,
                Ok(()) => Outcome::Reject,
                Err(Error::Singular { .. }) if !at_end => Outcome::Jump,
                Err(Error::Singular { .. }) => {
                    if self.limit(t) && self.bridge(t) {
                        Outcome::Accept
                    } else {
                        Outcome::Reject
                    }
                }
                Err(Error::NoConvergence { .. }) => Outcome::Reject,
                Err(e) => return Err(e.clone()),
            };
            match outcome {
                Outcome::Accept => {
                    jumps = 0;
                    substeps += 1;
                    self.next.stats.substeps = substeps;
                    self.commit(t_try)?;
                    if at_end {
                        return Ok(());
                    }
                    h = (2.0 * h_try).min(span);
                    continue;
                }
                Outcome::Jump if jumps < MAX_JUMPS => {
                    if jumps == 0 {
                        zone_at = t_try;
                    }
                    jumps += 1;
                    h = 2.0 * h_try;
                    continue;
                }
                Outcome::Jump | Outcome::Reject => {}
            }
            // A failed jump: approach the neighbourhood closer before the
            // next one (a lock-up when that is no longer possible).
            h = if jumps > 0 {
                0.5 * (zone_at - from)
            } else {
                0.5 * h_try
            };
            jumps = 0;
            // NaN-safe: a comparison with NaN is false, so not progressing.
            let progressing = h > MIN_FRACTION * span && from + h > from;
            let stuck = !progressing;
            if stuck || tries >= MAX_SUBSTEPS {
                let failure = match attempt {
                    Err(e) => e,
                    // Converged, but off the branch every time.
                    Ok(()) => Error::BranchLost {
                        from,
                        t,
                        substeps: tries,
                    },
                };
                let mut e = self.locate_limit(from, t_try, failure);
                if let Error::Singular { dependency, .. } = &mut e
                    && dependency.rank.is_none()
                    && dependency.dim <= MAX_DENSE_DIAGNOSIS
                {
                    // A sub-step's failure past the step's diagnosis budget:
                    // diagnosed now, at the last Φ_q evaluated near it.
                    *dependency = crate::diagnose::dependency(
                        &self.system,
                        &self.ws.jac,
                        self.options.singular_tolerance,
                    );
                }
                if let Error::Singular { t, dependency } = &e {
                    self.events.push(SingularEvent {
                        t: *t,
                        kind: SingularKind::LockUp,
                        dependency: dependency.clone(),
                    });
                }
                return Err(e);
            }
        }
    }

    /// `self.next` holds q at the output time `t`, within the threshold of a
    /// singular configuration, where Φ_q does not determine q̇ and q̈. Solves
    /// a regular state on the branch beyond it (at t + (t − t_a), doubling
    /// the distance until regular and on the branch) and gives `self.next`
    /// the branch's values: cubic Hermite interpolation of q (with q̇ as its
    /// derivative) and of q̇ (with q̈) between regular states on either
    /// side (the bracket narrowed, by halving, as long as both ends stay
    /// regular), q̈ the derivative of the latter. Flags it.
    /// `false` if no regular state beyond was found.
    fn bridge(&mut self, t: f64) -> bool {
        // Every solve here must pass the branch test, which refuses one of
        // more than MAX_UPDATES_UNREFINED Newton updates: Newton stops
        // there, the same states found, and a probe with no solution (past
        // a lock-up every one fails) costs that many updates, not
        // `max_iterations`.
        let max_iterations = self.options.max_iterations;
        self.options.max_iterations = max_iterations.min(MAX_UPDATES_UNREFINED);
        let found = self.bridge_probes(t);
        self.options.max_iterations = max_iterations;
        found
    }

    /// [`bridge`](Self::bridge) with its solves' updates capped.
    fn bridge_probes(&mut self, t: f64) -> bool {
        std::mem::swap(&mut self.next, &mut self.aside);
        let ta = self.state.t;
        // A regular state beyond t on the branch: b.
        let mut tb = t + (t - ta);
        let mut found = false;
        let mut failed = 0;
        for _ in 0..30 {
            match self.attempt(tb) {
                Ok(()) if !self.next.stats.near_singular && self.acceptable() => {
                    found = true;
                    break;
                }
                Ok(()) => failed = 0,
                Err(_) => failed += 1,
            }
            // No solution from the prediction at this many distances in a
            // row, each twice the last: nothing on the branch beyond (past a
            // lock-up every probe fails), or not within reach of the
            // prediction.
            if failed == MAX_FAILED_PROBES {
                break;
            }
            tb = t + 2.0 * (tb - t);
        }
        if found {
            // Narrow the bracket [a, b] around t while both ends stay
            // regular and on the branch: interpolation error falls as its
            // width to the fourth.
            std::mem::swap(&mut self.next, &mut self.bracket_b);
            self.bracket_a.clone_from(&self.state);
            let mut delta = 0.5 * (t - ta).min(tb - t);
            for _ in 0..40 {
                std::mem::swap(&mut self.state, &mut self.bracket_a);
                let left = self.attempt(t - delta).is_ok()
                    && !self.next.stats.near_singular
                    && self.acceptable();
                std::mem::swap(&mut self.state, &mut self.bracket_a);
                if !left {
                    break;
                }
                // Candidate a in `spare`, b predicted from it.
                std::mem::swap(&mut self.next, &mut self.spare);
                std::mem::swap(&mut self.state, &mut self.spare);
                let right = self.attempt(t + delta).is_ok()
                    && !self.next.stats.near_singular
                    && self.acceptable();
                std::mem::swap(&mut self.state, &mut self.spare);
                if !right {
                    break;
                }
                std::mem::swap(&mut self.spare, &mut self.bracket_a);
                std::mem::swap(&mut self.next, &mut self.bracket_b);
                delta *= 0.5;
            }
            let (a, b) = (&self.bracket_a, &self.bracket_b);
            let span = b.t - a.t;
            let s = (t - a.t) / span;
            let (s2, s3) = (s * s, s * s * s);
            let (h00, h10, h01, h11) = (
                2.0 * s3 - 3.0 * s2 + 1.0,
                s3 - 2.0 * s2 + s,
                -2.0 * s3 + 3.0 * s2,
                s3 - s2,
            );
            let (d00, d10, d01, d11) = (
                6.0 * s2 - 6.0 * s,
                3.0 * s2 - 4.0 * s + 1.0,
                -6.0 * s2 + 6.0 * s,
                3.0 * s2 - 2.0 * s,
            );
            let out = &mut self.aside;
            for i in 0..out.qd.len() {
                // Newton's q within the threshold is accurate only to about
                // √tol along the free direction; the branch's is smoother.
                out.q[i] =
                    h00 * a.q[i] + h10 * span * a.qd[i] + h01 * b.q[i] + h11 * span * b.qd[i];
                let (va, vb, aa, ab) = (a.qd[i], b.qd[i], a.qdd[i], b.qdd[i]);
                out.qd[i] = h00 * va + h10 * span * aa + h01 * vb + h11 * span * ab;
                out.qdd[i] = (d00 * va + d01 * vb) / span + d10 * aa + d11 * ab;
            }
            out.h_back = f64::NAN;
        }
        std::mem::swap(&mut self.next, &mut self.aside);
        self.factorization = Factorization::None;
        if found {
            self.next.stats.near_singular = true;
            if self.next.stats.pivot_ratio < ROUNDOFF_RATIO {
                self.next.det_sign = 0.0;
            }
        }
        found
    }

    /// At the output time `t` Φ_q is singular (the LU refused it): takes
    /// the Taylor prediction from the current state as q if Φ is nearly
    /// satisfied there (the caller then bridges the rates).
    fn limit(&mut self, t: f64) -> bool {
        predict_into(&self.state, t, &mut self.pred);
        self.system
            .phi(&mut self.scratch, &self.pred, t, &mut self.ws.phi);
        let residual = inf_norm(&self.ws.phi);
        let close =
            self.ws.rows.scaled(&self.ws.phi) <= LIMIT_RESIDUAL * self.options.residual_tolerance;
        if !close {
            return false;
        }
        self.next.q.copy_from_slice(&self.pred);
        self.next.t = t;
        self.next.stats = crate::state::StepStats {
            residual,
            near_singular: true,
            ..Default::default()
        };
        self.next.det_sign = 0.0;
        true
    }

    /// A near-singular state at `t`: opens or updates the run of them.
    pub(super) fn note_near_singular(&mut self, t: f64) {
        let ratio = self.next.stats.pivot_ratio;
        let worse = self.zone.as_ref().is_none_or(|z| ratio < z.worst_ratio);
        if !worse {
            return;
        }
        self.factored = 0;
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t, &mut self.ws.jac);
        let dependency = crate::diagnose::dependency(
            &self.system,
            &self.ws.jac,
            self.options.singular_tolerance,
        );
        let event = SingularEvent {
            t,
            kind: SingularKind::Toggle,
            dependency,
        };
        match &mut self.zone {
            Some(zone) => {
                zone.worst_ratio = ratio;
                zone.event = event;
            }
            None => {
                self.zone = Some(Zone {
                    worst_ratio: ratio,
                    event,
                    flipped: false,
                });
            }
        }
    }

    /// det Φ_q has opposite signs at the current state and at `self.next`
    /// (at `t`): bisects (at 0.4 of the interval) the time between them along the branch (each
    /// solve from the last state on the current side) to find where it
    /// changes, and diagnoses Φ_q there. Leaves `self.next` and the state as
    /// they were. Event path: allocates two states.
    ///
    /// # Errors
    /// [`Error::BranchJump`] when the bisection narrows the change down to
    /// roundoff of t with the branch's last state there regular (full rank,
    /// condition below the near-singular threshold τ^−0.4): a branch is
    /// smooth where Φ_q is regular, so no singular configuration lies in
    /// between, and the solution at `t` is on another branch that Newton
    /// jumped to from a step too long for the motion. Reporting it as a
    /// passage would name a singular configuration that is not there (and a
    /// driver turning many times per step would do so at every step).
    pub(super) fn locate_passage(&mut self, t: f64) -> Result<SingularEvent, Error> {
        let mut candidate = self.next.clone();
        // The left end: a copy of the current state, moved right as the
        // bisection proceeds; the current state itself is kept.
        let left_sign = self.branch_sign;
        let mut left = self.state.clone();
        let (mut lo, mut hi) = (self.state.t, t);
        // The state may already be past `t` (a passage's limit
        // taken at an output time just behind the sub-steps): then nothing
        // is bisected, and nothing learnt of the branch between them.
        let forward = lo < hi;
        std::mem::swap(&mut self.state, &mut left);
        let mut singular_at = None;
        let mut end = End::Rounds;
        'bisection: for _ in 0..MAX_BISECTIONS {
            // Not the midpoint: grids symmetric about t* would put the first
            // one on it, where det Φ_q's sign is noise.
            let mut mid = lo + 0.4 * (hi - lo);
            if !(lo < mid && mid < hi) || hi - lo <= 1e-12 * (1.0 + hi.abs()) {
                end = End::Narrowed;
                break;
            }
            // From a coarse step, Newton may fail or leave the branch at the
            // midpoint: move it towards the left end until it does not.
            let mut tries = 0;
            // Only the sign matters here: a near-singular solution counts.
            loop {
                let attempt = self.attempt(mid);
                let at_roundoff = attempt.is_ok()
                    && self.next.stats.near_singular
                    && self.next.stats.pivot_ratio < ROUNDOFF_RATIO;
                if at_roundoff || matches!(attempt, Err(Error::Singular { .. })) {
                    // Φ_q is singular at mid itself (its det's sign is
                    // noise): that is the time.
                    singular_at = Some(mid);
                    end = End::Singular;
                    break 'bisection;
                }
                let ok = attempt.is_ok() && (self.next.stats.near_singular || self.acceptable());
                if ok && self.next.det_sign != 0.0 {
                    break;
                }
                tries += 1;
                mid = lo + 0.5 * (mid - lo);
                let inside = lo < mid;
                if tries > 60 || !inside {
                    end = End::GaveUp;
                    break 'bisection;
                }
            }
            let sign = self.next.det_sign;
            if sign * left_sign > 0.0 {
                lo = mid;
                // A solution very near singular narrows the interval but
                // does not become the base of predictions (its rates are
                // noise).
                if self.next.stats.pivot_ratio > BASE_RATIO {
                    std::mem::swap(&mut self.state, &mut self.next);
                }
            } else if sign * left_sign < 0.0 {
                hi = mid;
            } else {
                end = End::GaveUp;
                break;
            }
        }
        // Φ_q at the last state before the change of sign.
        let t_star = singular_at.unwrap_or(lo + 0.5 * (hi - lo));
        self.factored = 0;
        self.system.jacobian(
            &mut self.scratch,
            &self.state.q,
            self.state.t,
            &mut self.ws.jac,
        );
        let dependency = crate::diagnose::dependency(
            &self.system,
            &self.ws.jac,
            self.options.singular_tolerance,
        );
        // The state diagnosed is the branch's last one, at the interval's
        // left end (not an older base: a near-singular solution there would
        // not have become one).
        let at = self.state.t;
        std::mem::swap(&mut self.state, &mut left);
        std::mem::swap(&mut self.next, &mut candidate);
        self.factorization = Factorization::None;
        let regular = dependency.rank == Some(dependency.dim)
            && dependency.condition.is_some_and(|c| {
                c < crate::diagnose::near_singular_condition(self.options.singular_tolerance)
            });
        // A change down to roundoff with the branch regular there, or every
        // round spent walking a regular branch (each midpoint too far for
        // Newton to stay on it, as when a driver turns many times a step)
        // without reaching the change: no singular configuration found.
        if forward && matches!(end, End::Narrowed | End::Rounds) && at == lo && regular {
            return Err(Error::BranchJump {
                from: self.state.t,
                t,
                at,
                condition: dependency.condition.unwrap_or(f64::NAN),
            });
        }
        Ok(SingularEvent {
            t: t_star,
            kind: SingularKind::Bifurcation,
            dependency,
        })
    }

    /// Newton converged at `t_good` (the current state) but not at `t_bad`:
    /// bisects [t_good, t_bad] with full Newton, warm-started from the last
    /// time that converged, down to roundoff. If the solutions end at a time
    /// t* where Φ_q is nearly singular — equilibrated condition ≥ τ^−0.4, a limit point of
    /// the motion — the failure is a lock-up: returns [`Error::Singular`] at
    /// t* with the dependent equations. Otherwise returns `failure`
    /// unchanged. Error path only: allocates, leaves the state untouched.
    fn locate_limit(&mut self, t_good: f64, t_bad: f64, failure: Error) -> Error {
        let options = Options {
            predictor: false,
            modified_newton: false,
            ..self.options
        };
        let mut factorization = Factorization::None;
        let mut q_good = self.state.q.clone();
        let (mut lo, mut hi) = (t_good, t_bad);
        let mut q = q_good.clone();
        for _ in 0..MAX_BISECTIONS {
            let mid = lo + 0.5 * (hi - lo);
            if !(lo < mid && mid < hi) {
                break;
            }
            q.copy_from_slice(&q_good);
            self.factored = 0;
            let solved = solve_position(
                Eval {
                    system: &self.system,
                    scratch: &mut self.scratch,
                },
                Lu {
                    lu: &mut self.lu,
                    factorization: &mut factorization,
                },
                &mut q,
                mid,
                &options,
                &mut self.ws,
                Took {
                    stats: &mut StepStats::default(),
                    travel: &mut Travel::default(),
                },
            );
            match solved {
                Ok(_) => {
                    lo = mid;
                    q_good.copy_from_slice(&q);
                }
                Err(Error::NoConvergence { .. } | Error::Singular { .. }) => hi = mid,
                Err(other) => return other,
            }
        }
        self.factorization = Factorization::None;
        self.factored = 0;
        self.system
            .jacobian(&mut self.scratch, &q_good, lo, &mut self.ws.jac);
        if check_jacobian(&self.system, lo, &self.ws.jac).is_err() {
            return failure;
        }
        let tolerance = self.options.singular_tolerance;
        let dependency = crate::diagnose::dependency(&self.system, &self.ws.jac, tolerance);
        match dependency.condition {
            Some(condition) if condition >= crate::diagnose::near_singular_condition(tolerance) => {
                Error::Singular { t: lo, dependency }
            }
            _ => failure,
        }
    }
}
