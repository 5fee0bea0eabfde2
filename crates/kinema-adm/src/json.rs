//! A small, tolerant JSON reader that keeps the position of every value.
//!
//! It accepts standard JSON plus what simEngine2D's reader accepted:
//! arithmetic on numeric literals wherever a number is expected
//! (`[187/255, 98/255, 0]`, `2*pi`, `-(1 + 2)^2`; the `fun` language without
//! `t`, see [`crate::fun`]), tabs anywhere whitespace is allowed, and a
//! missing final newline. A UTF-8 byte-order mark is skipped; tabs inside
//! strings are kept. Duplicate keys in an object are an error (the model
//! would be ambiguous).
//!
//! Nesting is limited to [`MAX_DEPTH`] levels, so the recursive descent is
//! bounded; no input makes the reader panic.

use kinema_model::Diagnostics;

use crate::fun::Expr;
use crate::pos::Pos;

/// The deepest nesting of arrays and objects accepted.
pub const MAX_DEPTH: usize = 64;

/// A JSON value and where it starts in the source.
#[derive(Clone, Debug, PartialEq)]
pub struct Value {
    /// Position of the value's first character.
    pub pos: Pos,
    /// The value.
    pub kind: Kind,
}

/// The kinds of JSON values.
#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    /// `null`
    Null,
    /// `true` or `false`
    Bool(bool),
    /// A number, possibly written as arithmetic (`187/255`).
    Number(f64),
    /// A string.
    String(Str),
    /// An array.
    Array(Vec<Value>),
    /// An object: its members in source order.
    Object(Vec<Member>),
}

/// A JSON string with enough information to locate characters inside it.
#[derive(Clone, Debug, PartialEq)]
pub struct Str {
    /// The decoded text.
    pub text: String,
    /// Whether the source had no escape sequences, so that character `k` of
    /// `text` is at column `pos.col + 1 + k` of the source.
    pub verbatim: bool,
}

/// An object member: key, key position, value.
#[derive(Clone, Debug, PartialEq)]
pub struct Member {
    /// The key.
    pub key: String,
    /// Position of the key's opening quote.
    pub key_pos: Pos,
    /// The value.
    pub value: Value,
}

impl Value {
    /// A short description of the kind of value, for "expected …, found …".
    #[must_use]
    pub fn describe(&self) -> &'static str {
        match self.kind {
            Kind::Null => "null",
            Kind::Bool(_) => "a boolean",
            Kind::Number(_) => "a number",
            Kind::String(_) => "a string",
            Kind::Array(_) => "an array",
            Kind::Object(_) => "an object",
        }
    }

    /// The members, if this is an object.
    #[must_use]
    pub fn as_object(&self) -> Option<&[Member]> {
        match &self.kind {
            Kind::Object(m) => Some(m),
            _ => None,
        }
    }

    /// The elements, if this is an array.
    #[must_use]
    pub fn as_array(&self) -> Option<&[Value]> {
        match &self.kind {
            Kind::Array(a) => Some(a),
            _ => None,
        }
    }

    /// The number, if this is a number.
    #[must_use]
    pub fn as_f64(&self) -> Option<f64> {
        match self.kind {
            Kind::Number(x) => Some(x),
            _ => None,
        }
    }

    /// The string, if this is a string.
    #[must_use]
    pub fn as_str(&self) -> Option<&Str> {
        match &self.kind {
            Kind::String(s) => Some(s),
            _ => None,
        }
    }

    /// The member `key` of an object (the first one; keys are unique).
    #[must_use]
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.as_object()?
            .iter()
            .find(|m| m.key == key)
            .map(|m| &m.value)
    }

    /// The position of character `k` of a string value (exact when the string
    /// has no escapes; otherwise the position just after the opening quote).
    #[must_use]
    pub fn pos_in_string(&self, k: usize) -> Pos {
        let inner = self.pos.advance('"');
        match &self.kind {
            Kind::String(s) if s.verbatim => s.text.chars().take(k).fold(inner, Pos::advance),
            _ => inner,
        }
    }
}

/// Parses a whole JSON text.
///
/// # Errors
/// One diagnostic, at the first syntax error, saying what was expected.
pub fn parse(text: &str) -> Result<Value, Diagnostics> {
    read(text).map_err(|e| {
        let mut one = Diagnostics::new();
        one.push(e.pos.error(e.message));
        one
    })
}

