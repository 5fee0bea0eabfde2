//! The dynamics part of the syntax: a body's inertia fields, `gravity` and
//! `force` items.
//!
//! ```text
//! Body     := "body" Ident "{" ( BodyField ","? )* "}"
//! BodyField:= "guess" ":" Triple | "mass" ":" Expr | "inertia" ":" Expr | "velocity" ":" Triple
//! Triple   := "(" Expr "," Expr "," Expr ","? ")"
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

/// `velocity: (vx, vy, omega)` in a body's block: the body's initial
/// velocity (ẋ, ẏ, φ̇), where forward dynamics starts.
#[derive(Clone, Debug)]
pub struct BodyVelocity {
    /// The `velocity` keyword's span.
    pub keyword: Span,
    /// (ẋ, ẏ, φ̇), constant expressions of params.
    pub value: [Expr; 3],
}

/// What a body's block holds.
#[derive(Default)]
pub(super) struct BodyFields {
    pub(super) guess: Option<[Expr; 3]>,
    pub(super) mass: Option<Expr>,
    pub(super) inertia: Option<Expr>,
    pub(super) velocity: Option<BodyVelocity>,
}

/// `( a, b, c )` after `field:` (`shape` is how the message writes it,
/// `(x, y, phi)`), a last comma allowed.
fn parse_triple(content: ParseStream<'_>, field: &str, shape: &str) -> syn::Result<[Expr; 3]> {
    expect::<Token![:]>(content, &format!("`:` after `{field}`"))?;
    if !content.peek(syn::token::Paren) {
        return Err(expected(content, &format!("`{shape}` after `{field}:`")));
    }
    let article = if field.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    let inner;
    parenthesized!(inner in content);
    let x: Expr = inner.parse()?;
    expect::<Token![,]>(&inner, &format!("`,`: {article} {field} is `{shape}`"))?;
    let y: Expr = inner.parse()?;
    expect::<Token![,]>(&inner, &format!("`,`: {article} {field} is `{shape}`"))?;
    let z: Expr = inner.parse()?;
    if inner.peek(Token![,]) {
        inner.parse::<Token![,]>()?;
    }
    if !inner.is_empty() {
        // error: expected `)`: a guess is `(x, y, phi)`, found `,`
        return Err(expected(
            &inner,
            &format!("`)`: {article} {field} is `{shape}`"),
        ));
    }
    Ok([x, y, z])
}

/// The inside of a body's `{ … }`: `guess`, `mass`, `inertia` and
/// `velocity` fields in any order, each at most once, separated by commas.
pub(super) fn parse_body_fields(content: ParseStream<'_>) -> syn::Result<BodyFields> {
    let mut fields = BodyFields::default();
    while !content.is_empty() {
        let lookahead = content.lookahead1();
        if lookahead.peek(kw::guess) {
            let k = content.parse::<kw::guess>()?;
            if fields.guess.is_some() {
                return Err(syn::Error::new(k.span, "a body has one `guess`"));
            }
            fields.guess = Some(parse_triple(content, "guess", "(x, y, phi)")?);
        } else if lookahead.peek(kw::velocity) {
            let k = content.parse::<kw::velocity>()?;
            if fields.velocity.is_some() {
                // error: a body has one `velocity`
                return Err(syn::Error::new(k.span, "a body has one `velocity`"));
            }
            let value = parse_triple(content, "velocity", "(vx, vy, omega)")?;
            fields.velocity = Some(BodyVelocity {
                keyword: Span::new(k.span),
                value,
            });
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
                "`guess`, `mass`, `inertia`, `velocity` or `}` in a body's block",
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
