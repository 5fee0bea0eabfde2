//! Kinematic analysis over time: [`Solver`].

use crate::error::{Error, Quantity};
use crate::linalg::{Auto, LinalgError, LinearSolver, scale_and_finite};
use crate::newton::{
    Factorization, Workspace, check_coordinates, check_equations, check_jacobian, factor,
    solve_position,
};
use crate::options::Options;
use crate::state::State;
use crate::system::System;
use crate::trajectory::Trajectory;

/// Bisections of a failed step when looking for a limit point (2⁻⁶⁰ of the
/// step: below roundoff of t).
const MAX_BISECTIONS: usize = 60;

/// Position, velocity and acceleration analysis of a [`System`], step by
/// step.
///
/// At each time t the solver
///
/// 1. solves Φ(q, t) = 0 for q by Newton–Raphson (see [`Options`]);
/// 2. factors Φ_q(q, t) once at the converged q;
/// 3. solves Φ_q q̇ = ν(q, t) and Φ_q q̈ = γ(q, q̇, t) with that factorization.
///
/// The solver owns the system, the linear solver `L` and every buffer; after
/// construction [`step`](Self::step) does not allocate on the dense paths
/// ([`DenseLu`](crate::linalg::DenseLu), [`DynDenseLu`](crate::linalg::DynDenseLu)).
/// That makes it fit for an application loop:
///
/// ```
/// # #[cfg(feature = "handwritten")] {
/// use kinema_runtime::{Solver, Options, linalg::DenseLu, handwritten::SliderCrank};
///
/// let mut solver = Solver::<SliderCrank, DenseLu<9>>::with_options(SliderCrank::default(), Options::default())?;
/// for frame in 0..60 {
///     let state = solver.step(frame as f64 / 60.0)?;
///     let slider_x = state.q()[6];
///     let slider_speed = state.qd()[6];
///     # let _ = (slider_x, slider_speed);
/// }
/// # }
/// # Ok::<(), kinema_runtime::Error>(())
/// ```
///
/// The first [`step`](Self::step) (or [`assemble`](Self::assemble)) starts
/// Newton from the system's initial guess; later steps start from the
/// previous state, so times must increase.
#[derive(Debug)]
pub struct Solver<S: System, L: LinearSolver = Auto> {
    system: S,
    lu: L,
    options: Options,
    ws: Workspace,
    /// The state being computed; swapped with `state` on success, so a
    /// failed step leaves the last good state intact.
    next: State,
    state: State,
    assembled: bool,
    factorization: Factorization,
}

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// A solver with [`Options::default`], the linear solver analysed from
    /// the system's Jacobian pattern.
    pub fn new(system: S) -> Result<Self, Error> {
        Self::with_options(system, Options::default())
    }

    /// A solver with the given options, the linear solver analysed from the
    /// system's Jacobian pattern.
    pub fn with_options(system: S, options: Options) -> Result<Self, Error> {
        let lu = L::analyze(system.len(), system.jacobian_pattern())?;
        Self::with_linear_solver(system, options, lu)
    }

    /// A solver with the given options and an already analysed linear solver
    /// (e.g. [`Auto::with_threshold`]). It must have been analysed from this
    /// system's dimension and Jacobian pattern; the dimension is checked
    /// here, the number of nonzeros at each factorization.
    pub fn with_linear_solver(system: S, options: Options, lu: L) -> Result<Self, Error> {
        let n = system.len();
        if lu.dim() != n {
            return Err(LinalgError::Dimension {
                what: "linear solver dimension",
                expected: n,
                found: lu.dim(),
            }
            .into());
        }
        let nnz = system.jacobian_pattern().len();
        Ok(Self {
            system,
            lu,
            options,
            ws: Workspace::new(n, nnz),
            next: State::zeros(n),
            state: State::zeros(n),
            assembled: false,
            factorization: Factorization::None,
        })
    }

    /// Number of coordinates n.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.state.q.len()
    }

    /// The system.
    #[must_use]
    pub fn system(&self) -> &S {
        &self.system
    }

    /// The system, mutably: change its parameters between steps.
    #[must_use]
    pub fn system_mut(&mut self) -> &mut S {
        &mut self.system
    }

    /// Gives the system back.
    #[must_use]
    pub fn into_system(self) -> S {
        self.system
    }

    /// The linear solver.
    #[must_use]
    pub fn linear_solver(&self) -> &L {
        &self.lu
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &Options {
        &self.options
    }

    /// Replaces the options; takes effect at the next step.
    pub fn set_options(&mut self, options: Options) {
        self.options = options;
    }

    /// The last state computed, if any.
    #[must_use]
    pub fn state(&self) -> Option<&State> {
        self.assembled.then_some(&self.state)
    }

    /// Forgets the current state: the next [`step`](Self::step) assembles
    /// from the initial guess again.
    pub fn reset(&mut self) {
        self.assembled = false;
        self.factorization = Factorization::None;
    }

    /// Assembly: position, velocity and acceleration at `t0`, Newton starting
    /// from the system's initial guess.
    pub fn assemble(&mut self, t0: f64) -> Result<&State, Error> {
        if !t0.is_finite() {
            return Err(Error::NonFiniteTime { t: t0 });
        }
        self.system.initial_guess(&mut self.next.q);
        check_coordinates(&self.system, t0, Quantity::InitialGuess, &self.next.q)?;
        self.factorization = Factorization::None;
        self.solve_at(t0)?;
        Ok(&self.state)
    }

    /// Advances to time `t` (> the last state's time): position from the
    /// previous state (with the predictor q + h q̇ + h²/2 q̈ if enabled),
    /// then velocity and acceleration. The first call assembles at `t`.
    ///
    /// On error the last good state is kept, so the caller may change the
    /// system's parameters or the options and try again.
    pub fn step(&mut self, t: f64) -> Result<&State, Error> {
        if !self.assembled {
            return self.assemble(t);
        }
        if !t.is_finite() {
            return Err(Error::NonFiniteTime { t });
        }
        let previous = self.state.t;
        // False for NaN too.
        let increasing = t > previous;
        if !increasing {
            return Err(Error::NonIncreasingTime {
                index: 0,
                previous,
                t,
            });
        }
        if self.options.predictor {
            let h = t - previous;
            let half_h2 = 0.5 * h * h;
            let guess = self.next.q.iter_mut();
            for (((x, &q), &qd), &qdd) in guess
                .zip(&self.state.q)
                .zip(&self.state.qd)
                .zip(&self.state.qdd)
            {
                *x = q + h * qd + half_h2 * qdd;
            }
        } else {
            self.next.q.copy_from_slice(&self.state.q);
        }
        match self.solve_at(t) {
            Ok(()) => Ok(&self.state),
            Err(e @ Error::NoConvergence { .. }) => Err(self.locate_limit(previous, t, e)),
            Err(e) => Err(e),
        }
    }

    /// Runs the analysis over a strictly increasing time grid: assembly at
    /// `times[0]`, then a step at each later time.
    pub fn run(&mut self, times: &[f64]) -> Result<Trajectory, Error> {
        let (&t0, _) = times.split_first().ok_or(Error::EmptyTimeGrid)?;
        for (index, w) in times.windows(2).enumerate() {
            let increasing = w[1] > w[0];
            if !increasing {
                return Err(Error::NonIncreasingTime {
                    index: index + 1,
                    previous: w[0],
                    t: w[1],
                });
            }
        }
        let mut trajectory = Trajectory::for_system(&self.system, times.len());
        trajectory.push(self.assemble(t0)?.clone());
        for &t in &times[1..] {
            trajectory.push(self.step(t)?.clone());
        }
        Ok(trajectory)
    }

    /// Position analysis from the guess in `self.next.q`, then velocity and
    /// acceleration; commits the state on success.
    fn solve_at(&mut self, t: f64) -> Result<(), Error> {
        let result = self.solve_inner(t);
        if result.is_err() {
            self.factorization = Factorization::None;
        }
        result?;
        std::mem::swap(&mut self.state, &mut self.next);
        self.assembled = true;
        Ok(())
    }

    /// Newton converged at `t_good` (the current state) but not at `t_bad`:
    /// bisects [t_good, t_bad] with full Newton, warm-started from the last
    /// time that converged, down to roundoff. If the solutions end at a time
    /// t* where Φ_q is nearly singular — σ_min/σ_max ≤ √τ, a limit point of
    /// the motion — the failure is a lock-up: returns [`Error::Singular`] at
    /// t* with the dependent equations. Otherwise returns `failure`
    /// unchanged. Error path only: allocates, leaves the state untouched.
    fn locate_limit(&mut self, t_good: f64, t_bad: f64, failure: Error) -> Error {
        let options = Options {
            predictor: false,
            modified_newton: false,
            ..self.options
        };
        let tolerance = self.options.singular_tolerance.sqrt();
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
            let solved = solve_position(
                &mut self.system,
                &mut self.lu,
                &mut factorization,
                &mut q,
                mid,
                &options,
                &mut self.ws,
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
        self.system.jacobian(&q_good, lo, &mut self.ws.jac);
        if check_jacobian(&self.system, lo, &self.ws.jac).is_err() {
            return failure;
        }
        let dependency = crate::diagnose::dependency(&self.system, &self.ws.jac, tolerance);
        match dependency.condition {
            Some(condition) if condition * tolerance >= 1.0 => {
                Error::Singular { t: lo, dependency }
            }
            _ => failure,
        }
    }

    fn solve_inner(&mut self, t: f64) -> Result<(), Error> {
        let State { q, qd, qdd, .. } = &mut self.next;
        let converged = solve_position(
            &mut self.system,
            &mut self.lu,
            &mut self.factorization,
            q,
            t,
            &self.options,
            &mut self.ws,
        )?;
        if !converged.jacobian_current {
            self.system.jacobian(q, t, &mut self.ws.jac);
        }
        self.factorization = Factorization::None;
        factor(
            &self.system,
            &mut self.lu,
            t,
            &self.ws.jac,
            self.options.singular_tolerance,
        )?;
        self.factorization = Factorization::Stale;

        // A non-finite ν (γ) gives a non-finite q̇ (q̈): each right-hand side
        // entry reaches its own entry of the solution, and NaN and ∞ survive
        // every arithmetic operation of a solve. So only the solutions are
        // checked; on failure the right-hand side is evaluated again (the
        // solve overwrote it) to name the culprit.
        let (system, lu) = (&mut self.system, &mut self.lu);
        let quantities = (Quantity::Nu, Quantity::Velocity);
        solve_checked(system, lu, t, qd, quantities, |s, rhs| s.nu(q, t, rhs))?;
        let quantities = (Quantity::Gamma, Quantity::Acceleration);
        solve_checked(system, lu, t, qdd, quantities, |s, rhs| {
            s.gamma(q, qd, t, rhs)
        })
        .map_err(|e| velocity_overflow(system, q, qd, t, e))?;

        self.next.t = t;
        self.next.stats = converged.stats;
        Ok(())
    }
}

/// A velocity this large has a square within a factor 10⁶ of overflow: a
/// non-finite γ next to it comes from the velocities, not from its equation.
const OVERFLOWING_VELOCITY: f64 = 1.3e151;

/// Names the root cause of a non-finite γ when the velocities are so large
/// that γ's products of them overflow: the largest velocity and the equation
/// of ν behind it ([`Error::VelocityOverflow`]). Other errors pass through.
/// Runs on the error path only (it evaluates ν again).
#[cold]
fn velocity_overflow<S: System>(system: &mut S, q: &[f64], qd: &[f64], t: f64, e: Error) -> Error {
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
    system.nu(q, t, &mut nu);
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

/// Fills `x` with a right-hand side (`fill`), solves Φ_q x = rhs in place,
/// and only if x is not finite evaluates the right-hand side again to name
/// the culprit: a non-finite equation (`quantities.0`) or else a solution
/// that overflowed (`quantities.1`).
fn solve_checked<S: System, L: LinearSolver>(
    system: &mut S,
    lu: &mut L,
    t: f64,
    x: &mut [f64],
    quantities: (Quantity, Quantity),
    mut fill: impl FnMut(&mut S, &mut [f64]),
) -> Result<(), Error> {
    fill(system, x);
    lu.solve_in_place(x)?;
    if !scale_and_finite(x).1 {
        fill(system, x);
        check_equations(system, t, quantities.0, x)?;
        lu.solve_in_place(x)?;
        check_coordinates(system, t, quantities.1, x)?;
    }
    Ok(())
}
