//! `kinema run` of forward dynamics: a `.kin` model with NDOF > 0 and
//! inertia, or a simEngine2D model under a Dynamics ACF. HHT-α at a fixed
//! step (`--step`, or the ACF's `stepSize`) shortened to land on every
//! output time; the CSV has the columns of a Dynamics I run (q, q̇, q̈,
//! named points and outputs, λ, reactions, driver efforts); the summary
//! gives the consistency corrections at the start, Newton's work and the
//! energy balance.

use std::fmt::Write as _;
use std::time::Instant;

use kinema::forward::DynamicsRun;
use kinema::forward::TapeForward;
use kinema::integrate::{Consistency, Integrator as MotionEngine, Monitor, Prescribed};
use kinema::{Accurate, Axis, Body, Hht, HhtOptions, IntegrateError, PrecisionScope};

use super::args::Integrator;
use super::files::RunFiles;
use super::load::Loaded;
use super::output::{CsvSink, Destination, duration, time};
use super::plan::{ForwardPlan, OutputPlan};
use super::shared::grid::MAX_PLOT_STATES;
use super::{Failure, print_stderr, print_stdout};

/// The motion engine of a run and the head of its summary line.
struct Engine {
    motion: Box<dyn MotionEngine<TapeForward>>,
    /// "HHT-α (…), step ≤ h", "accurate (…), rtol r", "prescribed …".
    head: String,
    /// Whether the motion is prescribed (not integrated).
    prescribed: bool,
}

impl std::ops::Deref for Engine {
    type Target = dyn MotionEngine<TapeForward>;
    fn deref(&self) -> &Self::Target {
        &*self.motion
    }
}

impl std::ops::DerefMut for Engine {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut *self.motion
    }
}

impl Engine {
    /// The summary's line on the integrator.
    fn describe(&self) -> String {
        format!("{}: {}", self.head, self.motion.counters())
    }
}

/// Most singular configurations warned about one by one; the summary
/// counts them all.
const MAX_PASSAGE_WARNINGS: usize = 20;

/// The columns `--energy` adds after the dynamics columns.
const ENERGY_COLUMNS: [&str; 3] = ["energy.kinetic", "energy.potential", "energy.work"];

/// Runs forward dynamics of `loaded` as `plan` says, writing the state at
/// each of its output times to `outputs`.
///
/// # Errors
/// Usage errors (a model without inertia, an output that cannot be
/// created); [`Failure::Analysis`] when a step fails (the rows before it
/// are kept).
pub fn run(loaded: &Loaded, plan: &ForwardPlan, outputs: &OutputPlan) -> Result<(), Failure> {
    let start = Instant::now();
    let (h, outputs_t) = (plan.step, &plan.times[..]);
    let d = loaded.model.derivation();
    let Some(fwd) = loaded.model.forward_system() else {
        return Err(Failure::usage(format_args!(
            "`{}` has no inertia: forward dynamics needs `mass` and `inertia` on every body",
            loaded.file
        )));
    };
    let n = d.nc();
    let q0 = loaded.model.initial_configuration();
    let qd0 = initial_velocities(loaded, n);

    let system = loaded.model.system();
    let dyn_names = system.dynamics_column_names(d.rows.len(), loaded.adm.is_some());
    let mut extra = dyn_names.clone();
    if plan.energy {
        extra.extend(ENERGY_COLUMNS.map(String::from));
    }
    let files = RunFiles::create(outputs, d, &extra)?;
    let mut samples = files
        .keep_states()
        .then(|| super::plot::Samples::new(n).with_dynamics(&dyn_names));
    let RunFiles {
        csv: sink,
        plot: plot_target,
        page: page_target,
    } = files;

    let analysis_start = Instant::now();
    let t0 = outputs_t.first().copied().unwrap_or(0.0);
    let (mut motion, consistency) = Motion::start(plan, fwd, [&q0, &qd0], t0)?;
    let sink = motion.integrate(
        plan.energy,
        loaded,
        &system,
        (outputs_t, h),
        sink,
        &mut samples,
    )?;
    let csv = (sink.destination().clone(), sink.rows(), sink.columns());
    sink.finish()?;
    let analysis = analysis_start.elapsed();
    let title = format!("{}: forward dynamics", loaded.checked().name);
    if let (Some(target), Some(samples)) = (plot_target, &samples) {
        target.write(loaded, &system, samples, &title)?;
    }
    if let (Some(target), Some(samples)) = (page_target, &samples) {
        target.write(loaded, &system, samples, &[], &title)?;
    }
    let s = summary(
        &Summary {
            plan,
            outputs,
            loaded,
            consistency: &consistency,
            t0,
            times: (start.elapsed(), analysis),
            csv: (&csv.0, csv.1, csv.2),
        },
        &mut motion,
    );
    if csv.0 == Destination::Stdout {
        print_stderr(&s);
        Ok(())
    } else {
        print_stdout(&s)
    }
}

