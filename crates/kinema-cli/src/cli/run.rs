//! `kinema run MODEL` of a kinematic plan ([`KinematicPlan`]): kinematic
//! analysis over a time grid through the tape back end, streaming the CSV,
//! with a summary and an optional plot.

use std::fmt::Write as _;
use std::path::Path;
use std::time::{Duration, Instant};

use kinema::{Auto, SingularEvent, SingularKind, Solver, State, TapeSystem};

use super::args::Backend;
use super::files::RunFiles;
use super::load::Loaded;
use super::output::{CsvSink, Destination, duration, rows_at, time};
use super::plan::{KinematicPlan, OutputPlan};
use super::plot::Samples;
use super::progress::Progress;
use super::sensitivity::SensitivityColumns;
use super::shared::grid::{Grid, MAX_PLOT_STATES};
use super::shared::report::{assembly_warnings, run_error};
use super::warnings::{
    equation_of, kink_function, print_imprecision_warning, print_kink_warning,
    print_singular_warnings,
};
use super::{Failure, animate};

/// What the run cost, for the summary.
#[derive(Debug, Clone, Default)]
struct Stats {
    assembly_iterations: usize,
    steps: usize,
    iterations: usize,
    max_iterations: usize,
    /// Steps placed in closed form (`Options::closed_form`).
    closed_form: usize,
    worst_residual: f64,
    worst_residual_t: f64,
    events: usize,
}

impl Stats {
    /// Records one analysis; `first` is the assembly, always recorded first.
    fn record(&mut self, first: bool, state: &State) {
        let s = state.stats();
        if first {
            self.assembly_iterations = s.iterations;
        } else {
            self.steps += 1;
            self.iterations += s.iterations;
            self.max_iterations = self.max_iterations.max(s.iterations);
            self.closed_form += usize::from(s.closed_form);
        }
        if first || s.residual > self.worst_residual {
            self.worst_residual = s.residual;
            self.worst_residual_t = state.t();
        }
    }
}

