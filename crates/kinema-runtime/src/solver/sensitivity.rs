//! [`Solver::sensitivities`]: the algorithm of
//! [`crate::sensitivity`] with the step's factorization.

use crate::error::Error;
use crate::linalg::{LinalgError, LinearSolver};
use crate::sensitivity::{Augmented, Sensitivities, SensitivitySystem, sensitivity_loop};
use crate::solver::Solver;
use crate::system::System;

fn dimension(what: &'static str, expected: usize, found: usize) -> Error {
    Error::Setup(LinalgError::Dimension {
        what,
        expected,
        found,
    })
}

/// `out` was made for a system of `z`'s dimensions.
fn check_buffers<Z: SensitivitySystem + ?Sized>(
    z: &Z,
    out: &Sensitivities<Z>,
) -> Result<(), Error> {
    if (z.param_count(), z.coordinate_count(), z.result_count()) == (out.k, out.nc, out.m) {
        return Ok(());
    }
    Err(dimension(
        "sensitivity buffers of the system",
        z.param_count() * 3 * (z.coordinate_count() + z.result_count()),
        out.values.len(),
    ))
}

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// Computes every param's sensitivities at the current state (after a
    /// successful [`step`](Self::step)) into `out`, the solver's system
    /// evaluating the right-hand sides (generated code): see
    /// [`sensitivity`](crate::sensitivity). Three solves per param with the
    /// step's factorization of Φ_q; no allocation.
    ///
    /// # Errors
    /// As [`sensitivities_of`](Self::sensitivities_of).
    pub fn sensitivities(&mut self, out: &mut Sensitivities<S>) -> Result<(), Error>
    where
        S: SensitivitySystem,
    {
        check_buffers(&self.system, out)?;
        self.factor_for_sensitivities(out.nc)?;
        let Solver {
            system,
            state,
            lu,
            ws,
            scratch,
            ..
        } = self;
        let system = &*system;
        let prepare = |own: &mut S::SensitivityScratch, at: Augmented<'_>| {
            system.prepare_after_step(own, at, scratch);
        };
        sensitivity_loop(system, state, out, prepare, false, |rhs| {
            ws.scaling.solve(lu, rhs).map_err(Error::Setup)
        })
    }

    /// [`sensitivities`](Self::sensitivities) with the right-hand sides
    /// evaluated by `z`, a system beside the solver's (the tape back
    /// end's compiled sensitivity tapes), of the same model and parameter
    /// values.
    ///
    /// # Errors
    /// No state ([`LinalgError::NotFactored`]); Φ_q singular when the
    /// state's factorization had to be made again (an interpolated
    /// near-singular row); `z` or `out` of other dimensions than the
    /// system ([`LinalgError::Dimension`]). A value that is not finite is
    /// written as it is (check them where they are written, as the solver
    /// checks its rates).
    pub fn sensitivities_of<Z: SensitivitySystem + ?Sized>(
        &mut self,
        z: &Z,
        out: &mut Sensitivities<Z>,
    ) -> Result<(), Error> {
        self.sensitivities_at_levels(z, out, false)
    }

    /// [`sensitivities_of`](Self::sensitivities_of) at the position level
    /// only: ∂q/∂p and the result columns' ∂y/∂p — one solve per param
    /// instead of three, for a caller that reads no rate's sensitivity (a
    /// least-squares fit of positions). The velocity and acceleration
    /// levels of `out` are set to NaN.
    ///
    /// # Errors
    /// As [`sensitivities_of`](Self::sensitivities_of).
    pub fn position_sensitivities_of<Z: SensitivitySystem + ?Sized>(
        &mut self,
        z: &Z,
        out: &mut Sensitivities<Z>,
    ) -> Result<(), Error> {
        self.sensitivities_at_levels(z, out, true)
    }

    fn sensitivities_at_levels<Z: SensitivitySystem + ?Sized>(
        &mut self,
        z: &Z,
        out: &mut Sensitivities<Z>,
        positions_only: bool,
    ) -> Result<(), Error> {
        check_buffers(z, out)?;
        self.factor_for_sensitivities(out.nc)?;
        let Solver { state, lu, ws, .. } = self;
        let prepare = |own: &mut Z::SensitivityScratch, at: Augmented<'_>| z.prepare(own, at);
        sensitivity_loop(z, state, out, prepare, positions_only, |rhs| {
            ws.scaling.solve(lu, rhs).map_err(Error::Setup)
        })
    }

    /// Checks the state against `nc` and makes the LU Φ_q's at it.
    fn factor_for_sensitivities(&mut self, nc: usize) -> Result<(), Error> {
        if !self.assembled {
            return Err(Error::Setup(LinalgError::NotFactored));
        }
        let n = self.system.len();
        if n != nc {
            return Err(dimension("coordinates of the system", nc, n));
        }
        if self.state.q.len() != n || self.state.qd.len() != n || self.state.qdd.len() != n {
            return Err(dimension("coordinates of the state", n, self.state.q.len()));
        }
        self.factor_at_state()
    }
}