/// q̇ at the start: the model's stated initial velocities (a `.kin`
/// body's `velocity` item, zero elsewhere), or a simEngine2D body's `qd0`.
fn initial_velocities(loaded: &Loaded, n: usize) -> Vec<f64> {
    let mut qd0 = loaded.model.initial_velocities();
    qd0.resize(n, 0.0);
    if let Some(adm) = &loaded.adm {
        for (k, b) in adm.model.bodies.iter().enumerate() {
            let body = Body::new(k);
            let slot = body.coord(Axis::X).index()..=body.coord(Axis::Phi).index();
            if let (Some(v), Some(slot)) = (b.qd0, qd0.get_mut(slot)) {
                slot.copy_from_slice(&v);
            }
        }
    }
    qd0
}

/// The integration: the integrator, a copy of the system for the gravity
/// potential, and the energies at the start (for the work of the other
/// forces and the balance).
struct Motion {
    engine: Engine,
    /// Passages warned about so far.
    warned: usize,
    gravity_of: TapeForward,
    v0: f64,
    ke0: f64,
}

impl Motion {
    /// HHT from (q₀, q̇₀) made consistent (the accurate mode then starts
    /// from HHT's consistent state); a note when they were corrected.
    fn start(
        plan: &ForwardPlan,
        fwd: TapeForward,
        [q0, qd0]: [&[f64]; 2],
        t0: f64,
    ) -> Result<(Motion, Consistency), Failure> {
        let (h, rtol) = (plan.step, plan.rtol);
        let gravity_of = fwd.clone();
        let start_failure = |e: IntegrateError| {
            Failure::analysis(format_args!("forward dynamics cannot start: {e}"))
        };
        if plan.kind == DynamicsRun::Prescribed {
            let p = Prescribed::new(fwd, q0, t0).map_err(|e| {
                Failure::analysis(format_args!("the prescribed motion cannot start: {e}"))
            })?;
            let engine = Engine {
                motion: Box::new(p),
                head: "prescribed motion with redundant rows (minimum-norm solves at each output \
                       time)"
                    .to_owned(),
                prescribed: true,
            };
            return Ok((Motion::new(engine, gravity_of), Consistency::default()));
        }
        let accurate_system = (plan.integrator == Integrator::Accurate).then(|| fwd.clone());
        let options = HhtOptions {
            project_velocity: plan.project_velocity,
            ..HhtOptions::default()
        };
        let (hht, consistency) = Hht::new(fwd, q0, qd0, t0, options).map_err(start_failure)?;
        let engine = match accurate_system {
            None => Engine {
                head: format!(
                    "HHT-α (α = -0.1, β = 0.3025, γ = 0.6){}, step ≤ {h:e}",
                    if plan.project_velocity {
                        " with velocity projection"
                    } else {
                        ""
                    }
                ),
                motion: Box::new(hht),
                prescribed: false,
            },
            Some(system) => Engine {
                motion: Box::new(
                    Accurate::new(system, hht.q(), hht.qd(), t0, rtol).map_err(start_failure)?,
                ),
                head: format!(
                    "accurate (Dormand–Prince 5(4), index-1 with projection), rtol {rtol:e}"
                ),
                prescribed: false,
            },
        };
        // Corrections at the rounding of the start (cos(π/2) in a guess)
        // are not news.
        let roundoff = 1e-12 * (1.0 + q0.iter().chain(qd0).fold(0.0_f64, |m, x| m.max(x.abs())));
        if consistency.dq > roundoff || consistency.dqd > roundoff {
            print_stderr(&format!(
                "note: the initial conditions were made consistent: q moved by ‖Δq‖∞ = {:.3e} \
                 (‖Φ‖∞ was {:.3e}), q̇ by ‖Δq̇‖∞ = {:.3e} (‖Φ_q q̇ − ν‖∞ was {:.3e}), \
                 minimum-norm projections",
                consistency.dq, consistency.phi, consistency.dqd, consistency.velocity
            ));
        }
        Ok((Motion::new(engine, gravity_of), consistency))
    }

