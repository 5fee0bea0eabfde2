//! Reading a model file — `.kin` text, or a simEngine2D `.adm` whose model
//! `kinema_adm::build` makes directly (no `.kin` text in between; messages
//! point into the ADM file) — into a checked and derived model.

use std::path::Path;
use std::time::{Duration, Instant};

use kinema_adm::Analysis;
use kinema_model::{CheckedModel, Derivation};

use super::Failure;
use super::adm::AdmInput;

/// What a model file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// kinema's model language.
    Kin,
    /// A simEngine2D model (JSON).
    Adm,
}

impl Format {
    /// The format of `path`, from its extension: `.adm` (any case) is
    /// simEngine2D, anything else kinema's language.
    ///
    /// # Errors
    /// An ACF analysis file given where a model is expected.
    pub fn of(path: &Path) -> Result<Format, Failure> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("adm") => Ok(Format::Adm),
            Some("acf") => Err(Failure::usage(format_args!(
                "`{}` is a simEngine2D analysis file, not a model: give the .adm model and \
                 pass the analysis with --acf",
                path.display()
            ))),
            _ => Ok(Format::Kin),
        }
    }
}

/// A model read, checked and derived.
#[derive(Debug)]
pub struct Loaded {
    /// The file name as given, for messages.
    pub file: String,
    /// The validated model (joint points for plots).
    pub checked: CheckedModel,
    /// The derived model: the tape back end, the derivation text, the
    /// generated source.
    pub model: kinema::Model,
    /// Warnings, rendered.
    pub warnings: Vec<String>,
    /// The simEngine2D model, when the file was one.
    pub adm: Option<AdmInput>,
    /// Time spent reading, checking and deriving.
    pub elapsed: Duration,
}

impl Loaded {
    /// Prints the warnings (and, for an `.adm` model, what a kinematic run
    /// ignores) on standard error.
    pub fn print_warnings(&self) {
        for w in &self.warnings {
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
    let file = path.display().to_string();
    let (source, adm) = match Format::of(path)? {
        Format::Kin => {
            // At most kinema_model::MAX_SOURCE_BYTES: `/dev/zero` is an
            // error, not an exhausted memory.
            let source =
                kinema_model::Source::read(path).map_err(|r| Failure::Input(r.render()))?;
            (source.text().to_owned(), None)
        }
        Format::Adm => {
            let default = Analysis::default();
            let adm =
                AdmInput::read_checked(path, kinematic.then(|| analysis.unwrap_or(&default)))?;
            (adm.source.clone(), Some(adm))
        }
    };
    // An ADM model's spans are in its file's text, like a .kin file's.
    let parsed = match &adm {
        Some(adm) => Ok(kinema_adm::build(&adm.model)),
        None => kinema_model::ParsedModel::parse_str(&source),
    };
    let shown = &file;
    let checked = parsed
        .and_then(|m| m.check())
        .map_err(|d| Failure::Input(d.render(&source, shown)))?;
    let warnings = checked.warnings.render_each(&source, shown);
    let derivation =
        Derivation::new(&checked).map_err(|d| Failure::Input(d.render(&source, shown)))?;
    let model = kinema::Model::from_derivation(derivation);
    Ok(Loaded {
        file,
        checked,
        model,
        warnings,
        adm,
        elapsed: start.elapsed(),
    })
}
