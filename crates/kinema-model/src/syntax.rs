//! Phase 1: the syntax tree, parsed with syn. It keeps identifiers and spans
//! and resolves nothing: names, types and counts are checked in
//! [`crate::check`].
//!
//! ```text
//! Mechanism  := Doc* "mechanism" Ident "{" Item* "}"
//! Item       := Doc* ( Param | Body | Point | Coord | Curve | Equation | Output )
//! Param      := "param" Ident ( "=" Expr )? ";"
//! Body       := "body" Ident ( "{" BodyField,* "}" | ";" )   (guess, mass, inertia, velocity: syntax/dynamics.rs)
//! Point      := "point" Ident "." Ident "=" Expr ";"
//! Coord      := "coord" Ident ( "{" ( "guess" ":" Expr ","? )? "}" | ";" )
//! Curve      := "curve" Ident "." Ident "(" Ident ")" "=" Expr ";"
//! Equation   := ( "joint" | "constraint" | "driver" ) Ident ":" Expr ( "==" Expr )? ";"
//! Output     := "output" Ident ":" Expr ";"
//! Expr       := Product ( ( "+" | "-" ) Product )*
//! Product    := Unary ( ( "*" | "/" ) Unary )*
//! Unary      := "-"* Postfix
//! Postfix    := Primary ( "." Ident )*
//! Primary    := Number | Ident | Ident "(" Expr,* ")" | "(" Expr ")" | "(" Expr "," Expr,* ")"
//! Doc        := "///" text        (a `#[doc = "…"]` attribute)
//! ```
//!
//! Expressions are stored flat ([`Expr`]): children always precede their
//! parents, so every later pass is a forward loop, never a recursion.

use proc_macro2::TokenStream;
use syn::ext::IdentExt;
use syn::parse::{Parse, ParseStream};
use syn::{Ident, Token, braced, bracketed, parenthesized};

use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::source::LineIndex;
use crate::span::Span;

/// Custom keywords of the language.
pub(crate) mod kw {
    syn::custom_keyword!(mechanism);
    syn::custom_keyword!(param);
    syn::custom_keyword!(body);
    syn::custom_keyword!(point);
    syn::custom_keyword!(joint);
    syn::custom_keyword!(constraint);
    syn::custom_keyword!(driver);
    syn::custom_keyword!(guess);
    syn::custom_keyword!(doc);
    syn::custom_keyword!(output);
    syn::custom_keyword!(mass);
    syn::custom_keyword!(inertia);
    syn::custom_keyword!(velocity);
    syn::custom_keyword!(gravity);
    syn::custom_keyword!(force);
    syn::custom_keyword!(coord);
    syn::custom_keyword!(curve);
}

mod coord;
mod dynamics;
mod items;
mod lexing;
mod name;
mod output;
pub use coord::{CoordDecl, CurveDecl};
pub use dynamics::{BodyVelocity, ForceDecl, GravityDecl};
use items::parse_item;
use lexing::{lex_error, nesting_error};
pub use name::Name;
pub use output::OutputDecl;

/// Deepest nesting of parentheses, calls and groups accepted in one
/// expression. Deeper input is rejected with an error instead of risking the
/// stack.
pub const MAX_NESTING: usize = 128;

/// A mechanism as written: the root of the syntax tree.
#[derive(Clone, Debug)]
pub struct Mechanism {
    /// Doc comments before `mechanism`.
    pub docs: Vec<String>,
    /// The mechanism's name.
    pub name: Name,
    /// Declarations in source order.
    pub items: Vec<Item>,
    /// Errors recovered from while parsing items (parsing goes on after a bad
    /// item, so that independent mistakes are reported together).
    pub errors: Diagnostics,
}

/// One declaration inside `mechanism Name { … }`.
#[derive(Clone, Debug)]
pub enum Item {
    /// `param name = expr;`
    Param(ParamDecl),
    /// `body name { guess: (x, y, phi) }`
    Body(BodyDecl),
    /// `point body.name = (sx, sy);`
    Point(PointDecl),
    /// `joint|constraint|driver name: …;`
    Equation(EquationDecl),
    /// `output name: expr;` (a measure, see [`crate::outputs`])
    Output(OutputDecl),
    /// `gravity = (gx, gy);`
    Gravity(GravityDecl),
    /// `force name: element(…);`
    Force(ForceDecl),
    /// `coord name { guess: expr }`: a generalized coordinate of its own.
    Coord(CoordDecl),
    /// `curve body.name(u) = expr;`: a body-fixed parametric curve.
    Curve(CurveDecl),
}