    /// The motion from its engine; the energies at the start.
    fn new(mut engine: Engine, mut gravity_of: TapeForward) -> Motion {
        if let Some(dependency) = engine.monitor().redundancy() {
            print_stderr(&format!(
                "warning: redundant constraints at the start: {dependency}; the motion is \
                 determined, but the constraint forces of these equations are not: their λ, \
                 reactions and driver efforts are the minimum-norm values the solver gives"
            ));
        }
        let v0 = gravity_of.gravity_potential(engine.q()) + 0.0;
        let ke0 = engine.kinetic_energy();
        Motion {
            engine,
            warned: 0,
            gravity_of,
            v0,
            ke0,
        }
    }

    /// One `warning:` line for each singular configuration passed since
    /// the last call (at most [`MAX_PASSAGE_WARNINGS`], then one count at
    /// the end of the run: [`summary`]).
    fn warn_passages(&mut self) {
        let passages = self.engine.monitor().passages();
        for p in passages.iter().take(MAX_PASSAGE_WARNINGS).skip(self.warned) {
            print_stderr(&format!("warning: {p}"));
        }
        self.warned = passages.len().min(MAX_PASSAGE_WARNINGS);
    }

    /// [kinetic T, potential V (gravity), work W of the other forces and
    /// drivers since the start] now: W = (T + V) − (T₀ + V₀) for a
    /// conservative model, from the integrator's own work account.
    fn energies(&mut self) -> [f64; 3] {
        let v = self.gravity_of.gravity_potential(self.engine.q()) + 0.0;
        let work = self.engine.work() - (self.v0 - v);
        [self.engine.kinetic_energy(), v, work]
    }

    /// Integrates to every output time in turn (step `h`), writing each
    /// row and keeping the states the figure or the page draws (thinned
    /// to at most [`MAX_PLOT_STATES`]). The CSV, to finish.
    ///
    /// # Errors
    /// A failed step (the rows before it kept), a failed write.
    fn integrate(
        &mut self,
        energy_columns: bool,
        loaded: &Loaded,
        system: &kinema::TapeSystem,
        (outputs_t, h): (&[f64], f64),
        mut sink: CsvSink,
        samples: &mut Option<super::plot::Samples>,
    ) -> Result<CsvSink, Failure> {
        let d = loaded.model.derivation();
        let rows = d.rows.len();
        let mut row = kinema::dynamics::DynamicsRow::new(system, rows);
        let stride = outputs_t.len().div_ceil(MAX_PLOT_STATES).max(1);
        // The row's extra columns with the energies appended (`--energy`).
        let mut extra = Vec::new();
        // Rows with an equation its own arithmetic does not determine (every
        // equation checked on the first, those that read t after it).
        let mut imprecise = Vec::new();
        for (k, &t) in outputs_t.iter().enumerate() {
            if k > 0 {
                // An equation without a value inside the interval (a pole of
                // a driver between two steps) stops the run there: no step
                // size follows it, and one stepping over it would print
                // numbers of a model that does not exist there.
                let interval = (self.engine.t(), t, f64::NAN);
                let ahead =
                    kinema::undefined_between(system, row.scratch(), self.engine.q(), interval);
                let result = match ahead {
                    Some(u) => Err((None, Some(u))),
                    None => self.engine.advance_to(t, h).map_err(|e| (Some(e), None)),
                };
                self.warn_passages();
                if let Err((e, undefined)) = result {
                    super::warnings::print_imprecision_warning(system, &imprecise);
                    let undefined = undefined.or_else(|| {
                        let failed_at = match &e {
                            Some(
                                IntegrateError::NoConvergence { t, .. }
                                | IntegrateError::Singular { t, .. }
                                | IntegrateError::NonFinite { t, .. },
                            ) => *t,
                            _ => f64::NAN,
                        };
                        let bracket = (self.engine.t(), t, failed_at);
                        kinema::undefined_between(system, row.scratch(), self.engine.q(), bracket)
                    });
                    let cause = Cause {
                        monitor: self.engine.monitor(),
                        undefined,
                    };
                    return Err(step_failure(sink, e.as_ref(), loaded, &cause));
                }
            }
            let at = kinema::Motion {
                t: self.engine.t(),
                q: self.engine.q(),
                qd: self.engine.qd(),
                qdd: self.engine.qdd(),
            };
            row.fill(system, at, self.engine.lambda()).map_err(|e| {
                Failure::analysis(format_args!("the reactions at t = {}: {e}", at.t))
            })?;
            let scope = if k == 0 {
                PrecisionScope::All
            } else {
                PrecisionScope::Timed
            };
            // The integrator's q satisfies Φ to its own tolerance; its
            // roundoff at the unit size is the floor (as a kinematic run
            // of a model of size 1 or more).
            if let Some(i) =
                system.imprecision_at(row.scratch(), self.engine.q(), t, 0.0, 1.0, scope)
            {
                imprecise.push((t, i));
            }
            extra.clear();
            extra.extend_from_slice(row.dynamics());
            let sampled = k.is_multiple_of(stride) || k + 1 == outputs_t.len();
            let energy =
                (energy_columns || (samples.is_some() && sampled)).then(|| self.energies());
            if energy_columns && let Some(e) = energy {
                extra.extend(e);
            }
            let (q, qd, qdd) = (self.engine.q(), self.engine.qd(), self.engine.qdd());
            let [y, yd, ydd] = row.outputs();
            sink.write_values(t, [q, qd, qdd], [y, yd, ydd], &extra)?;
            if let Some(samples) = samples
                && sampled
            {
                samples.push_values(t, [q, qd, qdd]);
                samples.push_dynamics(row.dynamics());
                if let Some([kinetic, potential, work]) = energy {
                    samples.push_energy(kinetic, potential, work);
                }
            }
        }
        super::warnings::print_imprecision_warning(system, &imprecise);
        Ok(sink)
    }
}

