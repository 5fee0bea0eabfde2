//! The lexer and the recursive-descent parser of `fun` strings (nesting
//! bounded by [`MAX_DEPTH`]).

use super::*;

// ---------------------------------------------------------------- lexer

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Plus,
    Minus,
    Star,
    Slash,
    Caret,
    LParen,
    RParen,
    Comma,
    End,
}

impl Tok {
    fn describe(&self) -> String {
        match self {
            Tok::Num(x) => format!("the number `{}`", format_number(*x)),
            Tok::Ident(s) => format!("`{s}`"),
            Tok::Plus => "`+`".into(),
            Tok::Minus => "`-`".into(),
            Tok::Star => "`*`".into(),
            Tok::Slash => "`/`".into(),
            Tok::Caret => "`^`".into(),
            Tok::LParen => "`(`".into(),
            Tok::RParen => "`)`".into(),
            Tok::Comma => "`,`".into(),
            Tok::End => "the end of the expression".into(),
        }
    }
}

/// The tokens of `text`, each with its character offset; whitespace
/// separates, `End` closes.
fn lex(text: &str) -> Result<Vec<(Tok, usize)>, FunError> {
    let chars: Vec<char> = text.chars().collect();
    let mut toks = Vec::new();
    let mut i = 0;
    while let Some(&c) = chars.get(i) {
        let start = i;
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let next = chars.get(i + 1).copied();
        let (tok, end) =
            if c.is_ascii_digit() || (c == '.' && next.is_some_and(|d| d.is_ascii_digit())) {
                lex_number(&chars, i)?
            } else if c.is_alphabetic() || c == '_' {
                let end = (i..chars.len())
                    .find(|&k| !(chars[k].is_alphanumeric() || chars[k] == '_'))
                    .unwrap_or(chars.len());
                (Tok::Ident(chars[i..end].iter().collect()), end)
            } else {
                lex_operator(c, next, i)?
            };
        toks.push((tok, start));
        i = end;
    }
    toks.push((Tok::End, chars.len()));
    Ok(toks)
}

/// The number starting at `chars[start]`, and the offset after it:
/// `int ( "." frac )? ( [eE] [+-]? exp )?` with either part of the
/// mantissa possibly empty (`5.`, `.5`), read as `int.frac e exp` — but
/// `5.*t` is `5 .* t` (a dot before an element-wise operator belongs to
/// the operator). Out of the `f64` range is an error, and so is an `e`
/// without an exponent.
fn lex_number(chars: &[char], start: usize) -> Result<(Tok, usize), FunError> {
    let at = |k: usize| chars.get(k).copied();
    let digits = |from: usize| {
        (from..chars.len())
            .find(|&k| !chars[k].is_ascii_digit())
            .unwrap_or(chars.len())
    };
    let text = |a: usize, b: usize| -> String { chars.get(a..b).unwrap_or(&[]).iter().collect() };
    let mut i = digits(start);
    let int = text(start, i);
    let mut frac = String::new();
    if at(i) == Some('.') && !matches!(at(i + 1), Some('*' | '/' | '^')) {
        let end = digits(i + 1);
        frac = text(i + 1, end);
        i = end;
    }
    let mut exp = String::new();
    if matches!(at(i), Some('e' | 'E')) {
        let mut j = i + 1;
        if let Some(s @ ('+' | '-')) = at(j) {
            exp.push(s);
            j += 1;
        }
        if !at(j).is_some_and(|d| d.is_ascii_digit()) {
            return Err(FunError {
                offset: i,
                message: "malformed number: `e` must be followed by an exponent such as `e-5` \
                          (`e` is not a constant; write `exp(1)`)"
                    .into(),
            });
        }
        let end = digits(j);
        exp.push_str(&text(j, end));
        i = end;
    }
    let or_zero = |s: &str| {
        if s.is_empty() {
            "0".to_string()
        } else {
            s.to_string()
        }
    };
    let canonical = format!("{}.{}e{}", or_zero(&int), or_zero(&frac), or_zero(&exp));
    match canonical.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok((Tok::Num(x), i)),
        _ => Err(FunError {
            offset: start,
            message: format!("number `{}` is out of range", text(start, i)),
        }),
    }
}