/// `param name = expr;`
#[derive(Clone, Debug)]
pub struct ParamDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The `param` keyword's span.
    pub keyword: Span,
    /// The parameter's name.
    pub name: Name,
    /// Its default value (a constant expression), if written.
    pub value: Option<Expr>,
}

/// `body name { guess: (x, y, phi) }` or `body name;`
#[derive(Clone, Debug)]
pub struct BodyDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The body's name.
    pub name: Name,
    /// The initial guess `(x, y, phi)`, if written.
    pub guess: Option<[Expr; 3]>,
    /// Its mass (`mass: m`), if written: dynamics.
    pub mass: Option<Expr>,
    /// Its polar moment of inertia about its frame's origin (`inertia: J`),
    /// if written: dynamics.
    pub inertia: Option<Expr>,
    /// Its initial velocity (`velocity: (vx, vy, omega)`), if written:
    /// where forward dynamics starts (zero otherwise).
    pub velocity: Option<BodyVelocity>,
}

/// `point body.name = (sx, sy);`
#[derive(Clone, Debug)]
pub struct PointDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The body the point is fixed in.
    pub body: Name,
    /// The point's name.
    pub name: Name,
    /// Its local coordinates (a vector expression).
    pub value: Expr,
}

/// Which keyword introduced an equation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EquationKeyword {
    /// `joint`: a kinematic constraint.
    Joint,
    /// `constraint`: a kinematic constraint.
    Constraint,
    /// `driver`: a driving constraint (a function of time).
    Driver,
}

impl EquationKeyword {
    /// The keyword as written.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            EquationKeyword::Joint => "joint",
            EquationKeyword::Constraint => "constraint",
            EquationKeyword::Driver => "driver",
        }
    }
}

/// `joint|constraint|driver name: lhs == rhs;` or `…: library(args);`
#[derive(Clone, Debug)]
pub struct EquationDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The introducing keyword.
    pub keyword: EquationKeyword,
    /// The keyword's span.
    pub keyword_span: Span,
    /// The equation's name.
    pub name: Name,
    /// Left-hand side, or the library call.
    pub lhs: Expr,
    /// Right-hand side after `==`, if any.
    pub rhs: Option<Expr>,
}

/// A binary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
}

/// One node of a flat expression.
#[derive(Clone, Debug)]
pub enum ExprKind {
    /// A number literal; `suffix` is the Rust type suffix if one was written
    /// (an error, reported by the checker).
    Num {
        /// The value (may be non-finite, e.g. `1e999`: an error).
        value: f64,
        /// The literal's type suffix, empty if none.
        suffix: String,
    },
    /// A name: param, body, `pi`, `t`, `ground`.
    Ident(Name),
    /// `base.field`
    Field(u32, Name),
    /// `name(args…)`
    Call(Name, Vec<u32>),
    /// `(a, b, …)` with at least two elements.
    Tuple(Vec<u32>),
    /// `-a`
    Neg(u32),
    /// `a op b`
    Binary(BinOp, u32, u32),
}

/// A node and the span of its tokens.
#[derive(Clone, Debug)]
pub struct ExprNode {
    /// What the node is.
    pub kind: ExprKind,
    /// Its tokens.
    pub span: Span,
}

/// A flat expression: `nodes[root]` is the root; every node's children have
/// smaller indices than the node.
#[derive(Clone, Debug)]
pub struct Expr {
    /// The nodes, children first.
    pub nodes: Vec<ExprNode>,
    /// Index of the root node.
    pub root: u32,
}

impl Expr {
    /// The node at `i`.
    #[must_use]
    pub fn node(&self, i: u32) -> &ExprNode {
        &self.nodes[i as usize]
    }

    /// Span of the whole expression.
    #[must_use]
    pub fn span(&self) -> Span {
        self.node(self.root).span
    }

    /// Indices of the subtree rooted at `root`, in increasing order (children
    /// first). Iterative.
    #[must_use]
    pub fn subtree(&self, root: u32) -> Vec<u32> {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack = vec![root];
        let mut out = Vec::new();
        while let Some(i) = stack.pop() {
            if std::mem::replace(&mut seen[i as usize], true) {
                continue;
            }
            out.push(i);
            match &self.node(i).kind {
                ExprKind::Num { .. } | ExprKind::Ident(_) => {}
                ExprKind::Field(a, _) | ExprKind::Neg(a) => stack.push(*a),
                ExprKind::Call(_, args) | ExprKind::Tuple(args) => stack.extend(args),
                ExprKind::Binary(_, a, b) => {
                    stack.push(*a);
                    stack.push(*b);
                }
            }
        }
        out.sort_unstable();
        out
    }
}

