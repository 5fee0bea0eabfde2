//! The dynamics part of the syntax: a body's inertia fields, `gravity` and
//! `force` items.
//!
//! ```text
//! Body     := "body" Ident "{" ( BodyField ","? )* "}"
//! BodyField:= "guess" ":" "(" Expr "," Expr "," Expr ")" | "mass" ":" Expr | "inertia" ":" Expr
//! Gravity  := "gravity" "=" Expr ";"
//! Force    := "force" Ident ":" Expr ";"          a force element call
//! ```

use syn::parse::ParseStream;
use syn::{Token, parenthesized};

use super::{Expr, expect, expected, kw, name};
use crate::span::Span;

/// `gravity = (gx, gy);`: the acceleration of gravity, applied as m g to
/// every body.
#[derive(Clone, Debug)]
pub struct GravityDecl {
    /// The `gravity` keyword's span.
    pub keyword: Span,
    /// The vector (a constant expression of params).
    pub value: Expr,
}

/// `force name: element(args…);`: an applied force element.
#[derive(Clone, Debug)]
pub struct ForceDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The `force` keyword's span.
    pub keyword: Span,
    /// The force's name.
    pub name: crate::syntax::Name,
    /// The element call (`point_force(P, F)`, `torque(B, T)`, `rsda(…)`, `tsda(…)`).
    pub call: Expr,
}

/// What a body's block holds.
#[derive(Default)]
pub(super) struct BodyFields {
    pub(super) guess: Option<[Expr; 3]>,
    pub(super) mass: Option<Expr>,
    pub(super) inertia: Option<Expr>,
}

/// The inside of a body's `{ … }`: `guess`, `mass` and `inertia` fields in
/// any order, each at most once, separated by commas.
pub(super) fn parse_body_fields(content: ParseStream<'_>) -> syn::Result<BodyFields> {
    let mut fields = BodyFields::default();
    while !content.is_empty() {
        let lookahead = content.lookahead1();
        if lookahead.peek(kw::guess) {
            let k = content.parse::<kw::guess>()?;
            if fields.guess.is_some() {
                return Err(syn::Error::new(k.span, "a body has one `guess`"));
            }
            expect::<Token![:]>(content, "`:` after `guess`")?;
            if !content.peek(syn::token::Paren) {
                return Err(expected(content, "`(x, y, phi)` after `guess:`"));
            }
            let inner;
            parenthesized!(inner in content);
            let x: Expr = inner.parse()?;
            expect::<Token![,]>(&inner, "`,`: a guess is `(x, y, phi)`")?;
            let y: Expr = inner.parse()?;
            expect::<Token![,]>(&inner, "`,`: a guess is `(x, y, phi)`")?;
            let phi: Expr = inner.parse()?;
            if inner.peek(Token![,]) {
                inner.parse::<Token![,]>()?;
            }
            if !inner.is_empty() {
                // error: expected `)`: a guess is `(x, y, phi)`, found `,`
                return Err(expected(&inner, "`)`: a guess is `(x, y, phi)`"));
            }
            fields.guess = Some([x, y, phi]);
        } else if lookahead.peek(kw::mass) {
            let k = content.parse::<kw::mass>()?;
            if fields.mass.is_some() {
                return Err(syn::Error::new(k.span, "a body has one `mass`"));
            }
            expect::<Token![:]>(content, "`:` after `mass`")?;
            fields.mass = Some(content.parse()?);
        } else if lookahead.peek(kw::inertia) {
            let k = content.parse::<kw::inertia>()?;
            if fields.inertia.is_some() {
                return Err(syn::Error::new(k.span, "a body has one `inertia`"));
            }
            expect::<Token![:]>(content, "`:` after `inertia`")?;
            fields.inertia = Some(content.parse()?);
        } else {
            return Err(expected(
                content,
                "`guess`, `mass`, `inertia` or `}` in a body's block",
            ));
        }
        if content.peek(Token![,]) {
            content.parse::<Token![,]>()?;
        } else if !content.is_empty() {
            return Err(expected(content, "`,` or `}` after a body's field"));
        }
    }
    Ok(fields)
}

/// `gravity = (gx, gy);` after its keyword was seen.
pub(super) fn parse_gravity(input: ParseStream<'_>) -> syn::Result<GravityDecl> {
    let keyword = Span::new(input.parse::<kw::gravity>()?.span);
    expect::<Token![=]>(input, "`=`: gravity is `gravity = (gx, gy);`")?;
    let value: Expr = input.parse()?;
    expect::<Token![;]>(input, "`;` at the end of `gravity`")?;
    Ok(GravityDecl { keyword, value })
}

/// `force name: element(args…);` after its docs.
pub(super) fn parse_force(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<ForceDecl> {
    let keyword = Span::new(input.parse::<kw::force>()?.span);
    let name = name(input, "the force's name after `force`")?;
    expect::<Token![:]>(input, "`:` after the force's name")?;
    let call: Expr = input.parse()?;
    expect::<Token![;]>(input, "an operator or `;` at the end of the force")?;
    Ok(ForceDecl {
        docs,
        keyword,
        name,
        call,
    })
}
