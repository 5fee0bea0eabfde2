//! Diagnostics as the phases collect them: errors and warnings at token
//! spans. At the front door they become a [`Report`] (kinema-report: the
//! same diagnostics as data, at lines and columns, rendered like rustc);
//! in the proc-macro they become one combined `syn::Error` at the tokens.

use std::fmt;
use std::sync::Arc;

use kinema_report::{Entry, LineColumn, Report, Source, clip};
pub use kinema_report::{MAX_EXCERPT_WIDTH, MAX_KEPT, Severity};

use crate::span::Span;

/// One error or warning, pointing at the offending tokens.
#[derive(Clone, Debug)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// The main message, e.g. "expected a scalar, found a vector (point `crank.o`)".
    pub message: String,
    /// The offending tokens.
    pub span: Span,
    /// A short label printed after the carets.
    pub label: Option<String>,
    /// Extra advice, printed as `= help: …`.
    pub help: Option<String>,
}

impl Diagnostic {
    /// A new error.
    #[must_use]
    pub fn error(span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Error,
            message: message.into(),
            span,
            label: None,
            help: None,
        }
    }

    /// A new warning.
    #[must_use]
    pub fn warning(span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Warning,
            ..Diagnostic::error(span, message)
        }
    }

    /// Adds a help line.
    #[must_use]
    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    /// Adds a label after the carets.
    #[must_use]
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = Some(label.into());
        self
    }

    /// Renders the diagnostic as rustc does, for a model read from `source`
    /// (the whole text) named `file`:
    ///
    /// ```text
    /// error: unknown body `crnk`
    ///  --> bad.kin:3:25
    ///   |
    /// 3 |     joint pin: revolute(crnk(0, 0), rod(0, 0));
    ///   |                         ^^^^
    ///   |
    ///   = help: the bodies are `crank`, `rod`
    /// ```
    ///
    /// To render many diagnostics of one text, use a [`Renderer`] (or
    /// [`Diagnostics::render`]): this indexes the text's lines each time.
    #[must_use]
    pub fn render(&self, source: &str, file: &str) -> String {
        Renderer::new(source, file).render(self)
    }

    /// The diagnostic as data: its span resolved to lines and columns.
    #[must_use]
    pub fn entry(&self) -> Entry {
        let place = |p: proc_macro2::LineColumn| LineColumn {
            line: p.line,
            column: p.column,
        };
        Entry {
            severity: self.severity,
            message: self.message.clone(),
            start: place(self.span.start()),
            end: place(self.span.end()),
            label: self.label.clone(),
            help: self.help.clone(),
        }
    }

    /// The diagnostic as a `syn::Error` spanning the offending tokens (help
    /// and label appended to the message).
    #[must_use]
    pub fn to_syn_error(&self) -> syn::Error {
        let mut message = clip(&self.message).into_owned();
        if let Some(label) = &self.label {
            message.push_str(&format!(" ({label})"));
        }
        if let Some(help) = &self.help {
            message.push_str(&format!("\n= help: {help}"));
        }
        syn::Error::new_spanned(self.span.tokens(), message)
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.entry().fmt(f)
    }
}

/// Renders diagnostics of one text (kinema-report's renderer: the lines
/// are indexed once).
#[derive(Clone, Debug)]
pub struct Renderer<'a>(kinema_report::Renderer<'a>);

impl<'a> Renderer<'a> {
    /// A renderer for diagnostics of `source` (the whole text) named `file`.
    #[must_use]
    pub fn new(source: &'a str, file: &'a str) -> Self {
        Renderer(kinema_report::Renderer::new(source, file))
    }

    /// Renders one diagnostic (see [`Diagnostic::render`]).
    #[must_use]
    pub fn render(&self, d: &Diagnostic) -> String {
        self.0.render(&d.entry())
    }
}

/// All the errors and warnings found in a model, in source order of discovery.
///
/// At most [`MAX_KEPT`] errors and [`MAX_KEPT`] warnings are kept; the
/// others are counted ([`Diagnostics::error_count`] counts them all) and
/// reported by [`Diagnostics::render`] as "… and N more".
#[derive(Clone, Debug, Default)]
pub struct Diagnostics {
    items: Vec<Diagnostic>,
    kept_errors: usize,
    omitted_errors: usize,
    omitted_warnings: usize,
}

impl Diagnostics {
    /// No diagnostics.
    #[must_use]
    pub fn new() -> Self {
        Diagnostics::default()
    }

    /// Adds a diagnostic (or only counts it, past [`MAX_KEPT`] of its
    /// severity).
    pub fn push(&mut self, diagnostic: Diagnostic) {
        match diagnostic.severity {
            Severity::Error if self.kept_errors >= MAX_KEPT => self.omitted_errors += 1,
            Severity::Warning if self.items.len() - self.kept_errors >= MAX_KEPT => {
                self.omitted_warnings += 1;
            }
            severity => {
                if severity == Severity::Error {
                    self.kept_errors += 1;
                }
                self.items.push(diagnostic);
            }
        }
    }

    /// Appends all of `other`.
    pub fn extend(&mut self, other: Diagnostics) {
        self.omitted_errors += other.omitted_errors;
        self.omitted_warnings += other.omitted_warnings;
        for d in other.items {
            self.push(d);
        }
    }

