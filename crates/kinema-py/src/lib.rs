//! The native part of the Python package `kinema` (`kinema._kinema`).
//!
//! Everything here goes through the facade crate `kinema` (and
//! `kinema-adm` for simEngine2D files, as `kinema run` reads them): a run is
//! the same sequence of library calls as `kinema run`'s kinematic analysis
//! (crates/kinema-cli/src/cli/run.rs), forward dynamics and the
//! equilibrium the same as its dynamics runs ([`forward`], after
//! crates/kinema-cli/src/cli/forward.rs and equilibrium.rs), a sweep the
//! same as `kinema sweep`'s (crates/kinema-cli/src/cli/sweep.rs), so the
//! numbers are the CLI's CSV numbers bit for bit. The Python layer (python/kinema/) shapes the API:
//! results objects, warnings through `warnings`, pandas, Dask.
//!
//! The GIL is released while Rust runs ([`Python::detach`]); results come
//! back as one 2-D float64 numpy array made from the `Vec<f64>` the run
//! filled (no per-element conversion through Python objects).

use std::path::PathBuf;

mod forward;

use kinema::{Auto, Error, InverseDynamics, Options, SingularKind, Solver, System, TapeSystem};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

create_exception!(
    _kinema,
    KinemaError,
    PyException,
    "The base class of kinema's errors."
);
create_exception!(
    _kinema,
    ModelError,
    KinemaError,
    "A model that cannot be read, checked or derived: the message is the rendered diagnostics \
     (file:line:column, the source line, carets); `.diagnostics` holds them as data."
);
create_exception!(
    _kinema,
    AnalysisError,
    KinemaError,
    "An analysis that failed part-way: `.results` holds the rows computed before the failure."
);

/// Most solve times one run may have (as `kinema run`).
const MAX_TIMES: usize = 10_000_000;
/// Most singular configurations reported one by one (as `kinema run`).
const MAX_EVENT_WARNINGS: usize = 20;

/// A model read, checked and derived, with its parameter values.
#[pyclass(module = "kinema._kinema", frozen)]
struct NativeModel {
    model: kinema::Model,
    /// The system with the model's parameter values, compiled once
    /// (cloned per run; the JIT's code is shared).
    system: TapeSystem,
    file: String,
    /// A simEngine2D model: its analysis (the default grid) .
    analysis: Option<kinema_adm::Analysis>,
    /// A simEngine2D model's bodies' `qd0` (the start of forward dynamics).
    adm_qd0: Vec<Option<[f64; 3]>>,
    /// How the model moves ([`NativeModel::dynamics_run`]), decided once:
    /// for some models it takes an assembly and a rank decision.
    motion: std::sync::OnceLock<Option<forward::DynamicsRun>>,
}

/// A [`kinema::Report`] (a model with errors, a file that cannot be read,
/// an ADM or ACF file's mistakes) as the Python `ModelError`: the rendered
/// report its message, each entry a dict in `.diagnostics`.
fn model_error(py: Python<'_>, report: &kinema::Report) -> PyErr {
    let err = ModelError::new_err(report.render().trim_end().to_owned());
    let file = report.source().name();
    let diagnostics: Vec<Bound<'_, PyDict>> = report
        .entries()
        .iter()
        .filter_map(|d| {
            let dict = PyDict::new(py);
            dict.set_item("severity", d.severity.word()).ok()?;
            dict.set_item("message", &d.message).ok()?;
            dict.set_item("file", file).ok()?;
            dict.set_item("line", d.at().map(|a| a.0)).ok()?;
            dict.set_item("column", d.at().map(|a| a.1)).ok()?;
            dict.set_item("label", &d.label).ok()?;
            dict.set_item("help", &d.help).ok()?;
            Some(dict)
        })
        .collect();
    let _ = err.value(py).setattr("diagnostics", diagnostics);
    err
}

/// A Python `ModelError` with one message that concerns the whole file.
fn file_error(py: Python<'_>, file: &str, message: String) -> PyErr {
    model_error(py, &kinema::Report::whole_file(file, message))
}

fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

impl NativeModel {
    fn new(model: kinema::Model, file: String, analysis: Option<kinema_adm::Analysis>) -> Self {
        let system = model.system();
        NativeModel {
            model,
            system,
            file,
            analysis,
            adm_qd0: Vec::new(),
            motion: std::sync::OnceLock::new(),
        }
    }

    /// Whether the model runs a simEngine2D Dynamics analysis.
    fn adm_dynamics(&self) -> bool {
        self.analysis
            .as_ref()
            .is_some_and(|a| a.simulation == kinema_adm::Simulation::Dynamics)
    }

    /// How the model moves when it has inertia (see
    /// [`forward::dynamics_run`]); a Dynamics analysis is forward dynamics.
    fn dynamics_run(&self) -> Option<forward::DynamicsRun> {
        *self.motion.get_or_init(|| {
            let (q0, _) = forward::start_state(&self.model, &self.system, &self.adm_qd0);
            match forward::dynamics_run(&self.model, &self.system, &q0) {
                None if self.adm_dynamics() => Some(forward::DynamicsRun::Forward),
                kind => kind,
            }
        })
    }

    /// The system for a run on `backend` (`"jit"` or `"tape"`).
    fn system_for(&self, backend: &str) -> PyResult<TapeSystem> {
        match backend {
            "jit" => Ok(self.system.clone()),
            "tape" => {
                let mut system = self
                    .model
                    .clone()
                    .with_backend(kinema::Backend::Tape)
                    .system();
                for (i, &v) in self.system.params().iter().enumerate() {
                    system
                        .set_param_at(i, v)
                        .map_err(|e| value_error(e.to_string()))?;
                }
                Ok(system)
            }
            other => Err(value_error(format!(
                "backend must be \"jit\" or \"tape\", found {other:?}"
            ))),
        }
    }
}