/// Kinematic analysis (and inverse dynamics for a model with inertia)
/// over `grid`: the files created first, then the time loop, then the
/// figure, the page and the summary.
///
/// # Errors
/// [`Failure::Input`] for an output that cannot be created or a bad
/// `--columns`, [`Failure::Analysis`] when the analysis fails (the rows
/// computed before the failure are kept) or its results cannot be
/// written.
pub fn kinematics(
    loaded: &Loaded,
    plan: &KinematicPlan,
    outputs: &OutputPlan,
) -> Result<(), Failure> {
    let grid = &plan.grid;
    // Outputs are created before the analysis: a bad path fails at once.
    let system = loaded.model.system();
    if let Some(why) = system.jit_fallback() {
        super::print_stderr(&format!("note: {why}; running on the tape interpreter"));
    }
    let derivation = loaded.model.derivation();
    // Inverse dynamics needs the accelerations: no such columns with
    // positions only.
    let dynamics =
        super::dynamics::DynamicsColumns::new(&system, derivation.rows.len(), loaded.adm.is_some())
            .filter(|_| !plan.options.positions_only);
    let sensitivity = plan
        .sensitivity
        .clone()
        .map(|s| {
            let columns = dynamics.as_ref().map(|d| d.names());
            SensitivityColumns::new(*s, outputs, &loaded.model, columns)
        })
        .transpose()?;
    let mut extra: Vec<String> = dynamics.as_ref().map_or(&[][..], |d| d.names()).to_vec();
    extra.extend_from_slice(sensitivity.as_ref().map_or(&[][..], |s| s.names()));
    let files = RunFiles::create(outputs, derivation, &extra)?;

    let analysis_start = Instant::now();
    let mut solver = Solver::<TapeSystem, Auto>::with_options(system, plan.options)
        .map_err(|e| Failure::analysis(format_args!("cannot set up the solver: {e}")))?;
    let keep = files.keep_states();
    let RunFiles {
        csv,
        plot: plot_target,
        page: page_target,
    } = files;
    let mut rows = Rows::new(
        csv,
        &solver,
        derivation,
        (dynamics, sensitivity),
        keep,
        grid,
    );
    let mut stats = Stats::default();
    let mut progress = Progress::new(grid.times.len());
    for (k, (&t, &is_output)) in grid.times.iter().zip(&grid.output).enumerate() {
        if let Err(e) = solver.step(t) {
            progress.finish();
            return Err(step_failure(&solver, rows, loaded, page_target, grid, &e));
        }
        // A state exists after a successful step.
        let Some(state) = solver.state() else {
            continue;
        };
        stats.record(k == 0, state);
        if k == 0 {
            for w in assembly_warnings(loaded, solver.system(), state.q()) {
                eprintln!("{w}");
            }
        }
        if is_output {
            if state.near_singular() {
                rows.flagged.push(state.t());
            }
            if let Some(kink) = state.kink() {
                rows.kinks.push((state.t(), kink));
            }
            if let Some(imprecision) = rows.imprecision(&solver, state) {
                rows.imprecise.push((state.t(), imprecision));
            }
            if let Err(failure) = rows.write(&mut solver, loaded, t) {
                progress.finish();
                return Err(rows.stop(failure));
            }
        }
        progress.update(k + 1, t);
    }
    progress.finish();
    let events = solver.close_events().to_vec();
    print_singular_warnings(&events, &rows.flagged);
    print_kink_warnings(solver.system(), &rows);
    print_imprecision_warning(solver.system(), &rows.imprecise);
    print_sensitivity_warning(&rows);
    stats.events = events.len();
    let w = Instant::now();
    let sink = &rows.sink;
    let csv = (sink.destination().clone(), sink.rows(), sink.columns());
    rows.sink.finish()?;
    let write_time = rows.write_time + w.elapsed();
    let analysis = analysis_start.elapsed().saturating_sub(write_time);

    let title = plot_title(loaded, grid);
    let plot_start = Instant::now();
    if let (Some(target), Some(samples)) = (plot_target, &rows.samples) {
        target.write(loaded, solver.system(), samples, &title)?;
    }
    let plot_time = outputs.plot.as_ref().map(|_| plot_start.elapsed());
    let page_start = Instant::now();
    if let (Some(target), Some(samples)) = (page_target, &rows.samples) {
        let markers: Vec<animate::Marker> = events.iter().map(event_marker).collect();
        target.write(loaded, solver.system(), samples, &markers, &title)?;
    }
    let page_time = outputs.animate.as_ref().map(|_| page_start.elapsed());

    let destination = csv.0.clone();
    let summary = summary(&SummaryInput {
        loaded,
        backend: (plan.backend, solver.system().backend()),
        grid,
        stats: &stats,
        csv: (&csv.0, csv.1, csv.2),
        plot: outputs.plot.as_deref(),
        page: outputs.animate.as_deref(),
        total: plan.start.elapsed(),
        analysis,
        write: write_time,
        plot_time,
        page_time,
    });
    if destination == Destination::Stdout {
        super::print_stderr(&summary);
        Ok(())
    } else {
        super::print_stdout(&summary)
    }
}

/// The rows of a kinematic run: the CSV, inverse dynamics' columns, the
/// results' buffers, the states kept for a figure or page (thinned evenly
/// to at most [`MAX_PLOT_STATES`], the last one always kept), and the
/// output times flagged near singular.
struct Rows {
    sink: CsvSink,
    dynamics: Option<super::dynamics::DynamicsColumns>,
    /// `--sensitivity`'s columns, after the dynamics'.
    sensitivity: Option<SensitivityColumns>,
    /// A row's extra columns: inverse dynamics', then the sensitivities'.
    extra: Vec<f64>,
    results: [Vec<f64>; 3],
    scratch: <TapeSystem as kinema::System>::Scratch,
    samples: Option<Samples>,
    /// The last output state's time if thinning left it out of `samples`.
    skipped: Option<f64>,
    flagged: Vec<f64>,
    /// Output times whose q puts a function at its kink, and which: of an
    /// equation, of a result column.
    kinks: Vec<(f64, kinema::Kink)>,
    output_kinks: Vec<(f64, kinema::OutputKink)>,
    /// Output times whose equations their own roundoff does not determine,
    /// and the worst of each.
    imprecise: Vec<(f64, kinema::Imprecision)>,
    /// Whether a row has had the check of every equation.
    checked_all: bool,
    /// Output times in the grid, every how many one is kept, how many are
    /// written.
    outputs: usize,
    stride: usize,
    written: usize,
    write_time: Duration,
}

