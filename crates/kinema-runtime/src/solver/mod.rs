//! Kinematic analysis over time: [`Solver`].

use crate::diagnose::{MAX_DENSE_DIAGNOSIS, rank};
use crate::error::{Error, Quantity};
use crate::event::{SingularEvent, SingularKind};
use crate::linalg::{Auto, LinalgError, LinearSolver, LinearSolverFor};
use crate::newton::{
    DIAGNOSES_PER_STEP, Eval, Factorization, Lu, Took, Travel, Workspace, check_coordinates,
    factor, inf_norm, solve_position,
};
use crate::options::Options;
use crate::state::{State, StepStats};
use crate::system::System;
use crate::trajectory::Trajectory;

mod checked;
mod closed;
mod passage;

use checked::{Factored, solve_checked, velocity_overflow};

use passage::Zone;

/// With [`Options::positions_only`], the estimates of q̇ and q̈ are those
/// of a quadratic through three positions only when the two steps differ by
/// at most this factor (else a backward difference): a quadratic through
/// unevenly spaced points extrapolates their noise.
const QUADRATIC_STEP_RATIO: f64 = 4.0;

/// The monitor's gate: a pivot ratio below this is confirmed (or not) by the
/// equilibrated SVD. Measured on the test mechanisms (BENCHMARKS.md), the
/// ratio falls below 1e-2 well before the condition reaches τ^−0.4.
const PIVOT_GATE: f64 = 1e-2;

/// A step is accepted when its position differs from the Taylor prediction
/// by at most this fraction of the predicted motion, and its velocity from
/// q̇ + h q̈ by at most this fraction of ‖q̇‖ + ‖h q̈‖; else it is refined.
const CONSISTENCY: f64 = 0.3;

/// More Newton updates than this make a step be refined.
const MAX_UPDATES_UNREFINED: usize = 8;

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

