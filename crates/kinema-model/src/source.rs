//! The text of a model as lines, and the bytes of a model file as text.
//!
//! [`LineIndex`] records where every line starts once, so that any number of
//! diagnostics find their line by binary search instead of scanning the text
//! from its start each time (which made rendering quadratic in the number of
//! diagnostics). [`decode`] turns the bytes of a file into text, or says
//! where the first byte that is not UTF-8 is.

use proc_macro2::LineColumn;

use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::span::Span;

/// Where each line of a text starts. Lines end at `\n`; a `\r` before it is
/// not part of the line. Line numbers are 1-based and columns 0-based in
/// characters, as proc-macro2 counts them.
#[derive(Clone, Debug)]
pub struct LineIndex<'a> {
    text: &'a str,
    /// Byte offset of the start of each line; the first is 0.
    starts: Vec<usize>,
}

impl<'a> LineIndex<'a> {
    /// Indexes `text` (one pass over its bytes).
    #[must_use]
    pub fn new(text: &'a str) -> Self {
        let mut starts = vec![0];
        starts.extend(
            text.bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i + 1),
        );
        LineIndex { text, starts }
    }

    /// Number of lines (a text ending with `\n` has an empty last line).
    #[must_use]
    pub fn line_count(&self) -> usize {
        self.starts.len()
    }

    /// The text of line `line` (1-based) without its line ending; `None`
    /// past the end (or for line 0, which proc-macro2 gives spans without
    /// a place).
    #[must_use]
    pub fn line(&self, line: usize) -> Option<&'a str> {
        let start = *self.starts.get(line.checked_sub(1)?)?;
        let end = self
            .starts
            .get(line)
            .map_or(self.text.len(), |&next| next - 1);
        let text = self.text.get(start..end)?;
        Some(text.strip_suffix('\r').unwrap_or(text))
    }

    /// Line and column of the byte offset `offset` (clamped to the text;
    /// an offset inside a character counts as that character).
    #[must_use]
    pub fn line_column(&self, offset: usize) -> LineColumn {
        let offset = offset.min(self.text.len());
        // The last line starting at or before `offset`.
        let line = self.starts.partition_point(|&s| s <= offset);
        let start = self
            .starts
            .get(line.saturating_sub(1))
            .copied()
            .unwrap_or(0);
        let column = self.text.get(start..).map_or(0, |rest| {
            rest.char_indices()
                .take_while(|&(i, _)| start + i < offset)
                .count()
        });
        LineColumn { line, column }
    }

    /// The byte offset of a line and column (the end of the line for a
    /// column past it); `None` for a line that does not exist.
    #[must_use]
    pub fn offset(&self, at: LineColumn) -> Option<usize> {
        let start = *self.starts.get(at.line.checked_sub(1)?)?;
        let line = self.line(at.line)?;
        Some(
            start
                + line
                    .char_indices()
                    .nth(at.column)
                    .map_or(line.len(), |(i, _)| i),
        )
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

/// The bytes of a model file as text.
///
/// # Errors
/// When `bytes` is not UTF-8: one error at the first invalid byte, giving
/// its line, column and byte offset. Render it with the text read lossily
/// (`String::from_utf8_lossy(bytes)`), in which the invalid bytes are one
/// `U+FFFD` character at the same line and column.
pub fn decode(bytes: &[u8]) -> Result<&str, Diagnostics> {
    let error = match std::str::from_utf8(bytes) {
        Ok(text) => return Ok(text),
        Err(e) => e,
    };
    let at = error.valid_up_to();
    let valid = std::str::from_utf8(bytes.get(..at).unwrap_or_default()).unwrap_or_default();
    let index = LineIndex::new(valid);
    let place = index.line_column(at);
    let end = LineColumn {
        line: place.line,
        column: place.column + 1,
    };
    let byte = bytes.get(at).copied().unwrap_or(0);
    // error: the model is not UTF-8 text: byte 0xFF at line 3, column 7 (byte offset 42)
    let (what, label) = match error.error_len() {
        Some(_) => (format!("byte 0x{byte:02X}"), "not UTF-8"),
        None => (
            format!("an incomplete character (byte 0x{byte:02X}) at the end of the file"),
            "incomplete UTF-8 sequence",
        ),
    };
    let message = format!(
        "the model is not UTF-8 text: {what} at line {}, column {} (byte offset {at})",
        place.line,
        place.column + 1
    );
    let mut d = Diagnostics::new();
    d.push(
        Diagnostic::error(Span::at(place, end), message)
            .with_label(label)
            .with_help("model files are UTF-8 text; save the file as UTF-8"),
    );
    Err(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_and_columns() {
        let text = "ab\r\ncé\n\nxyz";
        let ix = LineIndex::new(text);
        assert_eq!(ix.line_count(), 4);
        assert_eq!(ix.line(1), Some("ab"));
        assert_eq!(ix.line(2), Some("cé"));
        assert_eq!(ix.line(3), Some(""));
        assert_eq!(ix.line(4), Some("xyz"));
        assert_eq!(ix.line(0), None);
        assert_eq!(ix.line(5), None);
        // Offsets: a=0 b=1 \r=2 \n=3 c=4 é=5..7 \n=7 \n=8 x=9
        let lc = |o| {
            let p = ix.line_column(o);
            (p.line, p.column)
        };
        assert_eq!(lc(0), (1, 0));
        assert_eq!(lc(4), (2, 0));
        assert_eq!(lc(5), (2, 1));
        assert_eq!(lc(7), (2, 2));
        assert_eq!(lc(8), (3, 0));
        assert_eq!(lc(10), (4, 1));
        assert_eq!(lc(1000), (4, 3));
    }

    #[test]
    fn invalid_utf8_is_located() {
        let bytes = b"line one\nab\xC3\xA9c\xFFd\n";
        let d = decode(bytes).err().unwrap_or_default();
        let first = d.iter().next().map(|d| (d.message.clone(), d.span.start()));
        let Some((message, start)) = first else {
            panic!("no error for invalid UTF-8");
        };
        assert_eq!((start.line, start.column), (2, 4));
        assert!(
            message.contains("byte 0xFF at line 2, column 5 (byte offset 14)"),
            "{message}"
        );
        // A character cut short by the end of the file.
        let d = decode(b"ok\xE2\x82").err().unwrap_or_default();
        let message = d
            .iter()
            .next()
            .map(|d| d.message.clone())
            .unwrap_or_default();
        assert!(message.contains("incomplete"), "{message}");
        assert!(message.contains("byte offset 2"), "{message}");
        assert_eq!(decode(b"fine").ok(), Some("fine"));
    }
}