/// The uniform grid of `kinema run --t-end T --steps N`: N + 1 times from 0,
/// the last exactly T (k·T/N, or (k/N)·T where k·T overflows).
fn uniform_grid(t_end: f64, steps: usize) -> Vec<f64> {
    (0..=steps)
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
        .collect()
}

/// Refuses times that are not finite and strictly increasing.
fn check_times(times: &[f64]) -> PyResult<()> {
    if times.is_empty() {
        return Err(value_error("times is empty: give at least one time"));
    }
    if times.len() > MAX_TIMES {
        return Err(value_error(format!(
            "{} times is more than one run takes (at most {MAX_TIMES})",
            times.len()
        )));
    }
    if let Some(k) = times.iter().position(|t| !t.is_finite()) {
        return Err(value_error(format!(
            "time {k} is {}: every time must be finite",
            times[k]
        )));
    }
    if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(value_error(format!(
            "the times must increase strictly: time {k} is {:e}, time {} is {:e} (a step below \
             the resolution of the times: use fewer steps or a later final time)",
            times[k],
            k + 1,
            times[k + 1]
        )));
    }
    Ok(())
}

/// The inverse-dynamics columns of a kinematic run of a model with inertia,
/// named and computed as `kinema run` does (crates/kinema-cli/src/cli/
/// dynamics.rs): the Lagrange multipliers, the joints' reactions, the
/// drivers' efforts.
struct DynamicsColumns {
    id: InverseDynamics,
    names: Vec<String>,
    values: Vec<f64>,
}

impl DynamicsColumns {
    fn new(system: &TapeSystem, rows: usize, adm: bool) -> Option<DynamicsColumns> {
        if !system.has_dynamics() {
            return None;
        }
        let names = system.dynamics_column_names(rows, adm);
        let values = vec![0.0; names.len()];
        Some(DynamicsColumns {
            id: InverseDynamics::new(system),
            names,
            values,
        })
    }

    fn compute(&mut self, solver: &mut Solver<TapeSystem, Auto>) -> Result<&[f64], Error> {
        solver.inverse_dynamics(&mut self.id)?;
        let flat = self
            .id
            .lambda()
            .iter()
            .chain(self.id.reactions().iter().flatten())
            .chain(self.id.efforts());
        for (v, &x) in self.values.iter_mut().zip(flat) {
            *v = x;
        }
        Ok(&self.values)
    }
}

/// A singular configuration met, as data.
struct Event {
    kind: &'static str,
    t: f64,
    equations: Vec<String>,
    message: String,
}

fn event_of(e: &kinema::SingularEvent) -> Event {
    Event {
        kind: match e.kind {
            SingularKind::Bifurcation => "bifurcation",
            SingularKind::Toggle => "toggle",
            SingularKind::LockUp => "lock-up",
            SingularKind::AtEnd => "at-end",
            _ => "other",
        },
        t: e.t,
        equations: e.dependency.equations.clone(),
        message: e.to_string(),
    }
}

/// What a kinematic run produced (the GIL released while it is made).
struct RunOutput {
    columns: Vec<String>,
    values: Vec<f64>,
    rows: usize,
    events: Vec<Event>,
    /// Output times within the threshold of a singular configuration.
    flagged: Vec<f64>,
    /// Output times at a kink of an equation, and which function.
    kinks: Vec<(f64, String)>,
    /// Output times at a kink of a result column: (t, column, function).
    output_kinks: Vec<(f64, String, String)>,
    /// Output times with an equation its own arithmetic does not
    /// determine: (t, equation, message).
    imprecise: Vec<(f64, String, String)>,
    /// The failure that stopped the run, if any.
    error: Option<String>,
    backend: &'static str,
}

/// Run options shared by `run` and `sweep`.
#[derive(Clone, Copy)]
struct RunOptions {
    positions_only: bool,
    stop_at_singular: bool,
}

impl RunOptions {
    fn solver_options(self) -> Options {
        Options::default()
            .with_stop_at_singular(self.stop_at_singular)
            .with_positions_only(self.positions_only)
    }
}

