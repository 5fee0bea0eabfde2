//! The one way into the language: a [`Source`] is parsed, checked and
//! derived, each step a type of its own and each failure a [`Report`].
//!
//! ```text
//! Source ──parse──► Parsed ──check──► Checked ──derive──► Derived
//!   (path + text)     (syntax tree)    (names, types,      (Φ, Φ_q, ν, γ, …
//!                                       counts; warnings)   and the warnings)
//! ```
//!
//! Every front end enters here: a `.kin` file ([`Source::read`]), model
//! text ([`Source::new`]), the tokens of `mechanism! { … }`
//! ([`Parsed::from_tokens`]) and a syntax tree built by another reader
//! whose spans point into its own file (the simEngine2D importer,
//! [`Parsed::new`]). The sequence parse → check → derive is written once,
//! in [`Parsed::derive`]; the phases themselves ([`ParsedModel::check`],
//! [`Derivation::new`]) stay available to code that wants one of them
//! alone.
//!
//! ```
//! use kinema_model::Source;
//! let source = Source::new(
//!     "pendulum.kin",
//!     "mechanism P { body bar; joint pin: revolute(bar(-1, 0), ground(0, 0));
//!                    driver swing: bar.phi == t; }",
//! );
//! let derived = match source.derive() {
//!     Ok(d) => d,
//!     Err(report) => panic!("{report}"),
//! };
//! assert_eq!(derived.derivation().dof.ndof(), 0);
//! assert!(derived.warnings().is_empty());
//! ```

use std::io::Read as _;
use std::path::Path;
use std::sync::Arc;

use proc_macro2::LineColumn;

use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::span::Span;
use crate::{CheckedModel, Derivation, ParsedModel};

/// The largest model (or simEngine2D analysis) file read: 16 MiB. A
/// thousand-body model is a few hundred kilobytes; reading stops past the
/// limit, so that a stream without end (`/dev/zero`) is an error, not an
/// exhausted memory.
pub const MAX_SOURCE_BYTES: u64 = 16 << 20;

/// A model's text and the name its messages give it (the file's path as
/// given, or a name chosen for text that has no file).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Source {
    name: String,
    text: String,
}

impl Source {
    /// Text with a name for messages.
    #[must_use]
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> Source {
        Source {
            name: name.into(),
            text: text.into(),
        }
    }

    /// Reads the file at `path`: at most [`MAX_SOURCE_BYTES`], UTF-8.
    ///
    /// # Errors
    /// A [`Report`] when the file cannot be read, is larger than the
    /// limit, or is not UTF-8 (then at the first byte that is not, shown on
    /// the text read lossily).
    pub fn read(path: &Path) -> Result<Source, Report> {
        let name = path.display().to_string();
        let whole_file = |message: String| Report::whole_file(&name, message);
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_SOURCE_BYTES + 1).read_to_end(&mut bytes))
            .map_err(|e| whole_file(format!("cannot read model file `{name}`: {e}")))?;
        if bytes.len() as u64 > MAX_SOURCE_BYTES {
            return Err(whole_file(format!(
                "cannot read model file `{name}`: the file is larger than {} MiB, the most \
                 kinema reads",
                MAX_SOURCE_BYTES >> 20
            )));
        }
        match String::from_utf8(bytes) {
            Ok(text) => Ok(Source { name, text }),
            Err(e) => {
                let bytes = e.into_bytes();
                let diagnostics = crate::source::decode(&bytes).err().unwrap_or_default();
                let text = String::from_utf8_lossy(&bytes).into_owned();
                Err(Report::new(Arc::new(Source { name, text }), diagnostics))
            }
        }
    }

    /// The name messages give the text.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The text.
    #[must_use]
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Parses the text as a `.kin` model.
    ///
    /// # Errors
    /// Lexer and parser errors.
    pub fn parse(self) -> Result<Parsed, Report> {
        let source = Arc::new(self);
        match ParsedModel::parse_str(&source.text) {
            Ok(model) => Ok(Parsed { source, model }),
            Err(diagnostics) => Err(Report::new(source, diagnostics)),
        }
    }

    /// Parses, checks and derives the text ([`Source::parse`], then
    /// [`Parsed::derive`]).
    ///
    /// # Errors
    /// The first phase's errors (with the warnings found so far).
    pub fn derive(self) -> Result<Derived, Report> {
        self.parse()?.derive()
    }
}

