//! The fitted model as `.kin` text: the model's own text with the fitted
//! params' values written in place of theirs — its comments, layout and
//! every other line kept, so the designer's file stays theirs.

use std::fmt;

use kinema_model::ParsedModel;
use kinema_model::syntax::Item;

/// Why a fitted model's text cannot be written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FittedKinError(String);

impl fmt::Display for FittedKinError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FittedKinError {}

/// `source` (a `.kin` model's text) with each param named in `values` set
/// to its value (`param l1 = 2.5;`, written so that it reads back as the
/// same `f64`).
///
/// # Errors
/// The text does not parse, or names a param it does not declare.
pub fn fitted_kin(source: &str, values: &[(String, f64)]) -> Result<String, FittedKinError> {
    let parsed = ParsedModel::parse_str(source).map_err(|d| {
        FittedKinError(format!(
            "the model's text does not parse: {}",
            d.iter()
                .next()
                .map_or_else(String::new, |e| e.message.clone())
        ))
    })?;
    // (byte range of the value, or the insertion point, replacement)
    let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    let starts = line_starts(source);
    for (name, value) in values {
        let decl = parsed
            .syntax()
            .items
            .iter()
            .find_map(|item| match item {
                Item::Param(p) if p.name.as_str() == name => Some(p),
                _ => None,
            })
            .ok_or_else(|| FittedKinError(format!("the model declares no param `{name}`")))?;
        let at = decl.name.span().end();
        let from = offset(source, &starts, at.line, at.column)
            .ok_or_else(|| FittedKinError(format!("cannot place param `{name}` in the text")))?;
        let semicolon = next_code(source, from, ';')
            .ok_or_else(|| FittedKinError(format!("param `{name}` has no `;`")))?;
        let text = format!("{value:?}");
        match next_code(&source[..semicolon], from, '=') {
            Some(eq) => edits.push((eq + 1..semicolon, format!(" {text}"))),
            None => edits.push((semicolon..semicolon, format!(" = {text}"))),
        }
    }
    edits.sort_by_key(|e| std::cmp::Reverse(e.0.start));
    let mut out = source.to_owned();
    for (range, text) in edits {
        out.replace_range(range, &text);
    }
    Ok(out)
}

/// The byte offset of each line's start.
fn line_starts(s: &str) -> Vec<usize> {
    std::iter::once(0)
        .chain(s.match_indices('\n').map(|(i, _)| i + 1))
        .collect()
}

/// The byte offset of (1-based line, 0-based character column).
fn offset(s: &str, starts: &[usize], line: usize, column: usize) -> Option<usize> {
    let start = *starts.get(line.checked_sub(1)?)?;
    let rest = &s[start..];
    match rest.char_indices().nth(column) {
        Some((i, _)) => Some(start + i),
        None => Some(s.len()),
    }
}

/// The first `c` at or after `from` that is not in a comment.
fn next_code(s: &str, from: usize, c: char) -> Option<usize> {
    let bytes = s.as_bytes();
    let mut i = from;
    while i < bytes.len() {
        if s[i..].starts_with("//") {
            i = s[i..].find('\n').map_or(bytes.len(), |n| i + n);
            continue;
        }
        if s[i..].starts_with("/*") {
            i = s[i + 2..].find("*/").map_or(bytes.len(), |n| i + 2 + n + 2);
            continue;
        }
        let ch = s[i..].chars().next()?;
        if ch == c {
            return Some(i);
        }
        i += ch.len_utf8();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_values_in_place_keeping_the_rest() {
        let src = "// a pendulum\nmechanism P {\n    /// its length\n    param l = 1.0; // metres\n    param m = 2 * 3; /* = 6; */\n    body b { guess: (0.5, 0.8, 1.0) }\n    joint pin: revolute(ground(0, 0), b(-l, 0));\n    driver d: b.phi == t;\n}\n";
        let out = fitted_kin(src, &[("l".to_owned(), 1.25), ("m".to_owned(), 0.1)]).unwrap();
        assert!(out.contains("param l = 1.25; // metres"), "{out}");
        assert!(out.contains("param m = 0.1; /* = 6; */"), "{out}");
        assert!(out.starts_with("// a pendulum\n"));
        let again = ParsedModel::parse_str(&out).unwrap();
        assert_eq!(again.syntax().items.len(), 5);
        let err = fitted_kin(src, &[("k".to_owned(), 1.0)]).unwrap_err();
        assert!(err.to_string().contains("no param `k`"));
    }
}