impl Rows {
    fn new(
        sink: CsvSink,
        solver: &Solver<TapeSystem, Auto>,
        derivation: &kinema::lang::Derivation,
        (dynamics, sensitivity): (
            Option<super::dynamics::DynamicsColumns>,
            Option<SensitivityColumns>,
        ),
        keep: bool,
        grid: &Grid,
    ) -> Rows {
        let m = derivation.outputs.len();
        let samples = keep.then(|| {
            let s = Samples::new(derivation.coordinates.len());
            match &dynamics {
                Some(d) => s.with_dynamics(d.names()),
                None => s,
            }
        });
        let outputs = grid.output.iter().filter(|&&o| o).count();
        let extra = dynamics.as_ref().map_or(0, |d| d.names().len())
            + sensitivity.as_ref().map_or(0, |s| s.names().len());
        Rows {
            sink,
            dynamics,
            sensitivity,
            extra: Vec::with_capacity(extra),
            results: [vec![0.0; m], vec![0.0; m], vec![0.0; m]],
            scratch: kinema::System::scratch(solver.system()),
            samples,
            skipped: None,
            flagged: Vec::new(),
            kinks: Vec::new(),
            output_kinks: Vec::new(),
            imprecise: Vec::new(),
            checked_all: false,
            outputs,
            stride: outputs.div_ceil(MAX_PLOT_STATES).max(1),
            written: 0,
            write_time: Duration::ZERO,
        }
    }

    /// The equation of `state` (an output row's) that its own arithmetic
    /// does not determine, if any: every equation on the first row, the
    /// equations that read t on the others (see
    /// [`kinema::PrecisionScope`]).
    fn imprecision(
        &mut self,
        solver: &Solver<TapeSystem, Auto>,
        state: &State,
    ) -> Option<kinema::Imprecision> {
        let (system, size) = (solver.system(), solver.model_size());
        let scope = if std::mem::replace(&mut self.checked_all, true) {
            kinema::PrecisionScope::Timed
        } else {
            kinema::PrecisionScope::All
        };
        system.imprecision(&mut self.scratch, state, size, scope)
    }

