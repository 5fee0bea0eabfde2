//! The items of a mechanism, one parser per keyword.

use syn::Token;
use syn::braced;
use syn::parse::ParseStream;

use super::{
    BodyDecl, EquationDecl, EquationKeyword, Expr, Item, ParamDecl, PointDecl, coord, dynamics,
    expect, expected, kw, name, output, parse_docs,
};
use crate::span::Span;

pub(super) fn parse_item(input: ParseStream<'_>) -> syn::Result<Item> {
    let item = parse_item_inner(input)?;
    if !input.peek(Token![$]) {
        // error: expected the end of the item, found `x`
        return Err(expected(input, "the end of the item"));
    }
    input.parse::<Token![$]>()?;
    Ok(item)
}

/// One item after its doc comments, chosen by its keyword.
fn parse_item_inner(input: ParseStream<'_>) -> syn::Result<Item> {
    let docs = parse_docs(input)?;
    let lookahead = input.lookahead1();
    if lookahead.peek(kw::param) {
        parse_param(input, docs).map(Item::Param)
    } else if lookahead.peek(kw::body) {
        parse_body(input, docs).map(Item::Body)
    } else if lookahead.peek(kw::point) {
        parse_point(input, docs).map(Item::Point)
    } else if lookahead.peek(kw::joint)
        || lookahead.peek(kw::constraint)
        || lookahead.peek(kw::driver)
    {
        parse_equation(input, docs).map(Item::Equation)
    } else if lookahead.peek(kw::output) {
        output::parse_output(input, docs).map(Item::Output)
    } else if lookahead.peek(kw::gravity) {
        dynamics::parse_gravity(input).map(Item::Gravity)
    } else if lookahead.peek(kw::force) {
        dynamics::parse_force(input, docs).map(Item::Force)
    } else if lookahead.peek(kw::coord) || lookahead.peek(kw::curve) {
        coord::parse_item(input, docs)
    } else {
        // error: expected an item (`param`, `body`, `point`, `coord`, `curve`, `joint`, `constraint`, `driver` or `output`), found `bdy`
        Err(expected(
            input,
            "an item (`param`, `body`, `point`, `coord`, `curve`, `joint`, `constraint`, `driver` or `output`)",
        ))
    }
}

/// `param name ( = expr )? ;`
fn parse_param(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<ParamDecl> {
    let keyword = Span::new(input.parse::<kw::param>()?.span);
    let name = name(input, "the param's name after `param`")?;
    let value = if input.peek(Token![=]) {
        input.parse::<Token![=]>()?;
        Some(input.parse::<Expr>()?)
    } else {
        None
    };
    expect::<Token![;]>(input, "`;` at the end of the param")?;
    Ok(ParamDecl {
        docs,
        keyword,
        name,
        value,
    })
}

/// `body name ;` or `body name { fields }` (guess, mass, inertia, velocity).
fn parse_body(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<BodyDecl> {
    input.parse::<kw::body>()?;
    let name = name(input, "the body's name after `body`")?;
    let lookahead = input.lookahead1();
    let fields = if lookahead.peek(Token![;]) {
        input.parse::<Token![;]>()?;
        dynamics::BodyFields::default()
    } else if lookahead.peek(syn::token::Brace) {
        let content;
        braced!(content in input);
        dynamics::parse_body_fields(&content)?
    } else {
        // error: expected `;` or `{ guess: (x, y, phi) }` after the body's name, found `(`
        return Err(expected(
            input,
            "`;` or `{ guess: (x, y, phi) }` after the body's name",
        ));
    };
    Ok(BodyDecl {
        docs,
        name,
        guess: fields.guess,
        mass: fields.mass,
        inertia: fields.inertia,
        velocity: fields.velocity,
    })
}

/// `point body.name = (sx, sy);`
fn parse_point(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<PointDecl> {
    input.parse::<kw::point>()?;
    let body = name(input, "a body's name after `point`")?;
    expect::<Token![.]>(input, "`.`: a point is `point body.name = (sx, sy);`")?;
    let name = name(input, "the point's name after `.`")?;
    expect::<Token![=]>(input, "`=`: a point is `point body.name = (sx, sy);`")?;
    let value: Expr = input.parse()?;
    expect::<Token![;]>(input, "`;` at the end of the point")?;
    Ok(PointDecl {
        docs,
        body,
        name,
        value,
    })
}

/// `joint|constraint|driver name: lhs ( == rhs )? ;`
fn parse_equation(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<EquationDecl> {
    let (keyword, keyword_span) = if input.peek(kw::joint) {
        (EquationKeyword::Joint, input.parse::<kw::joint>()?.span)
    } else if input.peek(kw::constraint) {
        (
            EquationKeyword::Constraint,
            input.parse::<kw::constraint>()?.span,
        )
    } else {
        (EquationKeyword::Driver, input.parse::<kw::driver>()?.span)
    };
    let name = name(input, "the equation's name")?;
    expect::<Token![:]>(input, "`:` after the equation's name")?;
    let lhs: Expr = input.parse()?;
    let rhs = if input.peek(Token![==]) {
        input.parse::<Token![==]>()?;
        Some(input.parse::<Expr>()?)
    } else {
        None
    };
    if !input.peek(Token![;]) {
        // error: expected `==` or `;`
        return Err(expected(
            input,
            if rhs.is_none() {
                "an operator, `==` or `;`"
            } else {
                "an operator or `;`"
            },
        ));
    }
    input.parse::<Token![;]>()?;
    Ok(EquationDecl {
        docs,
        keyword,
        keyword_span: Span::new(keyword_span),
        name,
        lhs,
        rhs,
    })
}
