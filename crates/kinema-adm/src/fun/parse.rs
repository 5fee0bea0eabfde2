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

fn lex(text: &str) -> Result<Vec<(Tok, usize)>, FunError> {
    let chars: Vec<char> = text.chars().collect();
    let mut toks = Vec::new();
    let mut i = 0;
    let err = |offset: usize, message: String| FunError { offset, message };
    while let Some(&c) = chars.get(i) {
        let at = |k: usize| chars.get(k).copied();
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let start = i;
        if c.is_ascii_digit() || (c == '.' && at(i + 1).is_some_and(|d| d.is_ascii_digit())) {
            let mut int = String::new();
            while let Some(d) = at(i).filter(char::is_ascii_digit) {
                int.push(d);
                i += 1;
            }
            let mut frac = String::new();
            // `5.*t` is `5 .* t`: a dot followed by an element-wise operator
            // belongs to the operator.
            if at(i) == Some('.') && !matches!(at(i + 1), Some('*' | '/' | '^')) {
                i += 1;
                while let Some(d) = at(i).filter(char::is_ascii_digit) {
                    frac.push(d);
                    i += 1;
                }
            }
            let mut exp = String::new();
            if matches!(at(i), Some('e' | 'E')) {
                let mut j = i + 1;
                if let Some(s @ ('+' | '-')) = at(j) {
                    exp.push(s);
                    j += 1;
                }
                if !at(j).is_some_and(|d| d.is_ascii_digit()) {
                    return Err(err(
                        i,
                        "malformed number: `e` must be followed by an exponent such as `e-5` \
                         (`e` is not a constant; write `exp(1)`)"
                            .into(),
                    ));
                }
                while let Some(d) = at(j).filter(char::is_ascii_digit) {
                    exp.push(d);
                    j += 1;
                }
                i = j;
            }
            let canonical = format!(
                "{}.{}e{}",
                if int.is_empty() { "0" } else { &int },
                if frac.is_empty() { "0" } else { &frac },
                if exp.is_empty() { "0" } else { &exp }
            );
            match canonical.parse::<f64>() {
                Ok(x) if x.is_finite() => toks.push((Tok::Num(x), start)),
                _ => {
                    let written: String = chars.get(start..i).unwrap_or(&[]).iter().collect();
                    return Err(err(start, format!("number `{written}` is out of range")));
                }
            }
            continue;
        }
        if c.is_alphabetic() || c == '_' {
            let mut name = String::new();
            while let Some(d) = at(i).filter(|d| d.is_alphanumeric() || *d == '_') {
                name.push(d);
                i += 1;
            }
            toks.push((Tok::Ident(name), start));
            continue;
        }
        let tok = match c {
            '+' => Tok::Plus,
            '-' => Tok::Minus,
            '*' => Tok::Star,
            '/' => Tok::Slash,
            '^' => Tok::Caret,
            '(' => Tok::LParen,
            ')' => Tok::RParen,
            ',' => Tok::Comma,
            '.' => match at(i + 1) {
                Some('*') => {
                    i += 1;
                    Tok::Star
                }
                Some('/') => {
                    i += 1;
                    Tok::Slash
                }
                Some('^') => {
                    i += 1;
                    Tok::Caret
                }
                _ => {
                    return Err(err(
                        i,
                        "unexpected `.`: expected a number such as `.5` or an operator `.*`, `./`, `.^`"
                            .into(),
                    ));
                }
            },
            '\\' => {
                return Err(err(
                    i,
                    "left division `\\` is not supported; write `/`".into(),
                ));
            }
            '\'' => {
                return Err(err(i, "the transpose `'` is not supported in a fun".into()));
            }
            other => {
                return Err(err(
                    i,
                    format!("unexpected character `{}`", other.escape_debug()),
                ));
            }
        };
        i += 1;
        toks.push((tok, start));
    }
    toks.push((Tok::End, chars.len()));
    Ok(toks)
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
        match self.peek() {
            Tok::Plus | Tok::Minus => {
                let neg = matches!(self.peek(), Tok::Minus);
                let at = self.offset();
                self.bump();
                self.enter()?;
                let a = self.unary()?;
                self.depth -= 1;
                if neg {
                    self.push(Node::Neg(a), at)
                } else {
                    Ok(a)
                }
            }
            _ => self.power(),
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
        match self.peek() {
            Tok::Plus | Tok::Minus => {
                let neg = matches!(self.peek(), Tok::Minus);
                let at = self.offset();
                self.bump();
                self.enter()?;
                let a = self.operand()?;
                self.depth -= 1;
                if neg {
                    self.push(Node::Neg(a), at)
                } else {
                    Ok(a)
                }
            }
            _ => self.primary(),
        }
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
