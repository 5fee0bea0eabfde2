//! Why a model's text could not be tokenized: one located error for where
//! proc-macro2's lexer stopped, and the nesting scan that refuses
//! too-deep input before the recursive parser sees it.

use super::*;

/// One error saying why the lexer stopped at `at` (where proc-macro2 gave
/// up: an unknown character, the opening bracket that is never closed, a
/// closing bracket that matches nothing, a literal that does not end).
pub(super) fn lex_error(source: &str, at: proc_macro2::LineColumn) -> Diagnostics {
    let index = LineIndex::new(source);
    let offset = index.offset(at).unwrap_or(source.len());
    let rest = source.get(offset..).unwrap_or_default();
    let mut chars = rest.chars();
    let c = chars.next();
    let next = chars.next();
    let span = index.span(offset, c.map_or(1, char::len_utf8));
    let closer = |open| match open {
        '(' => ')',
        '[' => ']',
        _ => '}',
    };
    let d = match c {
        // error: unclosed delimiter `(`: expected `)` before the end of the text
        Some(open @ ('(' | '[' | '{')) => Diagnostic::error(
            span,
            format!(
                "unclosed delimiter `{open}`: expected `{}` before the end of the text",
                closer(open)
            ),
        )
        .with_label("never closed"),
        Some(close @ (')' | ']' | '}')) => {
            // The text before the closer lexes except for the brackets
            // still open; the innermost of those is what `close` should
            // have matched.
            let before = source.get(..offset).unwrap_or_default();
            match before.parse::<TokenStream>() {
                Err(e) => {
                    let open_at = e.span().start();
                    let open = index
                        .offset(open_at)
                        .and_then(|o| source.get(o..))
                        .and_then(|s| s.chars().next())
                        .unwrap_or('(');
                    // error: mismatched closing delimiter `]`: expected `)` to close the `(` at 3:7
                    Diagnostic::error(
                        span,
                        format!(
                            "mismatched closing delimiter `{close}`: expected `{}` to close the `{open}` at {}:{}",
                            closer(open),
                            open_at.line,
                            open_at.column + 1
                        ),
                    )
                    .with_label(format!("expected `{}`", closer(open)))
                }
                // error: unexpected closing delimiter `)`: no bracket is open here
                Ok(_) => Diagnostic::error(
                    span,
                    format!("unexpected closing delimiter `{close}`: no bracket is open here"),
                )
                .with_label("unexpected"),
            }
        }
        Some('"') => {
            let closed = rest.get(1..).is_some_and(|r| r.contains('"'));
            if closed {
                Diagnostic::error(
                    span,
                    "invalid string literal (an unknown escape such as `\\q`?)",
                )
            } else {
                Diagnostic::error(span, "unterminated string literal: expected a closing `\"`")
                    .with_label("starts here")
            }
        }
        Some('/') if next == Some('*') => {
            Diagnostic::error(span, "unterminated block comment: expected `*/`")
                .with_label("starts here")
        }
        Some(d) if d.is_ascii_digit() => {
            let word: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || matches!(c, '.' | '_'))
                .take(40)
                .collect();
            Diagnostic::error(span, format!("invalid number `{word}`"))
                .with_help("numbers are written `2`, `0.5`, `1e-3`")
        }
        Some(c) => {
            // error: unexpected character '`' (U+0060)
            let what = describe_char(c);
            Diagnostic::error(span, format!("unexpected character {what}")).with_help(
                "expected a name, a number, an operator (`+ - * / . , : ; = ==`) or a bracket",
            )
        }
        None => Diagnostic::error(span, "the model text ends unexpectedly"),
    };
    let mut out = Diagnostics::new();
    out.push(d);
    out
}

/// A character for a message: `'c' (U+0063)` when printable, `U+0000`
/// alone otherwise.
fn describe_char(c: char) -> String {
    let code = format!("U+{:04X}", u32::from(c));
    if c.is_control() || c.is_whitespace() || c == '\u{fffd}' || is_invisible(c) {
        code
    } else {
        format!("'{c}' ({code})")
    }
}

/// Format characters that print as nothing (zero-width, bidirectional).
fn is_invisible(c: char) -> bool {
    matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2060}'..='\u{2069}' | '\u{feff}')
}

/// Rejects text whose bracket nesting is deeper than the lexer and token
/// trees should see (deeply nested groups are built and dropped
/// recursively by proc-macro2), pointing at the first bracket past the
/// limit. Brackets inside comments (`//`, `///`, nested `/* */`) and string
/// literals are text, not groups, and do not count: an imported simEngine2D
/// body named `tan(abs(abs(…` appears in a comment.
pub(super) fn nesting_error(source: &str) -> Option<Diagnostics> {
    #[derive(Clone, Copy, PartialEq)]
    enum In {
        Code,
        LineComment,
        BlockComment(usize),
        Str,
    }
    let limit = 4 * MAX_NESTING;
    let mut depth = 0usize;
    let mut state = In::Code;
    let mut chars = source.char_indices().peekable();
    while let Some((offset, c)) = chars.next() {
        let next = chars.peek().map(|&(_, n)| n);
        match (state, c) {
            (In::LineComment, '\n') => state = In::Code,
            (In::LineComment, _) => {}
            (In::Str, '\\') => {
                chars.next();
            }
            (In::Str, '"') => state = In::Code,
            (In::Str, _) => {}
            (In::BlockComment(k), '*') if next == Some('/') => {
                chars.next();
                state = if k <= 1 {
                    In::Code
                } else {
                    In::BlockComment(k - 1)
                };
            }
            (In::BlockComment(k), '/') if next == Some('*') => {
                chars.next();
                state = In::BlockComment(k + 1);
            }
            (In::BlockComment(_), _) => {}
            (In::Code, '/') if next == Some('/') => state = In::LineComment,
            (In::Code, '/') if next == Some('*') => {
                chars.next();
                state = In::BlockComment(1);
            }
            (In::Code, '"') => state = In::Str,
            (In::Code, '(' | '[' | '{') => {
                depth += 1;
                if depth > limit {
                    let index = LineIndex::new(source);
                    let mut d = Diagnostics::new();
                    // error: brackets nested too deeply (more than 512 levels)
                    d.push(
                        Diagnostic::error(
                            index.span(offset, 1),
                            format!("brackets nested too deeply (more than {limit} levels)"),
                        )
                        .with_label(format!("level {depth}")),
                    );
                    return Some(d);
                }
            }
            (In::Code, ')' | ']' | '}') => depth = depth.saturating_sub(1),
            (In::Code, _) => {}
        }
    }
    None
}
