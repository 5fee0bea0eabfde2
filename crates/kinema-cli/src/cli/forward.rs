//! `kinema run` of forward dynamics: a `.kin` model with NDOF > 0 and
//! inertia, or a simEngine2D model under a Dynamics ACF. HHT-α at a fixed
//! step (`--step`, or the ACF's `stepSize`) shortened to land on every
//! output time; the CSV has the columns of a Dynamics I run (q, q̇, q̈,
//! named points and outputs, λ, reactions, driver efforts); the summary
//! gives the consistency corrections at the start, Newton's work and the
//! energy balance.

use std::fmt::Write as _;
use std::time::Instant;

use kinema::forward::TapeForward;
use kinema::integrate::Consistency;
use kinema::{
    Accurate, Dynamics, ForwardSystem, Hht, HhtOptions, IntegrateError, PrecisionScope, System,
};

use super::args::{Integrator, RunArgs};
use super::files::RunFiles;
use super::load::Loaded;
use super::output::{CsvSink, Destination, duration, time};
use super::{Failure, print_stderr, print_stdout};

/// Default step of a `.kin` model's forward dynamics.
pub const DEFAULT_STEP: f64 = 1e-3;
/// Default tolerance of `--integrator accurate`.
pub const DEFAULT_RTOL: f64 = 1e-8;

/// The integrator of a run.
enum Engine {
    Hht(Box<Hht<TapeForward>>),
    Accurate(Box<Accurate<TapeForward>>),
}

impl Engine {
    fn advance_to(&mut self, t: f64, h: f64) -> Result<(), IntegrateError> {
        match self {
            Engine::Hht(e) => e.advance_to(t, h),
            Engine::Accurate(e) => e.advance_to(t),
        }
    }
    fn t(&self) -> f64 {
        match self {
            Engine::Hht(e) => e.t(),
            Engine::Accurate(e) => e.t(),
        }
    }
    fn q(&self) -> &[f64] {
        match self {
            Engine::Hht(e) => e.q(),
            Engine::Accurate(e) => e.q(),
        }
    }
    fn qd(&self) -> &[f64] {
        match self {
            Engine::Hht(e) => e.qd(),
            Engine::Accurate(e) => e.qd(),
        }
    }
    fn qdd(&self) -> &[f64] {
        match self {
            Engine::Hht(e) => e.qdd(),
            Engine::Accurate(e) => e.qdd(),
        }
    }
    fn lambda(&self) -> &[f64] {
        match self {
            Engine::Hht(e) => e.lambda(),
            Engine::Accurate(e) => e.lambda(),
        }
    }
    fn work(&self) -> f64 {
        match self {
            Engine::Hht(e) => e.work(),
            Engine::Accurate(e) => e.work(),
        }
    }
    fn kinetic_energy(&mut self) -> f64 {
        match self {
            Engine::Hht(e) => e.kinetic_energy(),
            Engine::Accurate(e) => e.kinetic_energy(),
        }
    }
    fn system_mut(&mut self) -> &mut TapeForward {
        match self {
            Engine::Hht(e) => e.system_mut(),
            Engine::Accurate(e) => e.system_mut(),
        }
    }
    /// The summary's line on the integrator (`projected`: HHT projects
    /// velocities).
    fn describe(&self, h: f64, rtol: f64, projected: bool) -> String {
        match self {
            Engine::Hht(e) => {
                let stats = e.stats();
                format!(
                    "HHT-α (α = -0.1, β = 0.3025, γ = 0.6){}, step ≤ {h:e}: {} steps, Newton \
                     iterations per step mean {:.2}, max {}, {} factorizations",
                    if projected {
                        " with velocity projection"
                    } else {
                        ""
                    },
                    stats.steps,
                    if stats.steps == 0 {
                        0.0
                    } else {
                        stats.iterations as f64 / stats.steps as f64
                    },
                    stats.max_iterations,
                    stats.factorizations
                )
            }
            Engine::Accurate(e) => {
                let stats = e.stats();
                format!(
                    "accurate (Dormand–Prince 5(4), index-1 with projection), rtol {rtol:e}: \
                     {} steps accepted, {} rejected, {} evaluations",
                    stats.accepted, stats.rejected, stats.evaluations
                )
            }
        }
    }
}

