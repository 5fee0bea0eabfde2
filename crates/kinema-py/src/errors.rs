//! kinema's errors as Python exceptions: a [`kinema::Report`] as
//! `ModelError` (its entries as dicts), argument errors as `ValueError`.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::ModelError;

/// A [`kinema::Report`] (a model with errors, a file that cannot be read,
/// an ADM or ACF file's mistakes) as the Python `ModelError`: the rendered
/// report its message, each entry a dict in `.diagnostics`.
pub(crate) fn model_error(py: Python<'_>, report: &kinema::Report) -> PyErr {
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
pub(crate) fn file_error(py: Python<'_>, file: &str, message: String) -> PyErr {
    model_error(py, &kinema::Report::whole_file(file, message))
}

pub(crate) fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// `a, b, c` (or "none").
pub(crate) fn known(names: &[String]) -> String {
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
