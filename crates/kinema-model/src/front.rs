//! The one way into the language: a [`Source`] is parsed, checked and
//! derived, each step a type of its own and each failure a [`Report`].
//!
//! ```text
//! Source ──parse──► Parsed ──check──► Checked ──derive──► Derived
//!   (path + text)     (syntax tree)    (names, types,      (Φ, Φ_q, ν, γ, …
//!                                       counts; warnings)   and the warnings)
//! ```
//!
//! Every front end enters here: a `.kin` file ([`Source::read`]) or model
//! text ([`Source::new`]) through [`Parsed::from_source`], the tokens of
//! `mechanism! { … }` ([`Parsed::from_tokens`]) and a syntax tree built by
//! another reader whose spans point into its own file (the simEngine2D
//! importer, [`Parsed::new`]). The sequence check → derive is written once,
//! in [`Parsed::derive_at_tokens`]; every other entry goes through it. A
//! [`Report`] is the diagnostics as data (kinema-report): `Send`, at lines
//! and columns. Only the proc-macro, whose spans are the compiler's, keeps
//! the phases' [`Diagnostics`] (the `_at_tokens` forms).
//!
//! ```
//! use kinema_model::Source;
//! use kinema_model::Derived;
//! let source = Source::new(
//!     "pendulum.kin",
//!     "mechanism P { body bar; joint pin: revolute(bar(-1, 0), ground(0, 0));
//!                    driver swing: bar.phi == t; }",
//! );
//! let derived = match Derived::from_source(source) {
//!     Ok(d) => d,
//!     Err(report) => panic!("{report}"),
//! };
//! assert_eq!(derived.derivation().dof.ndof(), 0);
//! assert!(derived.warnings().is_empty());
//! ```

use std::sync::Arc;

pub use kinema_report::{Entry, MAX_SOURCE_BYTES, Report, Source};

use crate::{CheckedModel, Derivation, Diagnostics, ParsedModel};

/// A parsed model and the source its spans point into.
#[derive(Clone, Debug)]
pub struct Parsed {
    source: Arc<Source>,
    model: ParsedModel,
}

impl Parsed {
    /// Parses model text.
    ///
    /// # Errors
    /// Lexer and parser errors.
    pub fn from_source(source: Source) -> Result<Parsed, Report> {
        let source = Arc::new(source);
        match ParsedModel::parse_str(source.text()) {
            Ok(model) => Ok(Parsed { source, model }),
            Err(diagnostics) => Err(diagnostics.report(source)),
        }
    }

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
    /// are the compiler's, which only a `syn::Error` can point at: the
    /// failures of this path stay [`Diagnostics`] (see
    /// [`Parsed::derive_at_tokens`]).
    ///
    /// # Errors
    /// Parser errors.
    pub fn from_tokens(tokens: proc_macro2::TokenStream) -> Result<Parsed, Diagnostics> {
        Ok(Parsed {
            source: Arc::new(Source::new("mechanism!", "")),
            model: ParsedModel::parse_tokens(tokens)?,
        })
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
        let source = self.source.clone();
        self.check_at_tokens().map_err(|d| d.report(source))
    }

    /// Checks and derives the model.
    ///
    /// # Errors
    /// The checker's errors, or the derivation's.
    pub fn derive(self) -> Result<Derived, Report> {
        let source = self.source.clone();
        self.derive_at_tokens().map_err(|d| d.report(source))
    }

    /// [`Parsed::check`], its failure at the tokens' spans.
    ///
    /// # Errors
    /// As [`Parsed::check`].
    pub fn check_at_tokens(self) -> Result<Checked, Diagnostics> {
        Ok(Checked {
            model: self.model.check()?,
            source: self.source,
        })
    }

    /// [`Parsed::derive`], its failure at the tokens' spans (what the
    /// proc-macro turns into `syn::Error`s): the one place the phases are
    /// chained.
    ///
    /// # Errors
    /// As [`Parsed::derive`].
    pub fn derive_at_tokens(self) -> Result<Derived, Diagnostics> {
        self.check_at_tokens()?.derive_at_tokens()
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
        let source = self.source.clone();
        self.derive_at_tokens().map_err(|d| d.report(source))
    }

    /// [`Checked::derive`], its failure at the tokens' spans.
    ///
    /// # Errors
    /// As [`Checked::derive`].
    pub fn derive_at_tokens(self) -> Result<Derived, Diagnostics> {
        let derivation = Derivation::new(&self.model)?;
        let warnings = self.model.warnings.report(self.source.clone());
        Ok(Derived {
            source: self.source,
            checked: self.model,
            derivation,
            warnings,
        })
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
    /// Parses, checks and derives model text ([`Parsed::from_source`],
    /// then [`Parsed::derive`]).
    ///
    /// # Errors
    /// The first failing phase's errors (with the warnings found so far).
    pub fn from_source(source: Source) -> Result<Derived, Report> {
        Parsed::from_source(source)?.derive()
    }

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

    fn derive(name: &str, text: &str) -> Result<Derived, Report> {
        Derived::from_source(Source::new(name, text))
    }

    #[test]
    fn each_phase_reports_against_its_source() {
        let parse = derive("a.kin", "mechanism M { body b; driver d: b.x == ; }").err();
        let rendered = parse.map(|r| r.render()).unwrap_or_default();
        assert!(rendered.contains("--> a.kin:1:"), "{rendered}");

        let check = derive("b.kin", "mechanism M {\n body b;\n driver d: c.x == t;\n}").err();
        let rendered = check.map(|r| r.render()).unwrap_or_default();
        assert!(rendered.contains("--> b.kin:3:"), "{rendered}");
        assert!(rendered.contains("could not check `b.kin`"), "{rendered}");
    }

    #[test]
    fn warnings_are_diagnostics() {
        let derived = derive(
            "w.kin",
            "mechanism M { body b; driver d: b.x == 1; constraint c: b.y == 0; \
             constraint e: b.phi == 0; }",
        );
        let Ok(derived) = derived else {
            panic!("{:?}", derived.err().map(|r| r.render()));
        };
        assert_eq!(derived.warnings().error_count(), 0);
        assert_eq!(derived.warnings().entries().len(), 1);
        assert!(derived.warnings().render().contains("--> w.kin:1:"));
    }
}
