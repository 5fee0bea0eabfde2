//! simEngine2D specifics: reading an ADM model and its ACF analysis,
//! refusing what kinematics cannot run, noting what it ignores, and naming
//! ADM constraints in run-time messages. `kinema import` lives here too.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

use kinema_adm::{Analysis, Model, Names, Report, RowOrigin, Source};

use super::{Failure, print_stdout};

/// An ADM model read for a kinematic run.
#[derive(Debug)]
pub struct AdmInput {
    /// The model as read.
    pub model: Model,
    /// Its identifiers in the emitted `.kin` (bodies, constraints).
    pub names: Names,
    /// kinema row name → the ADM constraint it comes from.
    rows: HashMap<String, usize>,
    /// What a kinematic run ignores (forces, unknown keys), one line each.
    ignored: Vec<String>,
    /// The reader's warnings, against the file's text.
    warnings: Report,
}

impl AdmInput {
    /// The ADM model read from `path`, checked that it runs as kinematics
    /// under `analysis` (no check without one: the equilibrium of a model
    /// with free degrees of freedom).
    ///
    /// # Errors
    /// [`Failure::Input`]: the refusal of a Dynamics analysis or of
    /// NDOF ≠ 0, with the counts, or of a force kinema cannot compute.
    pub fn checked(
        model: Model,
        source: &Source,
        path: &Path,
        analysis: Option<&Analysis>,
    ) -> Result<AdmInput, Failure> {
        if let Some(analysis) = analysis {
            kinema_adm::check_kinematic(&model, analysis).map_err(Failure::usage)?;
        }
        super::dynamics::refuse_point_force_files(&model, path)?;
        let names = Names::of(&model);
        let rows = names
            .rows(&model)
            .into_iter()
            .map(|RowOrigin { row, constraint }| (row, constraint))
            .collect();
        let ignored = kinema_adm::ignored_by_kinematics(&model);
        let warnings = model.warnings.report(Arc::new(source.clone()));
        Ok(AdmInput {
            model,
            names,
            rows,
            ignored,
            warnings,
        })
    }

    /// Prints the reader's warnings and what a kinematic run ignores on
    /// standard error.
    pub fn print_notes(&self) {
        print_warnings(&self.warnings);
        for line in &self.ignored {
            super::print_stderr(&format!("note: ignored by kinematic analysis: {line}"));
        }
    }

    /// The ADM constraint a kinema row (or equation) name comes from, as
    /// `constraint "name" (id k, Type)`.
    pub fn describe_row(&self, row: &str) -> Option<String> {
        let k = self.rows.get(row).copied().or_else(|| {
            // An equation name (a rack-pinion's `name_1`) rather than a row.
            self.names
                .constraints
                .iter()
                .position(|idents| idents.iter().any(|i| i == row))
        })?;
        let c = self.model.constraints.get(k)?;
        Some(format!(
            "constraint \"{}\" (id {}, {})",
            c.name,
            c.id,
            c.kind.type_name()
        ))
    }

    /// Lines that name the ADM constraint of every kinema equation `names`
    /// mentions, for appending to a run-time error.
    pub fn explain(&self, names: &[&str]) -> String {
        let mut out = String::new();
        let mut seen = Vec::new();
        for name in names {
            if seen.contains(name) {
                continue;
            }
            seen.push(name);
            if let Some(d) = self.describe_row(name) {
                let _ = write!(out, "\n  = note: equation `{name}` is ADM {d}");
            }
        }
        out
    }
}

/// Reads an ADM file: the model and its source.
///
/// # Errors
/// [`Failure::Input`] with every located error, rendered.
pub fn read_model(path: &Path) -> Result<(Model, Source), Failure> {
    Model::read(path).map_err(|report| Failure::Input(report.render()))
}

/// Prints the reader's warnings on standard error: each on its own, as the
/// warnings of a `.kin` model are.
fn print_warnings(warnings: &Report) {
    for warning in warnings.render_each() {
        super::print_stderr(warning.trim_end());
    }
}

/// Reads the analysis: the ACF at `path`, or the engine's kinematics.acf.
///
/// # Errors
/// [`Failure::Input`] with the ACF reader's located errors, rendered.
pub fn read_analysis(path: Option<&Path>) -> Result<Analysis, Failure> {
    let Some(path) = path else {
        return Ok(Analysis::default());
    };
    Analysis::read(path).map_err(|report| Failure::Input(report.render()))
}

/// `kinema import MODEL.adm`: prints the model as `.kin` text. A model that
/// is not kinematic (NDOF ≠ 0) is still printed, with a note: the text is
/// the starting point for adding drivers.
///
/// # Errors
/// [`Failure::Input`] for an unreadable or invalid ADM file.
pub fn import(path: &Path) -> Result<(), Failure> {
    let (model, source) = read_model(path)?;
    print_warnings(&model.warnings.report(Arc::new(source)));
    if let Err(refusal) = kinema_adm::check_kinematic(&model, &Analysis::default()) {
        super::print_stderr(&format!("note: {refusal}"));
    }
    print_stdout(&kinema_adm::to_kin(&model))
}