/// Builds a flat expression while parsing.
struct ExprBuilder {
    nodes: Vec<ExprNode>,
}

impl ExprBuilder {
    fn push(&mut self, kind: ExprKind, span: Span) -> u32 {
        // Cannot overflow u32 in practice: a token stream that large does
        // not fit in memory; if it did, the panic names it (never an alias).
        let id = crate::idx(self.nodes.len());
        self.nodes.push(ExprNode { kind, span });
        id
    }
    fn span(&self, i: u32) -> Span {
        self.nodes[i as usize].span
    }
}

impl Parse for Expr {
    fn parse(input: ParseStream<'_>) -> syn::Result<Self> {
        let mut b = ExprBuilder { nodes: Vec::new() };
        let root = parse_sum(input, &mut b, 0)?;
        Ok(Expr {
            nodes: b.nodes,
            root,
        })
    }
}

fn parse_sum(input: ParseStream<'_>, b: &mut ExprBuilder, depth: usize) -> syn::Result<u32> {
    let mut lhs = parse_product(input, b, depth)?;
    loop {
        let op = if input.peek(Token![+]) {
            input.parse::<Token![+]>()?;
            BinOp::Add
        } else if input.peek(Token![-]) && !input.peek(Token![->]) && !input.peek(Token![-=]) {
            input.parse::<Token![-]>()?;
            BinOp::Sub
        } else {
            return Ok(lhs);
        };
        let rhs = parse_product(input, b, depth)?;
        let span = b.span(lhs).to(b.span(rhs));
        lhs = b.push(ExprKind::Binary(op, lhs, rhs), span);
    }
}

fn parse_product(input: ParseStream<'_>, b: &mut ExprBuilder, depth: usize) -> syn::Result<u32> {
    let mut lhs = parse_unary(input, b, depth)?;
    loop {
        let op = if input.peek(Token![*]) && !input.peek(Token![*=]) {
            input.parse::<Token![*]>()?;
            BinOp::Mul
        } else if input.peek(Token![/]) && !input.peek(Token![/=]) {
            input.parse::<Token![/]>()?;
            BinOp::Div
        } else {
            return Ok(lhs);
        };
        let rhs = parse_unary(input, b, depth)?;
        let span = b.span(lhs).to(b.span(rhs));
        lhs = b.push(ExprKind::Binary(op, lhs, rhs), span);
    }
}

fn parse_unary(input: ParseStream<'_>, b: &mut ExprBuilder, depth: usize) -> syn::Result<u32> {
    // A run of unary minus signs is read in a loop, not by recursion.
    let mut minus = Vec::new();
    while input.peek(Token![-]) {
        minus.push(input.parse::<Token![-]>()?.span);
    }
    let mut e = parse_postfix(input, b, depth)?;
    while let Some(m) = minus.pop() {
        let span = Span::new(m).to(b.span(e));
        e = b.push(ExprKind::Neg(e), span);
    }
    Ok(e)
}

fn parse_postfix(input: ParseStream<'_>, b: &mut ExprBuilder, depth: usize) -> syn::Result<u32> {
    let mut e = parse_primary(input, b, depth)?;
    while input.peek(Token![.]) && !input.peek(Token![..]) {
        input.parse::<Token![.]>()?;
        let field = name(
            input,
            "a field name after `.` (`x`, `y`, `phi` or a point name)",
        )?;
        let span = b.span(e).to(field.span());
        if let ExprKind::Num { value, suffix } = &b.nodes[e as usize].kind
            && suffix.is_empty()
        {
            return Err(exponent_error(input, *value, &field, span));
        }
        e = b.push(ExprKind::Field(e, field), span);
    }
    Ok(e)
}

