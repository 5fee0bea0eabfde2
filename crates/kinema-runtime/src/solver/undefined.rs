//! Functions of time that leave their domain ([`System::undefined`]): the
//! check before every step and assembly, and the bisection that locates
//! the first such time, also used by the forward (dynamics) runs through
//! [`locate_undefined`] and [`undefined_between`]. Off the per-step hot
//! path but for one question per step.

use super::Solver;
use crate::error::Error;
use crate::linalg::LinearSolver;
use crate::system::System;

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// Before a step from `t0` to `t` (at assembly `t0 == t`): whether an
    /// equation's function of time leaves its domain in (t0, t] (see
    /// [`System::undefined`]): the step's bracket asked first, and the
    /// first point located by bisection to roundoff of t; then t itself.
    /// The system's answer over a bracket is a first-order one with a
    /// margin: a bracket that no half confirms is no finding.
    #[inline]
    pub(super) fn check_defined(&mut self, t0: f64, t: f64) -> Result<(), Error> {
        // `next.q` holds the guess at assembly, the last iterate (of the
        // right length) otherwise: functions of time alone do not read it.
        let mut found = None;
        if t0 < t {
            let half = 0.5 * (t - t0);
            let q = &self.next.q;
            if self
                .system
                .undefined(&mut self.scratch, q, t0 + half, half)
                .is_some()
            {
                found = self.locate_undefined(t0, t);
            }
            // The edge of a domain (√0, acos(±1)) is a finding only where
            // the domain is left: at the step's end (where the derivative
            // is unbounded, and the next step would be outside) or before
            // it; one the function only touches between two times of the
            // grid (`acos(cos t)` at π) is not, the motion goes on.
            if let Some((at, u)) = found
                && u.domain == crate::state::Domain::Edge
            {
                let at_end = t - at <= 1e-12 * (t - t0);
                let q = &self.next.q;
                if at_end {
                    found = Some((t, u));
                } else if self
                    .system
                    .undefined(&mut self.scratch, q, t, 0.0)
                    .is_none()
                {
                    found = None;
                }
            }
            // A point within roundoff of the step's end that is undefined
            // itself (a pole at a time of the grid) is that time.
            if let Some((at, _)) = found
                && t - at <= 1e-12 * (t - t0)
                && let Some(u) = self
                    .system
                    .undefined(&mut self.scratch, &self.next.q, t, 0.0)
            {
                found = Some((t, u));
            }
        }
        if found.is_none() {
            let q = &self.next.q;
            found = self
                .system
                .undefined(&mut self.scratch, q, t, 0.0)
                .map(|u| (t, u));
        }
        match found {
            None => Ok(()),
            Some((t, u)) => Err(Error::Undefined {
                t,
                equation: self.system.equation_name(u.equation).to_owned(),
                function: u.function,
                domain: u.domain,
                argument: u.argument,
            }),
        }
    }

    /// A bracket [t0, t] in which an equation is reported undefined: the
    /// first point in time that the system confirms at every scale, down
    /// to roundoff of t, searched depth first, earlier halves first (a
    /// report over a bracket is a first-order bound with a margin, so both
    /// halves of one may be reported, and a reported half may hold no
    /// point); the point and what is undefined there, or `None` if none
    /// is confirmed.
    #[cold]
    #[inline(never)]
    fn locate_undefined(&mut self, t0: f64, t: f64) -> Option<(f64, crate::Undefined)> {
        locate_undefined(&self.system, &mut self.scratch, &self.next.q, (t0, t))
    }
}

/// The first point of [t0, t] where one of `system`'s equations is
/// undefined or unbounded ([`System::undefined`]), located by bisection to
/// roundoff of t: both halves of a flagged bracket are searched, the
/// earlier first, because the system's answer over a bracket is a
/// first-order one with a margin (a bracket no half confirms is no
/// finding). `q` is any state of the right length (the functions asked
/// about are of time alone). Allocates a small stack; for the failure and
/// pre-step paths, not the step.
pub fn locate_undefined<S: System>(
    system: &S,
    scratch: &mut S::Scratch,
    q: &[f64],
    (t0, t): (f64, f64),
) -> Option<(f64, crate::Undefined)> {
    // At most this many questions: a false report dies out within a few
    // halvings, a true one is confirmed by a few dozen per level.
    let mut budget = 20_000usize;
    let mut stack = vec![(t0, t)];
    while let Some((lo, hi)) = stack.pop() {
        let mid = lo + 0.5 * (hi - lo);
        if !(mid > lo && mid < hi) {
            // Down to roundoff: the point itself if an end is one, else
            // the bracket's middle, within roundoff of it.
            for at in [lo, hi, mid] {
                let error = if at == mid { 0.5 * (hi - lo) } else { 0.0 };
                if let Some(u) = system.undefined(scratch, q, at, error) {
                    return Some((at, u));
                }
            }
            continue;
        }
        // Later half pushed first: the earlier one is searched first.
        for (a, b) in [(mid, hi), (lo, mid)] {
            if budget == 0 {
                return None;
            }
            budget -= 1;
            let half = 0.5 * (b - a);
            if system.undefined(scratch, q, a + half, half).is_some() {
                stack.push((a, b));
            }
        }
    }
    None
}

/// The first equation undefined or unbounded in time ([`System::undefined`])
/// between a state reached at `t0` and the time `t1` not reached, as the
/// error a run reports: at `failed_at` first when it is finite (where an
/// integrator failed: a pole met exactly), else over the bracket,
/// narrowed by [`locate_undefined`]. `None` when every equation is
/// defined there. For the failure and pre-step paths of a forward run.
pub fn undefined_between<S: System>(
    system: &S,
    scratch: &mut S::Scratch,
    q: &[f64],
    (t0, t1, failed_at): (f64, f64, f64),
) -> Option<Error> {
    let at = |t: f64, u: crate::Undefined| Error::Undefined {
        t,
        equation: system.equation_name(u.equation).to_owned(),
        function: u.function,
        domain: u.domain,
        argument: u.argument,
    };
    if failed_at.is_finite()
        && let Some(u) = system.undefined(scratch, q, failed_at, 0.0)
    {
        return Some(at(failed_at, u));
    }
    let (lo, hi) = (t0.min(t1), t0.max(t1));
    let half = 0.5 * (hi - lo);
    system.undefined(scratch, q, lo + half, half)?;
    let (t, u) = locate_undefined(system, scratch, q, (lo, hi))?;
    Some(at(t, u))
}
