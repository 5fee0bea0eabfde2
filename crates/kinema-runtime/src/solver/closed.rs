//! [`Options::closed_form`](crate::Options::closed_form): a step whose
//! positions are placed in closed form ([`Linkage`](crate::Linkage))
//! instead of solved by Newton, where that is safe.

use crate::linalg::LinearSolver;
use crate::newton::inf_norm;
use crate::state::StepStats;
use crate::system::System;

use super::Solver;

/// The smallest dyad margin (sine of the angle between a dyad's links)
/// placed in closed form: below it (about 0.57°) Newton and the monitor
/// solve the step, so that every singular configuration is met by the one
/// machinery that locates and classifies it. The dyad's condition there is
/// about 100 times its best, far from the monitor's threshold (τ^−0.4 =
/// 10⁴ at the default τ).
const MARGIN: f64 = 1e-2;

/// The smallest pivot ratio at which a placement is kept: twice the
/// monitor's gate ([`PIVOT_GATE`](super::PIVOT_GATE)), below which alone
/// it checks the singular values and may flag the state.
const HAND_OVER: f64 = 2.0 * super::PIVOT_GATE;

/// Placements between two readings of the monitor's pivots at most.
const WATCH_EVERY: u32 = 256;

/// The closed-form placement's scratch and the dyads' branches.
#[derive(Debug, Default)]
pub(super) struct ClosedForm {
    angles: Vec<f64>,
    rot: Vec<[f64; 2]>,
    branches: Vec<f64>,
    /// `branches` are those of the current state (read from it, or kept
    /// through the closed-form steps since): false after any other step.
    pub(super) current: bool,
    /// A placement whose margin falls below this is watched (see
    /// [`Solver::watch`]).
    watch_margin: f64,
    /// Placements since the pivots were last read.
    unwatched: u32,
}

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// Places `self.next` at `t` in closed form, if the options ask for it,
    /// the system has a linkage, the current state is regular, and the
    /// placement is well clear of a singular configuration, satisfies
    /// Φ = 0 to the residual tolerance and passes the branch test
    /// ([`acceptable`](Self::acceptable)); `false` (and `self.next`
    /// overwritten) otherwise, for Newton to solve the step.
    #[inline]
    pub(super) fn place_closed_form(&mut self, t: f64) -> bool {
        if !(self.options.positions_only && self.options.closed_form) {
            return false;
        }
        let Some(linkage) = self.system.linkage() else {
            return false;
        };
        let base_regular = !self.state.stats.near_singular && self.zone.is_none();
        if !base_regular || 3 * linkage.bodies() != self.next.q.len() {
            return false;
        }
        let c = &mut self.closed;
        if c.branches.len() != linkage.dyads() || c.rot.len() != linkage.bodies() {
            size(c, linkage.bodies(), linkage.angles(), linkage.dyads());
        }
        if !c.current {
            linkage.read_branches(&self.state.q, &mut c.rot, &mut c.branches);
            c.current = true;
            c.watch_margin = f64::INFINITY;
        }
        self.system
            .linkage_angles(&mut self.scratch, t, &mut c.angles);
        let margin = linkage.place(
            &c.angles,
            &self.state.q,
            &c.branches,
            &mut c.rot,
            &mut self.next.q,
        );
        // NaN is never placed.
        let clear = margin >= MARGIN;
        if !clear {
            return false;
        }
        // The motion predicted from the current state must not cross a
        // dyad's singular configuration either: there the analytic
        // continuation changes branch, which Newton follows (from the same
        // prediction) and the monitor records; the placement would not.
        super::predict_into(&self.state, t, &mut self.pred);
        if !linkage.same_side(&self.next.q, &self.pred) {
            return false;
        }
        self.system
            .phi(&mut self.scratch, &self.next.q, t, &mut self.ws.phi);
        let residual = inf_norm(&self.ws.phi);
        let satisfied =
            self.ws
                .rows
                .satisfied(&self.ws.phi, residual, self.options.residual_tolerance);
        if !satisfied {
            return false;
        }
        self.factored = 0;
        self.next.t = t;
        self.next.stats = StepStats {
            residual,
            pivot_ratio: self.state.stats.pivot_ratio,
            closed_form: true,
            ..StepStats::default()
        };
        self.next.det_sign = self.branch_sign;
        self.difference_rates(t);
        if !self.acceptable() {
            return false;
        }
        // Last, so that only a placement that passed everything else
        // leaves its factorization in the LU: the monitor of a Newton step
        // after a rejected one reads the pivots Newton alone would have
        // made, or this reading's smaller ratio (on the cautious side).
        let c = &mut self.closed;
        let watched = margin < c.watch_margin || c.unwatched >= WATCH_EVERY;
        if !watched {
            c.unwatched += 1;
            return true;
        }
        let Some(ratio) = self.watch(t) else {
            return false;
        };
        self.next.stats.pivot_ratio = ratio;
        // The pivot ratio falls about as the margin does: the next reading
        // where it would reach the hand-over ratio, or at half the margin
        // (the ratio may fall faster; the flags are some hundred times
        // lower still).
        self.closed.watch_margin = margin * (HAND_OVER / ratio).min(0.5);
        self.closed.unwatched = 0;
        true
    }

    /// Reads the monitor's pivots of Φ_q at the placed q (factored as
    /// Newton's last iterate is): their ratio if the placement is well
    /// clear of what the monitor flags (the ratio at least [`HAND_OVER`],
    /// twice the ratio below which the monitor looks closer at all, and
    /// det Φ_q on the branch's side of 0), else `None`. A dyad's margin
    /// bounds its own condition, not the whole system's (a tiny link beside
    /// long ones, a frame far from its pins): this is what keeps every
    /// configuration the monitor would flag, and its events, Newton's. Read
    /// at the first placement after Newton; after that wherever the
    /// smallest margin has fallen to where the ratio, falling with it,
    /// would reach the hand-over ratio (and at least to half the margin of
    /// the last reading), and every [`WATCH_EVERY`] placements.
    #[cold]
    #[inline(never)]
    fn watch(&mut self, t: f64) -> Option<f64> {
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t, &mut self.ws.jac);
        self.factor_jacobian(t).ok()?;
        let report = self.lu.pivot_report()?;
        let same_side = self.branch_sign == 0.0 || report.det_sign == self.branch_sign;
        (same_side && report.ratio >= HAND_OVER).then_some(report.ratio)
    }
}

/// Sizes the scratch for a linkage (once per solver and linkage).
#[cold]
#[inline(never)]
fn size(c: &mut ClosedForm, bodies: usize, angles: usize, dyads: usize) {
    c.angles = vec![0.0; angles];
    c.rot = vec![[0.0; 2]; bodies];
    c.branches = vec![0.0; dyads];
    c.current = false;
}
