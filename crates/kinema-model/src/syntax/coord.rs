//! The syntax of the `coord` and `curve` items (a coordinate of its own, a
//! body-fixed curve), on which the follower constraints are built. What
//! they mean is in [`crate::follower`]; their checks are in
//! `check/coord.rs`.

use syn::parse::ParseStream;
use syn::{Token, braced, parenthesized};

use super::{Expr, Item, Name, expect, expected, kw, name};

/// `coord name { guess: expr }` or `coord name;`
#[derive(Clone, Debug)]
pub struct CoordDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The coordinate's name.
    pub name: Name,
    /// The initial guess (a constant expression of params), if written.
    pub guess: Option<Expr>,
}

/// `curve body.name(u) = expr;`
#[derive(Clone, Debug)]
pub struct CurveDecl {
    /// Doc comments.
    pub docs: Vec<String>,
    /// The body the curve is fixed in.
    pub body: Name,
    /// The curve's name.
    pub name: Name,
    /// The curve's parameter, a name bound in `value` only.
    pub param: Name,
    /// Its local coordinates: a vector expression of params and `param`.
    pub value: Expr,
}

/// Parses a `coord` or `curve` item (the next token is one of the keywords).
pub(crate) fn parse_item(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<Item> {
    if input.peek(kw::coord) {
        input.parse::<kw::coord>()?;
        let name = name(input, "the coordinate's name after `coord`")?;
        let lookahead = input.lookahead1();
        let guess = if lookahead.peek(Token![;]) {
            input.parse::<Token![;]>()?;
            None
        } else if lookahead.peek(syn::token::Brace) {
            let content;
            braced!(content in input);
            let mut guess = None;
            if !content.is_empty() {
                expect::<kw::guess>(&content, "`guess` or `}`")?;
                expect::<Token![:]>(&content, "`:` after `guess`")?;
                guess = Some(content.parse::<Expr>()?);
                if content.peek(Token![,]) {
                    content.parse::<Token![,]>()?;
                }
                if !content.is_empty() {
                    // error: expected `}`: a coordinate has only a `guess`, found `x`
                    return Err(expected(&content, "`}`: a coordinate has only a `guess`"));
                }
            }
            guess
        } else {
            // error: expected `;` or `{ guess: value }` after the coordinate's name, found `=`
            return Err(expected(
                input,
                "`;` or `{ guess: value }` after the coordinate's name",
            ));
        };
        return Ok(Item::Coord(CoordDecl { docs, name, guess }));
    }
    input.parse::<kw::curve>()?;
    // curve body.name(u) = (x(u), y(u));
    let body = name(input, "a body's name after `curve`")?;
    expect::<Token![.]>(input, "`.`: a curve is `curve body.name(u) = (x, y);`")?;
    let cname = name(input, "the curve's name after `.`")?;
    if !input.peek(syn::token::Paren) {
        // error: expected `(u)`: the curve's parameter, found `=`
        return Err(expected(
            input,
            "`(u)`: the curve's parameter (a curve is `curve body.name(u) = (x, y);`)",
        ));
    }
    let content;
    parenthesized!(content in input);
    let param = name(&content, "the name of the curve's parameter")?;
    if !content.is_empty() {
        // error: expected `)`: a curve has one parameter, found `,`
        return Err(expected(&content, "`)`: a curve has one parameter"));
    }
    expect::<Token![=]>(input, "`=`: a curve is `curve body.name(u) = (x, y);`")?;
    let value: Expr = input.parse()?;
    expect::<Token![;]>(input, "`;` at the end of the curve")?;
    Ok(Item::Curve(CurveDecl {
        docs,
        body,
        name: cname,
        param,
        value,
    }))
}
