//! One step of the analysis: attempted by Newton from the Taylor
//! prediction (or the closed-form placement), polished near a singular
//! configuration, and either committed or handed to the refinement
//! ([`passage`](super::passage)). The monitor and the branch test that
//! decide it are in [`monitor`](super::monitor), the rates solved at the
//! converged q in [`rates`](super::rates).

use super::{PIVOT_GATE, Solver, predict_into};
use crate::error::Error;
use crate::event::SingularKind;
use crate::linalg::LinearSolver;
use crate::newton::{
    DIAGNOSES_PER_STEP, Eval, Factorization, Lu, Took, Travel, inf_norm, solve_position,
};
use crate::options::Options;
use crate::state::StepStats;
use crate::system::System;

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// From the current state at `t0` to `t`: one step if it is accepted,
    /// else internal sub-steps (see "Singular configurations").
    pub(super) fn advance(&mut self, t0: f64, t: f64) -> Result<(), Error> {
        self.ws.diagnoses_left = DIAGNOSES_PER_STEP;
        // The step as the options ask; the refinement below always starts
        // Newton from the Taylor prediction (following the branch). After a
        // change of the system (a parameter set between steps) the motion
        // may jump: the converged step is taken as it is, unless it is near
        // singular.
        let changed = std::mem::take(&mut self.changed);
        if !changed && self.place_closed_form(t) {
            return self.commit(t);
        }
        self.closed.current = false;
        if self.attempt_from(t, self.options.predictor).is_ok()
            && !self.next.stats.near_singular
            && !self.estimated_flip()
            && (changed || self.quiet() || self.acceptable())
        {
            return self.commit(t);
        }
        // Sub-steps commit as they go; a stop at a singular configuration
        // gives the state at t0 back.
        self.held.clone_from(&self.state);
        let (events, zone, sign) = (self.events.len(), self.zone.clone(), self.branch_sign);
        let result = if self.options.positions_only {
            self.substeps_with_rates(t0, t)
        } else {
            self.substeps(t0, t)
        };
        if let Err(e) = &result {
            // What the failed step found is rolled back with it, but for the
            // lock-up that ended it.
            let lock_up = self
                .events
                .last()
                .filter(|e| e.kind == SingularKind::LockUp)
                .cloned();
            self.events.truncate(events);
            self.events
                .extend(lock_up.filter(|_| matches!(e, Error::Singular { .. })));
            (self.zone, self.branch_sign) = (zone, sign);
            std::mem::swap(&mut self.state, &mut self.held);
            self.factorization = Factorization::None;
        }
        result
    }

    /// With [`Options::positions_only`], whether `self.next` is on the
    /// other side of det Φ_q = 0 from the current state: a bifurcation
    /// passed, or a jump to another branch that the estimated rates'
    /// prediction followed (they lag the motion where it speeds up: a
    /// four-bar's coupler whipping round on 30° steps). The step is then
    /// refined with solved rates, as the full analysis refines it, instead
    /// of taken with the flip located as a bifurcation.
    #[inline]
    fn estimated_flip(&self) -> bool {
        self.options.positions_only && self.branch_sign * self.next.det_sign < 0.0
    }

    /// [`Options::positions_only`]'s refinement: the sub-steps predict
    /// from solved rates, starting with the current state's. Its difference
    /// estimates are the quadratic's through the last three positions,
    /// which across a kink of the motion (a coordinate through the kink of
    /// an `abs`) point the wrong way however short the sub-step, so the
    /// branch test would never pass (finding F17). The rates are the
    /// estimates again from the next step on.
    #[cold]
    #[inline(never)]
    fn substeps_with_rates(&mut self, t0: f64, t: f64) -> Result<(), Error> {
        self.options.positions_only = false;
        let result = self
            .solve_state_rates(t0)
            .and_then(|()| self.substeps(t0, t));
        self.options.positions_only = true;
        result
    }

    /// q̇ and q̈ of the current state solved at its q (at `t0`), unless it
    /// is near singular (its rates are then the branch's limits already).
    fn solve_state_rates(&mut self, t0: f64) -> Result<(), Error> {
        if self.state.stats.near_singular {
            return Ok(());
        }
        std::mem::swap(&mut self.state, &mut self.next);
        self.renew_scratch();
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t0, &mut self.ws.jac);
        let solved = self.factor_and_rates(t0);
        std::mem::swap(&mut self.state, &mut self.next);
        solved?;
        // Solved, not the quadratic's: the next estimate starts afresh.
        self.state.h_back = f64::NAN;
        Ok(())
    }

    /// Solves at `t` from the current state into `self.next` (Newton from
    /// the Taylor prediction), then runs the monitor.
    pub(super) fn attempt(&mut self, t: f64) -> Result<(), Error> {
        self.attempt_from(t, true)
    }

    /// [`attempt`](Self::attempt), Newton starting from the prediction or,
    /// with `predict` false, from the current q.
    #[inline]
    fn attempt_from(&mut self, t: f64, predict: bool) -> Result<(), Error> {
        if predict {
            predict_into(&self.state, t, &mut self.next.q);
        } else {
            self.next.q.copy_from_slice(&self.state.q);
        }
        let solved = self.solve_inner(t);
        if solved.is_err() {
            self.factorization = Factorization::None;
        }
        solved?;
        self.monitor();
        if self.next.stats.pivot_ratio < PIVOT_GATE && !self.next.stats.near_singular {
            self.polish(t)?;
        }
        Ok(())
    }

    /// Near a singular configuration the rates' error grows like the
    /// condition times the position's, which Newton's tolerance leaves at
    /// condition × 10⁻¹²: solves again from the converged q down to
    /// roundoff (an update below 10⁻¹⁵ (1 + ‖q‖∞)). Only where the monitor's
    /// gate fires.
    #[cold]
    fn polish(&mut self, t: f64) -> Result<(), Error> {
        // Best effort: a polish that does not reduce ‖Φ‖ or fails keeps
        // the solution as it was, so this never fails.
        self.spare.clone_from(&self.next);
        let options = Options {
            residual_tolerance: 0.0,
            update_tolerance: 0.0,
            max_iterations: 2,
            predictor: false,
            modified_newton: false,
            ..self.options
        };
        self.factored = 0;
        let _ = solve_position(
            Eval {
                system: &self.system,
                scratch: &mut self.scratch,
            },
            Lu {
                lu: &mut self.lu,
                factorization: &mut self.factorization,
            },
            &mut self.next.q,
            t,
            &options,
            &mut self.ws,
            Took {
                stats: &mut StepStats::default(),
                travel: &mut Travel::default(),
            },
        );
        self.system
            .phi(&mut self.scratch, &self.next.q, t, &mut self.ws.phi);
        let residual = inf_norm(&self.ws.phi);
        let better = residual <= self.spare.stats.residual;
        if !(better && self.rates(t).is_ok()) {
            std::mem::swap(&mut self.next, &mut self.spare);
            self.factorization = Factorization::None;
            return Ok(());
        }
        self.next.stats.residual = residual;
        Ok(())
    }

    #[inline]
    pub(super) fn solve_inner(&mut self, t: f64) -> Result<(), Error> {
        self.factored = 0;
        let q = &mut self.next.q;
        let jacobian_current = solve_position(
            Eval {
                system: &self.system,
                scratch: &mut self.scratch,
            },
            Lu {
                lu: &mut self.lu,
                factorization: &mut self.factorization,
            },
            q,
            t,
            &self.options,
            &mut self.ws,
            Took {
                stats: &mut self.next.stats,
                travel: &mut self.travel,
            },
        )?;
        self.next.t = t;
        if self.options.positions_only {
            self.difference_rates(t);
            return Ok(());
        }
        if !jacobian_current {
            self.system
                .jacobian(&mut self.scratch, &self.next.q, t, &mut self.ws.jac);
        }
        self.factor_and_rates(t)
    }
}