/// A syntax error: where and what (made a diagnostic once, by [`parse`]).
struct Error {
    pos: Pos,
    message: String,
}

fn read(text: &str) -> Result<Value, Error> {
    let mut r = Reader {
        chars: text.chars().collect(),
        i: 0,
        pos: Pos::start(),
    };
    if r.peek() == Some('\u{feff}') {
        r.bump();
    }
    r.skip_ws();
    if r.peek().is_none() {
        return Err(r.error_here("the file is empty: expected a JSON object"));
    }
    let v = r.value(0)?;
    r.skip_ws();
    if let Some(c) = r.peek() {
        return Err(r.error_here(format!(
            "unexpected `{}` after the end of the JSON value",
            c.escape_debug()
        )));
    }
    Ok(v)
}

struct Reader {
    chars: Vec<char>,
    i: usize,
    pos: Pos,
}

impl Reader {
    fn peek(&self) -> Option<char> {
        self.chars.get(self.i).copied()
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.i += 1;
        self.pos = self.pos.advance(c);
        Some(c)
    }

    fn skip_ws(&mut self) {
        while matches!(self.peek(), Some(' ' | '\t' | '\n' | '\r')) {
            self.bump();
        }
    }

    fn error_at(&self, pos: Pos, message: impl Into<String>) -> Error {
        Error {
            pos,
            message: message.into(),
        }
    }

    fn error_here(&self, message: impl Into<String>) -> Error {
        self.error_at(self.pos, message)
    }

    fn found(&self) -> String {
        match self.peek() {
            None => "the end of the file".to_string(),
            Some(c) => format!("`{}`", c.escape_debug()),
        }
    }