/// The operator or bracket `c` at offset `i` (`next` after it), and the
/// offset after it: `+ - * / ^ ( ) ,` and MATLAB's element-wise `.*`,
/// `./`, `.^` (the same on scalars). Left division and the transpose are
/// refused by name.
fn lex_operator(c: char, next: Option<char>, i: usize) -> Result<(Tok, usize), FunError> {
    let err = |message: String| FunError { offset: i, message };
    let tok = match c {
        '+' => Tok::Plus,
        '-' => Tok::Minus,
        '*' => Tok::Star,
        '/' => Tok::Slash,
        '^' => Tok::Caret,
        '(' => Tok::LParen,
        ')' => Tok::RParen,
        ',' => Tok::Comma,
        '.' => {
            let tok = match next {
                Some('*') => Tok::Star,
                Some('/') => Tok::Slash,
                Some('^') => Tok::Caret,
                _ => {
                    return Err(err(
                        "unexpected `.`: expected a number such as `.5` or an operator `.*`, `./`, `.^`"
                            .into(),
                    ));
                }
            };
            return Ok((tok, i + 2));
        }
        '\\' => return Err(err("left division `\\` is not supported; write `/`".into())),
        '\'' => return Err(err("the transpose `'` is not supported in a fun".into())),
        other => {
            return Err(err(format!(
                "unexpected character `{}`",
                other.escape_debug()
            )));
        }
    };
    Ok((tok, i + 1))
}

// ---------------------------------------------------------------- parser

pub(super) struct Parser {
    toks: Vec<(Tok, usize)>,
    pos: usize,
    nodes: Vec<Node>,
    offsets: Vec<usize>,
    text: String,
    allow_t: bool,
    depth: usize,
    lex_error: Option<FunError>,
}

const FUNCTIONS: &str = "sin, cos, tan, asin, acos, atan, sinh, cosh, tanh, exp, log, log10, \
                         sqrt, abs, atan2, power";

impl Parser {
    pub(super) fn new(text: &str, allow_t: bool) -> Self {
        let (toks, lex_error) = match lex(text) {
            Ok(t) => (t, None),
            Err(e) => (vec![(Tok::End, 0)], Some(e)),
        };
        Parser {
            toks,
            pos: 0,
            nodes: Vec::new(),
            offsets: Vec::new(),
            text: text.to_string(),
            allow_t,
            depth: 0,
            lex_error,
        }
    }

    pub(super) fn run(mut self) -> Result<Expr, FunError> {
        if let Some(e) = self.lex_error.take() {
            return Err(e);
        }
        if matches!(self.peek(), Tok::End) {
            return Err(FunError {
                offset: 0,
                message: "empty expression: expected a number or an expression in t".into(),
            });
        }
        self.sum()?;
        if !matches!(self.peek(), Tok::End) {
            let what = self.peek().describe();
            return Err(self.error(format!(
                "expected an operator (`+ - * / ^`) or the end of the expression, found {what}"
            )));
        }
        Ok(Expr {
            nodes: self.nodes,
            offsets: self.offsets,
            text: self.text,
        })
    }

    fn peek(&self) -> &Tok {
        self.toks.get(self.pos).map_or(&Tok::End, |(t, _)| t)
    }

    fn offset(&self) -> usize {
        self.toks.get(self.pos).map_or(0, |&(_, o)| o)
    }

    fn bump(&mut self) {
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
    }

    fn error(&self, message: String) -> FunError {
        FunError {
            offset: self.offset(),
            message,
        }
    }

    /// Appends `node`, written at character `offset` (its operator, name or
    /// number).
    fn push(&mut self, node: Node, offset: usize) -> Result<u32, FunError> {
        let id = u32::try_from(self.nodes.len())
            .map_err(|_| self.error("expression too large".into()))?;
        self.nodes.push(node);
        self.offsets.push(offset);
        Ok(id)
    }

