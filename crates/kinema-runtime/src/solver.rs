//! Kinematic analysis over time: [`Solver`].

use crate::diagnose::{MAX_DENSE_DIAGNOSIS, rank};
use crate::error::{Error, Quantity};
use crate::event::{SingularEvent, SingularKind};
use crate::linalg::{Auto, LinalgError, LinearSolver, LinearSolverFor, scale_and_finite};
use crate::newton::{
    DIAGNOSES_PER_STEP, Factorization, Scaling, Workspace, check_coordinates, check_equations,
    check_jacobian, factor, inf_norm, solve_position,
};
use crate::options::Options;
use crate::state::State;
use crate::system::System;
use crate::trajectory::Trajectory;

/// Bisections of a failed step when looking for a limit point (2⁻⁶⁰ of the
/// step: below roundoff of t).
const MAX_BISECTIONS: usize = 60;

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

/// Sub-steps shorter than this fraction of the step end the refinement
/// (a lock-up, diagnosed by bisection).
const MIN_FRACTION: f64 = 1e-13;

/// At most this many successive jumps (each twice as far) over a
/// near-singular neighbourhood.
const MAX_JUMPS: usize = 20;

/// At most this many internal sub-step attempts per step.
const MAX_SUBSTEPS: usize = 1000;

/// In the bisection of a passage, a solution with a pivot ratio above this
/// may serve as the base of the next prediction.
const BASE_RATIO: f64 = 1e-6;

/// A pivot ratio below this is roundoff: the sign of det Φ_q means nothing.
const ROUNDOFF_RATIO: f64 = 1e-8;

/// A limit (the Taylor prediction taken where Φ_q is singular) must satisfy
/// ‖Φ‖∞ ≤ this multiple of the residual tolerance.
const LIMIT_RESIDUAL: f64 = 100.0;

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
    assembled: bool,
    /// The system was lent out mutably since the last step (its parameters
    /// may have changed): the previous state's Taylor prediction says
    /// nothing about the next one, so the next step is not held to it.
    changed: bool,
    factorization: Factorization,
    /// Sign of det Φ_q on the branch so far (0 before the first known).
    branch_sign: f64,
    /// Singular configurations met so far.
    events: Vec<SingularEvent>,
    /// An open run of near-singular states without a sign change: the
    /// worst one, as a toggle event in waiting.
    zone: Option<Zone>,
}

/// What a sub-step's solution means for the refinement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// On the branch: the next base.
    Accept,
    /// Within the threshold of a singular configuration: jump over it.
    Jump,
    /// Failed or off the branch: halve.
    Reject,
}

/// A run of near-singular states.
#[derive(Debug, Clone)]
struct Zone {
    worst_ratio: f64,
    event: SingularEvent,
    flipped: bool,
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
            scratch: system.scratch(),
            system,
            lu,
            options,
            ws: Workspace::new(n, nnz),
            next: State::zeros(n),
            state: State::zeros(n),
            held: State::zeros(n),
            aside: State::zeros(n),
            spare: State::zeros(n),
            bracket_a: State::zeros(n),
            bracket_b: State::zeros(n),
            pred: vec![0.0; n].into_boxed_slice(),
            assembled: false,
            changed: false,
            factorization: Factorization::None,
            branch_sign: 0.0,
            events: Vec::new(),
            zone: None,
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
        self.changed = true;
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
        if !t0.is_finite() {
            return Err(Error::NonFiniteTime { t: t0 });
        }
        self.ws.diagnoses_left = DIAGNOSES_PER_STEP;
        self.system.initial_guess(&mut self.next.q);
        check_coordinates(&self.system, t0, Quantity::InitialGuess, &self.next.q)?;
        // Assembly starts afresh: the steps after it follow its branch.
        self.changed = false;
        self.factorization = Factorization::None;
        self.branch_sign = 0.0;
        self.zone = None;
        self.events.clear();
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

