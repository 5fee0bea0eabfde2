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
//! results objects, warnings through `warnings`, pandas, Dask; it checks
//! the user's arguments and hands each analysis one request dict
//! ([`request`]), so the native signatures stay short.
//!
//! The GIL is released while Rust runs ([`Python::detach`]); results come
//! back as one 2-D float64 numpy array made from the `Vec<f64>` the run
//! filled (no per-element conversion through Python objects).

use std::path::PathBuf;

mod errors;
mod forward;
mod request;
mod run;
mod sweep;

use kinema::dynamics::DynamicsColumns;
use kinema::uniform_times as uniform_grid;
use request::{ForwardRequest, RunRequest, SweepRequest};
use run::{RunOptions, backend_name, check_times, run_kinematics};
use sweep::run_sweep;

use errors::{file_error, known, model_error, value_error};

use kinema::{System, TapeSystem};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
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
            names.extend(dy.names().iter().cloned());
        }
        Ok(names)
    }

    /// Kinematic analysis over `times` (outputs where `outputs` is true,
    /// all by default), as `kinema run`. Returns a dict: `columns`,
    /// `values` (rows × columns float64), `events`, `flagged`, `kinks`,
    /// `output_kinks`, `imprecise`, `error` (None, or why the run stopped:
    /// the rows are those before it), `backend`. `times` None: the grid of
    /// `t_end` and `steps` ([`NativeModel::grid`]), made here rather than
    /// passed through Python lists. The arguments come as one dict, a
    /// [`RunRequest`].
    fn run<'py>(
        &self,
        py: Python<'py>,
        request: &Bound<'py, PyDict>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let RunRequest {
            times,
            outputs,
            columns,
            positions_only,
            stop_at_singular,
            backend,
            t_end,
            steps,
        } = request::extract("run", request, RunRequest::KEYS)?;
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
        let selection = kinema::columns::Selection::of_option(columns.as_deref(), d)
            .map_err(|e| value_error(e.to_string()))?
            .with_positions_only(positions_only);
        let header = selection.header(d);
        let system = self.system_for(&backend)?;
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
    /// `consistency`, `integrator`, `energies`, `motion`. The arguments
    /// come as one dict, a [`ForwardRequest`].
    fn forward<'py>(
        &self,
        py: Python<'py>,
        request: &Bound<'py, PyDict>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let ForwardRequest {
            times,
            columns,
            integrator,
            step,
            rtol,
            project_velocity,
            energy,
            backend,
        } = request::extract("forward", request, ForwardRequest::KEYS)?;
        check_times(&times)?;
        let integrator = match integrator.as_str() {
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
        let selection = kinema::columns::Selection::of_option(columns.as_deref(), d)
            .map_err(|e| value_error(e.to_string()))?;
        let system = self.system_for(&backend)?;
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
            forward::run_forward(&forward::ForwardRun {
                model: &self.model,
                system: &system,
                file: &self.file,
                kind,
                start: [&q0, &qd0],
                times: &times,
                selection: &selection,
                options: &options,
            })
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
    /// `values`, `failures` [(variant from 0, message)], `flagged`. The
    /// arguments come as one dict, a [`SweepRequest`].
    fn sweep<'py>(
        &self,
        py: Python<'py>,
        request: &Bound<'py, PyDict>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let SweepRequest {
            names,
            table,
            times,
            first,
            positions_only,
            stop_at_singular,
            backend,
            threads,
        } = request::extract("sweep", request, SweepRequest::KEYS)?;
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
        let system = self.system_for(&backend)?;
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