/// The error for a field after a number: `1.e5` lexes as the field `e5` of
/// the integer `1` (as in Rust), which the user meant as a number.
fn exponent_error(input: ParseStream<'_>, value: f64, field: &Name, span: Span) -> syn::Error {
    let name = field.to_string();
    let digits = name
        .strip_prefix(['e', 'E'])
        .filter(|d| d.chars().all(|c| c.is_ascii_digit() || c == '_'));
    let Some(digits) = digits else {
        // error: a number has no fields: expected a body or a vector before `.x`
        return syn::Error::new_spanned(
            span.tokens(),
            format!("a number has no fields: expected a body or a vector before `.{name}`"),
        );
    };
    let mut span = span;
    let mut exponent = digits.to_string();
    let mut tail = String::new();
    if digits.is_empty() {
        // `1.e-5`: the sign and the exponent are separate tokens.
        let sign = if input.peek(Token![-]) {
            Some('-')
        } else if input.peek(Token![+]) {
            Some('+')
        } else {
            None
        };
        if let Some(sign) = sign
            && input.peek2(syn::LitInt)
        {
            let fork = input.fork();
            if let (Ok(_), Ok(lit)) = (
                fork.parse::<proc_macro2::Punct>(),
                fork.parse::<syn::LitInt>(),
            ) {
                exponent = format!("{sign}{}", lit.base10_digits());
                tail.clone_from(&exponent);
                span = span.to(Span::new(lit.span()));
            }
        }
    }
    let exponent = if exponent.is_empty() {
        "…".to_string()
    } else {
        exponent
    };
    let written = if value.fract() == 0.0 && value.abs() < 1e15 {
        format!("{value:.0}")
    } else {
        format!("{value}")
    };
    // error: `1.e5` is not a number: write `1e5` or `1.0e5`
    syn::Error::new_spanned(
        span.tokens(),
        format!(
            "`{written}.{name}{tail}` is not a number (it reads as the field `{name}` of `{written}`): write `{written}e{exponent}` or `{written}.0e{exponent}`"
        ),
    )
}

/// The next token as a message shows it (`` `body` ``, "the end of the
/// item"), or `None` at the end of the input or group (where syn itself
/// says "unexpected end of input").
fn found(input: ParseStream<'_>) -> Option<String> {
    use proc_macro2::{Delimiter, TokenTree};
    let (tt, _) = input.cursor().token_tree()?;
    Some(match tt {
        TokenTree::Punct(p) if p.as_char() == '$' => "the end of the item".to_string(),
        TokenTree::Group(g) => match g.delimiter() {
            Delimiter::Parenthesis => "`(`".to_string(),
            Delimiter::Bracket => "`[`".to_string(),
            Delimiter::Brace => "`{`".to_string(),
            Delimiter::None => "a group".to_string(),
        },
        tt => {
            let text = tt.to_string();
            match text.char_indices().nth(40) {
                Some((cut, _)) => format!("`{}…`", &text[..cut]),
                None => format!("`{text}`"),
            }
        }
    })
}

/// "expected `what`, found `…`" at the next token, with a hint for the
/// usual confusions (a Rust keyword as a name, `^` or `**` for a power).
pub(crate) fn expected(input: ParseStream<'_>, what: &str) -> syn::Error {
    use proc_macro2::TokenTree;
    let hint = match input.cursor().token_tree() {
        Some((TokenTree::Ident(i), _)) if i == "_" => " (`_` cannot be a name)",
        Some((TokenTree::Punct(p), _)) if p.as_char() == '^' => {
            " (a power is `powi(x, 2)` or `pow(x, y)`)"
        }
        Some((TokenTree::Punct(p), _))
            if p.as_char() == '*' && what.starts_with("an expression") =>
        {
            " (a power is `powi(x, 2)` or `pow(x, y)`)"
        }
        _ => "",
    };
    match found(input) {
        Some(f) => input.error(format!("expected {what}, found {f}{hint}")),
        None => input.error(format!("expected {what}")),
    }
}

/// True when the next token is a name (see [`name`]).
fn is_name(input: ParseStream<'_>) -> bool {
    input.peek(Ident::peek_any) && !input.peek(Token![_])
}

/// A name: any identifier, Rust keywords included (`body box`, `param
/// type`, `point B.ref`); `r#type` is the name `type`. Generated code spells
/// a name that is a Rust keyword as a raw identifier. `_` is not a name.
pub(crate) fn name(input: ParseStream<'_>, what: &str) -> syn::Result<Name> {
    if is_name(input) {
        return Ok(Name::from(Ident::parse_any(input)?));
    }
    Err(expected(input, what))
}

/// Parses a `T` (a token or a name), or says what was expected and found.
pub(crate) fn expect<T: Parse>(input: ParseStream<'_>, what: &str) -> syn::Result<T> {
    if let Ok(t) = input.fork().parse::<T>() {
        input.parse::<T>()?;
        return Ok(t);
    }
    Err(expected(input, what))
}