    /// Assembly met a singular Φ_q: perhaps the motion starts at a singular
    /// configuration. The branch that leaves it is assembled a little later,
    /// at t0 + δ (δ the first of 10⁻⁴, 2·10⁻⁴, … (1 + |t0|) where Φ_q is not
    /// near singular), from the initial guess — the user's picture of the
    /// mechanism chooses the branch — and followed back to t0 by its Taylor
    /// expansion (q⃛ from a second solve at t0 + 2δ). If that satisfies
    /// Φ(q, t0) = 0 to √tol, it is the start,
    /// flagged (q̇, q̈ are the branch's limits); otherwise `failure`.
    #[cold]
    fn singular_start(&mut self, t0: f64, failure: Error) -> Result<(), Error> {
        let scale = 1.0 + t0.abs();
        let mut delta = 1e-4 * scale;
        let mut found = false;
        for _ in 0..12 {
            self.system.initial_guess(&mut self.next.q);
            if self.solve_inner(t0 + delta).is_ok() {
                self.monitor();
                if !self.next.stats.near_singular {
                    found = true;
                    break;
                }
            }
            delta *= 2.0;
        }
        self.factorization = Factorization::None;
        if !found {
            return Err(failure);
        }
        // Back along the branch from t0 + δ, with q⃛ from a second solve at
        // t0 + 2δ (else 0): q(t0) = q − δ q̇ + δ²/2 q̈ − δ³/6 q⃛,
        // q̇(t0) = q̇ − δ q̈ + δ²/2 q⃛, q̈(t0) = q̈ − δ q⃛.
        std::mem::swap(&mut self.state, &mut self.next);
        let second = self.attempt(t0 + 2.0 * delta).is_ok() && !self.next.stats.near_singular;
        self.spare.clone_from(&self.state);
        let (one, two) = (&self.state, &self.next);
        let out = &mut self.spare;
        for i in 0..out.q.len() {
            let jerk = if second {
                (two.qdd[i] - one.qdd[i]) / delta
            } else {
                0.0
            };
            let (q, qd, qdd) = (one.q[i], one.qd[i], one.qdd[i]);
            out.q[i] =
                q - delta * qd + 0.5 * delta * delta * qdd - delta * delta * delta / 6.0 * jerk;
            out.qd[i] = qd - delta * qdd + 0.5 * delta * delta * jerk;
            out.qdd[i] = qdd - delta * jerk;
        }
        std::mem::swap(&mut self.next, &mut self.spare);
        self.system
            .phi(&mut self.scratch, &self.next.q, t0, &mut self.ws.phi);
        let residual = inf_norm(&self.ws.phi);
        let close =
            residual <= self.options.residual_tolerance.sqrt() * (1.0 + inf_norm(&self.next.q));
        if !close {
            return Err(failure);
        }
        self.next.t = t0;
        self.next.stats = crate::state::StepStats {
            residual,
            pivot_ratio: 0.0,
            near_singular: true,
            ..Default::default()
        };
        self.next.det_sign = 0.0;
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t0, &mut self.ws.jac);
        Ok(())
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