/// A model's diagnostics (errors and warnings, as data) with the source
/// they point into, rendered once, in rustc's style, by [`Report::render`]
/// (or `Display`).
#[derive(Clone, Debug)]
pub struct Report {
    source: Arc<Source>,
    diagnostics: Diagnostics,
}

impl Report {
    /// `diagnostics` whose spans point into `source`.
    #[must_use]
    pub fn new(source: Arc<Source>, diagnostics: Diagnostics) -> Report {
        Report {
            source,
            diagnostics,
        }
    }

    /// One error about a whole file (`name`), at no place in it: a file that
    /// cannot be read.
    #[must_use]
    pub fn whole_file(name: &str, message: impl Into<String>) -> Report {
        // Line 0 is a place no text has: the renderer names the file alone.
        let nowhere = LineColumn { line: 0, column: 0 };
        let mut diagnostics = Diagnostics::new();
        diagnostics.push(Diagnostic::error(Span::at(nowhere, nowhere), message));
        Report::new(Arc::new(Source::new(name, "")), diagnostics)
    }

    /// The diagnostics, in the order found.
    #[must_use]
    pub fn diagnostics(&self) -> &Diagnostics {
        &self.diagnostics
    }

    /// The diagnostics, without the source.
    #[must_use]
    pub fn into_diagnostics(self) -> Diagnostics {
        self.diagnostics
    }

    /// The source the diagnostics point into.
    #[must_use]
    pub fn source(&self) -> &Source {
        &self.source
    }

    /// No diagnostic at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.diagnostics.is_empty()
    }

    /// How many errors were found (kept or not).
    #[must_use]
    pub fn error_count(&self) -> usize {
        self.diagnostics.error_count()
    }

    /// Every diagnostic rendered, then the summary line when there are
    /// errors (see [`Diagnostics::render`]).
    #[must_use]
    pub fn render(&self) -> String {
        self.diagnostics
            .render(&self.source.text, &self.source.name)
    }

    /// Each diagnostic rendered on its own (see [`Diagnostics::render_each`]).
    #[must_use]
    pub fn render_each(&self) -> Vec<String> {
        self.diagnostics
            .render_each(&self.source.text, &self.source.name)
    }

    /// The errors as one combined `syn::Error` at their tokens (the
    /// proc-macro's form; see [`Diagnostics::into_syn_error`]).
    #[must_use]
    pub fn into_syn_error(self) -> syn::Error {
        self.diagnostics.into_syn_error()
    }
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.render().trim_end())
    }
}

impl std::error::Error for Report {}

/// A parsed model and the source its spans point into.
#[derive(Clone, Debug)]
pub struct Parsed {
    source: Arc<Source>,
    model: ParsedModel,
}

impl Parsed {
    /// A syntax tree built by another reader (the simEngine2D importer),
    /// its spans pointing into `source`.
    #[must_use]
    pub fn new(source: Source, model: ParsedModel) -> Parsed {
        Parsed {
            source: Arc::new(source),
            model,
        }
    }

    /// Parses the tokens of a `mechanism! { … }` invocation. Their spans
    /// are the compiler's: the source has no text, and a failure is meant
    /// for [`Report::into_syn_error`].
    ///
    /// # Errors
    /// Parser errors.
    pub fn from_tokens(tokens: proc_macro2::TokenStream) -> Result<Parsed, Report> {
        let source = Arc::new(Source::new("mechanism!", ""));
        match ParsedModel::parse_tokens(tokens) {
            Ok(model) => Ok(Parsed { source, model }),
            Err(diagnostics) => Err(Report::new(source, diagnostics)),
        }
    }

    /// The parsed model.
    #[must_use]
    pub fn model(&self) -> &ParsedModel {
        &self.model
    }

    /// The source.
    #[must_use]
    pub fn source(&self) -> &Source {
        &self.source
    }

