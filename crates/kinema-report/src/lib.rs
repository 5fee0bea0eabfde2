//! kinema's diagnostics as data: a model's [`Source`], its errors and
//! warnings ([`Entry`]: severity, message, line and column, label, help),
//! and the [`Report`] that holds both and renders itself like rustc:
//!
//! ```text
//! error: unknown body `crnk`
//!  --> bad.kin:3:25
//!   |
//! 3 |     joint pin: revolute(crnk(0, 0), rod(0, 0));
//!   |                         ^^^^
//!   |
//!   = help: the bodies are `crank`, `rod`
//! ```
//!
//! A report is plain data (`Send`, `Sync`, `Clone`, `PartialEq`): the runtime's
//! error carries it, so `?` on loading a model works in a function that
//! returns `kinema::Error`, and the Python package reads its entries. The
//! model language (kinema-model) collects diagnostics at token spans while
//! it parses and checks, and resolves them to a report at its front door;
//! the simEngine2D reader (kinema-adm) reports the same way. This crate
//! depends on nothing of kinema's, so the runtime can carry a report
//! without the language.

use std::borrow::Cow;
use std::fmt;
use std::io::Read as _;
use std::path::Path;
use std::sync::Arc;

use unicode_width::UnicodeWidthChar;

/// Most errors a [`Report`] keeps, and separately most warnings; the
/// others are only counted. Memory and rendered text stay bounded whatever
/// the input (a hostile file can hold a hundred thousand mistakes).
pub const MAX_KEPT: usize = 100;

/// Widest excerpt of a source line in a rendered diagnostic, in terminal
/// columns; a longer line is cut around the carets, with `...` where text
/// was left out.
pub const MAX_EXCERPT_WIDTH: usize = 100;

/// Columns of the line kept before the carets when a line is cut.
const CONTEXT_BEFORE: usize = 40;

/// Longest message, label or help printed, in characters (messages quote
/// user names, which may be megabytes long).
const MAX_TEXT: usize = 500;

/// The largest model (or simEngine2D analysis) file read: 16 MiB. A
/// thousand-body model is a few hundred kilobytes; reading stops past the
/// limit, so that a stream without end (`/dev/zero`) is an error, not an
/// exhausted memory.
pub const MAX_SOURCE_BYTES: u64 = 16 << 20;

/// How serious a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The model is rejected.
    Error,
    /// The model is accepted, but probably not what the user meant.
    Warning,
}

impl Severity {
    /// `error` or `warning`, as rendered.
    #[must_use]
    pub fn word(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
        }
    }
}

/// A place in a text: 1-based line, 0-based column in characters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct LineColumn {
    /// 1-based line (0: no place in the text).
    pub line: usize,
    /// 0-based column, in characters.
    pub column: usize,
}

/// One error or warning, at a place in its source.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Error or warning.
    pub severity: Severity,
    /// The main message, e.g. "unknown body `crnk`".
    pub message: String,
    /// Where it starts; line 0 when it concerns the whole file (one that
    /// cannot be read).
    pub start: LineColumn,
    /// Where it ends (exclusive).
    pub end: LineColumn,
    /// A short label printed after the carets.
    pub label: Option<String>,
    /// Extra advice, printed as `= help: …`.
    pub help: Option<String>,
}

impl Entry {
    /// An error about a whole file, at no place in it.
    #[must_use]
    pub fn whole_file(message: impl Into<String>) -> Entry {
        Entry {
            severity: Severity::Error,
            message: message.into(),
            start: LineColumn::default(),
            end: LineColumn::default(),
            label: None,
            help: None,
        }
    }

    /// Where it points: 1-based line and column (in characters), or `None`
    /// when it concerns the whole file.
    #[must_use]
    pub fn at(&self) -> Option<(usize, usize)> {
        (self.start.line > 0).then_some((self.start.line, self.start.column + 1))
    }
}