    /// From the current state at `t0` to `t`: one step if it is accepted,
    /// else internal sub-steps (see "Singular configurations").
    fn advance(&mut self, t0: f64, t: f64) -> Result<(), Error> {
        self.ws.diagnoses_left = DIAGNOSES_PER_STEP;
        // After a change of the system (a parameter set between steps) the
        // motion may jump: the converged step is taken as it is, unless it
        // is near singular.
        if std::mem::take(&mut self.changed)
            && self.attempt_from(t, self.options.predictor).is_ok()
            && !self.next.stats.near_singular
        {
            return self.commit(t);
        }
        // The step as the options ask; the refinement below always starts
        // Newton from the Taylor prediction (following the branch).
        if self.attempt_from(t, self.options.predictor).is_ok()
            && !self.next.stats.near_singular
            && self.acceptable()
        {
            return self.commit(t);
        }
        // Sub-steps commit as they go; a stop at a singular configuration
        // gives the state at t0 back.
        self.held.clone_from(&self.state);
        let (events, zone, sign) = (self.events.len(), self.zone.clone(), self.branch_sign);
        let result = self.substeps(t0, t);
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

    /// The refinement of [`advance`](Self::advance): sub-steps from t0 to
    /// t. A sub-step is halved when it fails or leaves the branch, doubled
    /// after one that succeeds. A sub-step ending within the threshold of a
    /// singular configuration is not a base for the next one: the next
    /// jumps over it (twice as far), predicted from the regular state
    /// before it. If the output time t itself is within the threshold, its
    /// rates are bridged (see [`bridge`](Self::bridge)).
    fn substeps(&mut self, t0: f64, t: f64) -> Result<(), Error> {
        let span = t - t0;
        let mut h = 0.5 * span;
        let (mut substeps, mut tries) = (0usize, 0usize);
        let mut jumps = 0usize;
        // Where the last run of jumps started (a near-singular solution).
        let mut zone_at = f64::NAN;
        loop {
            tries += 1;
            let from = self.state.t;
            let remaining = t - from;
            let t_try = if h >= remaining * (1.0 - 1e-9) {
                t
            } else {
                from + h
            };
            let h_try = t_try - from;
            let attempt = self.attempt(t_try);
            let at_end = t_try >= t;
            let outcome = match &attempt {
                Ok(()) if self.next.stats.near_singular => {
                    self.note_near_singular(t_try);
                    if !at_end {
                        Outcome::Jump
                    } else if self.bridge(t) {
                        Outcome::Accept
                    } else {
                        Outcome::Reject
                    }
                }
                Ok(()) if self.acceptable() => Outcome::Accept,
                Ok(()) => Outcome::Reject,
                Err(Error::Singular { .. }) if !at_end => Outcome::Jump,
                Err(Error::Singular { .. }) => {
                    if self.limit(t) && self.bridge(t) {
                        Outcome::Accept
                    } else {
                        Outcome::Reject
                    }
                }
                Err(Error::NoConvergence { .. }) => Outcome::Reject,
                Err(e) => return Err(e.clone()),
            };
            match outcome {
                Outcome::Accept => {
                    jumps = 0;
                    substeps += 1;
                    self.next.stats.substeps = substeps;
                    self.commit(t_try)?;
                    if at_end {
                        return Ok(());
                    }
                    h = (2.0 * h_try).min(span);
                    continue;
                }
                Outcome::Jump if jumps < MAX_JUMPS => {
                    if jumps == 0 {
                        zone_at = t_try;
                    }
                    jumps += 1;
                    h = 2.0 * h_try;
                    continue;
                }
                Outcome::Jump | Outcome::Reject => {}
            }
            // A failed jump: approach the neighbourhood closer before the
            // next one (a lock-up when that is no longer possible).
            h = if jumps > 0 {
                0.5 * (zone_at - from)
            } else {
                0.5 * h_try
            };
            jumps = 0;
            // NaN-safe: a comparison with NaN is false, so not progressing.
            let progressing = h > MIN_FRACTION * span && from + h > from;
            let stuck = !progressing;
            if stuck || tries >= MAX_SUBSTEPS {
                let failure = match attempt {
                    Err(e) => e,
                    // Converged, but off the branch every time.
                    Ok(()) => Error::BranchLost {
                        from,
                        t,
                        substeps: tries,
                    },
                };
                let mut e = self.locate_limit(from, t_try, failure);
                if let Error::Singular { dependency, .. } = &mut e
                    && dependency.rank.is_none()
                    && dependency.dim <= MAX_DENSE_DIAGNOSIS
                {
                    // A sub-step's failure past the step's diagnosis budget:
                    // diagnosed now, at the last Φ_q evaluated near it.
                    *dependency = crate::diagnose::dependency(
                        &self.system,
                        &self.ws.jac,
                        self.options.singular_tolerance,
                    );
                }
                if let Error::Singular { t, dependency } = &e {
                    self.events.push(SingularEvent {
                        t: *t,
                        kind: SingularKind::LockUp,
                        dependency: dependency.clone(),
                    });
                }
                return Err(e);
            }
        }
    }

    /// `self.next` holds q at the output time `t`, within the threshold of a
    /// singular configuration, where Φ_q does not determine q̇ and q̈. Solves
    /// a regular state on the branch beyond it (at t + (t − t_a), doubling
    /// the distance until regular and on the branch) and gives `self.next`
    /// the branch's values: cubic Hermite interpolation of q (with q̇ as its
    /// derivative) and of q̇ (with q̈) between regular states on either
    /// side (the bracket narrowed, by halving, as long as both ends stay
    /// regular), q̈ the derivative of the latter. Flags it.
    /// `false` if no regular state beyond was found.
    fn bridge(&mut self, t: f64) -> bool {
        std::mem::swap(&mut self.next, &mut self.aside);
        let ta = self.state.t;
        // A regular state beyond t on the branch: b.
        let mut tb = t + (t - ta);
        let mut found = false;
        for _ in 0..30 {
            if self.attempt(tb).is_ok() && !self.next.stats.near_singular && self.acceptable() {
                found = true;
                break;
            }
            tb = t + 2.0 * (tb - t);
        }
        if found {
            // Narrow the bracket [a, b] around t while both ends stay
            // regular and on the branch: interpolation error falls as its
            // width to the fourth.
            std::mem::swap(&mut self.next, &mut self.bracket_b);
            self.bracket_a.clone_from(&self.state);
            let mut delta = 0.5 * (t - ta).min(tb - t);
            for _ in 0..40 {
                std::mem::swap(&mut self.state, &mut self.bracket_a);
                let left = self.attempt(t - delta).is_ok()
                    && !self.next.stats.near_singular
                    && self.acceptable();
                std::mem::swap(&mut self.state, &mut self.bracket_a);
                if !left {
                    break;
                }
                // Candidate a in `spare`, b predicted from it.
                std::mem::swap(&mut self.next, &mut self.spare);
                std::mem::swap(&mut self.state, &mut self.spare);
                let right = self.attempt(t + delta).is_ok()
                    && !self.next.stats.near_singular
                    && self.acceptable();
                std::mem::swap(&mut self.state, &mut self.spare);
                if !right {
                    break;
                }
                std::mem::swap(&mut self.spare, &mut self.bracket_a);
                std::mem::swap(&mut self.next, &mut self.bracket_b);
                delta *= 0.5;
            }
            let (a, b) = (&self.bracket_a, &self.bracket_b);
            let span = b.t - a.t;
            let s = (t - a.t) / span;
            let (s2, s3) = (s * s, s * s * s);
            let (h00, h10, h01, h11) = (
                2.0 * s3 - 3.0 * s2 + 1.0,
                s3 - 2.0 * s2 + s,
                -2.0 * s3 + 3.0 * s2,
                s3 - s2,
            );
            let (d00, d10, d01, d11) = (
                6.0 * s2 - 6.0 * s,
                3.0 * s2 - 4.0 * s + 1.0,
                -6.0 * s2 + 6.0 * s,
                3.0 * s2 - 2.0 * s,
            );
            let out = &mut self.aside;
            for i in 0..out.qd.len() {
                // Newton's q within the threshold is accurate only to about
                // √tol along the free direction; the branch's is smoother.
                out.q[i] =
                    h00 * a.q[i] + h10 * span * a.qd[i] + h01 * b.q[i] + h11 * span * b.qd[i];
                let (va, vb, aa, ab) = (a.qd[i], b.qd[i], a.qdd[i], b.qdd[i]);
                out.qd[i] = h00 * va + h10 * span * aa + h01 * vb + h11 * span * ab;
                out.qdd[i] = (d00 * va + d01 * vb) / span + d10 * aa + d11 * ab;
            }
        }
        std::mem::swap(&mut self.next, &mut self.aside);
        self.factorization = Factorization::None;
        if found {
            self.next.stats.near_singular = true;
            if self.next.stats.pivot_ratio < ROUNDOFF_RATIO {
                self.next.det_sign = 0.0;
            }
        }
        found
    }

    /// Solves at `t` from the current state into `self.next` (Newton from
    /// the Taylor prediction), then runs the monitor.
    fn attempt(&mut self, t: f64) -> Result<(), Error> {
        self.attempt_from(t, true)
    }

    /// [`attempt`](Self::attempt), Newton starting from the prediction or,
    /// with `predict` false, from the current q.
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
        let _ = solve_position(
            &self.system,
            &mut self.scratch,
            &mut self.lu,
            &mut self.factorization,
            &mut self.next.q,
            t,
            &options,
            &mut self.ws,
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

    /// At the output time `t` Φ_q is singular (the LU refused it): takes
    /// the Taylor prediction from the current state as q if Φ is nearly
    /// satisfied there (the caller then bridges the rates).
    fn limit(&mut self, t: f64) -> bool {
        predict_into(&self.state, t, &mut self.pred);
        self.system
            .phi(&mut self.scratch, &self.pred, t, &mut self.ws.phi);
        let residual = inf_norm(&self.ws.phi);
        let close = residual <= LIMIT_RESIDUAL * self.options.residual_tolerance;
        if !close {
            return false;
        }
        self.next.q.copy_from_slice(&self.pred);
        self.next.t = t;
        self.next.stats = crate::state::StepStats {
            residual,
            near_singular: true,
            ..Default::default()
        };
        self.next.det_sign = 0.0;
        true
    }

    /// Makes `self.next` (solved at `t`) the current state, after
    /// recording the singular configurations it reveals: a change of sign
    /// of det Φ_q (located by bisection), the start or end of a run of
    /// near-singular states.
    fn commit(&mut self, t: f64) -> Result<(), Error> {
        let sign = self.next.det_sign;
        let near = self.next.stats.near_singular;
        let flipped = self.branch_sign * sign < 0.0;
        if flipped {
            let event = self.locate_passage(t);
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

    /// A near-singular state at `t`: opens or updates the run of them.
    fn note_near_singular(&mut self, t: f64) {
        let ratio = self.next.stats.pivot_ratio;
        let worse = self.zone.as_ref().is_none_or(|z| ratio < z.worst_ratio);
        if !worse {
            return;
        }
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t, &mut self.ws.jac);
        let dependency = crate::diagnose::dependency(
            &self.system,
            &self.ws.jac,
            self.options.singular_tolerance,
        );
        let event = SingularEvent {
            t,
            kind: SingularKind::Toggle,
            dependency,
        };
        match &mut self.zone {
            Some(zone) => {
                zone.worst_ratio = ratio;
                zone.event = event;
            }
            None => {
                self.zone = Some(Zone {
                    worst_ratio: ratio,
                    event,
                    flipped: false,
                });
            }
        }
    }

    /// det Φ_q has opposite signs at the current state and at `self.next`
    /// (at `t`): bisects (at 0.4 of the interval) the time between them along the branch (each
    /// solve from the last state on the current side) to find where it
    /// changes, and diagnoses Φ_q there. Leaves `self.next` and the state as
    /// they were. Event path: allocates two states.
    fn locate_passage(&mut self, t: f64) -> SingularEvent {
        let mut candidate = self.next.clone();
        // The left end: a copy of the current state, moved right as the
        // bisection proceeds; the current state itself is kept.
        let left_sign = self.branch_sign;
        let mut left = self.state.clone();
        let (mut lo, mut hi) = (self.state.t, t);
        std::mem::swap(&mut self.state, &mut left);
        let mut singular_at = None;
        'bisection: for _ in 0..MAX_BISECTIONS {
            // Not the midpoint: grids symmetric about t* would put the first
            // one on it, where det Φ_q's sign is noise.
            let mut mid = lo + 0.4 * (hi - lo);
            if !(lo < mid && mid < hi) || hi - lo <= 1e-12 * (1.0 + hi.abs()) {
                break;
            }
            // From a coarse step, Newton may fail or leave the branch at the
            // midpoint: move it towards the left end until it does not.
            let mut tries = 0;
            // Only the sign matters here: a near-singular solution counts.
            loop {
                let attempt = self.attempt(mid);
                let at_roundoff = attempt.is_ok()
                    && self.next.stats.near_singular
                    && self.next.stats.pivot_ratio < ROUNDOFF_RATIO;
                if at_roundoff || matches!(attempt, Err(Error::Singular { .. })) {
                    // Φ_q is singular at mid itself (its det's sign is
                    // noise): that is the time.
                    singular_at = Some(mid);
                    break 'bisection;
                }
                let ok = attempt.is_ok() && (self.next.stats.near_singular || self.acceptable());
                if ok && self.next.det_sign != 0.0 {
                    break;
                }
                tries += 1;
                mid = lo + 0.5 * (mid - lo);
                let inside = lo < mid;
                if tries > 60 || !inside {
                    break 'bisection;
                }
            }
            let sign = self.next.det_sign;
            if sign * left_sign > 0.0 {
                lo = mid;
                // A solution very near singular narrows the interval but
                // does not become the base of predictions (its rates are
                // noise).
                if self.next.stats.pivot_ratio > BASE_RATIO {
                    std::mem::swap(&mut self.state, &mut self.next);
                }
            } else if sign * left_sign < 0.0 {
                hi = mid;
            } else {
                break;
            }
        }
        // Φ_q at the last state before the change of sign.
        let t_star = singular_at.unwrap_or(lo + 0.5 * (hi - lo));
        self.system.jacobian(
            &mut self.scratch,
            &self.state.q,
            self.state.t,
            &mut self.ws.jac,
        );
        let dependency = crate::diagnose::dependency(
            &self.system,
            &self.ws.jac,
            self.options.singular_tolerance,
        );
        std::mem::swap(&mut self.state, &mut left);
        std::mem::swap(&mut self.next, &mut candidate);
        self.factorization = Factorization::None;
        SingularEvent {
            t: t_star,
            kind: SingularKind::Bifurcation,
            dependency,
        }
    }

    /// Newton converged at `t_good` (the current state) but not at `t_bad`:
    /// bisects [t_good, t_bad] with full Newton, warm-started from the last
    /// time that converged, down to roundoff. If the solutions end at a time
    /// t* where Φ_q is nearly singular — equilibrated condition ≥ τ^−0.4, a limit point of
    /// the motion — the failure is a lock-up: returns [`Error::Singular`] at
    /// t* with the dependent equations. Otherwise returns `failure`
    /// unchanged. Error path only: allocates, leaves the state untouched.
    fn locate_limit(&mut self, t_good: f64, t_bad: f64, failure: Error) -> Error {
        let options = Options {
            predictor: false,
            modified_newton: false,
            ..self.options
        };
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
                &self.system,
                &mut self.scratch,
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
        self.system
            .jacobian(&mut self.scratch, &q_good, lo, &mut self.ws.jac);
        if check_jacobian(&self.system, lo, &self.ws.jac).is_err() {
            return failure;
        }
        let tolerance = self.options.singular_tolerance;
        let dependency = crate::diagnose::dependency(&self.system, &self.ws.jac, tolerance);
        match dependency.condition {
            Some(condition) if condition >= crate::diagnose::near_singular_condition(tolerance) => {
                Error::Singular { t: lo, dependency }
            }
            _ => failure,
        }
    }

    fn solve_inner(&mut self, t: f64) -> Result<(), Error> {
        let q = &mut self.next.q;
        let converged = solve_position(
            &self.system,
            &mut self.scratch,
            &mut self.lu,
            &mut self.factorization,
            q,
            t,
            &self.options,
            &mut self.ws,
        )?;
        if !converged.jacobian_current {
            self.system
                .jacobian(&mut self.scratch, q, t, &mut self.ws.jac);
        }
        self.next.t = t;
        self.next.stats = converged.stats;
        self.factor_and_rates(t)
    }

    /// Φ_q at `self.next.q` (then in `ws.jac`) factored, q̇ and q̈ solved.
    fn rates(&mut self, t: f64) -> Result<(), Error> {
        self.system
            .jacobian(&mut self.scratch, &self.next.q, t, &mut self.ws.jac);
        self.factor_and_rates(t)
    }

    /// Factors Φ_q from `ws.jac` and solves q̇ and q̈ of `self.next`.
    fn factor_and_rates(&mut self, t: f64) -> Result<(), Error> {
        let State { q, qd, qdd, .. } = &mut self.next;
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

        // A non-finite ν (γ) gives a non-finite q̇ (q̈): each right-hand side
        // entry reaches its own entry of the solution, and NaN and ∞ survive
        // every arithmetic operation of a solve. So only the solutions are
        // checked; on failure the right-hand side is evaluated again (the
        // solve overwrote it) to name the culprit.
        let (system, scratch) = (&self.system, &mut self.scratch);
        let (lu, scaling) = (&mut self.lu, &self.ws.scaling);
        let quantities = (Quantity::Nu, Quantity::Velocity);
        solve_checked(system, scratch, lu, scaling, t, qd, quantities, |c, rhs| {
            system.nu(c, q, t, rhs);
        })?;
        let quantities = (Quantity::Gamma, Quantity::Acceleration);
        solve_checked(
            system,
            scratch,
            lu,
            scaling,
            t,
            qdd,
            quantities,
            |c, rhs| {
                system.gamma(c, q, qd, t, rhs);
            },
        )
        .map_err(|e| velocity_overflow(system, scratch, q, qd, t, e))?;
        Ok(())
    }
}

/// The Taylor prediction q + h q̇ + h²/2 q̈ of `state` at `t` (h = t − its
/// time) into `out`.
fn predict_into(state: &State, t: f64, out: &mut [f64]) {
    let h = t - state.t;
    let half_h2 = 0.5 * h * h;
    let n = out.len();
    let (q, qd, qdd) = (&state.q[..n], &state.qd[..n], &state.qdd[..n]);
    for i in 0..n {
        out[i] = q[i] + h * qd[i] + half_h2 * qdd[i];
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
fn velocity_overflow<S: System>(
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

/// Fills `x` with a right-hand side (`fill`), solves Φ_q x = rhs in place,
/// and only if x is not finite evaluates the right-hand side again to name
/// the culprit: a non-finite equation (`quantities.0`) or else a solution
/// that overflowed (`quantities.1`).
#[allow(clippy::too_many_arguments)]
fn solve_checked<S: System, L: LinearSolver>(
    system: &S,
    scratch: &mut S::Scratch,
    lu: &mut L,
    scaling: &Scaling,
    t: f64,
    x: &mut [f64],
    quantities: (Quantity, Quantity),
    mut fill: impl FnMut(&mut S::Scratch, &mut [f64]),
) -> Result<(), Error> {
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