    /// A hint when the next character starts a value: a comma is missing.
    fn missing_comma_hint(&self) -> &'static str {
        match self.peek() {
            Some('{' | '[' | '"') => " (is a `,` missing before it?)",
            _ => "",
        }
    }

    fn value(&mut self, depth: usize) -> Result<Value, Error> {
        let pos = self.pos;
        match self.peek() {
            Some('{') => self.object(depth),
            Some('[') => self.array(depth),
            Some('"') => {
                let s = self.string()?;
                Ok(Value {
                    pos,
                    kind: Kind::String(s),
                })
            }
            Some(c) if c.is_ascii_alphabetic() => {
                let word: String = self.chars[self.i..]
                    .iter()
                    .take_while(|c| c.is_ascii_alphanumeric() || **c == '_')
                    .collect();
                let kind = match word.as_str() {
                    "true" => Kind::Bool(true),
                    "false" => Kind::Bool(false),
                    "null" => Kind::Null,
                    _ => return self.number(),
                };
                for _ in 0..word.chars().count() {
                    self.bump();
                }
                Ok(Value { pos, kind })
            }
            Some(c) if c.is_ascii_digit() || matches!(c, '-' | '+' | '.' | '(') => self.number(),
            _ => Err(self.error_here(format!(
                "expected a value (object, array, string, number, true, false or null), found {}",
                self.found()
            ))),
        }
    }

    /// A number, possibly written as arithmetic: everything up to the next
    /// `,` `]` `}` (outside parentheses) is evaluated as a constant
    /// expression of the `fun` language.
    fn number(&mut self) -> Result<Value, Error> {
        let start = self.pos;
        let mut depth = 0usize;
        let mut end = self.i;
        while let Some(&c) = self.chars.get(end) {
            match c {
                '(' => depth += 1,
                ')' if depth > 0 => depth -= 1,
                ',' | ']' | '}' | '"' | '{' | '[' | ':' if depth == 0 => break,
                _ => {}
            }
            end += 1;
        }
        let text: String = self.chars[self.i..end].iter().collect();
        let trimmed_len = text.trim_end().chars().count();
        match Expr::parse_constant(&text) {
            Ok(x) => {
                for _ in 0..trimmed_len {
                    self.bump();
                }
                Ok(Value {
                    pos: start,
                    kind: Kind::Number(x),
                })
            }
            Err(e) => {
                let pos = text.chars().take(e.offset).fold(start, Pos::advance);
                let shown = text.trim();
                let shown = if shown.chars().count() > 40 {
                    format!("{}…", shown.chars().take(40).collect::<String>())
                } else {
                    shown.to_string()
                };
                Err(self.error_at(
                    pos,
                    format!("expected a number, cannot read `{shown}`: {}", e.message),
                ))
            }
        }
    }

    fn string(&mut self) -> Result<Str, Error> {
        let open = self.pos;
        self.bump(); // opening quote
        let mut text = String::new();
        let mut verbatim = true;
        loop {
            let here = self.pos;
            match self.bump() {
                None | Some('\n') => {
                    return Err(self.error_at(
                        open,
                        "unterminated string: this `\"` has no closing `\"` on its line",
                    ));
                }
                Some('"') => return Ok(Str { text, verbatim }),
                Some('\\') => {
                    verbatim = false;
                    let c = self.bump();
                    match c {
                        Some('"') => text.push('"'),
                        Some('\\') => text.push('\\'),
                        Some('/') => text.push('/'),
                        Some('b') => text.push('\u{8}'),
                        Some('f') => text.push('\u{c}'),
                        Some('n') => text.push('\n'),
                        Some('r') => text.push('\r'),
                        Some('t') => text.push('\t'),
                        Some('u') => {
                            let hi = self.hex4(here)?;
                            let code = if (0xD800..0xDC00).contains(&hi)
                                && self.peek() == Some('\\')
                                && self.chars.get(self.i + 1) == Some(&'u')
                            {
                                self.bump();
                                self.bump();
                                let lo = self.hex4(here)?;
                                if (0xDC00..0xE000).contains(&lo) {
                                    0x10000 + ((hi - 0xD800) << 10) + (lo - 0xDC00)
                                } else {
                                    0xFFFD
                                }
                            } else {
                                hi
                            };
                            text.push(char::from_u32(code).unwrap_or('\u{fffd}'));
                        }
                        _ => {
                            return Err(self.error_at(
                                here,
                                "invalid escape in string: expected one of \\\" \\\\ \\/ \\b \\f \\n \\r \\t \\uXXXX",
                            ));
                        }
                    }
                }
                Some(c) => text.push(c),
            }
        }
    }

    fn hex4(&mut self, at: Pos) -> Result<u32, Error> {
        let mut v = 0u32;
        for _ in 0..4 {
            let d = self.peek().and_then(|c| c.to_digit(16)).ok_or_else(|| {
                self.error_at(at, "invalid \\u escape: expected four hexadecimal digits")
            })?;
            self.bump();
            v = v * 16 + d;
        }
        Ok(v)
    }

    fn enter(&self, depth: usize) -> Result<usize, Error> {
        if depth >= MAX_DEPTH {
            Err(self.error_here(format!(
                "nesting too deep (more than {MAX_DEPTH} levels of arrays and objects)"
            )))
        } else {
            Ok(depth + 1)
        }
    }

    fn array(&mut self, depth: usize) -> Result<Value, Error> {
        let pos = self.pos;
        let depth = self.enter(depth)?;
        self.bump(); // [
        let mut items = Vec::new();
        self.skip_ws();
        if self.peek() == Some(']') {
            self.bump();
            return Ok(Value {
                pos,
                kind: Kind::Array(items),
            });
        }
        loop {
            self.skip_ws();
            if self.peek() == Some(']') && !items.is_empty() {
                return Err(self.error_here("trailing comma: expected a value after `,`"));
            }
            items.push(self.value(depth)?);
            self.skip_ws();
            match self.peek() {
                Some(',') => {
                    self.bump();
                }
                Some(']') => {
                    self.bump();
                    return Ok(Value {
                        pos,
                        kind: Kind::Array(items),
                    });
                }
                _ => {
                    return Err(self.error_here(format!(
                        "expected `,` or `]` in the array opened at line {}, column {}, found {}{}",
                        pos.line,
                        pos.col,
                        self.found(),
                        self.missing_comma_hint()
                    )));
                }
            }
        }
    }

    fn object(&mut self, depth: usize) -> Result<Value, Error> {
        let pos = self.pos;
        let depth = self.enter(depth)?;
        self.bump(); // {
        let mut members: Vec<Member> = Vec::new();
        self.skip_ws();
        if self.peek() == Some('}') {
            self.bump();
            return Ok(Value {
                pos,
                kind: Kind::Object(members),
            });
        }
        loop {
            self.skip_ws();
            let key_pos = self.pos;
            match self.peek() {
                Some('"') => {}
                Some('}') if !members.is_empty() => {
                    return Err(self.error_here("trailing comma: expected a key after `,`"));
                }
                _ => {
                    return Err(self.error_here(format!(
                        "expected a key in double quotes, found {}",
                        self.found()
                    )));
                }
            }
            let key = self.string()?.text;
            if let Some(first) = members.iter().find(|m| m.key == key) {
                return Err(self.error_at(
                    key_pos,
                    format!(
                        "duplicate key \"{key}\" (first at line {}, column {})",
                        first.key_pos.line, first.key_pos.col
                    ),
                ));
            }
            self.skip_ws();
            if self.peek() != Some(':') {
                return Err(self.error_here(format!(
                    "expected `:` after the key \"{key}\", found {}",
                    self.found()
                )));
            }
            self.bump();
            self.skip_ws();
            let value = self.value(depth)?;
            members.push(Member {
                key,
                key_pos,
                value,
            });
            self.skip_ws();
            match self.peek() {
                Some(',') => {
                    self.bump();
                }
                Some('}') => {
                    self.bump();
                    return Ok(Value {
                        pos,
                        kind: Kind::Object(members),
                    });
                }
                _ => {
                    return Err(self.error_here(format!(
                        "expected `,` or `}}` after the value of \"{}\", found {}{}",
                        members.last().map_or("", |m| m.key.as_str()),
                        self.found(),
                        self.missing_comma_hint()
                    )));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(text: &str) -> Result<Value, Box<kinema_model::Diagnostic>> {
        parse(text).map_err(|d| Box::new(d.into_iter().next().expect("one diagnostic")))
    }

    #[test]
    fn strict_json() {
        let v = p("{\"a\": [1, -2.5e-1, true, null], \"b\": \"x\\ty\"}").expect("parses");
        let a = v.get("a").and_then(Value::as_array).expect("array");
        assert_eq!(a[1].as_f64(), Some(-0.25));
        assert_eq!(
            v.get("b").and_then(Value::as_str).map(|s| s.text.as_str()),
            Some("x\ty")
        );
    }

    #[test]
    fn arithmetic_numbers() {
        let v = p("{\"c\": [187/255, 98/255, 0], \"d\": 2*pi, \"e\": -(1 + 2)^2}").expect("parses");
        let c = v.get("c").and_then(Value::as_array).expect("array");
        assert_eq!(c[0].as_f64(), Some(187.0 / 255.0));
        assert_eq!(
            v.get("d").and_then(Value::as_f64),
            Some(2.0 * std::f64::consts::PI)
        );
        assert_eq!(v.get("e").and_then(Value::as_f64), Some(-9.0));
    }

    #[test]
    fn positions() {
        let v = p("{\n\t\"a\":\n  [1,\t2]}").expect("parses");
        let a = v.get("a").expect("a");
        assert_eq!((a.pos.line, a.pos.col), (3, 3));
        let two = &a.as_array().expect("array")[1];
        assert_eq!((two.pos.line, two.pos.col), (3, 7));
    }

    #[test]
    fn errors_have_positions() {
        let e = p("{\"a\": [1, 2}").expect_err("bad");
        let start = e.span.start();
        assert_eq!((start.line, start.column + 1), (1, 12));
        let e = p("{\"a\": 1/0}").expect_err("bad");
        assert!(e.message.contains("finite"), "{}", e.message);
        let e = p("{\"a\": 1 2}").expect_err("bad");
        assert!(e.message.contains("expected a number"), "{}", e.message);
        let e = p("{\"a\": 1, \"a\": 2}").expect_err("dup");
        assert!(e.message.contains("duplicate"), "{}", e.message);
        assert!(p("").is_err());
        assert!(p("{").is_err());
        assert!(p("[1,]").is_err());
        assert!(p("\"abc").is_err());
        assert!(p("{} x").is_err());
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let deep = "[".repeat(100_000);
        let e = p(&deep).expect_err("too deep");
        assert!(e.message.contains("nesting too deep"));
        let parens = format!("{{\"a\": {}1{}}}", "(".repeat(10_000), ")".repeat(10_000));
        assert!(p(&parens).is_err());
    }
}