/// A pivot ratio below this is roundoff: the sign of det Φ_q means nothing.
const ROUNDOFF_RATIO: f64 = 1e-8;

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
///
/// With [`Options::positions_only`] and a system that is a linkage of
/// cranks and dyads ([`System::linkage`]), a step's positions are placed
/// in closed form instead ([`Options::closed_form`]), on the branch of
/// the previous state, and checked against Φ and the branch test; steps
/// near a singular configuration stay Newton's and the monitor's.
///
/// # Singular configurations
///
/// After every solve a monitor reads the LU's pivots ([`PivotReport`]): the
/// sign of det Φ_q and the pivot ratio. A ratio below 1e-2 is confirmed by
/// the equilibrated SVD ([`crate::diagnose::rank`]); Φ_q is *near singular*
/// when its condition reaches τ^−0.4 (10⁴). A step is refined into internal
/// sub-steps (not output) when its solution is near singular, needs many
/// Newton updates, or leaves the branch (position or velocity far from the
/// Taylor prediction). So the motion follows one smooth branch whatever the
/// grid:
///
/// * where det Φ_q changes sign (a [`SingularKind::Bifurcation`]) the run
///   keeps the analytic continuation — the branch on which q and q̇ are
///   continuous — and locates the time by bisection;
/// * an output row near singular gets the branch's values, not a solve:
///   q, q̇ and q̈ interpolated (cubic Hermite) between regular states on the
///   branch on either side, and is flagged
///   ([`StepStats::near_singular`](crate::StepStats::near_singular));
/// * where no continuation exists (a dead point) the step fails with
///   [`Error::Singular`] at the located time.
///
/// Each event is recorded ([`events`](Self::events)); with
/// [`Options::stop_at_singular`] the first one stops the run instead.
///
/// [`PivotReport`]: crate::linalg::PivotReport
#[derive(Debug)]
pub struct Solver<S: System, L: LinearSolver = Auto> {
    system: S,
    /// The system's evaluation scratch (see [`System::Scratch`]).
    scratch: S::Scratch,
    lu: L,
    options: Options,
    ws: Workspace,
    /// The state being computed; swapped with `state` on success, so a
    /// failed step leaves the last good state intact.
    next: State,
    state: State,
    /// The state at the start of a refined step, given back if the step
    /// fails or stops at a singular configuration.
    held: State,
    /// Scratch state of [`bridge`](Self::bridge).
    aside: State,
    /// Scratch state of [`polish`](Self::polish) and [`bridge`](Self::bridge).
    spare: State,
    /// The ends of [`bridge`](Self::bridge)'s bracket.
    bracket_a: State,
    bracket_b: State,
    /// Taylor prediction from the last state.
    pred: Box<[f64]>,
    /// The tag ([`State`]'s `tag`) of the state whose Φ_q the LU and
    /// `ws.jac` hold (0 when they hold something else: every path that
    /// factors or overwrites `ws.jac` clears it first), and whether that
    /// factorization was equilibrated: inverse dynamics reuses it for the
    /// state kept.
    factored: u64,
    factored_scaled: bool,
    /// The last tag given out (tags are never reused).
    tags: u64,
    /// How far Newton moved q in the last attempt (see
    /// [`quiet`](Self::quiet)).
    travel: Travel,
    assembled: bool,
    /// The system was lent out mutably since the last step (its parameters
    /// may have changed): the previous state's Taylor prediction says
    /// nothing about the next one, so the next step is not held to it.
    changed: bool,
    /// The system was lent out mutably since the scratch was made: it may
    /// be another system now, whose evaluations would misread this one's
    /// caches, so the next step or assembly makes a new scratch.
    stale_scratch: bool,
    factorization: Factorization,
    /// Sign of det Φ_q on the branch so far (0 before the first known).
    branch_sign: f64,
    /// Singular configurations met so far.
    events: Vec<SingularEvent>,
    /// An open run of near-singular states without a sign change: the
    /// worst one, as a toggle event in waiting.
    zone: Option<Zone>,
    /// Closed-form placement (see [`Options::closed_form`]).
    closed: closed::ClosedForm,
}

/// Construction: `L` must be a linear solver for `S` ([`LinearSolverFor`]),
/// which keeps a generated LU to the system it was generated for.
impl<S: System, L: LinearSolverFor<S>> Solver<S, L> {
    /// A solver with [`Options::default`], the linear solver analysed from
    /// the system's Jacobian pattern.
    pub fn new(system: S) -> Result<Self, Error> {
        Self::with_options(system, Options::default())
    }

    /// A solver with the given options, the linear solver analysed from the
    /// system's Jacobian pattern.
    pub fn with_options(system: S, options: Options) -> Result<Self, Error> {
        let lu = L::analyze_system(&system)?;
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
        Ok(Self {
            ws: Workspace::new(&system),
            scratch: system.scratch(),
            system,
            lu,
            options,
            next: State::zeros(n),
            state: State::zeros(n),
            held: State::zeros(n),
            aside: State::zeros(n),
            spare: State::zeros(n),
            bracket_a: State::zeros(n),
            bracket_b: State::zeros(n),
            pred: vec![0.0; n].into_boxed_slice(),
            factored: 0,
            factored_scaled: false,
            tags: 0,
            travel: Travel::default(),
            assembled: false,
            changed: false,
            stale_scratch: false,
            factorization: Factorization::None,
            branch_sign: 0.0,
            events: Vec::new(),
            zone: None,
            closed: closed::ClosedForm::default(),
        })
    }
}