impl fmt::Display for Entry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.severity.word(), clip(&self.message))?;
        if let Some((line, column)) = self.at() {
            write!(f, " (at {line}:{column})")?;
        }
        Ok(())
    }
}

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
    /// limit, or is not UTF-8 (see [`Source::from_bytes`]).
    pub fn read(path: &Path) -> Result<Source, Report> {
        Source::read_as(path, &path.display().to_string())
    }

    /// [`Source::read`], naming the text `name` in messages (the path as
    /// the user wrote it, when `path` is where it was resolved).
    ///
    /// # Errors
    /// As [`Source::read`].
    pub fn read_as(path: &Path, name: &str) -> Result<Source, Report> {
        Source::read_text(path, name, "model file")
    }

    /// [`Source::read_as`] for a text that is not a model: `what` names it
    /// in messages ("cannot read parameter table `params.csv`: …").
    ///
    /// # Errors
    /// As [`Source::read`].
    pub fn read_text(path: &Path, name: &str, what: &str) -> Result<Source, Report> {
        let cannot =
            |why: String| Report::whole_file(name, format!("cannot read {what} `{name}`: {why}"));
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_SOURCE_BYTES + 1).read_to_end(&mut bytes))
            .map_err(|e| cannot(e.to_string()))?;
        if bytes.len() as u64 > MAX_SOURCE_BYTES {
            return Err(cannot(format!(
                "the file is larger than {} MiB, the most kinema reads",
                MAX_SOURCE_BYTES >> 20
            )));
        }
        Source::from_bytes(name, bytes)
    }

    /// The bytes of a file as text.
    ///
    /// # Errors
    /// When `bytes` are not UTF-8: one error at the first invalid byte,
    /// giving its line, column and byte offset, shown on the text read
    /// lossily (where the invalid bytes are one `U+FFFD` at the same line
    /// and column).
    pub fn from_bytes(name: &str, bytes: Vec<u8>) -> Result<Source, Report> {
        let error = match String::from_utf8(bytes) {
            Ok(text) => return Ok(Source::new(name, text)),
            Err(e) => e,
        };
        let at = error.utf8_error().valid_up_to();
        let incomplete = error.utf8_error().error_len().is_none();
        let bytes = error.into_bytes();
        let valid = std::str::from_utf8(bytes.get(..at).unwrap_or_default()).unwrap_or_default();
        let place = LineIndex::new(valid).line_column(at);
        let byte = bytes.get(at).copied().unwrap_or(0);
        // error: the model is not UTF-8 text: byte 0xFF at line 3, column 7 (byte offset 42)
        let (what, label) = if incomplete {
            (
                format!("an incomplete character (byte 0x{byte:02X}) at the end of the file"),
                "incomplete UTF-8 sequence",
            )
        } else {
            (format!("byte 0x{byte:02X}"), "not UTF-8")
        };
        let entry = Entry {
            severity: Severity::Error,
            message: format!(
                "the model is not UTF-8 text: {what} at line {}, column {} (byte offset {at})",
                place.line,
                place.column + 1
            ),
            start: place,
            end: LineColumn {
                line: place.line,
                column: place.column + 1,
            },
            label: Some(label.to_owned()),
            help: Some("model files are UTF-8 text; save the file as UTF-8".to_owned()),
        };
        let text = String::from_utf8_lossy(&bytes).into_owned();
        Err(Report::new(
            Arc::new(Source::new(name, text)),
            vec![entry],
            (0, 0),
        ))
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
}

/// A model's diagnostics, as data, with the source they point into: at
/// most [`MAX_KEPT`] errors and [`MAX_KEPT`] warnings, the others counted.
/// Rendered once, in rustc's style, by [`Report::render`] (or `Display`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Report {
    source: Arc<Source>,
    entries: Vec<Entry>,
    errors: usize,
    omitted_errors: usize,
    omitted_warnings: usize,
}

impl Report {
    /// `entries` (each kept) of `source`; `omitted` errors and warnings
    /// found beyond them.
    #[must_use]
    pub fn new(source: Arc<Source>, entries: Vec<Entry>, omitted: (usize, usize)) -> Report {
        let kept = entries
            .iter()
            .filter(|e| e.severity == Severity::Error)
            .count();
        Report {
            source,
            entries,
            errors: kept + omitted.0,
            omitted_errors: omitted.0,
            omitted_warnings: omitted.1,
        }
    }

