//! The text of a model as lines.
//!
//! [`LineIndex`] records where every line starts once, so that any number of
//! diagnostics find their line by binary search instead of scanning the text
//! from its start each time (which made rendering quadratic in the number of
//! diagnostics). Reading a file as text (the size cap, the UTF-8 rule) is
//! kinema-report's [`Source::read`](kinema_report::Source::read).

use proc_macro2::LineColumn;

use crate::span::Span;

/// Where each line of a text starts (kinema-report's index), with places
/// as proc-macro2's line and column, as spans hold them.
#[derive(Clone, Debug)]
pub struct LineIndex<'a>(kinema_report::LineIndex<'a>);

fn from_report(p: kinema_report::LineColumn) -> LineColumn {
    LineColumn {
        line: p.line,
        column: p.column,
    }
}

impl<'a> LineIndex<'a> {
    /// Indexes `text` (one pass over its bytes).
    #[must_use]
    pub fn new(text: &'a str) -> Self {
        LineIndex(kinema_report::LineIndex::new(text))
    }

    /// Number of lines (a text ending with `\n` has an empty last line).
    #[must_use]
    pub fn line_count(&self) -> usize {
        self.0.line_count()
    }

    /// The text of line `line` (1-based) without its line ending.
    #[must_use]
    pub fn line(&self, line: usize) -> Option<&'a str> {
        self.0.line(line)
    }

    /// Line and column of the byte offset `offset` (clamped to the text).
    #[must_use]
    pub fn line_column(&self, offset: usize) -> LineColumn {
        from_report(self.0.line_column(offset))
    }

    /// The byte offset of a line and column (the end of the line for a
    /// column past it); `None` for a line that does not exist.
    #[must_use]
    pub fn offset(&self, at: LineColumn) -> Option<usize> {
        self.0.offset(kinema_report::LineColumn {
            line: at.line,
            column: at.column,
        })
    }

    /// A span covering the `len` bytes at `offset` (at least one character).
    #[must_use]
    pub fn span(&self, offset: usize, len: usize) -> Span {
        let start = self.line_column(offset);
        let mut end = self.line_column(offset.saturating_add(len));
        if end.line == start.line && end.column <= start.column {
            end.column = start.column + 1;
        }
        Span::at(start, end)
    }
}