    /// Validates the model (every rule of [`crate::check`]).
    ///
    /// # Errors
    /// Every error found, with the warnings.
    pub fn check(self) -> Result<Checked, Report> {
        match self.model.check() {
            Ok(model) => Ok(Checked {
                source: self.source,
                model,
            }),
            Err(diagnostics) => Err(Report::new(self.source, diagnostics)),
        }
    }

    /// Checks and derives the model: the one place the phases are chained.
    ///
    /// # Errors
    /// The checker's errors, or the derivation's.
    pub fn derive(self) -> Result<Derived, Report> {
        self.check()?.derive()
    }
}

/// A validated model and its source.
#[derive(Clone, Debug)]
pub struct Checked {
    source: Arc<Source>,
    model: CheckedModel,
}

impl Checked {
    /// The validated model (its warnings in `warnings`).
    #[must_use]
    pub fn model(&self) -> &CheckedModel {
        &self.model
    }

    /// The source.
    #[must_use]
    pub fn source(&self) -> &Source {
        &self.source
    }

    /// Derives the model ([`Derivation::new`]).
    ///
    /// # Errors
    /// An equation whose derivatives outgrow the budget.
    pub fn derive(self) -> Result<Derived, Report> {
        match Derivation::new(&self.model) {
            Ok(derivation) => {
                let warnings = Report::new(self.source.clone(), self.model.warnings.clone());
                Ok(Derived {
                    source: self.source,
                    checked: self.model,
                    derivation,
                    warnings,
                })
            }
            Err(diagnostics) => Err(Report::new(self.source, diagnostics)),
        }
    }
}

/// A derived model: the validated model, its derivation and the checker's
/// warnings.
#[derive(Clone, Debug)]
pub struct Derived {
    source: Arc<Source>,
    checked: CheckedModel,
    derivation: Derivation,
    warnings: Report,
}

impl Derived {
    /// The validated model.
    #[must_use]
    pub fn checked(&self) -> &CheckedModel {
        &self.checked
    }

    /// The derivation.
    #[must_use]
    pub fn derivation(&self) -> &Derivation {
        &self.derivation
    }

    /// The warnings (a report without errors; empty when there are none).
    #[must_use]
    pub fn warnings(&self) -> &Report {
        &self.warnings
    }

    /// The source.
    #[must_use]
    pub fn source(&self) -> &Source {
        &self.source
    }

    /// The validated model, the derivation and the warnings.
    #[must_use]
    pub fn into_parts(self) -> (CheckedModel, Derivation, Report) {
        (self.checked, self.derivation, self.warnings)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_phase_reports_against_its_source() {
        let parse = Source::new("a.kin", "mechanism M { body b; driver d: b.x == ; }")
            .derive()
            .err();
        let rendered = parse.map(|r| r.render()).unwrap_or_default();
        assert!(rendered.contains("--> a.kin:1:"), "{rendered}");

        let check = Source::new("b.kin", "mechanism M {\n body b;\n driver d: c.x == t;\n}")
            .derive()
            .err();
        let rendered = check.map(|r| r.render()).unwrap_or_default();
        assert!(rendered.contains("--> b.kin:3:"), "{rendered}");
        assert!(rendered.contains("could not check `b.kin`"), "{rendered}");
    }

    #[test]
    fn warnings_are_diagnostics() {
        let derived = Source::new(
            "w.kin",
            "mechanism M { body b; driver d: b.x == 1; constraint c: b.y == 0; \
             constraint e: b.phi == 0; }",
        )
        .derive();
        let Ok(derived) = derived else {
            panic!("{:?}", derived.err().map(|r| r.render()));
        };
        assert_eq!(derived.warnings().error_count(), 0);
        assert_eq!(derived.warnings().diagnostics().len(), 1);
        assert!(derived.warnings().render().contains("--> w.kin:1:"));
    }

    #[test]
    fn unreadable_files_are_reports() {
        let missing = Source::read(Path::new("/nonexistent/kinema/model.kin")).err();
        let rendered = missing.map(|r| r.render()).unwrap_or_default();
        assert!(
            rendered.starts_with("error: cannot read model file `/nonexistent/kinema/model.kin`"),
            "{rendered}"
        );
    }
}
