//! simEngine2D specifics: reading an ADM model and its ACF analysis,
//! refusing what kinematics cannot run, noting what it ignores, and naming
//! ADM constraints in run-time messages. `kinema import` lives here too.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use kinema_adm::{Analysis, Diagnostic, Model, Names, RowOrigin};

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
        Ok(AdmInput {
            model,
            names,
            rows,
            ignored,
        })
    }

    /// Prints the reader's warnings and what a kinematic run ignores on
    /// standard error.
    pub fn print_notes(&self) {
        for w in &self.model.warnings {
            super::print_stderr(&render(w, "warning"));
        }
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

/// Reads an ADM file: the model and the file's text.
///
/// # Errors
/// [`Failure::Input`] with every located error.
pub fn read_model(path: &Path) -> Result<(Model, String), Failure> {
    let name = path.display().to_string();
    let read = kinema_adm::read_text(path)
        .map_err(|e| kinema_adm::Error::from(Diagnostic::whole_file(&name, e.to_string())))
        .and_then(|text| Model::parse(&text, &name).map(|m| (m, text)));
    read.map_err(|e| {
        let file = path.display();
        let mut out = String::new();
        for d in e.diagnostics() {
            out.push_str(&render(d, "error"));
            out.push_str("\n\n");
        }
        let n = e.diagnostics().len();
        let s = if n == 1 { "" } else { "s" };
        let _ = write!(
            out,
            "error: could not read `{file}` due to {n} previous error{s}"
        );
        Failure::Input(out)
    })
}

/// Reads the analysis: the ACF at `path`, or the engine's kinematics.acf.
///
/// # Errors
/// [`Failure::Input`] with the ACF reader's located errors.
pub fn read_analysis(path: Option<&Path>) -> Result<Analysis, Failure> {
    let Some(path) = path else {
        return Ok(Analysis::default());
    };
    Analysis::read(path).map_err(|e| {
        let out: Vec<String> = e.diagnostics().iter().map(|d| render(d, "error")).collect();
        Failure::Input(out.join("\n\n"))
    })
}

/// A reader diagnostic in the look of the `.kin` diagnostics (rustc's):
/// `severity: message`, then ` --> file:line:col`, the source line and a
/// caret.
pub fn render(d: &Diagnostic, severity: &str) -> String {
    let mut out = format!("{severity}: {}", d.message);
    let Some(pos) = d.pos else {
        let _ = write!(out, "\n --> {}", d.file);
        return out;
    };
    let num = pos.line.to_string();
    let pad = " ".repeat(num.len());
    let _ = write!(out, "\n{pad}--> {}:{}:{}", d.file, pos.line, pos.col);
    if let Some(line) = &d.line_text {
        // Tabs are kept in the caret's padding so that it lines up.
        let caret_pad: String = line
            .chars()
            .take(pos.col.saturating_sub(1) as usize)
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        let _ = write!(
            out,
            "\n{pad} |\n{num} | {}\n{pad} | {caret_pad}^",
            line.trim_end()
        );
    }
    out
}

/// `kinema import MODEL.adm`: prints the model as `.kin` text. A model that
/// is not kinematic (NDOF ≠ 0) is still printed, with a note: the text is
/// the starting point for adding drivers.
///
/// # Errors
/// [`Failure::Input`] for an unreadable or invalid ADM file.
pub fn import(path: &Path) -> Result<(), Failure> {
    let (model, _) = read_model(path)?;
    for w in &model.warnings {
        super::print_stderr(&render(w, "warning"));
    }
    if let Err(refusal) = kinema_adm::check_kinematic(&model, &Analysis::default()) {
        super::print_stderr(&format!("note: {refusal}"));
    }
    print_stdout(&kinema_adm::to_kin(&model))
}