    /// One error about a whole file (`name`), at no place in it: a file that
    /// cannot be read.
    #[must_use]
    pub fn whole_file(name: &str, message: impl Into<String>) -> Report {
        Report::new(
            Arc::new(Source::new(name, "")),
            vec![Entry::whole_file(message)],
            (0, 0),
        )
    }

    /// The entries kept, in the order found.
    #[must_use]
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The source the entries point into.
    #[must_use]
    pub fn source(&self) -> &Source {
        &self.source
    }

    /// The source, shared.
    #[must_use]
    pub fn shared_source(&self) -> &Arc<Source> {
        &self.source
    }

    /// No entry at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty() && self.omitted_errors + self.omitted_warnings == 0
    }

    /// How many errors were found (kept or not).
    #[must_use]
    pub fn error_count(&self) -> usize {
        self.errors
    }

    /// "… and N more errors not shown", when some were not kept.
    fn omitted_note(&self) -> Option<String> {
        let plural = |n: usize, what: &str| {
            let s = if n == 1 { "" } else { "s" };
            format!("{n} more {what}{s}")
        };
        let parts: Vec<String> = [
            (self.omitted_errors, "error"),
            (self.omitted_warnings, "warning"),
        ]
        .into_iter()
        .filter(|&(n, _)| n > 0)
        .map(|(n, what)| plural(n, what))
        .collect();
        (!parts.is_empty()).then(|| {
            format!(
                "… and {} not shown (only the first {MAX_KEPT} of each kind are)",
                parts.join(" and ")
            )
        })
    }

    /// A renderer of entries of this report's source (to render some of
    /// them, one at a time).
    #[must_use]
    pub fn renderer(&self) -> Renderer<'_> {
        Renderer::new(&self.source.text, &self.source.name)
    }

    /// Each entry rendered (one index of the text's lines for all), then a
    /// `note: … and N more` line when some were not kept.
    #[must_use]
    pub fn render_each(&self) -> Vec<String> {
        let renderer = Renderer::new(&self.source.text, &self.source.name);
        let mut out: Vec<String> = self.entries.iter().map(|d| renderer.render(d)).collect();
        if let Some(note) = self.omitted_note() {
            out.push(format!("note: {note}\n"));
        }
        out
    }

    /// Every entry rendered, separated by blank lines, then how many more
    /// were found but not kept, then a summary line when there are errors
    /// (`error: could not check `bad.kin` due to 2 previous errors`).
    #[must_use]
    pub fn render(&self) -> String {
        let mut out = String::new();
        for d in self.render_each() {
            out.push_str(&d);
            out.push('\n');
        }
        let n = self.errors;
        if n > 0 {
            let s = if n == 1 { "" } else { "s" };
            out.push_str(&format!(
                "error: could not check `{}` due to {n} previous error{s}\n",
                self.source.name
            ));
        }
        out
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.render().trim_end())
    }
}

impl std::error::Error for Report {}

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
}

/// Renders entries of one text: its lines are indexed once, so that
/// rendering `n` entries costs `O(n log lines)` plus their lines, not `n`
/// scans of the text.
#[derive(Clone, Debug)]
pub struct Renderer<'a> {
    index: LineIndex<'a>,
    file: &'a str,
}

impl<'a> Renderer<'a> {
    /// A renderer for entries of `source` (the whole text) named `file`.
    #[must_use]
    pub fn new(source: &'a str, file: &'a str) -> Self {
        Renderer {
            index: LineIndex::new(source),
            file,
        }
    }

