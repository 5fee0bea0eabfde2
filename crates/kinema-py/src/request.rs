//! The arguments of the native analyses, one request each: a dict the
//! Python layer (python/kinema/) builds, extracted into a struct. The
//! Python layer is the public API and checks the user's arguments; the
//! native methods take one request rather than a long keyword list, and a
//! key the Python layer leaves out takes the default below.

use pyo3::exceptions::{PyKeyError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The default back end, as the Python layer's `backend="jit"`.
fn jit() -> String {
    "jit".to_owned()
}

/// The default integrator, as the Python layer's `integrator="hht"`.
fn hht() -> String {
    "hht".to_owned()
}

/// The arguments of `NativeModel.run` (kinematic analysis).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct RunRequest {
    /// The solve times, or None for the grid of `t_end` and `steps`.
    pub(crate) times: Option<Vec<f64>>,
    /// Which of `times` are output rows (all when left out).
    #[pyo3(default)]
    pub(crate) outputs: Option<Vec<bool>>,
    /// `kinema run --columns` (all when left out).
    #[pyo3(default)]
    pub(crate) columns: Option<String>,
    #[pyo3(default)]
    pub(crate) positions_only: bool,
    #[pyo3(default)]
    pub(crate) stop_at_singular: bool,
    /// `"jit"` or `"tape"`.
    #[pyo3(default = jit())]
    pub(crate) backend: String,
    /// The final time of the grid when `times` is None.
    #[pyo3(default)]
    pub(crate) t_end: Option<f64>,
    /// The grid's number of steps when `times` is None.
    #[pyo3(default)]
    pub(crate) steps: Option<i64>,
}

impl RunRequest {
    /// The keys a run request may have (its fields).
    pub(crate) const KEYS: &'static [&'static str] = &[
        "times",
        "outputs",
        "columns",
        "positions_only",
        "stop_at_singular",
        "backend",
        "t_end",
        "steps",
    ];
}

/// The arguments of `NativeModel.forward` (forward dynamics).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct ForwardRequest {
    /// The output times, increasing; the motion starts at the first.
    pub(crate) times: Vec<f64>,
    /// `kinema run --columns` (all when left out).
    #[pyo3(default)]
    pub(crate) columns: Option<String>,
    /// `"hht"` or `"accurate"`.
    #[pyo3(default = hht())]
    pub(crate) integrator: String,
    /// HHT's largest step (the model's default step when left out).
    #[pyo3(default)]
    pub(crate) step: Option<f64>,
    /// The accurate integrator's tolerance (its default when left out).
    #[pyo3(default)]
    pub(crate) rtol: Option<f64>,
    #[pyo3(default)]
    pub(crate) project_velocity: bool,
    #[pyo3(default)]
    pub(crate) energy: bool,
    /// `"jit"` or `"tape"`.
    #[pyo3(default = jit())]
    pub(crate) backend: String,
}

impl ForwardRequest {
    /// The keys a forward request may have (its fields).
    pub(crate) const KEYS: &'static [&'static str] = &[
        "times",
        "columns",
        "integrator",
        "step",
        "rtol",
        "project_velocity",
        "energy",
        "backend",
    ];
}

/// The arguments of `NativeModel.sweep`.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct SweepRequest<'py> {
    /// The swept parameters, one column of `table` each.
    pub(crate) names: Vec<String>,
    /// A 2-D array of numbers: one row per variant.
    pub(crate) table: Bound<'py, PyAny>,
    /// The solve times, every one an output.
    pub(crate) times: Vec<f64>,
    /// The variants are numbered from `first + 1` (a shard's offset).
    #[pyo3(default)]
    pub(crate) first: usize,
    #[pyo3(default)]
    pub(crate) positions_only: bool,
    #[pyo3(default)]
    pub(crate) stop_at_singular: bool,
    /// `"jit"` or `"tape"`.
    #[pyo3(default = jit())]
    pub(crate) backend: String,
    /// Threads for the variants (all cores when left out).
    #[pyo3(default)]
    pub(crate) threads: Option<usize>,
}

impl SweepRequest<'_> {
    /// The keys a sweep request may have (its fields).
    pub(crate) const KEYS: &'static [&'static str] = &[
        "names",
        "table",
        "times",
        "first",
        "positions_only",
        "stop_at_singular",
        "backend",
        "threads",
    ];
}

/// The request `T` of the analysis `what` from `dict`, whose keys must be
/// among `keys`. Every failure is a TypeError that names the key: an
/// unknown key (a misspelt one would otherwise be ignored), a missing one,
/// or a value of the wrong type (PyO3's message names the field, its cause
/// says why: both go into the message).
pub(crate) fn extract<'a, 'py, T>(
    what: &str,
    dict: &'a Bound<'py, PyDict>,
    keys: &[&str],
) -> PyResult<T>
where
    T: FromPyObject<'a, 'py, Error = PyErr>,
{
    let py = dict.py();
    for key in dict.keys() {
        let known = key
            .extract::<String>()
            .is_ok_and(|k| keys.contains(&k.as_str()));
        if !known {
            return Err(PyTypeError::new_err(format!(
                "{what} request: unknown key {}; the keys are {}",
                key.repr()?,
                keys.join(", ")
            )));
        }
    }
    dict.extract::<T>().map_err(|e| {
        if e.is_instance_of::<PyKeyError>(py) {
            return PyTypeError::new_err(format!(
                "{what} request: the key {} is missing",
                e.value(py)
            ));
        }
        match e.cause(py) {
            Some(cause) => {
                let flat =
                    PyTypeError::new_err(format!("{what} request: {}: {cause}", e.value(py)));
                flat.set_cause(py, Some(cause));
                flat
            }
            None => e,
        }
    })
}
