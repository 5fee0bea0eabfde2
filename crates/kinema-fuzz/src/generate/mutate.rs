//! Mutation of real inputs: structured (tokens and lines of a model file:
//! numbers replaced by extreme ones, names swapped for other names or
//! keywords, lines duplicated, dropped or exchanged, expressions spliced in)
//! and, as a minority, byte-level (flips, insertions, deletions).

use super::{EXTREME, KEYWORDS};
use crate::rng::Rng;

/// A token of a model file: a run of identifier characters, a number, or
/// any other single character.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Tok {
    Word(String),
    Number(String),
    Other(char),
}

fn tokenize(text: &str) -> Vec<Tok> {
    let mut out = Vec::new();
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_ascii_digit() || (c == '.' && chars.get(i + 1).is_some_and(char::is_ascii_digit)) {
            let start = i;
            while i < chars.len()
                && (chars[i].is_ascii_alphanumeric()
                    || chars[i] == '.'
                    || ((chars[i] == '-' || chars[i] == '+') && matches!(chars[i - 1], 'e' | 'E')))
            {
                i += 1;
            }
            out.push(Tok::Number(chars[start..i].iter().collect()));
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(Tok::Word(chars[start..i].iter().collect()));
        } else {
            out.push(Tok::Other(c));
            i += 1;
        }
    }
    out
}

fn untokenize(toks: &[Tok]) -> String {
    let mut s = String::new();
    for t in toks {
        match t {
            Tok::Word(w) | Tok::Number(w) => s.push_str(w),
            Tok::Other(c) => s.push(*c),
        }
    }
    s
}

/// Applies 1 to 4 structured mutations to `seed`. `splice` gives an
/// expression (or `fun` string) of the seed's language to put in place of a
/// number or a string.
pub fn structured(rng: &mut Rng, seed: &str, splice: &mut dyn FnMut(&mut Rng) -> String) -> String {
    let mut text = seed.to_string();
    let rounds = rng.range(1, 4);
    for _ in 0..rounds {
        text = match rng.weighted(&[6, 3, 2, 2, 2, 1, 3]) {
            0 => replace_number(rng, &text, None),
            1 => {
                let e = splice(rng);
                replace_number(rng, &text, Some(e))
            }
            2 => replace_word(rng, &text),
            3 => line_op(rng, &text),
            4 => {
                let e = splice(rng);
                replace_string(rng, &text, e)
            }
            5 => {
                let mut toks = tokenize(&text);
                if !toks.is_empty() {
                    let k = rng.below(toks.len());
                    toks.remove(k);
                }
                untokenize(&toks)
            }
            _ => {
                // Double a token run: (x) → ((x)), names repeated.
                let mut toks = tokenize(&text);
                if !toks.is_empty() {
                    let k = rng.below(toks.len());
                    let n = rng.range(1, 8).min(toks.len() - k);
                    let run: Vec<Tok> = toks[k..k + n].to_vec();
                    for (j, t) in run.into_iter().enumerate() {
                        toks.insert(k + n + j, t);
                    }
                }
                untokenize(&toks)
            }
        };
    }
    text
}

fn replace_number(rng: &mut Rng, text: &str, with: Option<String>) -> String {
    let mut toks = tokenize(text);
    let numbers: Vec<usize> = toks
        .iter()
        .enumerate()
        .filter(|(_, t)| matches!(t, Tok::Number(_)))
        .map(|(i, _)| i)
        .collect();
    if numbers.is_empty() {
        return text.to_string();
    }
    let k = *rng.pick(&numbers);
    let new = with.unwrap_or_else(|| (*rng.pick(EXTREME)).to_string());
    toks[k] = Tok::Number(new);
    untokenize(&toks)
}

fn replace_word(rng: &mut Rng, text: &str) -> String {
    let mut toks = tokenize(text);
    let words: Vec<usize> = toks
        .iter()
        .enumerate()
        .filter(|(_, t)| matches!(t, Tok::Word(_)))
        .map(|(i, _)| i)
        .collect();
    if words.is_empty() {
        return text.to_string();
    }
    let k = *rng.pick(&words);
    let new = if rng.chance(0.5) {
        (*rng.pick(KEYWORDS)).to_string()
    } else {
        match &toks[*rng.pick(&words)] {
            Tok::Word(w) => w.clone(),
            _ => "x".to_string(),
        }
    };
    toks[k] = Tok::Word(new);
    untokenize(&toks)
}

/// Replaces the contents of one `"…"` string (an ADM name or `fun`).
fn replace_string(rng: &mut Rng, text: &str, with: String) -> String {
    let quotes: Vec<usize> = text.match_indices('"').map(|(i, _)| i).collect();
    if quotes.len() < 2 {
        return text.to_string();
    }
    let pair = rng.below(quotes.len() / 2) * 2;
    let (a, b) = (quotes[pair], quotes[pair + 1]);
    let escaped = super::adm::json_string(&with);
    format!("{}{}{}", &text[..a], escaped, &text[b + 1..])
}

fn line_op(rng: &mut Rng, text: &str) -> String {
    let mut lines: Vec<&str> = text.lines().collect();
    if lines.is_empty() {
        return text.to_string();
    }
    let k = rng.below(lines.len());
    match rng.below(4) {
        0 => {
            lines.remove(k);
        }
        1 => {
            let hi = if rng.chance(0.1) { 200 } else { 3 };
            let n = rng.range(1, hi);
            for _ in 0..n {
                lines.insert(k, lines[k]);
            }
        }
        2 => {
            let j = rng.below(lines.len());
            lines.swap(k, j);
        }
        _ => {
            let j = rng.below(lines.len());
            let l = lines[j];
            lines.insert(k, l);
        }
    }
    let mut out = lines.join("\n");
    out.push('\n');
    out
}

/// Byte-level mutation: 1 to 8 flips, insertions (of bytes that matter to
/// the lexers: NUL, quotes, brackets, invalid UTF-8), deletions or
/// truncation.
pub fn bytes(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut data = seed.to_vec();
    let rounds = rng.range(1, 8);
    for _ in 0..rounds {
        let len = data.len();
        match rng.below(5) {
            0 if len > 0 => {
                let k = rng.below(len);
                data[k] ^= 1 << rng.below(8);
            }
            1 => {
                let k = rng.below(len + 1);
                let b = *rng.pick(&[
                    0u8, b'"', b'`', b'(', b')', b'{', b'}', b'[', b']', 0xff, 0xc3, b'\\', b'\n',
                    b'/', b'*', b'e', b'.', b'#', b'\'',
                ]);
                data.insert(k, b);
            }
            2 if len > 0 => {
                let k = rng.below(len);
                data.remove(k);
            }
            3 if len > 0 => {
                let k = rng.below(len);
                data.truncate(k);
            }
            _ => {
                let k = rng.below(len + 1);
                let b = (rng.next_u64() & 0xff) as u8;
                data.insert(k, b);
            }
        }
    }
    data
}