/// What the summary of a forward-dynamics run reports.
struct Summary<'a> {
    plan: &'a ForwardPlan,
    outputs: &'a OutputPlan,
    loaded: &'a Loaded,
    consistency: &'a Consistency,
    t0: f64,
    /// Total and analysis time.
    times: (std::time::Duration, std::time::Duration),
    /// Where the CSV went, its rows and columns.
    csv: (&'a Destination, usize, usize),
}

/// The summary: the model, grid, integrator, consistency corrections, the
/// energies at both ends and the balance (with a warning on standard error
/// when it is off by more than 1 % of the energies), times, files.
fn summary(s: &Summary<'_>, motion: &mut Motion) -> String {
    let (plan, loaded) = (s.plan, s.loaded);
    let d = loaded.model.derivation();
    let (n, rows) = (d.nc(), d.rows.len());
    let [ke, v, other] = motion.energies();
    let (ke0, v0) = (motion.ke0, motion.v0);
    let mut out = String::new();
    let nb = d.bodies.len();
    let _ = writeln!(
        out,
        "{} ({}): {nb} bod{}, {n} coordinates, {rows} equations, {} (tape back \
         end)",
        loaded.checked().name,
        loaded.file,
        if nb == 1 { "y" } else { "ies" },
        if motion.engine.prescribed {
            "prescribed motion with redundant rows"
        } else {
            "forward dynamics"
        }
    );
    let _ = writeln!(out, "  grid: {}", plan.description);
    let _ = writeln!(out, "  integrator: {}", motion.engine.describe());
    let _ = writeln!(
        out,
        "  start: ‖Δq‖∞ = {:.2e}, ‖Δq̇‖∞ = {:.2e} (consistency projections)",
        s.consistency.dq, s.consistency.dqd
    );
    let _ = writeln!(
        out,
        "  energy at t = {}: kinetic {ke:.9e}, potential (gravity) {v:.9e}; at t = {}: kinetic \
         {ke0:.9e}, potential {v0:.9e}",
        time(motion.engine.t()),
        time(s.t0)
    );
    let balance = (ke + v) - (ke0 + v0) - other;
    let _ = writeln!(
        out,
        "  work of the other forces and drivers {other:.9e}; balance error {balance:.3e}"
    );
    warn_balance(plan.integrator, balance, [ke, v, ke0, v0, other]);
    let monitor = motion.engine.monitor();
    let passages = monitor.passages();
    if !passages.is_empty() {
        let times: Vec<String> = passages.iter().map(|p| time(p.t)).collect();
        let _ = writeln!(
            out,
            "  singular configurations passed: {} (t = {})",
            passages.len(),
            times.join(", ")
        );
        if passages.len() > MAX_PASSAGE_WARNINGS {
            print_stderr(&format!(
                "warning: … and {} more singular configurations passed, up to t = {} (not \
                 listed one by one)",
                passages.len() - MAX_PASSAGE_WARNINGS,
                time(passages[passages.len() - 1].t)
            ));
        }
    }
    if let Some(d) = monitor.redundancy() {
        let _ = writeln!(
            out,
            "  redundant constraints: {} (rank {} of {})",
            d.redundant.join(", "),
            d.rank.unwrap_or(0),
            d.dim
        );
    }
    let _ = writeln!(
        out,
        "  time: {} (model {}, analysis {})",
        duration(s.times.0),
        duration(loaded.elapsed),
        duration(s.times.1)
    );
    let (destination, out_rows, columns) = s.csv;
    let csv = match destination {
        Destination::Stdout => "standard output".to_string(),
        Destination::File(p) => format!("`{}`", p.display()),
    };
    let _ = write!(out, "  wrote {csv} ({out_rows} rows × {columns} columns)");
    for p in [s.outputs.plot.as_deref(), s.outputs.animate.as_deref()]
        .into_iter()
        .flatten()
    {
        let _ = write!(out, " and `{}`", p.display());
    }
    out
}

