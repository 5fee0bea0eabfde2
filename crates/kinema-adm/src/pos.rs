//! Positions in an ADM or ACF text, and the diagnostics that point at them.
//!
//! The readers count where every JSON value (and every field of a plain
//! ACF) starts as a [`Pos`]; a mistake becomes a kinema-model
//! [`Diagnostic`] whose span is that one character of the file's text, so
//! that it renders like any message about a `.kin` file (rustc's style,
//! [`kinema_model::Report`]).

use kinema_model::{Diagnostic, Span};
use proc_macro2::LineColumn;

/// A position in a source text: 1-based line and column (columns count
/// characters, a tab is one column), and the 0-based character offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Pos {
    /// 1-based line number.
    pub line: u32,
    /// 1-based column, in characters.
    pub col: u32,
    /// 0-based offset in characters from the start of the text.
    pub offset: usize,
}

impl Pos {
    /// The position of the first character of a text.
    #[must_use]
    pub const fn start() -> Self {
        Pos {
            line: 1,
            col: 1,
            offset: 0,
        }
    }

    /// The position reached from `self` after reading `c`.
    #[must_use]
    pub fn advance(self, c: char) -> Self {
        if c == '\n' {
            Pos {
                line: self.line.saturating_add(1),
                col: 1,
                offset: self.offset + 1,
            }
        } else {
            Pos {
                line: self.line,
                col: self.col.saturating_add(1),
                offset: self.offset + 1,
            }
        }
    }

    /// The span of the one character at `self` (kinema-model's columns are
    /// 0-based).
    #[must_use]
    pub fn span(self) -> Span {
        let line = self.line as usize;
        let column = self.col.saturating_sub(1) as usize;
        Span::at(
            LineColumn { line, column },
            LineColumn {
                line,
                column: column + 1,
            },
        )
    }

    /// An error at `self`.
    #[must_use]
    pub fn error(self, message: impl Into<String>) -> Diagnostic {
        Diagnostic::error(self.span(), message)
    }

    /// A warning at `self`.
    #[must_use]
    pub fn warning(self, message: impl Into<String>) -> Diagnostic {
        Diagnostic::warning(self.span(), message)
    }
}

/// `diagnostics` in the order of the text (a stable sort: two at one place
/// keep the order they were found in), kept as kinema-model keeps them.
pub(crate) fn in_order(mut diagnostics: Vec<Diagnostic>) -> kinema_model::Diagnostics {
    diagnostics.sort_by_key(|d| {
        let start = d.span.start();
        (start.line, start.column)
    });
    let mut out = kinema_model::Diagnostics::new();
    for d in diagnostics {
        out.push(d);
    }
    out
}
