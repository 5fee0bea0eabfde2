//! `kinema run MODEL`: kinematic analysis over a time grid through the tape
//! back end, streaming the CSV, with a summary and an optional plot.

use std::fmt::Write as _;
use std::path::Path;
use std::time::{Duration, Instant};

use kinema::{Auto, Options, SingularEvent, SingularKind, Solver, State, TapeSystem};
use kinema_adm::Analysis;

use super::args::{Backend, RunArgs};
use super::check::run_error;
use super::columns::Selection;
use super::load::{Format, Loaded, load};
use super::output::{CsvSink, Destination, Outputs, duration, time};
use super::plot::{self, Samples};
use super::progress::Progress;
use super::{Failure, adm, animate};

/// Default final time of a `.kin` run.
pub const DEFAULT_T_END: f64 = 1.0;
/// Default number of steps of a `.kin` run.
pub const DEFAULT_STEPS: usize = 100;
/// Most solve times a run may have (the grid is kept in memory: 9 bytes a
/// time).
pub const MAX_TIMES: usize = 10_000_000;
/// Most states kept for a plot; longer runs are thinned evenly (the last
/// state always kept).
pub const MAX_PLOT_STATES: usize = 5000;

/// The times to solve at, and which of them are outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Strictly increasing solve times, from 0.
    pub times: Vec<f64>,
    /// `output[k]`: whether `times[k]` is written out.
    pub output: Vec<bool>,
    /// What the grid is, for the summary.
    pub description: String,
}

impl Grid {
    /// `steps` equal steps from 0 to `t_end` (N + 1 times, all outputs; the
    /// last is exactly `t_end`).
    ///
    /// # Errors
    /// [`Failure::Input`] when the times do not increase: the step is below
    /// the resolution of the times (`t_end` 5e-324 in 10 steps).
    pub fn uniform(t_end: f64, steps: usize) -> Result<Grid, Failure> {
        let times: Vec<f64> = (0..=steps)
            .map(|k| {
                if k == steps {
                    t_end
                } else {
                    let p = k as f64 * t_end;
                    if p.is_finite() {
                        p / steps as f64
                    } else {
                        (k as f64 / steps as f64) * t_end
                    }
                }
            })
            .collect();
        check_increasing(&times, &|| {
            format!("--t-end {t_end:e} with --steps {steps}")
        })?;
        Ok(Grid {
            output: vec![true; times.len()],
            description: format!("{steps} equal steps from t = 0 to {}", time(t_end)),
            times,
        })
    }

    /// simEngine2D's grid: outputs at the ACF's `outputSteps + 1` times,
    /// solves also every `stepSize` in between (warm starts, as the engine
    /// did).
    ///
    /// # Errors
    /// [`Failure::Input`] when the output times do not increase (`source`
    /// says where `tend` and `outputSteps` came from).
    pub fn simengine(analysis: &Analysis, source: &dyn Fn() -> String) -> Result<Grid, Failure> {
        let outputs = analysis.output_times();
        check_increasing(&outputs, source)?;
        let solves = analysis.solve_times();
        let (mut times, mut output) = (Vec::new(), Vec::new());
        let (mut i, mut j) = (0, 0);
        while i < solves.len() || j < outputs.len() {
            let (s, o) = (solves.get(i).copied(), outputs.get(j).copied());
            let (t, is_output) = match (s, o) {
                (Some(s), Some(o)) if s == o => {
                    i += 1;
                    j += 1;
                    (s, true)
                }
                (Some(s), Some(o)) if s < o => {
                    i += 1;
                    (s, false)
                }
                (_, Some(o)) => {
                    j += 1;
                    (o, true)
                }
                (Some(s), None) => {
                    i += 1;
                    (s, false)
                }
                (None, None) => break,
            };
            // A solve within roundoff of the next output is that output
            // (the engine's `t + stepSize` drifts: 0.29 + 0.01 < 0.3).
            let near_output = !is_output
                && outputs
                    .get(j)
                    .is_some_and(|&o| o - t <= 1e-9 * analysis.step_size.abs());
            if near_output {
                continue;
            }
            // Keep the grid strictly increasing whatever the inputs.
            if times.last().is_none_or(|&last| t > last) {
                times.push(t);
                output.push(is_output);
            } else if is_output && let Some(last) = output.last_mut() {
                *last = true;
            }
        }
        let outputs_n = output.iter().filter(|&&o| o).count();
        Ok(Grid {
            description: format!(
                "{} outputs from t = 0 to {} (outputSteps {}), solved at {} times (stepSize {})",
                outputs_n,
                time(analysis.tend),
                analysis.output_steps,
                times.len(),
                time(analysis.step_size)
            ),
            times,
            output,
        })
    }
}

