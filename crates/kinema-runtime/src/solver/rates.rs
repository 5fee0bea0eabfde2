//! Φ_q factored at a solved q and the rates solved with it: q̇ and q̈
//! (or, with [`Options::positions_only`](crate::Options::positions_only),
//! their estimates from the last positions), the tags that say which
//! state the factorization belongs to, and the transposed solve that
//! inverse dynamics reuses it for.

use super::Solver;
use super::checked::{Factored, solve_checked, velocity_overflow};
use crate::error::{Error, Quantity};
use crate::linalg::{LinalgError, LinearSolver};
use crate::newton::{Factorization, factor};
use crate::state::State;
use crate::system::System;

/// With [`Options::positions_only`], the estimates of q̇ and q̈ are those
/// of a quadratic through three positions only when the two steps differ by
/// at most this factor (else a backward difference): a quadratic through
/// unevenly spaced points extrapolates their noise.
///
/// [`Options::positions_only`]: crate::Options::positions_only
const QUADRATIC_STEP_RATIO: f64 = 4.0;

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// [`Options::positions_only`]: instead of the rates, `self.next` gets
    /// estimates for the predictor and the branch test: q̇ and q̈ of the
    /// quadratic through the positions of the last three times (the
    /// current state's slope recovered from its own estimates, see
    /// [`State::h_back`]), which makes the prediction O(h³) as with the
    /// rates solved; or, when the current state's estimates did not come
    /// from that quadratic or the steps differ by more than
    /// [`QUADRATIC_STEP_RATIO`], q̇ = the backward difference and q̈ = 0.
    /// Zero when there is no current state or a value is not finite.
    ///
    /// [`Options::positions_only`]: crate::Options::positions_only
    #[inline]
    pub(super) fn difference_rates(&mut self, t: f64) {
        let base = &self.state;
        let h = t - base.t;
        let h0 = base.h_back;
        let assembled = self.assembled && h != 0.0 && h.is_finite();
        let quadratic = assembled
            && h0 > 0.0
            && h > 0.0
            && h0 <= QUADRATIC_STEP_RATIO * h
            && h <= QUADRATIC_STEP_RATIO * h0;
        let State {
            q, qd, qdd, h_back, ..
        } = &mut self.next;
        let n = q.len();
        let (q, qd, qdd) = (&q[..n], &mut qd[..n], &mut qdd[..n]);
        let (q0, qd0, qdd0) = (&base.q[..n], &base.qd[..n], &base.qdd[..n]);
        let mut sum = 0.0;
        if quadratic {
            // q̈ = 2 (s₁ − s₀) / (h₀ + h), q̇ = s₁ + h/2 q̈, with the slopes
            // s₁ = (q − q₀)/h and s₀ = q̇₀ − h₀/2 q̈₀.
            let (half_h0, c, half_h, inv_h) = (0.5 * h0, 2.0 / (h0 + h), 0.5 * h, 1.0 / h);
            for i in 0..n {
                let s1 = (q[i] - q0[i]) * inv_h;
                let s0 = qd0[i] - half_h0 * qdd0[i];
                qdd[i] = c * (s1 - s0);
                qd[i] = s1 + half_h * qdd[i];
                sum += qd[i] + qdd[i];
            }
        } else {
            qdd.fill(0.0);
            if assembled {
                let inv_h = 1.0 / h;
                for i in 0..n {
                    qd[i] = (q[i] - q0[i]) * inv_h;
                    sum += qd[i];
                }
            }
        }
        *h_back = h;
        if !(assembled && sum.is_finite()) {
            qd.fill(0.0);
            qdd.fill(0.0);
            *h_back = f64::NAN;
        }
    }

    /// Φ_q at `self.next.q` (then in `ws.jac`) factored, q̇ and q̈ solved
    /// (with [`Options::positions_only`], estimated instead).
    ///
    /// [`Options::positions_only`]: crate::Options::positions_only
    pub(super) fn rates(&mut self, t: f64) -> Result<(), Error> {
        self.factored = 0;
        if self.options.positions_only {
            self.difference_rates(t);
            return Ok(());
        }
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t, &mut self.ws.jac);
        self.factor_and_rates(t)
    }

    /// A tag no state has had (see `factored`).
    #[inline]
    fn new_tag(&mut self) -> u64 {
        self.tags += 1;
        self.tags
    }

    /// Factors Φ_q from `ws.jac` (at time `t`); the factorization is marked
    /// stale on success, none on failure.
    #[inline]
    pub(super) fn factor_jacobian(&mut self, t: f64) -> Result<(), Error> {
        self.factorization = Factorization::None;
        factor(
            &self.system,
            &mut self.lu,
            t,
            &self.ws.jac,
            &mut self.ws.scaling,
            self.options.singular_tolerance,
            &mut self.ws.diagnoses_left,
        )?;
        self.factorization = Factorization::Stale;
        Ok(())
    }

    /// Factors Φ_q from `ws.jac` and solves q̇ and q̈ of `self.next`.
    #[inline]
    pub(super) fn factor_and_rates(&mut self, t: f64) -> Result<(), Error> {
        self.factored = 0;
        self.factor_jacobian(t)?;
        let State { q, qd, qdd, .. } = &mut self.next;

        // A non-finite ν (γ) gives a non-finite q̇ (q̈): each right-hand side
        // entry reaches its own entry of the solution, and NaN and ∞ survive
        // every arithmetic operation of a solve. So only the solutions are
        // checked; on failure the right-hand side is evaluated again (the
        // solve overwrote it) to name the culprit.
        let (system, scratch) = (&self.system, &mut self.scratch);
        let (lu, scaling) = (&mut self.lu, &self.ws.scaling);
        let quantities = (Quantity::Nu, Quantity::Velocity);
        let factored = Factored {
            lu: &mut *lu,
            scaling,
        };
        solve_checked(system, scratch, factored, t, qd, quantities, |c, rhs| {
            system.nu(c, q, t, rhs);
        })?;
        let quantities = (Quantity::Gamma, Quantity::Acceleration);
        solve_checked(
            system,
            scratch,
            Factored { lu, scaling },
            t,
            qdd,
            quantities,
            |c, rhs| {
                system.gamma(c, q, qd, t, rhs);
            },
        )
        .map_err(|e| velocity_overflow(system, scratch, q, qd, t, e))?;
        // The LU and `ws.jac` now hold Φ_q at this q (inverse dynamics
        // reuses them when this state is the one kept).
        self.next.tag = self.new_tag();
        self.factored = self.next.tag;
        self.factored_scaled = self.ws.scaling.active;
        Ok(())
    }

    /// Overwrites `rhs` = b with λ = Φ_q⁻ᵀ b at the current state
    /// (Φ_qᵀ λ = b), and returns the system and Φ_q's values there
    /// (pattern order). The factorization of the step is reused; only when
    /// it is not that of the state kept (an interpolated near-singular row,
    /// a changed parameter) is Φ_q evaluated and factored again. Inverse
    /// dynamics solves λ with it, and the multipliers' parameter
    /// sensitivities λ_p (one solve per parameter). Does not allocate when
    /// the step's factorization is current.
    ///
    /// # Errors
    /// No state ([`LinalgError::NotFactored`]), `rhs` of the wrong length,
    /// or Φ_q singular at the state when it had to be factored again.
    pub fn solve_transposed_at_state(&mut self, rhs: &mut [f64]) -> Result<(&S, &[f64]), Error> {
        self.factor_at_state()?;
        self.ws.scaling.solve_transpose(&mut self.lu, rhs)?;
        Ok((&self.system, &self.ws.jac))
    }

    /// Overwrites `rhs` = b with x = Φ_q⁻¹ b at the current state
    /// (Φ_q x = b): the solve q̇ and q̈ had, for another right-hand side —
    /// what parameter sensitivities need (one solve per parameter and
    /// level). The factorization of the step is reused; only when it is
    /// not that of the state kept (an interpolated near-singular row, a
    /// changed parameter, `positions_only`) is Φ_q evaluated and factored
    /// again. Does not allocate when the step's factorization is current.
    ///
    /// # Errors
    /// No state ([`LinalgError::NotFactored`]), `rhs` of the wrong length,
    /// or Φ_q singular at the state when it had to be factored again.
    pub fn solve_at_state(&mut self, rhs: &mut [f64]) -> Result<(), Error> {
        self.factor_at_state()?;
        self.ws.scaling.solve(&mut self.lu, rhs)?;
        Ok(())
    }

    /// Makes the LU that of Φ_q at the current state: the step's when it
    /// is current, else evaluated and factored again.
    pub(super) fn factor_at_state(&mut self) -> Result<(), Error> {
        if !self.assembled {
            return Err(Error::Setup(LinalgError::NotFactored));
        }
        let current = self.factored != 0
            && self.factored == self.state.tag
            && self.factored_scaled == self.ws.scaling.active;
        if !current {
            self.renew_scratch();
            let t = self.state.t;
            self.system
                .jacobian(&mut self.scratch, &self.state.q, t, &mut self.ws.jac);
            self.factor_jacobian(t)?;
            self.state.tag = self.new_tag();
            self.factored = self.state.tag;
            self.factored_scaled = self.ws.scaling.active;
        }
        Ok(())
    }
}