fn parse_primary(input: ParseStream<'_>, b: &mut ExprBuilder, depth: usize) -> syn::Result<u32> {
    if depth >= MAX_NESTING {
        // error: expression nested too deeply (more than 128 levels of parentheses or calls)
        return Err(input.error(format!(
            "expression nested too deeply (more than {MAX_NESTING} levels of parentheses or calls)"
        )));
    }
    let lookahead = input.lookahead1();
    if lookahead.peek(syn::LitFloat) {
        let lit: syn::LitFloat = input.parse()?;
        let value = lit.base10_digits().parse::<f64>().unwrap_or(f64::NAN);
        Ok(b.push(
            ExprKind::Num {
                value,
                suffix: lit.suffix().to_string(),
            },
            Span::new(lit.span()),
        ))
    } else if lookahead.peek(syn::LitInt) {
        let lit: syn::LitInt = input.parse()?;
        let value = lit.base10_digits().parse::<f64>().unwrap_or(f64::NAN);
        Ok(b.push(
            ExprKind::Num {
                value,
                suffix: lit.suffix().to_string(),
            },
            Span::new(lit.span()),
        ))
    } else if lookahead.peek(Ident) || is_name(input) {
        let name = name(input, "a name")?;
        if input.peek(syn::token::Paren) {
            let content;
            let paren = parenthesized!(content in input);
            let args = parse_args(&content, b, depth + 1)?;
            let span = name.span().to(Span::new(paren.span.close()));
            Ok(b.push(ExprKind::Call(name, args), span))
        } else {
            let span = name.span();
            Ok(b.push(ExprKind::Ident(name), span))
        }
    } else if lookahead.peek(syn::token::Paren) {
        let content;
        let paren = parenthesized!(content in input);
        let span = Span::range(paren.span.open(), paren.span.close());
        let args = parse_args(&content, b, depth + 1)?;
        match args.as_slice() {
            // error: expected an expression, found `()`
            [] => Err(syn::Error::new(
                paren.span.join(),
                "expected an expression, found `()`",
            )),
            [single] => Ok(*single),
            _ => Ok(b.push(ExprKind::Tuple(args), span)),
        }
    } else {
        // error: expected an expression (a number, a name or `(`), found `;`
        Err(expected(input, "an expression (a number, a name or `(`)"))
    }
}

/// Comma-separated expressions (trailing comma allowed) filling `content`.
fn parse_args(
    content: ParseStream<'_>,
    b: &mut ExprBuilder,
    depth: usize,
) -> syn::Result<Vec<u32>> {
    let mut args = Vec::new();
    while !content.is_empty() {
        args.push(parse_sum(content, b, depth)?);
        if content.is_empty() {
            break;
        }
        expect::<Token![,]>(content, "`,` or the closing `)`")?;
    }
    Ok(args)
}