/// Whether `loaded` runs as forward dynamics: it has inertia and NDOF > 0.
pub fn is_forward(loaded: &Loaded) -> bool {
    loaded.model.derivation().dynamics.is_some() && loaded.checked.dof().ndof() > 0
}

/// Refuses the forward-dynamics options in a kinematic run.
///
/// # Errors
/// [`Failure::Input`] naming the option.
pub fn refuse_options(args: &RunArgs) -> Result<(), Failure> {
    if args.rtol.is_some()
        || args.integrator != Integrator::Hht
        || args.energy
        || args.project_velocity
    {
        return Err(Failure::usage(
            "--integrator, --rtol, --project-velocity and --energy are for forward dynamics (a \
             model with inertia and NDOF > 0, or a Dynamics ACF)",
        ));
    }
    if args.step.is_some() {
        return Err(Failure::usage(
            "--step is for forward dynamics (a model with inertia and NDOF > 0, or a Dynamics ACF); \
             a kinematic run takes --t-end and --steps",
        ));
    }
    Ok(())
}

/// The columns `--energy` adds after the dynamics columns.
const ENERGY_COLUMNS: [&str; 3] = ["energy.kinetic", "energy.potential", "energy.work"];

/// Runs forward dynamics of `loaded`, writing the state at each of
/// `outputs` (increasing, from t₀ = outputs[0]). `acf_step`: the ACF's
/// `stepSize`; `grid`: the grid's description for the summary.
///
/// # Errors
/// Usage errors (a bad step, `--plot`/`--animate`, a model without
/// inertia); [`Failure::Analysis`] when a step fails (the rows before it
/// are kept).
pub fn run(
    args: &RunArgs,
    loaded: &Loaded,
    outputs_t: &[f64],
    acf_step: Option<f64>,
    grid: &str,
) -> Result<(), Failure> {
    let start = Instant::now();
    let rtol = args.rtol.unwrap_or(DEFAULT_RTOL);
    let h = check_options(args, rtol, acf_step)?;
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
    let dyn_names = super::dynamics::column_names(&system, d.rows.len(), loaded.adm.is_some());
    let mut extra = dyn_names.clone();
    if args.energy {
        extra.extend(ENERGY_COLUMNS.map(String::from));
    }
    let files = RunFiles::create(args, d, &extra)?;
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
    let (mut motion, consistency) = Motion::start(args, fwd, [&q0, &qd0], t0, rtol)?;
    let sink = motion.integrate(args, loaded, &system, (outputs_t, h), sink, &mut samples)?;
    let csv = (sink.destination().clone(), sink.rows(), sink.columns());
    sink.finish()?;
    let analysis = analysis_start.elapsed();
    let title = format!("{}: forward dynamics", loaded.checked.name);
    if let (Some(target), Some(samples)) = (plot_target, &samples) {
        target.write(loaded, &system, samples, &title)?;
    }
    if let (Some(target), Some(samples)) = (page_target, &samples) {
        target.write(loaded, &system, samples, &[], &title)?;
    }
    let s = summary(
        &Summary {
            args,
            loaded,
            grid,
            h,
            rtol,
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

/// Checks the integrator's options against each other; the step: `--step`,
/// or the ACF's, or [`DEFAULT_STEP`].
fn check_options(args: &RunArgs, rtol: f64, acf_step: Option<f64>) -> Result<f64, Failure> {
    match args.integrator {
        Integrator::Hht if args.rtol.is_some() => {
            return Err(Failure::usage(
                "--rtol is the tolerance of --integrator accurate; HHT takes --step",
            ));
        }
        Integrator::Accurate if args.project_velocity => {
            return Err(Failure::usage(
                "--project-velocity is for --integrator hht: the accurate mode projects positions \
                 and velocities after every step already",
            ));
        }
        Integrator::Accurate if args.step.is_some() => {
            return Err(Failure::usage(
                "--step is HHT's; --integrator accurate chooses its steps to meet --rtol",
            ));
        }
        Integrator::Accurate if !(rtol > 1e-14 && rtol < 1.0) => {
            return Err(Failure::usage(format_args!(
                "--rtol must be in (1e-14, 1), not {rtol}"
            )));
        }
        _ => {}
    }
    if args.stop_at_singular {
        return Err(Failure::usage(
            "--stop-at-singular is for kinematic runs: forward dynamics stops at a step that \
             fails",
        ));
    }
    let h = args.step.or(acf_step).unwrap_or(DEFAULT_STEP);
    if !(h.is_finite() && h > 0.0) {
        return Err(Failure::usage(format_args!(
            "the step must be positive and finite, not {h}"
        )));
    }
    Ok(h)
}

/// q̇ at the start: the model's stated initial velocities (a `.kin`
/// body's `velocity` item, zero elsewhere), or a simEngine2D body's `qd0`.
fn initial_velocities(loaded: &Loaded, n: usize) -> Vec<f64> {
    let mut qd0 = loaded.model.initial_velocities();
    qd0.resize(n, 0.0);
    if let Some(adm) = &loaded.adm {
        for (k, b) in adm.model.bodies.iter().enumerate() {
            if let (Some(v), Some(slot)) = (b.qd0, qd0.get_mut(3 * k..3 * k + 3)) {
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
    gravity_of: TapeForward,
    v0: f64,
    ke0: f64,
}

impl Motion {
    /// HHT from (q₀, q̇₀) made consistent (the accurate mode then starts
    /// from HHT's consistent state); a note when they were corrected.
    fn start(
        args: &RunArgs,
        fwd: TapeForward,
        [q0, qd0]: [&[f64]; 2],
        t0: f64,
        rtol: f64,
    ) -> Result<(Motion, Consistency), Failure> {
        let mut gravity_of = fwd.clone();
        let accurate_system = (args.integrator == Integrator::Accurate).then(|| fwd.clone());
        let start_failure = |e: IntegrateError| {
            Failure::analysis(format_args!("forward dynamics cannot start: {e}"))
        };
        let options = HhtOptions {
            project_velocity: args.project_velocity,
            ..HhtOptions::default()
        };
        let (hht, consistency) = Hht::new(fwd, q0, qd0, t0, options).map_err(start_failure)?;
        let mut engine = match accurate_system {
            None => Engine::Hht(Box::new(hht)),
            Some(system) => Engine::Accurate(Box::new(
                Accurate::new(system, hht.q(), hht.qd(), t0, rtol).map_err(start_failure)?,
            )),
        };
        if consistency.dq > 0.0 || consistency.dqd > 0.0 {
            print_stderr(&format!(
                "note: the initial conditions were made consistent: q moved by ‖Δq‖∞ = {:.3e} \
                 (‖Φ‖∞ was {:.3e}), q̇ by ‖Δq̇‖∞ = {:.3e} (‖Φ_q q̇ − ν‖∞ was {:.3e}), \
                 minimum-norm projections",
                consistency.dq, consistency.phi, consistency.dqd, consistency.velocity
            ));
        }
        let v0 = gravity_of.gravity_potential(engine.q()) + 0.0;
        let ke0 = engine.kinetic_energy();
        let motion = Motion {
            engine,
            gravity_of,
            v0,
            ke0,
        };
        Ok((motion, consistency))
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
    /// to at most [`super::run::MAX_PLOT_STATES`]). The CSV, to finish.
    ///
    /// # Errors
    /// A failed step (the rows before it kept), a failed write.
    fn integrate(
        &mut self,
        args: &RunArgs,
        loaded: &Loaded,
        system: &kinema::TapeSystem,
        (outputs_t, h): (&[f64], f64),
        mut sink: CsvSink,
        samples: &mut Option<super::plot::Samples>,
    ) -> Result<CsvSink, Failure> {
        let d = loaded.model.derivation();
        let (n, rows) = (d.nc(), d.rows.len());
        let mut row = RowBuffers::new(system, n, rows, d.phi_q.entries.len(), d.outputs.len());
        let stride = outputs_t.len().div_ceil(super::run::MAX_PLOT_STATES).max(1);
        // The row's extra columns with the energies appended (`--energy`).
        let mut extra = Vec::new();
        // Rows with an equation its own arithmetic does not determine (every
        // equation checked on the first, those that read t after it).
        let mut imprecise = Vec::new();
        for (k, &t) in outputs_t.iter().enumerate() {
            if k > 0
                && let Err(e) = self.engine.advance_to(t, h)
            {
                super::run::print_imprecision_warning(system, &imprecise);
                return Err(step_failure(sink, &e, loaded));
            }
            row.fill(system, &mut self.engine)?;
            let scope = if k == 0 {
                PrecisionScope::All
            } else {
                PrecisionScope::Timed
            };
            // The integrator's q satisfies Φ to its own tolerance; its
            // roundoff at the unit size is the floor (as a kinematic run
            // of a model of size 1 or more).
            if let Some(i) =
                system.imprecision_at(&mut row.scratch, self.engine.q(), t, 0.0, 1.0, scope)
            {
                imprecise.push((t, i));
            }
            extra.clear();
            extra.extend_from_slice(&row.extra);
            let sampled = k.is_multiple_of(stride) || k + 1 == outputs_t.len();
            let energy = (args.energy || (samples.is_some() && sampled)).then(|| self.energies());
            if args.energy
                && let Some(e) = energy
            {
                extra.extend(e);
            }
            let (q, qd, qdd) = (self.engine.q(), self.engine.qd(), self.engine.qdd());
            let [y, yd, ydd] = &row.results;
            sink.write_values(t, [q, qd, qdd], [y, yd, ydd], &extra)?;
            if let Some(samples) = samples
                && sampled
            {
                samples.push_values(t, [q, qd, qdd]);
                samples.push_dynamics(&row.extra);
                if let Some([kinetic, potential, work]) = energy {
                    samples.push_energy(kinetic, potential, work);
                }
            }
        }
        super::run::print_imprecision_warning(system, &imprecise);
        Ok(sink)
    }
}

/// What the summary of a forward-dynamics run reports.
struct Summary<'a> {
    args: &'a RunArgs,
    loaded: &'a Loaded,
    /// The grid's description.
    grid: &'a str,
    h: f64,
    rtol: f64,
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
    let (args, loaded) = (s.args, s.loaded);
    let d = loaded.model.derivation();
    let (n, rows) = (d.nc(), d.rows.len());
    let [ke, v, other] = motion.energies();
    let (ke0, v0) = (motion.ke0, motion.v0);
    let mut out = String::new();
    let nb = d.bodies.len();
    let _ = writeln!(
        out,
        "{} ({}): {nb} bod{}, {n} coordinates, {rows} equations, forward dynamics (tape back \
         end)",
        loaded.checked.name,
        loaded.file,
        if nb == 1 { "y" } else { "ies" },
    );
    let _ = writeln!(out, "  grid: {}", s.grid);
    let _ = writeln!(
        out,
        "  integrator: {}",
        motion.engine.describe(s.h, s.rtol, args.project_velocity)
    );
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
    warn_balance(args, balance, [ke, v, ke0, v0, other]);
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
    for p in [args.plot.as_deref(), args.animate.as_deref()]
        .into_iter()
        .flatten()
    {
        let _ = write!(out, " and `{}`", p.display());
    }
    out
}

/// The balance is the run's own accuracy check: a large error is said, not
/// left in a number of the summary.
fn warn_balance(args: &RunArgs, balance: f64, energies: [f64; 5]) {
    let scale = energies.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    if balance.is_nan() || balance.abs() > 1e-2 * scale {
        print_stderr(&format!(
            "warning: the energy balance is off by {balance:.3e} ({:.1}% of the energies): the \
             results are not accurate; {}",
            100.0 * balance.abs() / scale.max(f64::MIN_POSITIVE),
            match args.integrator {
                Integrator::Hht => "try a smaller --step or --integrator accurate",
                Integrator::Accurate => "try a smaller --rtol",
            }
        ));
    }
}

fn step_failure(sink: CsvSink, e: &IntegrateError, loaded: &Loaded) -> Failure {
    let note = sink.finish_after_failure();
    let mut message = format!("error: forward dynamics of `{}`: {e}", loaded.file);
    if let Some(adm) = &loaded.adm
        && let IntegrateError::NoConvergence { equation, .. } = e
        && let Some(name) = equation
            .strip_prefix("constraint `")
            .and_then(|s| s.strip_suffix('`'))
    {
        message.push_str(&adm.explain(&[name]));
    }
    message.push_str(&note);
    Failure::Analysis(message)
}

/// Buffers of one CSV row's derived values.
struct RowBuffers {
    n: usize,
    rows: usize,
    q: Vec<f64>,
    jac: Vec<f64>,
    values: Vec<f64>,
    results: [Vec<f64>; 3],
    extra: Vec<f64>,
    scratch: <kinema::TapeSystem as System>::Scratch,
}

impl RowBuffers {
    fn new(
        system: &kinema::TapeSystem,
        n: usize,
        rows: usize,
        _nnz: usize,
        outputs: usize,
    ) -> RowBuffers {
        RowBuffers {
            n,
            rows,
            q: vec![0.0; n],
            jac: vec![0.0; rows * n],
            values: vec![0.0; system.dynamics_len()],
            results: [vec![0.0; outputs], vec![0.0; outputs], vec![0.0; outputs]],
            extra: Vec::new(),
            scratch: system.scratch(),
        }
    }

    /// Named points and outputs, λ, reactions and efforts at the state.
    fn fill(&mut self, system: &kinema::TapeSystem, hht: &mut Engine) -> Result<(), Failure> {
        let (n, rows) = (self.n, self.rows);
        let t = hht.t();
        self.q.copy_from_slice(hht.q());
        hht.system_mut().jacobian(&self.q, t, &mut self.jac);
        let (q, qd, qdd, lambda) = (hht.q(), hht.qd(), hht.qdd(), hht.lambda());
        {
            let [y, yd, ydd] = &mut self.results;
            kinema::Outputs::outputs(system, &mut self.scratch, t, q, qd, qdd, y, yd, ydd);
        }
        system.dynamics(&mut self.scratch, q, qd, t, &mut self.values);
        self.extra.clear();
        self.extra.extend_from_slice(lambda);
        let arms = self.values.get(2 * n..).unwrap_or(&[]);
        for (spec, arm) in system.reactions().iter().zip(arms.chunks_exact(2)) {
            let mut g = [0.0; 3];
            let (r0, r1) = (spec.rows.0 as usize, (spec.rows.1 as usize).min(rows));
            for (row, &l) in lambda.iter().enumerate().take(r1).skip(r0) {
                for (c, gc) in g.iter_mut().enumerate() {
                    let col = 3 * spec.body as usize + c;
                    *gc -= self.jac.get(row * n + col).copied().unwrap_or(f64::NAN) * l;
                }
            }
            let torque = g[2] - (-arm[1] * g[0] + arm[0] * g[1]);
            self.extra.extend([g[0], g[1], torque]);
        }
        let start = system.driving_start().min(rows);
        self.extra.extend(lambda[start..].iter().map(|l| -l));
        Ok(())
    }
}
