//! Precision lost to rounding ([`Precision`]): the equation of Φ whose
//! value, at a solution, its own arithmetic determines least, if that
//! moves the coordinates by more than [`Imprecision::THRESHOLD`] of their
//! scale. It reads a [`System`] through
//! [`phi_error_bounds`](System::phi_error_bounds) (each equation's error
//! bound, see [`roundoff`](crate::roundoff)) and
//! [`jacobian`](System::jacobian) (each equation's lever on q), so generated
//! code and the tape back end run the same check.

use crate::state::State;
use crate::system::System;

/// An equation of Φ whose value at a state is not determined to
/// [`Imprecision::THRESHOLD`] of the coordinates' scale by its own
/// arithmetic: the solution q, and q̇ and q̈ with it, are then the rounding
/// errors' as much as the model's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Imprecision {
    /// The equation (its index in Φ).
    pub equation: usize,
    /// The bound on the equation's error: its operations' roundoff and the
    /// coordinates' uncertainty, propagated to first order.
    pub error: f64,
    /// That error as a move of the coordinates, error / maxⱼ |∂Φᵢ/∂qⱼ|.
    pub shift: f64,
    /// The coordinates' scale it is measured against: the model's size plus
    /// ‖q‖∞.
    pub scale: f64,
}

impl Imprecision {
    /// How much of the coordinates' scale an equation's error may move
    /// them before the state counts as imprecise: fewer than six
    /// significant digits left. A model evaluated as written stays below
    /// 10⁻¹⁰ of it (every model of the repository, the kink cases among
    /// them, `tests/precision.rs`).
    pub const THRESHOLD: f64 = 1e-6;
}

/// Which equations a precision check looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrecisionScope {
    /// Every equation of Φ (costs an evaluation of Φ and Φ_q).
    All,
    /// The equations that read t alone
    /// ([`System::equation_reads_time`]): the equations whose precision
    /// can change along a run at a given scale of the coordinates (the
    /// others read q, whose scale the test follows, the parameters and
    /// constants).
    Timed,
}

/// Each row's lever on q, maxⱼ |∂Φᵢ/∂qⱼ|, into `lever` (zeroed first) from
/// the Jacobian's values `jac` and the row `row(k)` of each.
pub fn levers(jac: &[f64], row: &dyn Fn(usize) -> usize, lever: &mut [f64]) {
    lever.fill(0.0);
    for (k, &v) in jac.iter().enumerate() {
        if let Some(l) = lever.get_mut(row(k)) {
            *l = l.max(v.abs());
        }
    }
}

/// The worst of the equations whose error bounds are `errors` and levers
/// `lever` (the k-th is equation `equation(k)`), if it moves the
/// coordinates `q` by more than [`Imprecision::THRESHOLD`] of `size` +
/// ‖q‖∞. A row without a finite lever is singular, and an error that is
/// not a number a function at its kink: neither is this check's to report.
pub fn worst(
    errors: &[f64],
    lever: &[f64],
    equation: &dyn Fn(usize) -> usize,
    q: &[f64],
    size: f64,
) -> Option<Imprecision> {
    let q_max = q.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let scale = size.abs() + q_max;
    let mut worst: Option<Imprecision> = None;
    for (k, (&error, &l)) in errors.iter().zip(lever).enumerate() {
        let shift = error / l;
        if !(shift.is_finite() && shift > Imprecision::THRESHOLD * scale) {
            continue;
        }
        if worst.is_none_or(|w| shift > w.shift) {
            worst = Some(Imprecision {
                equation: equation(k),
                error,
                shift,
                scale,
            });
        }
    }
    worst
}

/// The precision check of a [`System`] and its buffers (allocated at
/// construction: a check does not allocate).
#[derive(Clone, Debug)]
pub struct Precision {
    errors: Vec<f64>,
    jac: Vec<f64>,
    lever: Vec<f64>,
}

impl Precision {
    /// Buffers for `system`.
    #[must_use]
    pub fn new<S: System + ?Sized>(system: &S) -> Precision {
        let n = system.len();
        Precision {
            errors: vec![0.0; n],
            jac: vec![0.0; system.jacobian_pattern().len()],
            lever: vec![0.0; n],
        }
    }

    /// The equation of Φ that, at `state`, its own arithmetic determines
    /// least, if it moves the coordinates by more than
    /// [`Imprecision::THRESHOLD`] of their scale (`size`, the model's, plus
    /// ‖q‖∞): an argument beyond f64's precision (`sin(1e30 * t)`), a
    /// difference of two large numbers that cancel. The coordinates are
    /// uncertain by the state's residual. `None` if every equation in
    /// `scope` is determined, or the system cannot bound its errors
    /// ([`System::phi_error_bounds`]). Not part of a step: call it on the
    /// states you keep.
    pub fn check<S: System + ?Sized>(
        &mut self,
        system: &S,
        scratch: &mut S::Scratch,
        state: &State,
        size: f64,
        scope: PrecisionScope,
    ) -> Option<Imprecision> {
        let (q, t, residual) = (state.q(), state.t(), state.stats().residual);
        self.check_at(system, scratch, (q, t, residual), size, scope)
    }

    /// [`check`](Self::check) at coordinates `q` and time `t`, each
    /// coordinate uncertain by `uncertainty` besides its roundoff at
    /// `size`.
    pub fn check_at<S: System + ?Sized>(
        &mut self,
        system: &S,
        scratch: &mut S::Scratch,
        (q, t, uncertainty): (&[f64], f64, f64),
        size: f64,
        scope: PrecisionScope,
    ) -> Option<Imprecision> {
        if q.len() != system.len() || self.errors.len() != system.len() {
            return None;
        }
        system.jacobian(scratch, q, t, &mut self.jac);
        if !system.phi_error_bounds(scratch, q, t, uncertainty, size, &mut self.errors) {
            return None;
        }
        let pattern = system.jacobian_pattern();
        levers(&self.jac, &|k| pattern[k].0 as usize, &mut self.lever);
        if scope == PrecisionScope::Timed {
            // The others are not this scope's: no lever, no report.
            for (i, l) in self.lever.iter_mut().enumerate() {
                if !system.equation_reads_time(i) {
                    *l = f64::NAN;
                }
            }
        }
        worst(&self.errors, &self.lever, &|i| i, q, size)
    }
}