impl<S: System, L: LinearSolver> Solver<S, L> {
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
        self.factored = 0;
        self.changed = true;
        self.stale_scratch = true;
        &mut self.system
    }

    /// A new scratch from the system if it was lent out mutably (see
    /// `stale_scratch`): once per change, not per step.
    fn renew_scratch(&mut self) {
        if std::mem::take(&mut self.stale_scratch) {
            self.scratch = self.system.scratch();
        }
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

    /// The model's size as assembly measured it for the residual test (see
    /// [`Options::residual_tolerance`]): its length scale — the largest
    /// |x|, |y| of the initial guess and the equations' lever arms —
    /// capped at 1; 1 before assembly. A coordinate at 0 is 0 within a
    /// unit roundoff of it: what [`System::kink`] and the outputs' kink
    /// checks take as the rounding floor.
    #[must_use]
    pub fn model_size(&self) -> f64 {
        self.ws.rows.size()
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
        self.factored = 0;
        self.assembled = false;
        self.factorization = Factorization::None;
        self.branch_sign = 0.0;
        self.zone = None;
        self.events.clear();
    }

    /// The singular configurations met so far (see "Singular
    /// configurations" above), in time order. A toggle is recorded when the
    /// motion leaves its neighbourhood, so call
    /// [`close_events`](Self::close_events) after the last step to have the
    /// one the run ends in ([`SingularKind::AtEnd`]).
    #[must_use]
    pub fn events(&self) -> &[SingularEvent] {
        &self.events
    }

    /// Records the singular configuration whose neighbourhood the motion
    /// has not left yet, as [`SingularKind::AtEnd`] (call after the last
    /// step), and returns every event.
    pub fn close_events(&mut self) -> &[SingularEvent] {
        // A run of near-singular states still open: the run ended in it.
        if let Some(zone) = self.zone.take()
            && !zone.flipped
        {
            self.events.push(SingularEvent {
                kind: SingularKind::AtEnd,
                ..zone.event
            });
        }
        &self.events
    }

    /// Assembly: position, velocity and acceleration at `t0`, Newton starting
    /// from the system's initial guess.
    pub fn assemble(&mut self, t0: f64) -> Result<&State, Error> {
        self.renew_scratch();
        if !t0.is_finite() {
            return Err(Error::NonFiniteTime { t: t0 });
        }
        self.ws.diagnoses_left = DIAGNOSES_PER_STEP;
        self.system.initial_guess(&mut self.next.q);
        self.check_defined(t0, t0)?;
        check_coordinates(&self.system, t0, Quantity::InitialGuess, &self.next.q)?;
        // The residual test's scale, from Φ_q at the guess.
        self.factored = 0;
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t0, &mut self.ws.jac);
        self.ws
            .rows
            .measure(self.system.jacobian_pattern(), &self.next.q, &self.ws.jac);
        // Assembly starts afresh: the steps after it follow its branch.
        self.changed = false;
        self.factorization = Factorization::None;
        self.branch_sign = 0.0;
        self.zone = None;
        self.events.clear();
        self.closed.current = false;
        let solved = self.solve_inner(t0);
        if solved.is_err() {
            self.factorization = Factorization::None;
        }
        match solved {
            Ok(()) => self.monitor(),
            Err(e @ Error::Singular { .. }) => self.singular_start(t0, e)?,
            Err(e) => return Err(e),
        }
        self.commit(t0)?;
        Ok(&self.state)
    }

    /// Advances to time `t` (> the last state's time): position from the
    /// previous state (with the predictor q + h q̇ + h²/2 q̈ if enabled),
    /// then velocity and acceleration; refined into internal sub-steps near
    /// a singular configuration (see "Singular configurations"). The first
    /// call assembles at `t`.
    ///
    /// On error the last good state is kept, so the caller may change the
    /// system's parameters or the options and try again.
    pub fn step(&mut self, t: f64) -> Result<&State, Error> {
        if !self.assembled {
            return self.assemble(t);
        }
        self.renew_scratch();
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
        self.check_defined(previous, t)?;
        self.advance(previous, t)?;
        Ok(&self.state)
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
        trajectory.set_events(self.close_events().to_vec());
        Ok(trajectory)
    }

    /// Before a step from `t0` to `t` (at assembly `t0 == t`): whether an
    /// equation's function of time leaves its domain in (t0, t] (see
    /// [`System::undefined`]): the step's bracket asked first, and the
    /// first point located by bisection to roundoff of t; then t itself.
    /// The system's answer over a bracket is a first-order one with a
    /// margin: a bracket that no half confirms is no finding.
    #[inline]
    fn check_defined(&mut self, t0: f64, t: f64) -> Result<(), Error> {
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

    /// From the current state at `t0` to `t`: one step if it is accepted,
    /// else internal sub-steps (see "Singular configurations").
    fn advance(&mut self, t0: f64, t: f64) -> Result<(), Error> {
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
    fn attempt(&mut self, t: f64) -> Result<(), Error> {
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

    /// Reads the LU's pivots for `self.next` (Φ_q at its q in `ws.jac`): det sign, pivot ratio, and near-singularity, confirmed by
    /// the equilibrated SVD when the ratio is below the gate.
    fn monitor(&mut self) {
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
    fn quiet(&self) -> bool {
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
    /// [`predict_into`] gives it), velocity likewise from q̇ + h q̈. A
    /// non-finite value rejects. Runs on every step: one pass over the
    /// states.
    fn acceptable(&self) -> bool {
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
    fn commit(&mut self, t: f64) -> Result<(), Error> {
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

    #[inline]
    fn solve_inner(&mut self, t: f64) -> Result<(), Error> {
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

    /// [`Options::positions_only`]: instead of the rates, `self.next` gets
    /// estimates for the predictor and the branch test: q̇ and q̈ of the
    /// quadratic through the positions of the last three times (the
    /// current state's slope recovered from its own estimates, see
    /// [`State::h_back`]), which makes the prediction O(h³) as with the
    /// rates solved; or, when the current state's estimates did not come
    /// from that quadratic or the steps differ by more than
    /// [`QUADRATIC_STEP_RATIO`], q̇ = the backward difference and q̈ = 0.
    /// Zero when there is no current state or a value is not finite.
    #[inline]
    fn difference_rates(&mut self, t: f64) {
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
    fn rates(&mut self, t: f64) -> Result<(), Error> {
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
    fn factor_jacobian(&mut self, t: f64) -> Result<(), Error> {
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
    fn factor_and_rates(&mut self, t: f64) -> Result<(), Error> {
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
}

/// The Taylor prediction q + h q̇ + h²/2 q̈ of `state` at `t` (h = t − its
/// time) into `out`.
#[inline]
fn predict_into(state: &State, t: f64, out: &mut [f64]) {
    let h = t - state.t;
    let half_h2 = 0.5 * h * h;
    let n = out.len();
    let (q, qd, qdd) = (&state.q[..n], &state.qd[..n], &state.qdd[..n]);
    for i in 0..n {
        out[i] = q[i] + h * qd[i] + half_h2 * qdd[i];
    }
}

impl<S: System, L: LinearSolver> Solver<S, L> {
    /// The system, its scratch and the current state (if any), borrowed
    /// together.
    pub(crate) fn parts(&mut self) -> (&S, &mut S::Scratch, Option<&State>) {
        self.renew_scratch();
        let state = self.assembled.then_some(&self.state);
        (&self.system, &mut self.scratch, state)
    }

    /// Overwrites `rhs` = b with λ = Φ_q⁻ᵀ b at the current state
    /// (Φ_qᵀ λ = b), and returns the system and Φ_q's values there
    /// (pattern order). The factorization of the step is reused; only when
    /// it is not that of the state kept (an interpolated near-singular row,
    /// a changed parameter) is Φ_q evaluated and factored again.
    pub(crate) fn solve_transposed_at_state(
        &mut self,
        rhs: &mut [f64],
    ) -> Result<(&S, &[f64]), Error> {
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
        self.ws.scaling.solve_transpose(&mut self.lu, rhs)?;
        Ok((&self.system, &self.ws.jac))
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