    /// Writes the row of the solver's state at output time `t` (inverse
    /// dynamics, results) and keeps it for the figure when its turn.
    ///
    /// # Errors
    /// Inverse dynamics failing, a write error, standard output closed, a
    /// value that overflowed: the run stops (see [`Rows::stop`]).
    fn write(
        &mut self,
        solver: &mut Solver<TapeSystem, Auto>,
        loaded: &Loaded,
        t: f64,
    ) -> Result<(), Failure> {
        if let Some(s) = &mut self.sensitivity {
            s.compute(solver).map_err(|e| {
                // The step's own factorization serves every row but those
                // flagged near singular, factored again at their q: exactly
                // singular there, ∂q/∂p does not exist.
                let singular = if matches!(e, kinema::Error::Singular { .. }) {
                    "at a singular configuration ∂q/∂p does not exist (it grows without \
                     bound near one); "
                } else {
                    ""
                };
                Failure::Analysis(format!(
                    "error: at t = {}: sensitivities: {}\n  = note: {singular}the rows before \
                     t = {} are kept",
                    time(t),
                    run_error(loaded, &e),
                    time(t),
                ))
            })?;
        }
        let dynamics = match &mut self.dynamics {
            Some(d) => d.compute(solver).map_err(|e| {
                Failure::Analysis(format!(
                    "error: inverse dynamics: {}",
                    run_error(loaded, &e)
                ))
            })?,
            None => &[],
        };
        self.extra.clear();
        self.extra.extend_from_slice(dynamics);
        if let Some(s) = &self.sensitivity {
            self.extra.extend_from_slice(s.values());
        }
        let extra = &self.extra[..];
        let Some(state) = solver.state() else {
            return Ok(());
        };
        let w = Instant::now();
        if self.sink.wants_outputs() {
            kinema::Outputs::outputs_of(
                solver.system(),
                &mut self.scratch,
                state,
                &mut self.results,
            );
            // With positions only, no rate is written.
            if !solver.options().positions_only
                && let Some(kink) =
                    solver
                        .system()
                        .output_kink(&mut self.scratch, state, solver.model_size())
            {
                self.output_kinks.push((t, kink));
            }
        }
        let [y, yd, ydd] = &self.results;
        self.sink.write_with(state, [y, yd, ydd], extra)?;
        self.skipped = Some(t);
        if let Some(s) = &mut self.samples
            && (self.written.is_multiple_of(self.stride) || self.written + 1 == self.outputs)
        {
            s.push(state);
            s.push_dynamics(&extra[..dynamics.len()]);
            self.skipped = None;
        }
        self.written += 1;
        self.write_time += w.elapsed();
        Ok(())
    }

    /// After [`Rows::write`] failed: the rows written are kept (the CSV
    /// closed) unless standard output is gone; the failure to report.
    fn stop(self, failure: Failure) -> Failure {
        if matches!(failure, Failure::Analysis(_)) {
            let _ = self.sink.finish();
        }
        failure
    }
}

/// A step failed: the singular passages before it are reported, the rows
/// before it are the CSV, the page (when asked) shows the states before
/// it with the failure marked. The error to report, with where the rows
/// went.
fn step_failure(
    solver: &Solver<TapeSystem, Auto>,
    mut rows: Rows,
    loaded: &Loaded,
    page_target: Option<animate::Target>,
    grid: &Grid,
    e: &kinema::Error,
) -> Failure {
    let passed: Vec<SingularEvent> = solver
        .events()
        .iter()
        .filter(|e| e.kind != SingularKind::LockUp)
        .cloned()
        .collect();
    print_singular_warnings(&passed, &rows.flagged);
    print_kink_warnings(solver.system(), &rows);
    print_imprecision_warning(solver.system(), &rows.imprecise);
    print_sensitivity_warning(&rows);
    // The rows before the failure are the CSV (the plot, not drawn, leaves
    // any earlier file in place).
    let rows_note = rows.sink.finish_after_failure();
    let failure = run_error(loaded, e);
    let mut message = format!("error: {failure}");
    message.push_str(&kink_note(solver));
    message.push_str(&imprecision_note(solver, &rows.imprecise));
    if let (Some(target), Some(samples)) = (page_target, &mut rows.samples) {
        let note = failed_page(
            target,
            solver,
            loaded,
            samples,
            rows.skipped,
            (&passed, &failure),
            &plot_title(loaded, grid),
        );
        message.push_str(&note);
    }
    message.push_str(&rows_note);
    Failure::Analysis(message)
}

/// A note for the error of a step that started from a state whose
/// equations their own arithmetic does not determine (an output row, the
/// last one written): the failure is more likely theirs than the step's.
fn imprecision_note(
    solver: &Solver<TapeSystem, Auto>,
    imprecise: &[(f64, kinema::Imprecision)],
) -> String {
    match (imprecise.last(), solver.state()) {
        (Some((t, i)), Some(state)) if *t == state.t() => format!(
            "\n  = note: at t = {}, where the step started, equation `{}` was not determined by \
             its own arithmetic (the warning above): no step size follows rounding errors",
            time(*t),
            kinema::System::equation_name(solver.system(), i.equation),
        ),
        _ => String::new(),
    }
}

