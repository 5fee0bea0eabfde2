//! Diagnostics: errors and warnings with a span, rendered like rustc for text
//! and converted to one combined `syn::Error` for the proc-macro.

use std::fmt;

use crate::span::Span;

/// How serious a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The model is rejected.
    Error,
    /// The model is accepted, but probably not what the user meant.
    Warning,
}

impl Severity {
    fn word(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
        }
    }
}

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
    #[must_use]
    pub fn render(&self, source: &str, file: &str) -> String {
        let mut out = format!("{}: {}\n", self.severity.word(), self.message);
        let start = self.span.start();
        let end = self.span.end();
        let line_text = if start.line >= 1 {
            source.lines().nth(start.line - 1)
        } else {
            None
        };
        let Some(line_text) = line_text else {
            out.push_str(&format!(" --> {file}\n"));
            if let Some(help) = &self.help {
                out.push_str(&format!(" = help: {help}\n"));
            }
            return out;
        };
        let line_no = start.line.to_string();
        let pad = " ".repeat(line_no.len());
        out.push_str(&format!(
            "{pad}--> {file}:{}:{}\n",
            start.line,
            start.column + 1
        ));
        out.push_str(&format!("{pad} |\n"));
        out.push_str(&format!("{line_no} | {line_text}\n"));
        let chars: Vec<char> = line_text.chars().collect();
        let first = start.column.min(chars.len());
        let last = if end.line == start.line {
            end.column.min(chars.len())
        } else {
            chars.len()
        };
        let width = last.saturating_sub(first).max(1);
        let indent: String = chars[..first]
            .iter()
            .map(|&c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        out.push_str(&format!("{pad} | {indent}{}", "^".repeat(width)));
        if let Some(label) = &self.label {
            out.push(' ');
            out.push_str(label);
        }
        out.push('\n');
        if let Some(help) = &self.help {
            out.push_str(&format!("{pad} |\n{pad} = help: {help}\n"));
        }
        out
    }

    /// The diagnostic as a `syn::Error` spanning the offending tokens (help
    /// and label appended to the message).
    #[must_use]
    pub fn to_syn_error(&self) -> syn::Error {
        let mut message = self.message.clone();
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
        write!(f, "{}: {}", self.severity.word(), self.message)?;
        let start = self.span.start();
        if start.line >= 1 {
            write!(f, " (at {}:{})", start.line, start.column + 1)?;
        }
        Ok(())
    }
}

/// All the errors and warnings found in a model, in source order of discovery.
#[derive(Clone, Debug, Default)]
pub struct Diagnostics {
    items: Vec<Diagnostic>,
}

impl Diagnostics {
    /// No diagnostics.
    #[must_use]
    pub fn new() -> Self {
        Diagnostics::default()
    }

    /// Adds a diagnostic.
    pub fn push(&mut self, diagnostic: Diagnostic) {
        self.items.push(diagnostic);
    }

    /// Appends all of `other`.
    pub fn extend(&mut self, other: Diagnostics) {
        self.items.extend(other.items);
    }

    /// Every diagnostic.
    pub fn iter(&self) -> std::slice::Iter<'_, Diagnostic> {
        self.items.iter()
    }

    /// Number of diagnostics (errors and warnings).
    #[must_use]
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// True when there is no diagnostic at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// True when at least one diagnostic is an error.
    #[must_use]
    pub fn has_errors(&self) -> bool {
        self.items.iter().any(|d| d.severity == Severity::Error)
    }

    /// Number of errors.
    #[must_use]
    pub fn error_count(&self) -> usize {
        self.items
            .iter()
            .filter(|d| d.severity == Severity::Error)
            .count()
    }

    /// Renders every diagnostic as rustc does (see [`Diagnostic::render`]),
    /// separated by blank lines, followed by a summary line when there are
    /// errors (`error: could not check `bad.kin` due to 2 previous errors`).
    #[must_use]
    pub fn render(&self, source: &str, file: &str) -> String {
        let mut out = String::new();
        for d in &self.items {
            out.push_str(&d.render(source, file));
            out.push('\n');
        }
        let n = self.error_count();
        if n > 0 {
            let s = if n == 1 { "" } else { "s" };
            out.push_str(&format!(
                "error: could not check `{file}` due to {n} previous error{s}\n"
            ));
        }
        out
    }

    /// All errors (warnings are left out: stable proc-macros cannot emit
    /// them) combined into one `syn::Error`, one message per error; `None`
    /// when there is no error.
    #[must_use]
    pub fn to_syn_error(&self) -> Option<syn::Error> {
        let mut combined: Option<syn::Error> = None;
        for d in self.items.iter().filter(|d| d.severity == Severity::Error) {
            let e = d.to_syn_error();
            match &mut combined {
                Some(c) => c.combine(e),
                None => combined = Some(e),
            }
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