    /// Renders one entry as rustc does. A source line wider than
    /// [`MAX_EXCERPT_WIDTH`] columns is cut around the carets; tabs are
    /// shown as four spaces and control characters as their Unicode
    /// pictures (`␀`), so the carets line up and the terminal receives no
    /// control codes from the model.
    #[must_use]
    pub fn render(&self, d: &Entry) -> String {
        let file = self.file;
        let mut out = format!("{}: {}\n", d.severity.word(), clip(&d.message));
        let (start, end) = (d.start, d.end);
        let Some(line_text) = self.index.line(start.line) else {
            out.push_str(&format!(" --> {file}\n"));
            if let Some(help) = &d.help {
                out.push_str(&format!(" = help: {}\n", clip(help)));
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
        let last = if end.line == start.line {
            end.column
        } else {
            usize::MAX
        };
        let shown = excerpt(line_text, start.column, last);
        out.push_str(&format!("{line_no} | {}\n", shown.text));
        out.push_str(&format!(
            "{pad} | {}{}",
            " ".repeat(shown.indent),
            "^".repeat(shown.carets)
        ));
        if let Some(label) = &d.label {
            out.push(' ');
            out.push_str(&clip(label));
        }
        out.push('\n');
        if let Some(help) = &d.help {
            out.push_str(&format!("{pad} |\n{pad} = help: {}\n", clip(help)));
        }
        out
    }
}

/// `text`, cut to [`MAX_TEXT`] characters.
pub fn clip(text: &str) -> Cow<'_, str> {
    match text.char_indices().nth(MAX_TEXT) {
        None => Cow::Borrowed(text),
        Some((cut, _)) => Cow::Owned(format!("{}…", &text[..cut])),
    }
}

/// How a character is shown in an excerpt, and how many columns it takes.
fn shown_char(c: char) -> (char, usize) {
    match c {
        // Tabs are expanded by the caller (four spaces).
        '\t' => (' ', 4),
        // C0 controls and DEL as their pictures: U+2400 + code, U+2421.
        '\0'..='\u{1f}' => (char::from_u32(0x2400 + c as u32).unwrap_or('\u{fffd}'), 1),
        '\u{7f}' => ('\u{2421}', 1),
        // C1 controls and the bidirectional controls, which would reorder
        // what the terminal shows.
        '\u{80}'..='\u{9f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' => ('\u{fffd}', 1),
        _ => (c, c.width().unwrap_or(0)),
    }
}

/// A source line as shown: the text, where the carets start (columns) and
/// how many there are.
struct Excerpt {
    text: String,
    indent: usize,
    carets: usize,
}

/// The part of `line` to show for a span from character `first` to
/// character `last` (exclusive; past the end means the end of the line).
/// Columns are terminal columns (wide characters take two). A line wider
/// than [`MAX_EXCERPT_WIDTH`] is cut to a window around `first`; cuts fall
/// between characters, and a wide character cut in two is shown as spaces.
fn excerpt(line: &str, first: usize, last: usize) -> Excerpt {
    // Pass 1: the columns of the span and of the whole line.
    let mut col = 0;
    let mut lo = None;
    let mut hi = None;
    for (i, c) in line.chars().enumerate() {
        if i == first {
            lo = Some(col);
        }
        if i == last {
            hi = Some(col);
        }
        col += shown_char(c).1;
    }
    let total = col;
    let lo = lo.unwrap_or(total);
    let hi = hi.unwrap_or(total).max(lo);
    let (win_lo, win_hi) = if total <= MAX_EXCERPT_WIDTH {
        (0, total)
    } else {
        let win_lo = lo
            .saturating_sub(CONTEXT_BEFORE)
            .min(total - MAX_EXCERPT_WIDTH);
        (win_lo, win_lo + MAX_EXCERPT_WIDTH)
    };
    // Pass 2: the characters inside the window.
    let mut text = String::new();
    if win_lo > 0 {
        text.push_str("...");
    }
    let prefix = text.len();
    let mut col = 0;
    for c in line.chars() {
        if col > win_hi {
            break;
        }
        let (shown, width) = shown_char(c);
        let end = col + width;
        if col >= win_lo && end <= win_hi {
            if width > 1 && shown == ' ' {
                text.push_str(&" ".repeat(width));
            } else {
                text.push(shown);
            }
        } else if end > win_lo && col < win_hi {
            // A wide character cut by the window: its visible columns.
            text.push_str(&" ".repeat(end.min(win_hi) - col.max(win_lo)));
        }
        col = end;
    }
    if win_hi < total {
        text.push_str("...");
    }
    let indent = prefix + lo.min(win_hi) - win_lo;
    let carets = hi.min(win_hi).saturating_sub(lo).max(1);
    Excerpt {
        text,
        indent,
        carets,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_utf8_is_located() {
        let first = |bytes: &[u8]| {
            Source::from_bytes("f.kin", bytes.to_vec())
                .err()
                .and_then(|r| r.entries().first().cloned())
        };
        let Some(e) = first(b"line one\nab\xC3\xA9c\xFFd\n") else {
            panic!("no error for invalid UTF-8");
        };
        assert_eq!(e.at(), Some((2, 5)));
        assert!(
            e.message
                .contains("byte 0xFF at line 2, column 5 (byte offset 14)"),
            "{}",
            e.message
        );
        // A character cut short by the end of the file.
        let message = first(b"ok\xE2\x82").map(|e| e.message).unwrap_or_default();
        assert!(message.contains("incomplete"), "{message}");
        assert!(message.contains("byte offset 2"), "{message}");
        assert!(Source::from_bytes("f.kin", b"fine".to_vec()).is_ok());
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

    /// Terminal width of rendered text.
    fn width(s: &str) -> usize {
        s.chars().map(|c| c.width().unwrap_or(0)).sum()
    }

    /// The characters of `text` in the display columns `[from, from + n)`.
    fn columns(text: &str, from: usize, n: usize) -> String {
        let mut col = 0;
        let mut out = String::new();
        for c in text.chars() {
            if col >= from && col < from + n {
                out.push(c);
            }
            col += c.width().unwrap_or(0);
        }
        out
    }

    /// Every line (short, long, ASCII, wide, multi-byte, tabs, controls)
    /// and every caret position: the excerpt is at most the budget wide,
    /// and the carets stand under exactly the characters of the span.
    #[test]
    fn excerpt_fits_and_carets_stand_under_the_span() {
        let pieces = ["a", "漢", "é", "\t", "\0", "xyz", "字字", " + "];
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |m: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % m as u64) as usize
        };
        for round in 0..400 {
            let n = if round % 2 == 0 { 5 } else { 40 + next(300) };
            let line: String = (0..n).map(|_| pieces[next(pieces.len())]).collect();
            let chars: Vec<char> = line.chars().collect();
            let first = next(chars.len() + 1);
            let last = (first + next(6)).min(chars.len() + 2);
            let e = excerpt(&line, first, last);
            assert!(
                width(&e.text) <= MAX_EXCERPT_WIDTH + 6,
                "{} columns: {:?}",
                width(&e.text),
                e.text
            );
            assert!(e.carets >= 1);
            // What the carets underline, as the line would show it.
            let under = columns(&e.text, e.indent, e.carets);
            let expected: String = chars
                .iter()
                .skip(first)
                .take(last.max(first + 1) - first)
                .map(|&c| match shown_char(c) {
                    (' ', 4) => "    ".to_string(),
                    (s, _) => s.to_string(),
                })
                .collect();
            if first < chars.len() && e.carets < MAX_EXCERPT_WIDTH / 2 {
                assert!(
                    !under.is_empty() && expected.starts_with(under.trim_end_matches('.')),
                    "line {line:?} first {first} last {last}: carets under {under:?}, span {expected:?} in {:?}",
                    e.text
                );
            }
        }
    }

    #[test]
    fn long_line_is_cut_around_the_caret() {
        let mut line = "x".repeat(1_000_000);
        line.push_str(" + 漢字 + bad");
        let first = line.chars().count() - 3;
        let e = excerpt(&line, first, first + 3);
        assert!(e.text.starts_with("..."), "{}", e.text);
        assert!(e.text.ends_with("漢字 + bad"), "{}", e.text);
        assert_eq!(columns(&e.text, e.indent, e.carets), "bad");
    }
}