/// `kinema run`'s kinematic loop: steps through `times`, writes a row at
/// each output time.
fn run_kinematics(
    system: TapeSystem,
    selection: &kinema::columns::Selection,
    header: Vec<String>,
    (times, outputs): (&[f64], &[bool]),
    options: RunOptions,
    adm: bool,
    (rows_n, nc): (usize, usize),
) -> Result<RunOutput, String> {
    let mut dynamics =
        DynamicsColumns::new(&system, rows_n, adm).filter(|_| !options.positions_only);
    let mut columns = vec!["t".to_owned()];
    columns.extend(header);
    if let Some(d) = &dynamics {
        columns.extend(d.names.iter().cloned());
    }
    let mut solver = Solver::<TapeSystem, Auto>::with_options(system, options.solver_options())
        .map_err(|e| format!("cannot set up the solver: {e}"))?;
    let m = kinema::Outputs::output_len(solver.system());
    let mut results = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
    let mut scratch = System::scratch(solver.system());
    let n_out = outputs.iter().filter(|&&o| o).count();
    let mut values: Vec<f64> = Vec::with_capacity(n_out * columns.len());
    // Whether the selection takes every coordinate and every result in
    // order (then each block is one copy).
    let whole = (
        is_whole(&selection.coordinates, nc),
        is_whole(&selection.outputs, m),
    );
    let mut out = RunOutput {
        columns,
        values: Vec::new(),
        rows: 0,
        events: Vec::new(),
        flagged: Vec::new(),
        kinks: Vec::new(),
        output_kinks: Vec::new(),
        imprecise: Vec::new(),
        error: None,
        backend: "tape",
    };
    let orders = selection.orders();
    let mut checked_all = false;
    for (&t, &is_output) in times.iter().zip(outputs) {
        if let Err(e) = solver.step(t) {
            out.events = solver
                .events()
                .iter()
                .filter(|e| e.kind != SingularKind::LockUp)
                .map(event_of)
                .collect();
            out.error = Some(e.to_string());
            break;
        }
        if !is_output {
            continue;
        }
        let Some(state) = solver.state() else {
            continue;
        };
        let size = solver.model_size();
        if state.near_singular() {
            out.flagged.push(state.t());
        }
        if let Some(kink) = state.kink() {
            let eq = kink.equation.map_or_else(
                || "an equation".to_owned(),
                |e| format!("equation `{}`", solver.system().equation_name(e)),
            );
            out.kinks
                .push((state.t(), format!("{} in {eq}", kink.function)));
        }
        let scope = if std::mem::replace(&mut checked_all, true) {
            kinema::PrecisionScope::Timed
        } else {
            kinema::PrecisionScope::All
        };
        if let Some(i) = solver
            .system()
            .imprecision(&mut scratch, state, size, scope)
        {
            let name = solver.system().equation_name(i.equation).to_owned();
            let message = format!(
                "equation `{name}` is not determined by its own arithmetic: its rounding error, \
                 up to {:.1e}, moves the coordinates by up to {:.1e} against their scale {:.1e}",
                i.error, i.shift, i.scale
            );
            out.imprecise.push((state.t(), name, message));
        }
        let extra: &[f64] = match &mut dynamics {
            Some(d) => match d.compute(&mut solver) {
                Ok(v) => v,
                Err(e) => {
                    out.error = Some(format!("inverse dynamics: {e}"));
                    break;
                }
            },
            None => &[],
        };
        let Some(state) = solver.state() else {
            continue;
        };
        if !selection.outputs.is_empty() {
            kinema::Outputs::outputs_of(solver.system(), &mut scratch, state, &mut results);
            if !options.positions_only
                && let Some(kink) =
                    solver
                        .system()
                        .output_kink(&mut scratch, state, solver.model_size())
            {
                let name = kinema::Outputs::output_name(solver.system(), kink.column).to_owned();
                out.output_kinks
                    .push((state.t(), name, kink.function.to_owned()));
            }
        }
        // The row straight into the table (one copy per block when the
        // selection is whole, as by default).
        let start = values.len();
        values.push(state.t());
        let states = [state.q(), state.qd(), state.qdd()];
        for v in &states[..orders] {
            push_selected(&mut values, v, &selection.coordinates, whole.0);
        }
        for v in &results[..orders] {
            push_selected(&mut values, v, &selection.outputs, whole.1);
        }
        values.extend_from_slice(extra);
        // Never a silent NaN or ∞ (as the CLI's CSV).
        if let Some(j) = first_non_finite(&values[start..]) {
            out.error = Some(format!(
                "at t = {t}: column `{}` is {} (it overflowed)",
                out.columns[j],
                values[start + j]
            ));
            values.truncate(start);
            break;
        }
        out.rows += 1;
    }
    if out.error.is_none() {
        out.events = solver.close_events().iter().map(event_of).collect();
    }
    out.backend = backend_name(solver.system());
    out.values = values;
    Ok(out)
}

/// The back end a system runs on.
fn backend_name(system: &TapeSystem) -> &'static str {
    match system.backend() {
        kinema::Backend::Jit => "jit",
        kinema::Backend::Tape => "tape",
    }
}

/// Whether `picked` is 0, 1, …, `len` − 1: a whole block.
fn is_whole(picked: &[usize], len: usize) -> bool {
    picked.len() == len && picked.iter().enumerate().all(|(i, &k)| i == k)
}

/// Appends the entries `picked` of `source` to `row` (NaN for one out of
/// range), or all of `source` by one copy when `whole`.
fn push_selected(row: &mut Vec<f64>, source: &[f64], picked: &[usize], whole: bool) {
    if whole {
        row.extend_from_slice(source);
    } else {
        row.extend(
            picked
                .iter()
                .map(|&k| source.get(k).copied().unwrap_or(f64::NAN)),
        );
    }
}

/// The first entry of `row` that is NaN or ±∞: a check of the whole row
/// first that needs no branch per entry (it vectorizes), the search only
/// when it fails.
fn first_non_finite(row: &[f64]) -> Option<usize> {
    if row.iter().fold(false, |bad, v| bad | !v.is_finite()) {
        row.iter().position(|v| !v.is_finite())
    } else {
        None
    }
}

/// The result of a sweep (the GIL released while it is made).
struct SweepOutput {
    values: Vec<f64>,
    rows: usize,
    /// (variant index from 0, error message).
    failures: Vec<(usize, String)>,
    /// (variant index from 0, what was flagged).
    flagged: Vec<(usize, String)>,
}

