//! Positions in a source text, and errors that point at them.
//!
//! Every error the crate reports is a [`Diagnostic`]: a file name, a 1-based
//! line and column, a message and the source line, rendered like a compiler
//! message:
//!
//! ```text
//! model.adm:42:22: constraint "rev" (id 3): field "body2": body 7 does not exist (the model has 2 bodies)
//!    |
//! 42 |       "body2": 7,
//!    |                ^
//! ```
//!
//! Reading a model reports every mistake it finds at once, so an [`Error`]
//! holds one or more diagnostics.

use std::fmt;
use std::io::Read as _;

/// The largest ADM or ACF file read: 16 MiB (a thousand-body model is a few
/// hundred kilobytes). Reading stops there, so that a stream without end
/// (`/dev/zero`) is an error, not an exhausted memory.
pub const MAX_FILE_BYTES: u64 = 16 << 20;

/// Why [`read_text`] could not read a file.
#[derive(Debug)]
pub enum ReadError {
    /// Opening or reading failed.
    Io(std::io::Error),
    /// The file is larger than [`MAX_FILE_BYTES`].
    TooLarge,
    /// The file is not UTF-8: the first bad byte and its 1-based line and
    /// column (in characters).
    NotUtf8 {
        /// The byte.
        byte: u8,
        /// Its line.
        line: usize,
        /// Its column.
        col: usize,
    },
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "cannot read the file: {e}"),
            ReadError::TooLarge => write!(
                f,
                "the file is larger than {} MiB, the most kinema reads",
                MAX_FILE_BYTES >> 20
            ),
            ReadError::NotUtf8 { byte, line, col } => write!(
                f,
                "the file is not UTF-8 text: byte 0x{byte:02x} at line {line}, column {col}"
            ),
        }
    }
}

impl std::error::Error for ReadError {}

/// Reads the text of `path`, at most [`MAX_FILE_BYTES`] (a stream without
/// end is read only that far).
///
/// # Errors
/// The file cannot be opened or read, is larger than the limit, or is not
/// UTF-8.
pub fn read_text(path: &std::path::Path) -> Result<String, ReadError> {
    let file = std::fs::File::open(path).map_err(ReadError::Io)?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(ReadError::Io)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(ReadError::TooLarge);
    }
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let good = bytes
            .get(..e.utf8_error().valid_up_to())
            .unwrap_or_default();
        let start = good.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        ReadError::NotUtf8 {
            byte: bytes.get(good.len()).copied().unwrap_or(0),
            line: good.iter().filter(|&&b| b == b'\n').count() + 1,
            col: String::from_utf8_lossy(good.get(start..).unwrap_or_default())
                .chars()
                .count()
                + 1,
        }
    })
}

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
}

/// A named source text (the contents of a file), able to turn a [`Pos`] and a
/// message into a [`Diagnostic`] carrying the offending line.
#[derive(Clone, Debug)]
pub struct Source<'a> {
    name: &'a str,
    text: &'a str,
}

impl<'a> Source<'a> {
    /// A source text called `name` (usually the file path as the user wrote it).
    #[must_use]
    pub fn new(name: &'a str, text: &'a str) -> Self {
        Source { name, text }
    }

    /// The name given to [`Source::new`].
    #[must_use]
    pub fn name(&self) -> &'a str {
        self.name
    }

    /// The text given to [`Source::new`].
    #[must_use]
    pub fn text(&self) -> &'a str {
        self.text
    }

    /// A diagnostic at `pos` with `message`, carrying the source line.
    #[must_use]
    pub fn diagnostic(&self, pos: Pos, message: impl Into<String>) -> Diagnostic {
        let line_text = self
            .text
            .split('\n')
            .nth(pos.line.saturating_sub(1) as usize)
            .map(|l| l.strip_suffix('\r').unwrap_or(l).to_string());
        Diagnostic {
            file: self.name.to_string(),
            pos: Some(pos),
            message: message.into(),
            line_text,
        }
    }
}

/// One error message, optionally located in a file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// The file name as given by the caller.
    pub file: String,
    /// Where the error is; `None` for errors about the whole file (it cannot
    /// be read, for instance).
    pub pos: Option<Pos>,
    /// The message, without the location.
    pub message: String,
    /// The source line at `pos`, if known, for the snippet.
    pub line_text: Option<String>,
}

impl Diagnostic {
    /// A diagnostic about a whole file, with no position.
    #[must_use]
    pub fn whole_file(file: impl Into<String>, message: impl Into<String>) -> Self {
        Diagnostic {
            file: file.into(),
            pos: None,
            message: message.into(),
            line_text: None,
        }
    }
}

impl fmt::Display for Diagnostic {
    /// `file:line:col: message`, then the source line and a caret under the
    /// column (tabs in the source line are kept so the caret lines up).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Some(pos) = self.pos else {
            return write!(f, "{}: {}", self.file, self.message);
        };
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, pos.line, pos.col, self.message
        )?;
        if let Some(line) = &self.line_text {
            let num = pos.line.to_string();
            let pad = " ".repeat(num.len());
            let caret_pad: String = line
                .chars()
                .take(pos.col.saturating_sub(1) as usize)
                .map(|c| if c == '\t' { '\t' } else { ' ' })
                .collect();
            write!(
                f,
                "\n{pad} |\n{num} | {line}\n{pad} | {caret_pad}^",
                line = line.trim_end()
            )?;
        }
        Ok(())
    }
}

/// The error type of the crate: one or more diagnostics (reading a model
/// reports every mistake it finds, not only the first).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    diagnostics: Vec<Diagnostic>,
}

impl Error {
    /// An error made of the given diagnostics (at least one is expected; an
    /// empty list renders as "unknown error").
    #[must_use]
    pub fn new(diagnostics: Vec<Diagnostic>) -> Self {
        Error { diagnostics }
    }

    /// The diagnostics, in the order of the source.
    #[must_use]
    pub fn diagnostics(&self) -> &[Diagnostic] {
        &self.diagnostics
    }
}

impl From<Diagnostic> for Error {
    fn from(d: Diagnostic) -> Self {
        Error {
            diagnostics: vec![d],
        }
    }
}

impl fmt::Display for Error {
    /// Every diagnostic, separated by blank lines.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.diagnostics.is_empty() {
            return write!(f, "unknown error");
        }
        for (i, d) in self.diagnostics.iter().enumerate() {
            if i > 0 {
                write!(f, "\n\n")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Error {}