/// A note for the error of a step that started from a state at a kink:
/// the motion past it is not determined by the model, so the step's
/// failure (a Jacobian undefined at the kink, a branch that the rounding
/// errors chose) has that cause, whatever its message says.
fn kink_note(solver: &Solver<TapeSystem, Auto>) -> String {
    let Some((state, kink)) = solver
        .state()
        .and_then(|state| Some((state, state.kink()?)))
    else {
        return String::new();
    };
    format!(
        "\n  = note: the last state solved (t = {}) lies where {} in {} is not differentiable: \
         the model does not determine the motion from there, the likely cause of this failure",
        time(state.t()),
        kink_function(kink.function).0,
        equation_of(solver.system(), kink),
    )
}

/// After a failed run: the page with the states computed before the
/// failure, the failure marked at the last good time. Returns a note for
/// the error message.
fn failed_page(
    target: animate::Target,
    solver: &Solver<TapeSystem, Auto>,
    loaded: &Loaded,
    samples: &mut Samples,
    skipped: Option<f64>,
    (events, failure): (&[SingularEvent], &str),
    title: &str,
) -> String {
    let path = target.path().display().to_string();
    // The last output state, if thinning left it out and the solver still
    // has it (its last good state; a later solve between outputs is no CSV
    // row and is not shown).
    if let Some(state) = solver.state()
        && skipped == Some(state.t())
    {
        samples.push(state);
    }
    let Some(t) = solver.state().map(State::t) else {
        return format!("\n  = note: no page written to `{path}`: no state was computed");
    };
    let mut markers: Vec<animate::Marker> = events.iter().map(event_marker).collect();
    markers.push(animate::Marker {
        t,
        label: format!("the run stopped: {failure}"),
    });
    match target.write(loaded, solver.system(), samples, &markers, title) {
        Ok(()) => format!(
            "\n  = note: `{path}` shows the motion up to t = {}, the failure marked",
            time(t)
        ),
        Err(Failure::Input(e) | Failure::Analysis(e)) => format!("\n  = note: {e}"),
        Err(Failure::Closed) => String::new(),
    }
}

/// A singular configuration's marker on the animation's time slider.
fn event_marker(event: &SingularEvent) -> animate::Marker {
    animate::Marker {
        t: event.t,
        label: event.to_string(),
    }
}

/// One `warning:` line for the output rows whose q puts a function of an
/// equation at a point where it is not differentiable (named by the first
/// such row: their q̇ and q̈ are roundoff), and one for those where a
/// result column's function is (their rates are).
fn print_kink_warnings(system: &TapeSystem, rows: &Rows) {
    if let Some((_, kink)) = rows.kinks.first() {
        let times: Vec<f64> = rows.kinks.iter().map(|k| k.0).collect();
        print_kink_warning(
            &times,
            &equation_of(system, *kink),
            kink.function,
            "q̇ and q̈ are not determined by the model (the derivatives there are the \
             rounding errors'); q is a solution",
        );
    }
    if let Some((_, kink)) = rows.output_kinks.first() {
        let name = kinema::Outputs::output_name(system, kink.column);
        let times: Vec<f64> = rows.output_kinks.iter().map(|k| k.0).collect();
        print_kink_warning(
            &times,
            &format!("result `{name}`"),
            kink.function,
            &format!(
                "`{name}_dot` and `{name}_ddot` are not determined (the rounding errors'); \
                 `{name}` is right"
            ),
        );
    }
}

/// With `--sensitivity`, one `warning:` line for the rows whose
/// sensitivity columns the model does not determine: rows flagged near
/// singular (∂q/∂p grows without bound as Φ_q becomes singular: the
/// columns there are large and inaccurate) and rows at a kink (of an
/// equation: every column; of a result: that result's).
fn print_sensitivity_warning(rows: &Rows) {
    if rows.sensitivity.is_none() {
        return;
    }
    let mut times: Vec<f64> = rows
        .flagged
        .iter()
        .copied()
        .chain(rows.kinks.iter().map(|k| k.0))
        .chain(rows.output_kinks.iter().map(|k| k.0))
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let Some(at) = rows_at(&times) else {
        return;
    };
    let their = if times.len() == 1 { "its" } else { "their" };
    eprintln!(
        "warning: {at} (the warnings above): {their} `d(…)/d(…)` sensitivity columns are not \
         determined by the model there — near a singular configuration ∂q/∂p grows without \
         bound, and at a kink the derivatives are the rounding errors'"
    );
}

