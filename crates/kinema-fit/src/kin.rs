//! The fitted model as `.kin` text: the model's own text with the fitted
//! params' values written in place of theirs — its comments, layout and
//! every other line kept, so the designer's file stays theirs.

use std::fmt;

use kinema_model::ParsedModel;
use kinema_model::syntax::Item;

/// A configuration by coordinate name (`crank.x`, a `coord`'s own name).
pub(crate) type Guesses<'a> = &'a dyn Fn(&str) -> Option<f64>;

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
    write(source, values, None)
}

/// [`fitted_kin`], and with `guesses` (a configuration: the value of each
/// coordinate by name, `crank.x`, `crank.phi`, a `coord`'s own name) each
/// body's `guess: (x, y, phi)` and each `coord`'s `guess` written as those
/// values (added where the model has none), so the model assembles on
/// that configuration's branch.
pub(crate) fn write(
    source: &str,
    values: &[(String, f64)],
    guesses: Option<Guesses<'_>>,
) -> Result<String, FittedKinError> {
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
    if let Some(value) = guesses {
        for item in &parsed.syntax().items {
            let (name, components): (&kinema_model::syntax::Name, Vec<String>) = match item {
                Item::Body(b) => (
                    &b.name,
                    ["x", "y", "phi"]
                        .iter()
                        .map(|c| format!("{}.{c}", b.name.as_str()))
                        .collect(),
                ),
                Item::Coord(c) => (&c.name, vec![c.name.as_str().to_owned()]),
                _ => continue,
            };
            let Some(numbers) = components
                .iter()
                .map(|c| value(c).map(|v| format!("{v:?}")))
                .collect::<Option<Vec<String>>>()
            else {
                continue;
            };
            let guess = if numbers.len() == 3 {
                format!("({})", numbers.join(", "))
            } else {
                numbers.join("")
            };
            let at = name.span().end();
            let from = offset(source, &starts, at.line, at.column).ok_or_else(|| {
                FittedKinError(format!("cannot place `{}` in the text", name.as_str()))
            })?;
            edits.push(guess_edit(source, from, &guess).ok_or_else(|| {
                FittedKinError(format!(
                    "cannot find the guess of `{}` in the text",
                    name.as_str()
                ))
            })?);
        }
    }
    edits.sort_by_key(|e| std::cmp::Reverse(e.0.start));
    let mut out = source.to_owned();
    for (range, text) in edits {
        out.replace_range(range, &text);
    }
    Ok(out)
}

/// The edit that makes the guess of the item whose name ends at `from`
/// `guess`: `name;` gets a block, a block without `guess` gets one first,
/// a `guess` has its value replaced (a body's parenthesized triple, a
/// coordinate's expression up to `,` or `}`).
fn guess_edit(s: &str, from: usize, guess: &str) -> Option<(std::ops::Range<usize>, String)> {
    let semicolon = next_code(s, from, ';');
    let brace = next_code(s, from, '{');
    match (semicolon, brace) {
        (Some(sc), b) if b.is_none_or(|b| sc < b) => {
            Some((sc..sc + 1, format!(" {{ guess: {guess} }}")))
        }
        (_, Some(open)) => {
            // Scan the block at depth 0 for the word `guess`.
            let mut depth = 0i32;
            let mut i = open + 1;
            let bytes = s.as_bytes();
            while i < bytes.len() {
                if s[i..].starts_with("//") || s[i..].starts_with("/*") {
                    let next = if s[i..].starts_with("//") {
                        s[i..].find('\n').map_or(bytes.len(), |n| i + n)
                    } else {
                        s[i + 2..].find("*/").map_or(bytes.len(), |n| i + 4 + n)
                    };
                    i = next;
                    continue;
                }
                let c = bytes[i];
                match c {
                    b'(' | b'{' | b'[' => depth += 1,
                    b')' | b']' => depth -= 1,
                    b'}' if depth == 0 => {
                        return Some((open + 1..open + 1, format!(" guess: {guess},")));
                    }
                    b'}' => depth -= 1,
                    _ => {}
                }
                let word = depth == 0
                    && s[i..].starts_with("guess")
                    && (i == 0 || !is_ident(bytes[i - 1]))
                    && !bytes.get(i + 5).is_some_and(|&b| is_ident(b));
                if word {
                    let colon = next_code(s, i + 5, ':')?;
                    // The value: up to the `,` or `}` closing it at depth 0.
                    let mut d = 0i32;
                    let mut j = colon + 1;
                    while j < bytes.len() {
                        match bytes[j] {
                            b'(' | b'[' | b'{' => d += 1,
                            b')' | b']' => d -= 1,
                            b'}' if d == 0 => break,
                            b'}' => d -= 1,
                            b',' if d == 0 => break,
                            _ => {}
                        }
                        j += 1;
                    }
                    let end = s[..j].trim_end().len();
                    return Some((colon + 1..end, format!(" {guess}")));
                }
                i += 1;
            }
            None
        }
        _ => None,
    }
}

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
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
#[allow(clippy::unwrap_used)] // tests: a failure should stop the test
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
        // Guesses written where they are, added where they are not.
        let src2 = "mechanism P {\n    param l = 1.0;\n    body a { mass: 1, guess: (0.5, sin(0.8), 1.0) }\n    body b;\n    body c { mass: 2 }\n    coord s { guess: pi / 2 }\n    joint pin: revolute(ground(0, 0), a(-l, 0));\n    driver d: a.phi == t;\n}\n";
        let q = |name: &str| -> Option<f64> {
            Some(match name {
                "a.x" => 1.0,
                "a.y" => 2.0,
                "a.phi" => 3.0,
                "s" => 0.25,
                _ if name.starts_with("b.") => 4.0,
                _ if name.starts_with("c.") => 5.0,
                _ => return None,
            })
        };
        let out = write(src2, &[], Some(&q)).unwrap();
        assert!(
            out.contains("body a { mass: 1, guess: (1.0, 2.0, 3.0) }"),
            "{out}"
        );
        assert!(out.contains("body b { guess: (4.0, 4.0, 4.0) }"), "{out}");
        assert!(
            out.contains("body c { guess: (5.0, 5.0, 5.0), mass: 2 }"),
            "{out}"
        );
        assert!(out.contains("coord s { guess: 0.25 }"), "{out}");
        ParsedModel::parse_str(&out).unwrap();
    }
}
