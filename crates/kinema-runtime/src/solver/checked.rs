//! The rate solves' error path: a non-finite ν, γ or solution traced back
//! to the equation or the coordinate behind it.

use crate::error::{Error, Quantity};
use crate::linalg::{LinearSolver, scale_and_finite};
use crate::newton::{Scaling, check_coordinates, check_equations};
use crate::system::System;

/// A velocity this large has a square within a factor 10⁶ of overflow: a
/// non-finite γ next to it comes from the velocities, not from its equation.
const OVERFLOWING_VELOCITY: f64 = 1.3e151;

/// Names the root cause of a non-finite γ when the velocities are so large
/// that γ's products of them overflow: the largest velocity and the equation
/// of ν behind it ([`Error::VelocityOverflow`]). Other errors pass through.
/// Runs on the error path only (it evaluates ν again).
#[cold]
pub(super) fn velocity_overflow<S: System>(
    system: &S,
    scratch: &mut S::Scratch,
    q: &[f64],
    qd: &[f64],
    t: f64,
    e: Error,
) -> Error {
    let Error::NonFinite {
        quantity: Quantity::Gamma,
        name,
        ..
    } = &e
    else {
        return e;
    };
    let largest = |v: &[f64]| {
        v.iter()
            .enumerate()
            .filter(|(_, x)| x.is_finite())
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map(|(i, &x)| (i, x))
    };
    let Some((k, velocity)) = largest(qd) else {
        return e;
    };
    if velocity.abs() < OVERFLOWING_VELOCITY {
        return e;
    }
    let mut nu = vec![0.0; qd.len()];
    system.nu(scratch, q, t, &mut nu);
    let Some((j, source_value)) = largest(&nu) else {
        return e;
    };
    Error::VelocityOverflow {
        t,
        equation: name.clone(),
        coordinate: system.coordinate_name(k).to_owned(),
        velocity,
        source_equation: system.equation_name(j).to_owned(),
        source_value,
    }
}

/// Φ_q's factorization, with the equilibration it was made with.
pub(super) struct Factored<'a, L> {
    pub(super) lu: &'a mut L,
    pub(super) scaling: &'a Scaling,
}

/// Fills `x` with a right-hand side (`fill`), solves Φ_q x = rhs in place,
/// and only if x is not finite evaluates the right-hand side again to name
/// the culprit: a non-finite equation (`quantities.0`) or else a solution
/// that overflowed (`quantities.1`).
#[inline]
pub(super) fn solve_checked<S: System, L: LinearSolver>(
    system: &S,
    scratch: &mut S::Scratch,
    factored: Factored<'_, L>,
    t: f64,
    x: &mut [f64],
    quantities: (Quantity, Quantity),
    mut fill: impl FnMut(&mut S::Scratch, &mut [f64]),
) -> Result<(), Error> {
    let Factored { lu, scaling } = factored;
    fill(scratch, x);
    scaling.solve(lu, x)?;
    if !scale_and_finite(x).1 {
        fill(scratch, x);
        check_equations(system, t, quantities.0, x)?;
        scaling.solve(lu, x)?;
        check_coordinates(system, t, quantities.1, x)?;
    }
    Ok(())
}
