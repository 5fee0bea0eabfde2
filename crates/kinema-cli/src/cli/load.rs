//! Reading a model file — `.kin` text, or a simEngine2D `.adm` whose syntax
//! tree kinema-adm makes directly (no `.kin` text in between; messages
//! point into the ADM file) — into a checked and derived model, through the
//! library's front door ([`kinema::ModelFile`]).

use std::path::Path;
use std::time::{Duration, Instant};

use kinema::lang::CheckedModel;
use kinema::{Format, ModelFile, Report};
use kinema_adm::Analysis;

use super::Failure;
use super::adm::AdmInput;

/// The command line's check of a model file's name: an ACF analysis
/// given where a model is expected says where the analysis goes.
///
/// # Errors
/// [`Failure::Input`] for an `.acf` file.
pub fn format_of(path: &Path) -> Result<Format, Failure> {
    Format::of(path).map_err(|_| {
        Failure::usage(format_args!(
            "`{}` is a simEngine2D analysis file, not a model: give the .adm model and \
             pass the analysis with --acf",
            path.display()
        ))
    })
}

/// A report as the command line's input failure (status 2).
pub fn input(report: &Report) -> Failure {
    Failure::Input(report.render())
}

/// A model read, checked and derived.
#[derive(Debug)]
pub struct Loaded {
    /// The file name as given, for messages.
    pub file: String,
    /// The validated model (joint points for plots).
    checked: CheckedModel,
    /// The derived model: the tape back end, the derivation text, the
    /// generated source, the warnings.
    pub model: kinema::Model,
    /// The simEngine2D model, when the file was one.
    pub adm: Option<AdmInput>,
    /// Time spent reading, checking and deriving.
    pub elapsed: Duration,
}

impl Loaded {
    /// Prints the warnings (and, for an `.adm` model, what a kinematic run
    /// ignores) on standard error.
    pub fn print_warnings(&self) {
        for w in self.model.warnings().render_each() {
            super::print_stderr(w.trim_end());
        }
        if let Some(adm) = &self.adm {
            adm.print_notes();
        }
    }

    /// The mechanism's name.
    pub fn name(&self) -> &str {
        &self.checked.name
    }

    /// The validated model.
    pub fn checked(&self) -> &CheckedModel {
        &self.checked
    }
}

/// Reads, checks and derives the model at `path`. For an `.adm` file the
/// model must be runnable as kinematics under `analysis` (the engine's
/// kinematics.acf when `None`).
///
/// # Errors
/// [`Failure::Input`] with the rendered diagnostics.
pub fn load(path: &Path, analysis: Option<&Analysis>) -> Result<Loaded, Failure> {
    load_with(path, analysis, true)
}

/// [`load`]; `kinematic` false skips the kinematic check of an `.adm`
/// model (NDOF = 0, a Kinematics analysis): `run --equilibrium`.
///
/// # Errors
/// As [`load`].
pub fn load_with(
    path: &Path,
    analysis: Option<&Analysis>,
    kinematic: bool,
) -> Result<Loaded, Failure> {
    let start = Instant::now();
    format_of(path)?;
    let mut file = ModelFile::read(path).map_err(|r| input(&r))?;
    // An ADM model is refused for what a kinematic run cannot do before
    // kinema's checker speaks: the engine's counts say more.
    let adm = match file.adm.take() {
        Some(model) => {
            let default = Analysis::default();
            let analysis = kinematic.then(|| analysis.unwrap_or(&default));
            Some(AdmInput::checked(model, file.source(), path, analysis)?)
        }
        None => None,
    };
    let (checked, model) = file.into_checked_model().map_err(|r| input(&r))?;
    Ok(Loaded {
        file: path.display().to_string(),
        checked,
        model,
        adm,
        elapsed: start.elapsed(),
    })
}