/// The balance is the run's own accuracy check: a large error is said, not
/// left in a number of the summary.
fn warn_balance(integrator: Integrator, balance: f64, energies: [f64; 5]) {
    let scale = energies.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    if balance.is_nan() || balance.abs() > 1e-2 * scale {
        print_stderr(&format!(
            "warning: the energy balance is off by {balance:.3e} ({:.1}% of the energies): the \
             results are not accurate; {}",
            100.0 * balance.abs() / scale.max(f64::MIN_POSITIVE),
            match integrator {
                Integrator::Hht => "try a smaller --step or --integrator accurate",
                Integrator::Accurate => "try a smaller --rtol",
            }
        ));
    }
}

/// What a failed step is put down to, beyond the integrator's own error.
struct Cause<'a> {
    monitor: &'a Monitor,
    /// An equation undefined or unbounded in the failed step's bracket.
    undefined: Option<kinema::Error>,
}

/// The error of a run that stopped: the integrator's `e` (none when the
/// run stopped before a step, at an undefined equation), its cause.
fn step_failure(
    sink: CsvSink,
    e: Option<&IntegrateError>,
    loaded: &Loaded,
    cause: &Cause<'_>,
) -> Failure {
    let note = sink.finish_after_failure();
    let monitor = cause.monitor;
    let mut message = format!("error: forward dynamics of `{}`: ", loaded.file);
    // An equation without a value explains the failure better than the
    // integrator's symptom of it (which follows as a note).
    match (&cause.undefined, e) {
        (Some(u), Some(e)) => {
            let _ = write!(message, "{u}\n  = note: the integrator stopped: {e}");
        }
        (Some(u), None) => {
            let _ = write!(message, "{u}: no step can be taken through it");
        }
        (None, Some(e)) => {
            let _ = write!(message, "{e}");
        }
        (None, None) => message.push_str("the run stopped"),
    }
    if monitor.near_singular() {
        let _ = write!(
            message,
            "\n  = note: the last state computed is at a singular configuration or next to one \
             (smallest scaled singular value of Φ_q {:.1e}): the step failed there",
            monitor.last_s()
        );
    }
    if let Some(adm) = &loaded.adm
        && let Some(IntegrateError::NoConvergence { equation, .. }) = e
        && let Some(name) = equation
            .strip_prefix("constraint `")
            .and_then(|s| s.strip_suffix('`'))
    {
        message.push_str(&adm.explain(&[name]));
    }
    message.push_str(&note);
    Failure::Analysis(message)
}