/// Parses `#![doc = "…"]` attributes (what `//!` comments become).
fn parse_inner_docs(input: ParseStream<'_>) -> syn::Result<Vec<String>> {
    let mut docs = Vec::new();
    while input.peek(Token![#]) && input.peek2(Token![!]) {
        input.parse::<Token![#]>()?;
        input.parse::<Token![!]>()?;
        let content;
        bracketed!(content in input);
        docs.push(doc_value(&content)?);
    }
    Ok(docs)
}

/// `doc = "…"` inside an attribute's brackets.
fn doc_value(content: ParseStream<'_>) -> syn::Result<String> {
    if !content.peek(kw::doc) {
        // error: expected a doc comment: only `///` doc comments are allowed as attributes
        return Err(syn::Error::new(
            content.span(),
            "expected a doc comment: only `///` and `//!` doc comments are allowed as attributes",
        ));
    }
    content.parse::<kw::doc>()?;
    content.parse::<Token![=]>()?;
    let text: syn::LitStr = content.parse()?;
    let value = text.value();
    Ok(value.strip_prefix(' ').unwrap_or(&value).to_string())
}

/// Parses `#[doc = "…"]` attributes (what `///` comments become).
fn parse_docs(input: ParseStream<'_>) -> syn::Result<Vec<String>> {
    let mut docs = Vec::new();
    while input.peek(Token![#]) && !input.peek2(Token![!]) {
        input.parse::<Token![#]>()?;
        let content;
        bracketed!(content in input);
        docs.push(doc_value(&content)?);
    }
    Ok(docs)
}

impl Parse for Mechanism {
    fn parse(input: ParseStream<'_>) -> syn::Result<Self> {
        // `//!` comments at the top of a file, then `///` comments.
        let mut docs = parse_inner_docs(input)?;
        docs.extend(parse_docs(input)?);
        // error: expected `mechanism Name { … }`, found `param`
        expect::<kw::mechanism>(input, "`mechanism Name { … }`")?;
        let name = name(input, "the mechanism's name after `mechanism`")?;
        if !input.peek(syn::token::Brace) {
            return Err(expected(input, "`{` after the mechanism's name"));
        }
        let content;
        braced!(content in input);
        // `//!` comments at the start of the mechanism's body.
        docs.extend(parse_inner_docs(&content)?);
        let body: TokenStream = content.parse()?;
        let close = body
            .clone()
            .into_iter()
            .last()
            .map_or_else(|| content.span(), |t| t.span());
        let mut items = Vec::new();
        let mut errors = Diagnostics::new();
        // Each item is parsed on its own, so that an error in one item
        // neither stops nor disturbs the others: independent mistakes are
        // all reported.
        for mut chunk in split_items(body) {
            let tokens: Vec<proc_macro2::TokenTree> = chunk.clone().into_iter().collect();
            let last = tokens.last().map_or(close, proc_macro2::TokenTree::span);
            // A `$` sentinel carrying the span of the item's last token ends
            // every item: "expected `;`" then points at the item instead of
            // at nowhere (the end of a token stream has no location).
            let mut end = proc_macro2::Punct::new('$', proc_macro2::Spacing::Alone);
            end.set_span(last);
            chunk.extend([proc_macro2::TokenTree::Punct(end)]);
            match syn::parse::Parser::parse2(parse_item, chunk) {
                Ok(item) => items.push(item),
                Err(e) => {
                    for d in Diagnostics::from(e) {
                        errors.push(missing_semicolon(d, &tokens));
                    }
                }
            }
        }
        if !input.is_empty() {
            // error: unexpected tokens after the mechanism
            return Err(expected(
                input,
                "the end of the text after the mechanism's `}`",
            ));
        }
        Ok(Mechanism {
            docs,
            name,
            items,
            errors,
        })
    }
}

/// A missing `;` is found at the first token of the next line; the error
/// is more useful at the end of the line where the `;` belongs (as rustc
/// does): when the token before the one found ends on an earlier line, the
/// error moves there.
fn missing_semicolon(mut d: Diagnostic, tokens: &[proc_macro2::TokenTree]) -> Diagnostic {
    if !d.message.starts_with("expected") || !d.message.contains("`;`") {
        return d;
    }
    let at = d.span.start();
    let key = |p: proc_macro2::LineColumn| (p.line, p.column);
    // The last token before the error; of a group, its closing bracket.
    let before = tokens
        .iter()
        .take_while(|t| key(t.span().end()) <= key(at))
        .last()
        .map(|t| match t {
            proc_macro2::TokenTree::Group(g) => g.span_close(),
            t => t.span(),
        });
    if let Some(before) = before
        && before.end().line < at.line
    {
        d.span = Span::new(before);
        d.label = Some("expected `;` after this".to_string());
    }
    d
}

/// Splits the tokens of the mechanism's body into items: an item ends after
/// a `;` or after a `{…}` group (a body's block).
fn split_items(body: TokenStream) -> Vec<TokenStream> {
    let mut items = Vec::new();
    let mut current: Vec<proc_macro2::TokenTree> = Vec::new();
    for tt in body {
        let end = match &tt {
            proc_macro2::TokenTree::Punct(p) => p.as_char() == ';',
            proc_macro2::TokenTree::Group(g) => g.delimiter() == proc_macro2::Delimiter::Brace,
            _ => false,
        };
        current.push(tt);
        if end {
            items.push(std::mem::take(&mut current).into_iter().collect());
        }
    }
    if !current.is_empty() {
        items.push(current.into_iter().collect());
    }
    items
}

/// Tokenizes `source` (text of a `.kin` file) and parses it. Lexer and parser
/// errors come back as diagnostics.
pub fn parse_str(source: &str) -> Result<Mechanism, Diagnostics> {
    if let Some(d) = nesting_error(source) {
        return Err(d);
    }
    let tokens: TokenStream = source
        .parse()
        .map_err(|e: proc_macro2::LexError| lex_error(source, e.span().start()))?;
    parse_tokens(tokens)
}

/// Parses a token stream (the input of `mechanism! { … }`).
pub fn parse_tokens(tokens: TokenStream) -> Result<Mechanism, Diagnostics> {
    syn::parse2::<Mechanism>(tokens).map_err(Diagnostics::from)
}