/// `kinema sweep`'s variant loop over rows `rows` (each the values of the
/// swept parameters, `indices` into the model's parameters); variant
/// numbers in the table start at `first + 1`.
fn run_sweep(
    system: TapeSystem,
    indices: Vec<usize>,
    table: &[Vec<f64>],
    first: usize,
    times: &[f64],
    options: RunOptions,
    threads: Option<usize>,
) -> SweepOutput {
    let width = indices.len();
    let set = move |s: &mut TapeSystem, row: &[f64]| {
        for (&i, &v) in indices.iter().zip(row) {
            // `indices` are positions of the model's own parameters,
            // resolved from their names before the sweep starts.
            let _ = s.set_param_at(i, v);
        }
    };
    let mut sweep = kinema::sweep::Sweep::new(system, set)
        .with_row_width(width)
        .with_options(options.solver_options());
    if let Some(n) = threads {
        sweep = sweep.with_threads(n);
    }
    let orders = if options.positions_only { 1 } else { 3 };
    let done = sweep.map(table, |k, solver| {
        let row = &table[k];
        let mut values: Vec<f64> = Vec::new();
        let m = kinema::Outputs::output_len(solver.system());
        let mut scratch = System::scratch(solver.system());
        let mut results = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
        let mut notes: Vec<String> = Vec::new();
        let (mut near, mut kinks) = (0usize, 0usize);
        let mut n = 0;
        let mut failure = None;
        for &t in times {
            if let Err(e) = solver.step(t) {
                failure = Some(e.to_string());
                break;
            }
            let Some(state) = solver.state() else { break };
            kinema::Outputs::outputs_of(solver.system(), &mut scratch, state, &mut results);
            near += usize::from(state.near_singular());
            kinks += usize::from(state.kink().is_some());
            values.push((first + k + 1) as f64);
            values.extend_from_slice(row);
            values.push(state.t());
            let states = [state.q(), state.qd(), state.qdd()];
            values.extend(states[..orders].iter().flat_map(|v| v.iter()));
            values.extend(results[..orders].iter().flatten());
            n += 1;
        }
        let events = if failure.is_some() {
            solver.events()
        } else {
            solver.close_events()
        };
        for e in events {
            notes.push(format!("{} at t = {}", e.kind, e.t));
        }
        if near > 0 {
            notes.push(format!(
                "{near} rows within the threshold of a singular configuration (q̇ and q̈ are the \
                 branch's limits, not solves)"
            ));
        }
        if kinks > 0 {
            notes.push(format!(
                "{kinks} rows at a kink of an equation (q̇ and q̈ are not determined)"
            ));
        }
        Ok((values, n, failure, notes))
    });
    let mut out = SweepOutput {
        values: Vec::new(),
        rows: 0,
        failures: Vec::new(),
        flagged: Vec::new(),
    };
    for (k, result) in done.into_iter().enumerate() {
        match result {
            Ok((values, n, failure, notes)) => {
                out.values.extend_from_slice(&values);
                out.rows += n;
                if let Some(f) = failure {
                    out.failures.push((first + k, f));
                }
                if !notes.is_empty() {
                    out.flagged.push((first + k, notes.join("; ")));
                }
            }
            Err(e) => out.failures.push((first + k, e.to_string())),
        }
    }
    out
}

/// A 2-D float64 array of `rows` × `cols` from a row-major buffer (moved
/// into numpy, not copied element by element).
fn array<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let a = Array2::from_shape_vec((rows, cols), values)
        .map_err(|e| value_error(format!("internal: result shape: {e}")))?;
    Ok(a.into_pyarray(py))
}

#[pymethods]
impl NativeModel {
    /// A model from `.kin` text; `file` names it in messages.
    #[staticmethod]
    fn from_text(py: Python<'_>, text: &str, file: &str) -> PyResult<NativeModel> {
        let model = py
            .detach(|| kinema::Model::from_source(text, file))
            .map_err(|e| model_error(py, &e))?;
        Ok(NativeModel::new(model, file.to_owned(), None))
    }