/// What the run cost, for the summary.
#[derive(Debug, Clone, Default)]
struct Stats {
    assembly_iterations: usize,
    steps: usize,
    iterations: usize,
    max_iterations: usize,
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
        }
        if first || s.residual > self.worst_residual {
            self.worst_residual = s.residual;
            self.worst_residual_t = state.t();
        }
    }
}

/// Checks `--t-end` and `--steps`; returns the number of steps.
pub fn check_grid_args(t_end: Option<f64>, steps: Option<i64>) -> Result<Option<usize>, Failure> {
    if let Some(t) = t_end
        && !(t.is_finite() && t > 0.0)
    {
        return Err(Failure::usage(format_args!(
            "--t-end must be a positive finite time (T > 0: the analysis runs from t = 0 to T), found {t}"
        )));
    }
    let Some(n) = steps else {
        return Ok(None);
    };
    if n < 1 {
        return Err(Failure::usage(format_args!(
            "--steps must be at least 1 (a whole number from 1 to {}), found {n}",
            MAX_TIMES - 1
        )));
    }
    match usize::try_from(n) {
        Ok(n) if n < MAX_TIMES => Ok(Some(n)),
        _ => Err(Failure::usage(format_args!(
            "--steps {n} is more than one run takes (at most {})",
            MAX_TIMES - 1
        ))),
    }
}

/// Refuses a grid whose times are not finite and strictly increasing (a
/// step below the resolution of the times: `--t-end 5e-324 --steps 10`);
/// `source` says where the values came from.
fn check_increasing(times: &[f64], source: &dyn Fn() -> String) -> Result<(), Failure> {
    let bad = times
        .windows(2)
        .position(|w| !(w[1] > w[0] && w[1].is_finite()));
    match bad {
        None if times.iter().all(|t| t.is_finite()) => Ok(()),
        _ => {
            let k = bad.unwrap_or(0);
            let (a, b) = (
                times.get(k).copied().unwrap_or(f64::NAN),
                times.get(k + 1).copied().unwrap_or(f64::NAN),
            );
            Err(Failure::usage(format_args!(
                "{}: the solve times do not increase (time {k} is {}, time {} is {}); \
                 the step is below the resolution of the times: use fewer steps or a later final time",
                source(),
                time(a),
                k + 1,
                time(b)
            )))
        }
    }
}

/// Where a simEngine2D analysis's `tend` and `outputSteps` came from, for
/// messages: `--t-end 5e-324 with outputSteps 500 of kinematics.acf`.
fn analysis_source(args: &RunArgs, analysis: &Analysis) -> String {
    let acf = args.acf.as_ref().map_or_else(
        || "the default kinematics.acf".to_string(),
        |p| format!("`{}`", p.display()),
    );
    let tend = match args.t_end {
        Some(t) => format!("--t-end {t:e}"),
        None => format!("tend {:e} of {acf}", analysis.tend),
    };
    let steps = match args.steps {
        Some(n) => format!("--steps {n}"),
        None => format!("outputSteps {} of {acf}", analysis.output_steps),
    };
    format!("{tend} with {steps} (stepSize {:e})", analysis.step_size)
}

/// Refuses a simEngine2D analysis with more solve times than [`MAX_TIMES`].
fn check_analysis_size(analysis: &Analysis) -> Result<(), Failure> {
    let solves = analysis.tend / analysis.step_size + analysis.output_steps as f64;
    if solves.is_finite() && solves < MAX_TIMES as f64 {
        Ok(())
    } else {
        Err(Failure::usage(format_args!(
            "the analysis asks for about {solves:.3e} solves (tend {} / stepSize {} + outputSteps {}); \
             one run takes fewer than {MAX_TIMES}",
            analysis.tend, analysis.step_size, analysis.output_steps
        )))
    }
}

