//! Diagnostics: errors and warnings with a span, rendered like rustc for text
//! and converted to one combined `syn::Error` for the proc-macro.

use std::borrow::Cow;
use std::fmt;

use unicode_width::UnicodeWidthChar;

use crate::source::LineIndex;
use crate::span::Span;

/// Most errors a [`Diagnostics`] keeps, and separately most warnings; the
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
    ///
    /// To render many diagnostics of one text, use a [`Renderer`] (or
    /// [`Diagnostics::render`]): this indexes the text's lines each time.
    #[must_use]
    pub fn render(&self, source: &str, file: &str) -> String {
        Renderer::new(source, file).render(self)
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
        write!(f, "{}: {}", self.severity.word(), clip(&self.message))?;
        let start = self.span.start();
        if start.line >= 1 {
            write!(f, " (at {}:{})", start.line, start.column + 1)?;
        }
        Ok(())
    }
}

/// Renders diagnostics of one text: its lines are indexed once, so that
/// rendering `n` diagnostics costs `O(n log lines)` plus their lines, not
/// `n` scans of the text.
#[derive(Clone, Debug)]
pub struct Renderer<'a> {
    index: LineIndex<'a>,
    file: &'a str,
}

impl<'a> Renderer<'a> {
    /// A renderer for diagnostics of `source` (the whole text) named `file`.
    #[must_use]
    pub fn new(source: &'a str, file: &'a str) -> Self {
        Renderer {
            index: LineIndex::new(source),
            file,
        }
    }

    /// Renders one diagnostic (see [`Diagnostic::render`]). A source line
    /// wider than [`MAX_EXCERPT_WIDTH`] columns is cut around the carets;
    /// tabs are shown as four spaces and control characters as their
    /// Unicode pictures (`␀`), so the carets line up and the terminal
    /// receives no control codes from the model.
    #[must_use]
    pub fn render(&self, d: &Diagnostic) -> String {
        let file = self.file;
        let mut out = format!("{}: {}\n", d.severity.word(), clip(&d.message));
        let start = d.span.start();
        let end = d.span.end();
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
fn clip(text: &str) -> Cow<'_, str> {
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

    /// Each diagnostic kept, rendered (see [`Diagnostic::render`]) with one
    /// index of the text's lines, then a `note: … and N more` line when some
    /// were not kept.
    #[must_use]
    pub fn render_each(&self, source: &str, file: &str) -> Vec<String> {
        let renderer = Renderer::new(source, file);
        let mut out: Vec<String> = self.items.iter().map(|d| renderer.render(d)).collect();
        if let Some(note) = self.omitted_note() {
            out.push(format!("note: {note}\n"));
        }
        out
    }

    /// Renders every diagnostic kept as rustc does (see
    /// [`Diagnostic::render`]), separated by blank lines, then how many more
    /// were found but not kept, then a summary line when there are errors
    /// (`error: could not check `bad.kin` due to 2 previous errors`).
    #[must_use]
    pub fn render(&self, source: &str, file: &str) -> String {
        let mut out = String::new();
        for d in self.render_each(source, file) {
            out.push_str(&d);
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
        if let Some(note) = self.omitted_note() {
            write!(f, "\n{note}")?;
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
        assert!(long.render("", "f.kin").len() < 2 * MAX_TEXT);
    }
}