    /// A model from a `.kin` file, or a simEngine2D `.adm` file (with its
    /// `.acf` analysis, the engine's kinematics.acf when `acf` is None).
    #[staticmethod]
    #[pyo3(signature = (path, acf=None))]
    fn from_file(py: Python<'_>, path: PathBuf, acf: Option<PathBuf>) -> PyResult<NativeModel> {
        let file = path.display().to_string();
        let is_adm = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("adm"));
        let is_acf = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("acf"));
        if is_acf {
            return Err(file_error(
                py,
                &file,
                format!(
                    "`{file}` is a simEngine2D analysis file, not a model: give the .adm model \
                     and pass the analysis as acf="
                ),
            ));
        }
        if !path.exists() {
            return Err(pyo3::exceptions::PyFileNotFoundError::new_err(format!(
                "no model file `{file}`"
            )));
        }
        if !is_adm && acf.is_some() {
            return Err(value_error("acf= is for simEngine2D .adm models only"));
        }
        // The front door the command line uses: the one size cap and
        // UTF-8 rule, .kin or .adm by the extension.
        let mut read = kinema::ModelFile::read(&path).map_err(|r| model_error(py, &r))?;
        let Some(adm) = read.adm.take() else {
            // The syntax tree holds spans that stay on this thread: no
            // detach (parsing is the fast part).
            let model = read.into_model().map_err(|r| model_error(py, &r))?;
            return Ok(NativeModel::new(model, file, None));
        };
        let analysis = match &acf {
            None => kinema_adm::Analysis::default(),
            Some(p) => kinema_adm::Analysis::read(p).map_err(|r| model_error(py, &r))?,
        };
        let dynamics = analysis.simulation == kinema_adm::Simulation::Dynamics;
        if dynamics {
            // As `kinema run`: a force the engine computes in MATLAB
            // cannot run.
            if let Some((name, id, mfile)) = kinema_adm::dynamics::point_force_files(&adm)
                .into_iter()
                .next()
            {
                return Err(file_error(
                    py,
                    &file,
                    format!(
                        "force \"{name}\" (id {id}, PointForceFile) of `{file}` computes its force \
                         with the MATLAB function `{mfile}` ({mfile}.m), which kinema cannot run"
                    ),
                ));
            }
        } else {
            kinema_adm::check_kinematic(&adm, &analysis)
                .map_err(|r| file_error(py, &file, r.to_string()))?;
        }
        let adm_qd0: Vec<Option<[f64; 3]>> = adm.bodies.iter().map(|b| b.qd0).collect();
        let model = read.into_model().map_err(|r| model_error(py, &r))?;
        if dynamics && model.derivation().dynamics.is_none() {
            return Err(KinemaError::new_err(format!(
                "`{file}` cannot run a Dynamics analysis: it has no inertia (every body needs \
                 `mass` and `jbar`)"
            )));
        }
        let mut native = NativeModel::new(model, file, Some(analysis));
        native.adm_qd0 = adm_qd0;
        Ok(native)
    }

    /// The file name (or the name given to the text).
    #[getter]
    fn file(&self) -> String {
        self.file.clone()
    }

    /// The mechanism's name.
    #[getter]
    fn name(&self) -> String {
        self.model.derivation().name.clone()
    }

    /// Whether the model came from a simEngine2D `.adm` file.
    #[getter]
    fn is_adm(&self) -> bool {
        self.analysis.is_some()
    }

    /// The parameters' names, in declaration order.
    fn param_names(&self) -> Vec<String> {
        self.system.param_names().to_vec()
    }

    /// The parameters' values, in declaration order.
    fn param_values(&self) -> Vec<f64> {
        self.system.params().to_vec()
    }

    /// The warnings of the model check, rendered.
    fn warnings(&self) -> Vec<String> {
        self.model.warnings().render_each()
    }

    /// The same model with some parameters set (names checked).
    fn with_params(&self, values: Vec<(String, f64)>) -> PyResult<NativeModel> {
        let mut system = self.system.clone();
        for (name, value) in &values {
            if !value.is_finite() {
                return Err(value_error(format!(
                    "parameter `{name}` must be a finite number, found {value}"
                )));
            }
            if system.set_param(name, *value).is_err() {
                return Err(value_error(format!(
                    "`{name}` is not a parameter of {}: its parameters are {}",
                    self.model.derivation().name,
                    known(system.param_names())
                )));
            }
        }
        Ok(NativeModel {
            model: self.model.clone(),
            system,
            file: self.file.clone(),
            analysis: self.analysis.clone(),
            adm_qd0: self.adm_qd0.clone(),
            // The parameters may change the rank at the start.
            motion: std::sync::OnceLock::new(),
        })
    }

    /// The degrees-of-freedom report and the model's names, as data.
    fn check<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = self.model.derivation();
        let dict = PyDict::new(py);
        dict.set_item("name", &d.name)?;
        dict.set_item("file", &self.file)?;
        dict.set_item("bodies", d.bodies.clone())?;
        let coords: Vec<&str> = d.coordinates.iter().map(|c| c.name.as_str()).collect();
        dict.set_item("coordinates", coords)?;
        let eqs: Vec<&str> = (0..d.rows.len())
            .map(|i| self.system.equation_name(i))
            .collect();
        dict.set_item("equations", eqs)?;
        dict.set_item("kinematic_equations", d.dof.kinematic)?;
        dict.set_item("driving_equations", d.dof.driving)?;
        dict.set_item("kdof", d.dof.kdof())?;
        dict.set_item(
            "dof",
            d.dof.coordinates as i64 - (d.dof.kinematic + d.dof.driving) as i64,
        )?;
        let outs: Vec<&str> = d.outputs.iter().map(|o| o.name.as_str()).collect();
        dict.set_item("results", outs)?;
        dict.set_item("params", self.param_names())?;
        dict.set_item("inertia", d.dynamics.is_some())?;
        dict.set_item("warnings", self.model.warnings().render_each())?;
        Ok(dict)
    }

    /// The grid of a run: the solve times and which are outputs. For a
    /// `.kin` model `steps` equal steps from 0 to `t_end` (1 s and 100
    /// steps by default); for an `.adm` model its analysis (tend,
    /// outputSteps overridden by `t_end`, `steps`), solved every stepSize.
    #[pyo3(signature = (t_end=None, steps=None))]
    fn grid(&self, t_end: Option<f64>, steps: Option<i64>) -> PyResult<(Vec<f64>, Vec<bool>)> {
        if let Some(t) = t_end
            && !(t.is_finite() && t > 0.0)
        {
            return Err(value_error(format!(
                "t_end must be a positive finite time in seconds (the analysis runs from t = 0 to \
                 t_end), found {t}"
            )));
        }
        let steps = match steps {
            None => None,
            Some(n) if n < 1 => {
                return Err(value_error(format!(
                    "steps must be at least 1 (a whole number from 1 to {}), found {n}",
                    MAX_TIMES - 1
                )));
            }
            Some(n) => match usize::try_from(n) {
                Ok(n) if n < MAX_TIMES => Some(n),
                _ => {
                    return Err(value_error(format!(
                        "steps {n} is more than one run takes (at most {})",
                        MAX_TIMES - 1
                    )));
                }
            },
        };
        match &self.analysis {
            None => {
                let times = uniform_grid(t_end.unwrap_or(1.0), steps.unwrap_or(100));
                check_times(&times)?;
                let outputs = vec![true; times.len()];
                Ok((times, outputs))
            }
            Some(a) => {
                let mut a = a.clone();
                if let Some(t) = t_end {
                    a.tend = t;
                }
                if let Some(n) = steps {
                    a.output_steps = n;
                }
                let solves = a.tend / a.step_size + a.output_steps as f64;
                if !(solves.is_finite() && solves < MAX_TIMES as f64) {
                    return Err(value_error(format!(
                        "the analysis asks for about {solves:.3e} solves; one run takes fewer \
                         than {MAX_TIMES}"
                    )));
                }
                a.check_times().map_err(|e| value_error(e.to_string()))?;
                if a.simulation == kinema_adm::Simulation::Dynamics {
                    // Forward dynamics: the output times, the ACF's
                    // stepSize the step between them (as `kinema run`).
                    let times = a.output_times();
                    check_times(&times)?;
                    let outputs = vec![true; times.len()];
                    return Ok((times, outputs));
                }
                let (times, outputs) = a.grid();
                check_times(&times)?;
                Ok((times, outputs))
            }
        }
    }

    /// The columns of a run: `t`, then the selection (`columns` as
    /// `kinema run --columns`, all without it), then inverse dynamics'.
    #[pyo3(signature = (columns=None, positions_only=false))]
    fn columns(&self, columns: Option<&str>, positions_only: bool) -> PyResult<Vec<String>> {
        let d = self.model.derivation();
        let selection = kinema::columns::Selection::of_option(columns, d)
            .map_err(|e| value_error(e.to_string()))?
            .with_positions_only(positions_only);
        let mut names = vec!["t".to_owned()];
        names.extend(selection.header(d));
        if !positions_only
            && let Some(dy) = DynamicsColumns::new(&self.system, d.rows.len(), self.is_adm())
        {
            names.extend(dy.names);
        }
        Ok(names)
    }

    /// Kinematic analysis over `times` (outputs where `outputs` is true,
    /// all by default), as `kinema run`. Returns a dict: `columns`,
    /// `values` (rows × columns float64), `events`, `flagged`, `kinks`,
    /// `output_kinks`, `imprecise`, `error` (None, or why the run stopped:
    /// the rows are those before it), `backend`. `times` None: the grid of
    /// `t_end` and `steps` ([`NativeModel::grid`]), made here rather than
    /// passed through Python lists.
    #[pyo3(signature = (times, outputs=None, columns=None, positions_only=false,
                        stop_at_singular=false, backend="jit", t_end=None, steps=None))]
    #[allow(clippy::too_many_arguments)]
    fn run<'py>(
        &self,
        py: Python<'py>,
        times: Option<Vec<f64>>,
        outputs: Option<Vec<bool>>,
        columns: Option<&str>,
        positions_only: bool,
        stop_at_singular: bool,
        backend: &str,
        t_end: Option<f64>,
        steps: Option<i64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (times, outputs) = match times {
            Some(times) => (times, outputs),
            None => {
                let (times, outputs) = self.grid(t_end, steps)?;
                (times, Some(outputs))
            }
        };
        check_times(&times)?;
        let outputs = outputs.unwrap_or_else(|| vec![true; times.len()]);
        if outputs.len() != times.len() {
            return Err(value_error(format!(
                "outputs has {} entries for {} times",
                outputs.len(),
                times.len()
            )));
        }
        let d = self.model.derivation();
        if d.rows.len() != d.nc() {
            return Err(KinemaError::new_err(format!(
                "{} has {} degrees of freedom left ({} coordinates, {} equations): kinematic \
                 analysis needs as many equations as coordinates{}",
                d.name,
                d.nc() as i64 - d.rows.len() as i64,
                d.nc(),
                d.rows.len(),
                if d.dynamics.is_some() {
                    "; a model with inertia runs forward dynamics (Model.run, Model.forward) or \
                     finds its equilibrium (Model.equilibrium)"
                } else {
                    "; with inertia (`mass` and `inertia` on every body) it would run forward \
                     dynamics"
                }
            )));
        }
        let selection = kinema::columns::Selection::of_option(columns, d)
            .map_err(|e| value_error(e.to_string()))?
            .with_positions_only(positions_only);
        let header = selection.header(d);
        let system = self.system_for(backend)?;
        let options = RunOptions {
            positions_only,
            stop_at_singular,
        };
        let (adm, rows_n, nc) = (self.is_adm(), d.rows.len(), d.nc());
        let start = std::time::Instant::now();
        let out = py
            .detach(|| {
                run_kinematics(
                    system,
                    &selection,
                    header,
                    (&times, &outputs),
                    options,
                    adm,
                    (rows_n, nc),
                )
            })
            .map_err(KinemaError::new_err)?;
        // The Rust part of the run (the solver loop into one buffer), for
        // measurements of the Python overhead around it.
        let rust_seconds = start.elapsed().as_secs_f64();
        let dict = PyDict::new(py);
        dict.set_item("rust_seconds", rust_seconds)?;
        let cols = out.columns.len();
        dict.set_item("values", array(py, out.values, out.rows, cols)?)?;
        dict.set_item("columns", out.columns)?;
        let events = PyList::empty(py);
        for e in &out.events {
            let ev = PyDict::new(py);
            ev.set_item("kind", e.kind)?;
            ev.set_item("t", e.t)?;
            ev.set_item("equations", e.equations.clone())?;
            ev.set_item("message", &e.message)?;
            events.append(ev)?;
        }
        dict.set_item("events", events)?;
        dict.set_item("max_event_warnings", MAX_EVENT_WARNINGS)?;
        dict.set_item("flagged", out.flagged)?;
        dict.set_item("kinks", out.kinks)?;
        dict.set_item("output_kinks", out.output_kinks)?;
        dict.set_item("imprecise", out.imprecise)?;
        dict.set_item("error", out.error)?;
        dict.set_item("backend", out.backend)?;
        Ok(dict)
    }

    /// How the model moves: `"kinematic"` (kinematics, and inverse
    /// dynamics with inertia), `"forward"` (forward dynamics: a model with
    /// inertia and free degrees of freedom, or a Dynamics analysis), or
    /// `"prescribed"` (fully driven with redundant rows: minimum-norm
    /// solves), as `kinema run` decides.
    #[getter]
    fn motion(&self, py: Python<'_>) -> &'static str {
        py.detach(|| self.dynamics_run())
            .map_or("kinematic", forward::DynamicsRun::name)
    }

    /// The step of forward dynamics when none is given: a Dynamics
    /// analysis's stepSize, 1e-3 s for a `.kin` model.
    #[getter]
    fn default_step(&self) -> f64 {
        match &self.analysis {
            Some(a) if self.adm_dynamics() => a.step_size,
            _ => forward::DEFAULT_STEP,
        }
    }

    /// Forward dynamics through `times` (increasing, from t0 = times[0]),
    /// as `kinema run` of a model with inertia and free degrees of
    /// freedom. Returns a dict as `run`, with `passages`, `redundancy`,
    /// `consistency`, `integrator`, `energies`, `motion`.
    #[pyo3(signature = (times, columns=None, integrator="hht", step=None, rtol=None,
                        project_velocity=false, energy=false, backend="jit"))]
    #[allow(clippy::too_many_arguments)]
    fn forward<'py>(
        &self,
        py: Python<'py>,
        times: Vec<f64>,
        columns: Option<&str>,
        integrator: &str,
        step: Option<f64>,
        rtol: Option<f64>,
        project_velocity: bool,
        energy: bool,
        backend: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        check_times(&times)?;
        let integrator = match integrator {
            "hht" => forward::Integrator::Hht,
            "accurate" => forward::Integrator::Accurate,
            other => {
                return Err(value_error(format!(
                    "integrator must be \"hht\" or \"accurate\", found {other:?}"
                )));
            }
        };
        // The CLI's option checks (crates/kinema-cli/src/cli/forward.rs).
        match integrator {
            forward::Integrator::Hht if rtol.is_some() => {
                return Err(value_error(
                    "rtol is the tolerance of integrator=\"accurate\"; HHT takes step",
                ));
            }
            forward::Integrator::Accurate if project_velocity => {
                return Err(value_error(
                    "project_velocity is for integrator=\"hht\": the accurate mode projects \
                     positions and velocities after every step already",
                ));
            }
            forward::Integrator::Accurate if step.is_some() => {
                return Err(value_error(
                    "step is HHT's; integrator=\"accurate\" chooses its steps to meet rtol",
                ));
            }
            _ => {}
        }
        let rtol = rtol.unwrap_or(forward::DEFAULT_RTOL);
        if !(rtol > 1e-14 && rtol < 1.0) {
            return Err(value_error(format!(
                "rtol must be in (1e-14, 1), not {rtol}"
            )));
        }
        let h = step.unwrap_or(self.default_step());
        if !(h.is_finite() && h > 0.0) {
            return Err(value_error(format!(
                "step must be a positive, finite time in seconds, not {h}"
            )));
        }
        let d = self.model.derivation();
        if d.dynamics.is_none() {
            return Err(KinemaError::new_err(format!(
                "`{}` has no inertia: forward dynamics needs `mass` and `inertia` on every body",
                self.file
            )));
        }
        let selection = kinema::columns::Selection::of_option(columns, d)
            .map_err(|e| value_error(e.to_string()))?;
        let system = self.system_for(backend)?;
        let options = forward::ForwardOptions {
            integrator,
            step: h,
            rtol,
            project_velocity,
            energy,
            adm: self.is_adm(),
        };
        let start = std::time::Instant::now();
        let out = py.detach(|| {
            let kind = self.dynamics_run().unwrap_or(forward::DynamicsRun::Forward);
            let (q0, qd0) = forward::start_state(&self.model, &system, &self.adm_qd0);
            forward::run_forward(
                &self.model,
                &system,
                &self.file,
                kind,
                [&q0, &qd0],
                &times,
                &selection,
                &options,
            )
        });
        let out = out.map_err(KinemaError::new_err)?;
        let rust_seconds = start.elapsed().as_secs_f64();
        let names = forward::columns(&self.model, &system, &selection, (self.is_adm(), energy));
        let dict = PyDict::new(py);
        dict.set_item("rust_seconds", rust_seconds)?;
        dict.set_item("values", array(py, out.values, out.rows, names.len())?)?;
        dict.set_item("columns", names)?;
        let passages = PyList::empty(py);
        for p in &out.passages {
            let ev = PyDict::new(py);
            ev.set_item("kind", "passage")?;
            ev.set_item("t", p.t)?;
            ev.set_item("sigma", p.sigma)?;
            ev.set_item("equations", p.equations.clone())?;
            ev.set_item("message", &p.message)?;
            passages.append(ev)?;
        }
        dict.set_item("passages", passages)?;
        dict.set_item("max_event_warnings", MAX_EVENT_WARNINGS)?;
        dict.set_item("redundancy", out.redundancy)?;
        let c = PyDict::new(py);
        c.set_item("dq", out.consistency.dq)?;
        c.set_item("phi", out.consistency.phi)?;
        c.set_item("dqd", out.consistency.dqd)?;
        c.set_item("velocity", out.consistency.velocity)?;
        c.set_item("corrected", out.corrected)?;
        dict.set_item("consistency", c)?;
        dict.set_item("integrator", out.integrator)?;
        let [ke, v, work, ke0, v0] = out.energies;
        let e = PyDict::new(py);
        e.set_item("kinetic", ke)?;
        e.set_item("potential", v)?;
        e.set_item("work", work)?;
        e.set_item("kinetic0", ke0)?;
        e.set_item("potential0", v0)?;
        e.set_item("balance", (ke + v) - (ke0 + v0) - work)?;
        dict.set_item("energies", e)?;
        dict.set_item("imprecise", out.imprecise)?;
        dict.set_item("error", out.error)?;
        dict.set_item(
            "motion",
            if out.prescribed {
                "prescribed"
            } else {
                "forward"
            },
        )?;
        dict.set_item("backend", backend_name(&system))?;
        Ok(dict)
    }

    /// The stable static equilibrium at t = 0, as `kinema run
    /// --equilibrium`: a dict with `columns`, `values` (one row: q, q̇ =
    /// q̈ = 0, points and outputs at rest, λ, reactions, efforts),
    /// `stability`, `eigenvalues`, `residual`, `gradient`, `iterations`.
    #[pyo3(signature = (columns=None, backend="jit"))]
    fn equilibrium<'py>(
        &self,
        py: Python<'py>,
        columns: Option<&str>,
        backend: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = self.model.derivation();
        if d.dynamics.is_none() {
            return Err(KinemaError::new_err(format!(
                "`{}` has no inertia, gravity or forces: the equilibrium needs a model with \
                 dynamics (`mass`, `inertia`, `gravity`, `force`)",
                self.file
            )));
        }
        let selection = kinema::columns::Selection::of_option(columns, d)
            .map_err(|e| value_error(e.to_string()))?;
        let system = self.system_for(backend)?;
        let (eq, row) = py
            .detach(|| forward::equilibrium(&self.model, &system, &selection))
            .map_err(|e| AnalysisError::new_err(format!("no equilibrium: {e}")))?;
        let names = forward::columns(&self.model, &system, &selection, (self.is_adm(), false));
        if let Some(j) = row.iter().position(|v| !v.is_finite()) {
            return Err(AnalysisError::new_err(format!(
                "at the equilibrium: column `{}` is {} (it overflowed)",
                names.get(j).map_or("?", String::as_str),
                row[j]
            )));
        }
        let dict = PyDict::new(py);
        dict.set_item("values", array(py, row, 1, names.len())?)?;
        dict.set_item("columns", names)?;
        dict.set_item("stability", eq.stability.to_string())?;
        dict.set_item(
            "stable",
            eq.stability == kinema::equilibrium::Stability::Stable,
        )?;
        dict.set_item("eigenvalues", eq.eigenvalues.clone())?;
        dict.set_item("residual", eq.residual)?;
        dict.set_item("gradient", eq.gradient)?;
        dict.set_item("iterations", eq.iterations)?;
        Ok(dict)
    }

    /// A sweep, as `kinema sweep`: for each row of `table` (the values of
    /// the parameters `names`, one column each) the run over `times`. The
    /// variants are numbered from `first + 1` (a shard's offset). Returns a
    /// dict: `columns` (`row`, the names, `t`, coordinates, results),
    /// `values`, `failures` [(variant from 0, message)], `flagged`.
    #[pyo3(signature = (names, table, times, first=0, positions_only=false,
                        stop_at_singular=false, backend="jit", threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn sweep<'py>(
        &self,
        py: Python<'py>,
        names: Vec<String>,
        table: &Bound<'py, PyAny>,
        times: Vec<f64>,
        first: usize,
        positions_only: bool,
        stop_at_singular: bool,
        backend: &str,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        check_times(&times)?;
        let d = self.model.derivation();
        if d.rows.len() != d.nc() {
            return Err(KinemaError::new_err(format!(
                "{} has {} degrees of freedom left: a sweep runs kinematic analysis, which needs \
                 as many equations as coordinates",
                d.name,
                d.nc() as i64 - d.rows.len() as i64
            )));
        }
        // Any 2-D array of numbers, made a C-contiguous, aligned float64
        // array first: one unpickled from a Dask frame may be unaligned,
        // which a view from Rust must not be.
        let table = py
            .import("numpy")?
            .call_method1("require", (table, "float64", ("C", "A")))?;
        let table = table
            .cast_into::<numpy::PyArray2<f64>>()
            .map_err(|_| value_error("the sweep table must be a 2-D array of numbers"))?;
        let table = table.readonly();
        let table = table.as_array();
        if table.ncols() != names.len() {
            return Err(value_error(format!(
                "the table has {} columns for {} parameter names",
                table.ncols(),
                names.len()
            )));
        }
        let mut indices = Vec::with_capacity(names.len());
        for name in &names {
            let Some(i) = self.system.param_names().iter().position(|p| p == name) else {
                return Err(value_error(format!(
                    "`{name}` is not a parameter of {}: its parameters are {}",
                    d.name,
                    known(self.system.param_names())
                )));
            };
            if indices.contains(&i) {
                return Err(value_error(format!("parameter `{name}` is named twice")));
            }
            indices.push(i);
        }
        let rows: Vec<Vec<f64>> = table.rows().into_iter().map(|r| r.to_vec()).collect();
        if let Some((k, j)) = rows
            .iter()
            .enumerate()
            .find_map(|(k, r)| r.iter().position(|v| !v.is_finite()).map(|j| (k, j)))
        {
            return Err(value_error(format!(
                "variant {} ({}): expected a finite number, found {}",
                first + k + 1,
                names[j],
                rows[k][j]
            )));
        }
        let system = self.system_for(backend)?;
        let options = RunOptions {
            positions_only,
            stop_at_singular,
        };
        let orders = if positions_only { 1 } else { 3 };
        let mut columns = vec!["row".to_owned()];
        columns.extend(names.iter().cloned());
        columns.push("t".to_owned());
        let coords: Vec<&str> = d.coordinates.iter().map(|c| c.name.as_str()).collect();
        let outs: Vec<&str> = d.outputs.iter().map(|o| o.name.as_str()).collect();
        for block in [&coords, &outs] {
            for suffix in &["", "_dot", "_ddot"][..orders] {
                columns.extend(block.iter().map(|c| format!("{c}{suffix}")));
            }
        }
        let out = py.detach(|| run_sweep(system, indices, &rows, first, &times, options, threads));
        let dict = PyDict::new(py);
        dict.set_item("values", array(py, out.values, out.rows, columns.len())?)?;
        dict.set_item("columns", columns)?;
        dict.set_item("failures", out.failures)?;
        dict.set_item("flagged", out.flagged)?;
        Ok(dict)
    }
}

/// `a, b, c` (or "none").
fn known(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_owned()
    } else {
        names
            .iter()
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The native module `kinema._kinema`.
#[pymodule]
fn _kinema(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<NativeModel>()?;
    m.add("KinemaError", py.get_type::<KinemaError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("AnalysisError", py.get_type::<AnalysisError>())?;
    m.add("MAX_TIMES", MAX_TIMES)?;
    Ok(())
}