    /// Every diagnostic kept (at most [`MAX_KEPT`] of each severity).
    pub fn iter(&self) -> std::slice::Iter<'_, Diagnostic> {
        self.items.iter()
    }

    /// Number of diagnostics (errors and warnings), kept or not.
    #[must_use]
    pub fn len(&self) -> usize {
        self.items.len() + self.omitted_errors + self.omitted_warnings
    }

    /// True when there is no diagnostic at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// True when at least one diagnostic is an error.
    #[must_use]
    pub fn has_errors(&self) -> bool {
        self.error_count() > 0
    }

    /// Diagnostics kept so far: a mark for [`help_since`](Self::help_since).
    pub(crate) fn kept(&self) -> usize {
        self.items.len()
    }

    /// Gives every error kept since `mark` (a [`kept`](Self::kept)) that
    /// has no help `help()`.
    pub(crate) fn help_since(&mut self, mark: usize, help: impl Fn() -> String) {
        for d in self.items.iter_mut().skip(mark) {
            if d.severity == Severity::Error && d.help.is_none() {
                d.help = Some(help());
            }
        }
    }

    /// Number of errors, kept or not.
    #[must_use]
    pub fn error_count(&self) -> usize {
        self.kept_errors + self.omitted_errors
    }

    /// Number of diagnostics found but not kept (past [`MAX_KEPT`]).
    #[must_use]
    pub fn omitted(&self) -> usize {
        self.omitted_errors + self.omitted_warnings
    }

    /// The diagnostics as data, with the source their spans point into.
    #[must_use]
    pub fn report(&self, source: Arc<Source>) -> Report {
        Report::new(
            source,
            self.items.iter().map(Diagnostic::entry).collect(),
            (self.omitted_errors, self.omitted_warnings),
        )
    }

    /// Each diagnostic kept, rendered (see [`Report::render_each`]).
    #[must_use]
    pub fn render_each(&self, source: &str, file: &str) -> Vec<String> {
        self.report(Arc::new(Source::new(file, source)))
            .render_each()
    }

    /// Renders every diagnostic as rustc does (see [`Report::render`]).
    #[must_use]
    pub fn render(&self, source: &str, file: &str) -> String {
        self.report(Arc::new(Source::new(file, source))).render()
    }

    /// All errors kept (warnings are left out: stable proc-macros cannot
    /// emit them) combined into one `syn::Error`, one message per error,
    /// and one more saying how many were not kept; `None` when there is no
    /// error.
    #[must_use]
    pub fn to_syn_error(&self) -> Option<syn::Error> {
        let mut combined: Option<syn::Error> = None;
        let mut last = None;
        for d in self.items.iter().filter(|d| d.severity == Severity::Error) {
            let e = d.to_syn_error();
            last = Some(d.span);
            match &mut combined {
                Some(c) => c.combine(e),
                None => combined = Some(e),
            }
        }
        if self.omitted_errors > 0
            && let (Some(c), Some(span)) = (&mut combined, last)
        {
            let s = if self.omitted_errors == 1 { "" } else { "s" };
            c.combine(syn::Error::new_spanned(
                span.tokens(),
                format!(
                    "… and {} more error{s} not shown (only the first {MAX_KEPT} are)",
                    self.omitted_errors
                ),
            ));
        }
        combined
    }

    /// Like [`Diagnostics::to_syn_error`], consuming `self`; a diagnostics
    /// list with no error gives a generic error (callers only convert
    /// failures).
    #[must_use]
    pub fn into_syn_error(self) -> syn::Error {
        self.to_syn_error()
            .unwrap_or_else(|| syn::Error::new(proc_macro2::Span::call_site(), "invalid mechanism"))
    }
}

impl IntoIterator for Diagnostics {
    type Item = Diagnostic;
    type IntoIter = std::vec::IntoIter<Diagnostic>;
    fn into_iter(self) -> Self::IntoIter {
        self.items.into_iter()
    }
}

impl<'a> IntoIterator for &'a Diagnostics {
    type Item = &'a Diagnostic;
    type IntoIter = std::slice::Iter<'a, Diagnostic>;
    fn into_iter(self) -> Self::IntoIter {
        self.items.iter()
    }
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.items.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{d}")?;
        }
        let omitted = self.omitted_errors + self.omitted_warnings;
        if omitted > 0 {
            write!(f, "\n… and {omitted} more not shown")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}

impl From<syn::Error> for Diagnostics {
    fn from(error: syn::Error) -> Self {
        let mut out = Diagnostics::new();
        for e in error {
            out.push(Diagnostic::error(Span::new(e.span()), e.to_string()));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diagnostics_are_capped_and_counted() {
        let mut d = Diagnostics::new();
        let span = Span::new(proc_macro2::Span::call_site());
        for i in 0..10_000 {
            d.push(Diagnostic::error(span, format!("e{i}")));
            d.push(Diagnostic::warning(span, format!("w{i}")));
        }
        assert_eq!(d.iter().count(), 2 * MAX_KEPT);
        assert_eq!(d.error_count(), 10_000);
        assert_eq!(d.len(), 20_000);
        let text = d.render("", "f.kin");
        assert!(
            text.contains("… and 9900 more errors and 9900 more warnings not shown"),
            "{text}"
        );
        assert!(text.ends_with("due to 10000 previous errors\n"), "{text}");
        let syn: Vec<String> = d
            .to_syn_error()
            .into_iter()
            .flatten()
            .map(|e| e.to_string())
            .collect();
        assert_eq!(syn.len(), MAX_KEPT + 1);
        assert!(
            syn[MAX_KEPT].contains("9900 more errors"),
            "{}",
            syn[MAX_KEPT]
        );
        // A huge message is clipped.
        let long = Diagnostic::error(span, "n".repeat(1_000_000));
        assert!(long.render("", "f.kin").len() < 1_000);
    }
}