/// Runs `kinema run`.
///
/// # Errors
/// [`Failure::Input`] for bad arguments or models, [`Failure::Analysis`]
/// when the analysis fails (the rows computed before the failure are kept)
/// or its results cannot be written.
/// `--positions-only` where it makes no sense: with `--equilibrium` (one
/// static state, whose rates are zero anyway), `--plot` (which draws
/// velocities and accelerations), and forward dynamics (`dynamics`: its
/// positions come from integrating the accelerations).
fn refuse_positions_only(args: &RunArgs, dynamics: bool) -> Result<(), Failure> {
    if !args.positions_only {
        return Ok(());
    }
    let conflict = if dynamics {
        "forward dynamics: its positions are integrated from the accelerations, which it must solve"
    } else if args.equilibrium {
        "--equilibrium: a static equilibrium is one state, its rates zero"
    } else if args.plot.is_some() {
        "--plot: the figure draws velocities and accelerations (--animate needs positions only)"
    } else {
        return Ok(());
    };
    Err(Failure::usage(format_args!(
        "--positions-only cannot be used with {conflict}"
    )))
}

pub fn run(args: &RunArgs) -> Result<(), Failure> {
    refuse_positions_only(args, false)?;
    if args.equilibrium {
        return super::equilibrium::run(args);
    }
    let start = Instant::now();
    let Backend::Tape = args.backend;
    let steps = check_grid_args(args.t_end, args.steps)?;
    let (grid, analysis) = match Format::of(&args.model)? {
        Format::Kin => {
            if args.acf.is_some() {
                return Err(Failure::usage(
                    "--acf is for simEngine2D models (.adm); a .kin model takes --t-end and --steps",
                ));
            }
            let grid = Grid::uniform(
                args.t_end.unwrap_or(DEFAULT_T_END),
                steps.unwrap_or(DEFAULT_STEPS),
            )?;
            (grid, None)
        }
        Format::Adm => {
            let mut analysis = adm::read_analysis(args.acf.as_deref())?;
            if let Some(t) = args.t_end {
                analysis.tend = t;
            }
            if let Some(n) = steps {
                analysis.output_steps = n;
            }
            check_analysis_size(&analysis)?;
            let source = || analysis_source(args, &analysis);
            if let Err(e) = analysis.check_times() {
                return Err(Failure::usage(format_args!("{}: {e}", source())));
            }
            if analysis.simulation == kinema_adm::Simulation::Dynamics {
                refuse_positions_only(args, true)?;
                let loaded = super::load::load_with(&args.model, None, false)?;
                loaded.print_warnings();
                if loaded.model.derivation().dynamics.is_none() {
                    return Err(Failure::usage(format_args!(
                        "`{}` cannot run a Dynamics analysis: it has no inertia (every body \
                         needs `mass` and `jbar`)",
                        loaded.file
                    )));
                }
                let description = format!(
                    "{} outputs from t = 0 to {} (outputSteps {}, stepSize {})",
                    analysis.output_steps + 1,
                    time(analysis.tend),
                    analysis.output_steps,
                    analysis.step_size
                );
                let times = analysis.output_times();
                return super::forward::run(
                    args,
                    &loaded,
                    &times,
                    Some(analysis.step_size),
                    &description,
                );
            }
            (Grid::simengine(&analysis, &source)?, Some(analysis))
        }
    };
    let loaded = load(&args.model, analysis.as_ref())?;
    loaded.print_warnings();
    if super::forward::is_forward(&loaded) {
        refuse_positions_only(args, true)?;
        return super::forward::run(args, &loaded, &grid.times, None, &grid.description);
    }
    super::forward::refuse_options(args)?;
    super::equilibrium::refuse_free_dof(&loaded)?;

    // Outputs are created before the analysis: a bad path fails at once.
    let system = loaded.model.system();
    let names: Vec<String> = loaded
        .model
        .derivation()
        .coordinates
        .iter()
        .map(|c| c.name.clone())
        .collect();
    let mut outputs = Outputs::new();
    outputs.input("the model", &args.model);
    if let Some(acf) = &args.acf {
        outputs.input("the analysis file", acf);
    }
    let derivation = loaded.model.derivation();
    let selection = Selection::of_option(args.columns.as_deref(), derivation)?
        .with_positions_only(args.positions_only);
    // Inverse dynamics needs the accelerations: no such columns with
    // positions only.
    let mut dynamics =
        super::dynamics::DynamicsColumns::new(&system, derivation.rows.len(), loaded.adm.is_some())
            .filter(|_| !args.positions_only);
    let mut header = selection.header(derivation);
    if let Some(d) = &dynamics {
        header.extend(d.names().iter().cloned());
    }
    let mut sink = CsvSink::create(&mut outputs, Destination::of(&args.out), &header, selection)?;
    let m = derivation.outputs.len();
    let mut results = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
    let plot_target = args
        .plot
        .as_deref()
        .map(|p| plot::Target::create(&mut outputs, p))
        .transpose()?;
    let page_target = args
        .animate
        .as_deref()
        .map(|p| animate::Target::create(&mut outputs, p))
        .transpose()?;

    let analysis_start = Instant::now();
    let options = Options::default()
        .with_stop_at_singular(args.stop_at_singular)
        .with_positions_only(args.positions_only);
    let mut solver = Solver::<TapeSystem, Auto>::with_options(system, options)
        .map_err(|e| Failure::analysis(format_args!("cannot set up the solver: {e}")))?;
    let mut result_scratch = kinema::System::scratch(solver.system());
    let keep = plot_target.is_some() || page_target.is_some();
    let mut samples = keep.then(|| {
        let s = Samples::new(names.len());
        match &dynamics {
            Some(d) => s.with_dynamics(d.names()),
            None => s,
        }
    });
    // The last output state's time if thinning left it out of `samples`.
    let mut skipped: Option<f64> = None;
    let mut flagged: Vec<f64> = Vec::new();
    let mut stats = Stats::default();
    let mut progress = Progress::new(grid.times.len());
    let mut write_time = Duration::ZERO;
    let outputs = grid.output.iter().filter(|&&o| o).count();
    let stride = outputs.div_ceil(MAX_PLOT_STATES).max(1);
    let mut written = 0usize;
    for (k, (&t, &is_output)) in grid.times.iter().zip(&grid.output).enumerate() {
        match solver.step(t) {
            Ok(_) => {}
            Err(e) => {
                progress.finish();
                let passed: Vec<SingularEvent> = solver
                    .events()
                    .iter()
                    .filter(|e| e.kind != SingularKind::LockUp)
                    .cloned()
                    .collect();
                print_singular_warnings(&passed, &flagged);
                // The rows before the failure are the CSV (the plot, not
                // drawn, leaves any earlier file in place).
                let rows = sink.rows();
                let destination = sink.destination().clone();
                let kept = match sink.finish() {
                    Ok(()) => rows,
                    // The analysis error is the one to report, even when
                    // standard output's reader has gone too.
                    Err(_) => 0,
                };
                let failure = run_error(&loaded, &e);
                let mut message = format!("error: {failure}");
                if let (Some(target), Some(samples)) = (page_target, &mut samples) {
                    let note = failed_page(
                        target,
                        &solver,
                        &loaded,
                        samples,
                        skipped,
                        (&passed, &failure),
                        &plot_title(&loaded, &grid),
                    );
                    message.push_str(&note);
                }
                if kept > 0
                    && let Destination::File(p) = &destination
                {
                    let _ = write!(
                        message,
                        "\n  = note: the {kept} rows computed before the failure are in `{}`",
                        p.display()
                    );
                }
                return Err(Failure::Analysis(message));
            }
        }
        // A state exists after a successful step.
        let Some(state) = solver.state() else {
            continue;
        };
        stats.record(k == 0, state);
        if k == 0 {
            for w in super::check::assembly_warnings(&loaded, solver.system(), state.q()) {
                eprintln!("{w}");
            }
        }
        if is_output && state.near_singular() {
            flagged.push(state.t());
        }
        if is_output {
            let extra = match &mut dynamics {
                Some(d) => match d.compute(&mut solver) {
                    Ok(v) => v,
                    Err(e) => {
                        progress.finish();
                        let _ = sink.finish();
                        return Err(Failure::Analysis(format!(
                            "error: inverse dynamics: {}",
                            run_error(&loaded, &e)
                        )));
                    }
                },
                None => &[],
            };
            let Some(state) = solver.state() else {
                continue;
            };
            let w = Instant::now();
            if sink.wants_outputs() {
                kinema::Outputs::outputs_of(
                    solver.system(),
                    &mut result_scratch,
                    state,
                    &mut results,
                );
            }
            let [y, yd, ydd] = &results;
            if let Err(failure) = sink.write_with(state, [y, yd, ydd], extra) {
                // A write error, standard output closed, or a value that
                // overflowed: the run stops, keeping the rows written.
                progress.finish();
                if matches!(failure, Failure::Analysis(_)) {
                    let _ = sink.finish();
                }
                return Err(failure);
            }
            skipped = Some(t);
            if let Some(s) = &mut samples
                && (written.is_multiple_of(stride) || written + 1 == outputs)
            {
                s.push(state);
                s.push_dynamics(extra);
                skipped = None;
            }
            written += 1;
            write_time += w.elapsed();
        }
        progress.update(k + 1, t);
    }
    progress.finish();
    let events = solver.close_events().to_vec();
    print_singular_warnings(&events, &flagged);
    stats.events = events.len();
    let w = Instant::now();
    let (rows, columns, destination) = (sink.rows(), sink.columns(), sink.destination().clone());
    sink.finish()?;
    write_time += w.elapsed();
    let analysis_time = analysis_start.elapsed().saturating_sub(write_time);

    let plot_start = Instant::now();
    if let (Some(target), Some(samples)) = (plot_target, &samples) {
        target.write(
            &loaded,
            solver.system(),
            samples,
            &plot_title(&loaded, &grid),
        )?;
    }
    let plot_time = args.plot.as_ref().map(|_| plot_start.elapsed());
    let page_start = Instant::now();
    if let (Some(target), Some(samples)) = (page_target, &samples) {
        let markers: Vec<animate::Marker> = events.iter().map(event_marker).collect();
        target.write(
            &loaded,
            solver.system(),
            samples,
            &markers,
            &plot_title(&loaded, &grid),
        )?;
    }
    let page_time = args.animate.as_ref().map(|_| page_start.elapsed());

    let summary = summary(&SummaryInput {
        loaded: &loaded,
        grid: &grid,
        stats: &stats,
        csv: (&destination, rows, columns),
        plot: args.plot.as_deref(),
        page: args.animate.as_deref(),
        total: start.elapsed(),
        analysis: analysis_time,
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

/// Most singular configurations warned about one by one; a run that meets
/// more (a mechanism that lingers near singular, one event per step) gets
/// the first ones and a count, so that stderr stays bounded.
const MAX_EVENT_WARNINGS: usize = 20;

/// One `warning:` line per singular configuration met (at most
/// [`MAX_EVENT_WARNINGS`], then a count of the rest), and one for the
/// output rows that hold branch limits instead of solves.
fn print_singular_warnings(events: &[SingularEvent], flagged: &[f64]) {
    for e in events.iter().take(MAX_EVENT_WARNINGS) {
        eprintln!("warning: {e}");
    }
    if let Some(rest) = events.get(MAX_EVENT_WARNINGS..).filter(|r| !r.is_empty()) {
        let last = rest.last().map_or(0.0, |e| e.t);
        eprintln!(
            "warning: … and {} more singular configurations, up to t = {} (not listed;              the motion lingers near singular: check the model's dimensions)",
            rest.len(),
            time(last)
        );
    }
    if let (Some(first), Some(last)) = (flagged.first(), flagged.last()) {
        let s = if flagged.len() == 1 { "" } else { "s" };
        let at = if flagged.len() == 1 {
            format!("t = {}", time(*first))
        } else {
            format!("t = {} … {}", time(*first), time(*last))
        };
        let (lie, their) = if flagged.len() == 1 {
            ("lies", "its")
        } else {
            ("lie", "their")
        };
        eprintln!(
            "warning: {} row{s} at {at} {lie} within the threshold of a singular configuration: \
             {their} q̇ and q̈ are the limits along the branch, not solves",
            flagged.len()
        );
    }
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
    let c = &s.loaded.checked;
    let mut out = String::new();
    let nb = c.bodies.len();
    let _ = writeln!(
        out,
        "{} ({}): {nb} bod{}, {} coordinates, tape back end",
        c.name,
        s.loaded.file,
        if nb == 1 { "y" } else { "ies" },
        3 * nb + c.coords.len()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_grid_ends_on_t_end() {
        let g = Grid::uniform(0.3, 3).expect("increasing");
        assert_eq!(g.times.len(), 4);
        assert_eq!(g.times.last().copied(), Some(0.3));
        assert!(g.output.iter().all(|&o| o));
    }

    #[test]
    fn simengine_grid_marks_outputs() {
        let a = Analysis {
            tend: 1.0,
            step_size: 0.1,
            output_steps: 4,
            ..Analysis::default()
        };
        let g = Grid::simengine(&a, &String::new).expect("increasing");
        assert!(g.times.windows(2).all(|w| w[1] > w[0]));
        let outs: Vec<f64> = g
            .times
            .iter()
            .zip(&g.output)
            .filter(|(_, o)| **o)
            .map(|(t, _)| *t)
            .collect();
        assert_eq!(outs, a.output_times());
        assert!(g.times.len() > outs.len());
    }
}
