//! The build-script path: a `.kin` file in, a formatted `.rs` file out.
//!
//! In `build.rs`:
//!
//! ```no_run
//! if let Err(e) = kinema_codegen::build::generate("models/slider_crank.kin", "slider_crank.rs") {
//!     eprintln!("{e}"); // file:line:col and the offending source line
//!     std::process::exit(1);
//! }
//! ```
//!
//! and in the crate: `include!(concat!(env!("OUT_DIR"), "/slider_crank.rs"));`
//! (see `examples/build-rs`).

use std::fmt;
use std::path::{Path, PathBuf};

use kinema_model::{Derivation, Derived, Report, Source};

use crate::{Config, generate_source};

/// Why a model file could not be turned into Rust.
#[derive(Debug)]
pub enum Error {
    /// The model file or the output could not be read or written.
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
    /// The model cannot be read or has errors: the report (diagnostics as
    /// data; its `Display` shows each with `file:line:col` and the source).
    Model(Report),
    /// `OUT_DIR` is not set: not running inside a build script.
    NoOutDir,
    /// The params [`Config::sensitivity`] names are not the model's (or
    /// their derivatives are too large): the message names the model's
    /// params.
    Sensitivity {
        /// The model file.
        path: PathBuf,
        /// Why.
        source: kinema_model::SensitivityError,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::Model(report) => f.write_str(report.render().trim_end()),
            Error::NoOutDir => f.write_str("OUT_DIR is not set (call this from a build script)"),
            Error::Sensitivity { path, source } => {
                write!(f, "{}: sensitivity: {source}", path.display())
            }
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            // The report (the sensitivity error) is the message itself
            // (Display), not a cause.
            Error::Model(_) | Error::NoOutDir | Error::Sensitivity { .. } => None,
        }
    }
}

/// Parses, checks and derives the model in `source`; `file` names it in
/// rendered diagnostics.
///
/// # Errors
/// [`Error::Model`] with every diagnostic.
pub fn derive_source(source: &str, file: &str) -> Result<Derivation, Error> {
    derive(Source::new(file, source))
}

fn derive(source: Source) -> Result<Derivation, Error> {
    match Derived::from_source(source) {
        Ok(derived) => Ok(derived.into_parts().1),
        Err(report) => Err(Error::Model(report)),
    }
}

/// Generates the Rust source for the model file at `model`.
///
/// # Errors
/// [`Error::Model`] if the file cannot be read (its size, UTF-8) or the
/// model has errors; [`Error::Sensitivity`] for params it does not have.
pub fn source_for_file(model: impl AsRef<Path>, options: &Config) -> Result<String, Error> {
    let source = Source::read(model.as_ref()).map_err(Error::Model)?;
    let derivation = derive(source)?;
    // Unknown param names are the build script's error, not a
    // `compile_error!` in the file it writes.
    if let Err(source) = crate::sensitivity::choose(&derivation, &options.sensitivity) {
        return Err(Error::Sensitivity {
            path: model.as_ref().to_path_buf(),
            source,
        });
    }
    Ok(generate_source(&derivation, options))
}

/// From a build script: generates `OUT_DIR/<output>` from the model file at
/// `model` (relative to the crate root) and tells Cargo to rerun when the
/// model changes. Include the result with
/// `include!(concat!(env!("OUT_DIR"), "/<output>"))`.
///
/// # Errors
/// [`Error::NoOutDir`] outside a build script, else as
/// [`source_for_file`], or [`Error::Io`] if the output cannot be written.
pub fn generate(model: impl AsRef<Path>, output: impl AsRef<Path>) -> Result<PathBuf, Error> {
    generate_with(model, output, &Config::default())
}

/// [`generate`] with explicit [`Config`] (e.g. a different runtime path).
///
/// # Errors
/// As [`generate`].
pub fn generate_with(
    model: impl AsRef<Path>,
    output: impl AsRef<Path>,
    options: &Config,
) -> Result<PathBuf, Error> {
    let out_dir = std::env::var_os("OUT_DIR").ok_or(Error::NoOutDir)?;
    let model = model.as_ref();
    println!("cargo::rerun-if-changed={}", model.display());
    let source = source_for_file(model, options)?;
    let path = Path::new(&out_dir).join(output);
    std::fs::write(&path, source).map_err(|source| Error::Io {
        path: path.clone(),
        source,
    })?;
    Ok(path)
}
