//! Model files: kinema's language (`.kin`, or any other name) and
//! simEngine2D models (`.adm`), read and parsed the same way.
//!
//! [`Model::from_file`] reads, checks and derives in one call. A program
//! that must look at an `.adm` model between reading and checking (the
//! command line refuses what a kinematic run cannot do, with the engine's
//! counts, before kinema's checker speaks) reads a [`ModelFile`] first and
//! derives it with [`ModelFile::into_model`].

use std::path::Path;

use kinema_model::{CheckedModel, Parsed, Report, Source};

use crate::Model;

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
    /// A simEngine2D analysis file (`.acf`) given where a model is expected.
    pub fn of(path: &Path) -> Result<Format, Report> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("adm") => Ok(Format::Adm),
            Some("acf") => Err(Report::whole_file(
                &path.display().to_string(),
                format!(
                    "`{}` is a simEngine2D analysis file, not a model: give the .adm model",
                    path.display()
                ),
            )),
            _ => Ok(Format::Kin),
        }
    }
}

/// A model file read and parsed, not yet checked.
#[derive(Debug)]
pub struct ModelFile {
    format: Format,
    parsed: Parsed,
    /// The simEngine2D model as read, for an `.adm` file (its analysis
    /// settings, forces and names are the caller's to use).
    pub adm: Option<kinema_adm::Model>,
}

impl ModelFile {
    /// Reads and parses the file at `path` (see [`Format::of`]). An `.adm`
    /// model's syntax tree points into its JSON text, so later messages
    /// show the ADM file's lines.
    ///
    /// # Errors
    /// A [`Report`]: the file cannot be read (larger than
    /// [`kinema_model::MAX_SOURCE_BYTES`], not UTF-8), or does not parse.
    pub fn read(path: &Path) -> Result<ModelFile, Report> {
        match Format::of(path)? {
            Format::Kin => Ok(ModelFile {
                format: Format::Kin,
                parsed: Parsed::from_source(Source::read(path)?)?,
                adm: None,
            }),
            Format::Adm => {
                let (adm, source) = kinema_adm::Model::read(path)?;
                Ok(ModelFile {
                    format: Format::Adm,
                    parsed: kinema_adm::parsed(&adm, source),
                    adm: Some(adm),
                })
            }
        }
    }

    /// The file's format.
    #[must_use]
    pub fn format(&self) -> Format {
        self.format
    }

    /// The source: the file's name and text.
    #[must_use]
    pub fn source(&self) -> &Source {
        self.parsed.source()
    }

    /// Checks and derives the model.
    ///
    /// # Errors
    /// A [`Report`] with every error found.
    pub fn into_model(self) -> Result<Model, Report> {
        self.parsed.derive().map(Model::from_derived)
    }

    /// [`ModelFile::into_model`], keeping the validated model too (its
    /// bodies, points and equations as declared: what a plot draws).
    ///
    /// # Errors
    /// As [`ModelFile::into_model`].
    pub fn into_checked_model(self) -> Result<(CheckedModel, Model), Report> {
        let derived = self.parsed.derive()?;
        let (checked, derivation, warnings) = derived.into_parts();
        Ok((checked, Model::from_parts(derivation, warnings)))
    }
}