fn plot_title(loaded: &Loaded, grid: &Grid) -> String {
    let end = grid.times.last().copied().unwrap_or(0.0);
    format!(
        "{} — kinematic analysis, t = 0 … {} s",
        loaded.name(),
        time(end)
    )
}

struct SummaryInput<'a> {
    loaded: &'a Loaded,
    /// The back end asked for, and the one in use at the end.
    backend: (Backend, kinema::Backend),
    grid: &'a Grid,
    stats: &'a Stats,
    /// Where the CSV went, its rows and columns.
    csv: (&'a Destination, usize, usize),
    plot: Option<&'a Path>,
    page: Option<&'a Path>,
    total: Duration,
    analysis: Duration,
    write: Duration,
    plot_time: Option<Duration>,
    page_time: Option<Duration>,
}

fn summary(s: &SummaryInput<'_>) -> String {
    let c = &s.loaded.checked();
    let mut out = String::new();
    let nb = c.bodies.len();
    let _ = writeln!(
        out,
        "{} ({}): {nb} bod{}, {} coordinates, {}",
        c.name,
        s.loaded.file,
        if nb == 1 { "y" } else { "ies" },
        3 * nb + c.coords.len(),
        match s.backend {
            (Backend::Tape, _) => "tape interpreter",
            (Backend::Jit, kinema::Backend::Jit) => "tape, then native code (JIT)",
            (Backend::Jit, kinema::Backend::Tape) =>
                "tape interpreter (the JIT had not finished compiling)",
        }
    );
    let _ = writeln!(out, "  grid: {}", s.grid.description);
    let st = s.stats;
    let mean = if st.steps == 0 {
        0.0
    } else {
        st.iterations as f64 / st.steps as f64
    };
    let _ = writeln!(
        out,
        "  Newton updates per step: mean {mean:.2}, max {} over {} steps (assembly: {})",
        st.max_iterations, st.steps, st.assembly_iterations
    );
    if st.closed_form > 0 {
        let _ = writeln!(
            out,
            "  placed in closed form (cranks and dyads, no iteration): {} of {} steps",
            st.closed_form, st.steps
        );
    }
    let _ = writeln!(
        out,
        "  worst residual ‖Φ‖∞ = {:.2e} (at t = {})",
        st.worst_residual,
        time(st.worst_residual_t)
    );
    if st.events > 0 {
        let s = if st.events == 1 { "" } else { "s" };
        let _ = writeln!(
            out,
            "  singular configurations: {} (see the warning{s})",
            st.events
        );
    }
    let mut parts = vec![
        format!("model {}", duration(s.loaded.elapsed)),
        format!("analysis {}", duration(s.analysis)),
        format!("CSV {}", duration(s.write)),
    ];
    if let Some(p) = s.plot_time {
        parts.push(format!("plot {}", duration(p)));
    }
    if let Some(p) = s.page_time {
        parts.push(format!("page {}", duration(p)));
    }
    let _ = writeln!(out, "  time: {} ({})", duration(s.total), parts.join(", "));
    let (destination, rows, columns) = s.csv;
    let csv = match destination {
        Destination::Stdout => "standard output".to_string(),
        Destination::File(p) => format!("`{}`", p.display()),
    };
    let _ = write!(out, "  wrote {csv} ({rows} rows × {columns} columns)");
    for p in [s.plot, s.page].into_iter().flatten() {
        let _ = write!(out, " and `{}`", p.display());
    }
    out.push('\n');
    out
}