    fn enter(&mut self) -> Result<(), FunError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            Err(self.error(format!(
                "expression nested too deeply (more than {MAX_DEPTH} levels)"
            )))
        } else {
            Ok(())
        }
    }

    fn sum(&mut self) -> Result<u32, FunError> {
        let mut lhs = self.product()?;
        loop {
            let op = match self.peek() {
                Tok::Plus => BinOp::Add,
                Tok::Minus => BinOp::Sub,
                _ => return Ok(lhs),
            };
            let at = self.offset();
            self.bump();
            let rhs = self.product()?;
            lhs = self.push(Node::Bin(op, lhs, rhs), at)?;
        }
    }

    fn product(&mut self) -> Result<u32, FunError> {
        let mut lhs = self.unary()?;
        loop {
            let op = match self.peek() {
                Tok::Star => BinOp::Mul,
                Tok::Slash => BinOp::Div,
                _ => return Ok(lhs),
            };
            let at = self.offset();
            self.bump();
            let rhs = self.unary()?;
            lhs = self.push(Node::Bin(op, lhs, rhs), at)?;
        }
    }

    fn unary(&mut self) -> Result<u32, FunError> {
        self.signed(Self::power)
    }

    /// Leading signs (`-` negates, `+` is dropped), then `rest`: a unary
    /// expression with `rest` = [`power`](Self::power), the right operand of
    /// `^` with `rest` = [`primary`](Self::primary).
    fn signed(&mut self, rest: fn(&mut Self) -> Result<u32, FunError>) -> Result<u32, FunError> {
        match self.peek() {
            Tok::Plus | Tok::Minus => {
                let neg = matches!(self.peek(), Tok::Minus);
                let at = self.offset();
                self.bump();
                self.enter()?;
                let a = self.signed(rest)?;
                self.depth -= 1;
                if neg {
                    self.push(Node::Neg(a), at)
                } else {
                    Ok(a)
                }
            }
            _ => rest(self),
        }
    }

    fn power(&mut self) -> Result<u32, FunError> {
        let mut lhs = self.primary()?;
        while matches!(self.peek(), Tok::Caret) {
            let at = self.offset();
            self.bump();
            let rhs = self.operand()?;
            lhs = self.push(Node::Bin(BinOp::Pow, lhs, rhs), at)?;
        }
        Ok(lhs)
    }

    /// The right operand of `^`: signs, then a primary.
    fn operand(&mut self) -> Result<u32, FunError> {
        self.signed(Self::primary)
    }

    fn primary(&mut self) -> Result<u32, FunError> {
        let offset = self.offset();
        match self.peek().clone() {
            Tok::Num(x) => {
                self.bump();
                self.push(Node::Num(x), offset)
            }
            Tok::LParen => {
                self.bump();
                self.enter()?;
                let inner = self.sum()?;
                self.depth -= 1;
                self.expect_close(offset)?;
                Ok(inner)
            }
            Tok::Ident(name) => {
                self.bump();
                if matches!(self.peek(), Tok::LParen) {
                    self.call(&name, offset)
                } else {
                    self.name(&name, offset)
                }
            }
            other => Err(self.error(format!(
                "expected a number, `t`, `pi`, a function call or `(`, found {}",
                other.describe()
            ))),
        }
    }

    fn expect_close(&mut self, open: usize) -> Result<(), FunError> {
        if matches!(self.peek(), Tok::RParen) {
            self.bump();
            Ok(())
        } else {
            let what = self.peek().describe();
            Err(self.error(format!(
                "expected `)` to close the `(` at character {}, found {what}",
                open + 1
            )))
        }
    }

    fn name(&mut self, name: &str, offset: usize) -> Result<u32, FunError> {
        let err = |message: String| FunError { offset, message };
        match name {
            "t" if self.allow_t => self.push(Node::T, offset),
            "t" => Err(err(
                "`t` is not allowed here: a constant number is expected".into(),
            )),
            "pi" => self.push(Node::Pi, offset),
            "e" => Err(err(
                "unknown name `e`: MATLAB has no constant `e`; write `exp(1)`".into(),
            )),
            "NONE" => Err(err(
                "`NONE` must be the whole string, exactly \"NONE\"".into()
            )),
            _ if Func::from_name(name).is_some() || Func2::from_name(name).is_some() => {
                Err(err(format!("`{name}` is a function: write `{name}(...)`")))
            }
            _ if self.allow_t => Err(err(format!(
                "unknown name `{name}`: a fun may use only `t` and `pi` (and functions)"
            ))),
            _ => Err(err(format!(
                "unknown name `{name}`: only numbers, `pi` and arithmetic are allowed here"
            ))),
        }
    }

    fn call(&mut self, name: &str, offset: usize) -> Result<u32, FunError> {
        let open = self.offset();
        self.bump(); // `(`
        self.enter()?;
        let mut args = Vec::new();
        if !matches!(self.peek(), Tok::RParen) {
            loop {
                args.push(self.sum()?);
                if matches!(self.peek(), Tok::Comma) {
                    self.bump();
                } else {
                    break;
                }
            }
        }
        self.depth -= 1;
        self.expect_close(open)?;
        let err = |message: String| FunError { offset, message };
        if let Some(f) = Func::from_name(name) {
            return match args[..] {
                [a] => self.push(Node::Call(f, a), offset),
                _ => Err(err(format!(
                    "`{name}` takes 1 argument, found {}",
                    args.len()
                ))),
            };
        }
        if let Some(f) = Func2::from_name(name) {
            return match args[..] {
                [a, b] => self.push(Node::Call2(f, a, b), offset),
                _ => Err(err(format!(
                    "`{name}` takes 2 arguments, found {}",
                    args.len()
                ))),
            };
        }
        if name == "t" || name == "pi" {
            return Err(err(format!("`{name}` is not a function")));
        }
        Err(err(format!(
            "unknown function `{name}` (supported: {FUNCTIONS})"
        )))
    }
}
