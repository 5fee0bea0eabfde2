//! Kinematic analysis over time: [`Solver`].
//!
//! Here the solver's state, its construction and its public interface
//! (assembly, a step, a run); the work of a step lives in submodules, one
//! responsibility each: `step` (a step attempted, polished, committed or
//! refined), `monitor` (the pivots read, the branch test, the events a
//! commit records), `rates` (Φ_q factored and q̇, q̈ solved), `passage`
//! (the refinement near singular configurations), `closed` (the
//! closed-form placement), `checked` (the rate solves' error path) and
//! `undefined` (functions of time leaving their domain).

use crate::error::{Error, Quantity};
use crate::event::{SingularEvent, SingularKind};
use crate::linalg::{Auto, LinalgError, LinearSolver, LinearSolverFor};
use crate::newton::{DIAGNOSES_PER_STEP, Factorization, Travel, Workspace, check_coordinates};
use crate::options::Options;
use crate::state::State;
use crate::system::System;
use crate::trajectory::Trajectory;

mod checked;
mod closed;
mod monitor;
mod passage;
mod rates;
mod sensitivity;
mod step;
mod undefined;

use passage::Zone;

pub use undefined::{locate_undefined, undefined_between};

/// The monitor's gate: a pivot ratio below this is confirmed (or not) by the
/// equilibrated SVD. Measured on the test mechanisms (BENCHMARKS.md), the
/// ratio falls below 1e-2 well before the condition reaches τ^−0.4.
const PIVOT_GATE: f64 = 1e-2;

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
}
