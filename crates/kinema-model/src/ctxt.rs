//! The context that collects every diagnostic of a check, so that the user
//! sees all independent mistakes at once (as serde_derive's `Ctxt`).

use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::span::Span;

/// Collects errors and warnings during a check.
#[derive(Default)]
pub(crate) struct Ctxt {
    diagnostics: Diagnostics,
}

impl Ctxt {
    /// Records an error.
    pub(crate) fn error(&mut self, span: Span, message: impl Into<String>) {
        self.diagnostics.push(Diagnostic::error(span, message));
    }

    /// Records a prepared diagnostic.
    pub(crate) fn push(&mut self, d: Diagnostic) {
        self.diagnostics.push(d);
    }

    /// Number of errors so far.
    pub(crate) fn error_count(&self) -> usize {
        self.diagnostics.error_count()
    }

    /// A mark of the diagnostics so far, for [`help_since`](Self::help_since).
    pub(crate) fn mark(&self) -> usize {
        self.diagnostics.kept()
    }

    /// Gives every error recorded since `mark` that has no help `help()`.
    pub(crate) fn help_since(&mut self, mark: usize, help: impl Fn() -> String) {
        self.diagnostics.help_since(mark, help);
    }

    /// All diagnostics.
    pub(crate) fn finish(self) -> Diagnostics {
        self.diagnostics
    }
}
