//! The syntax of a measure, `output NAME: EXPR;`. Its checks are in
//! `check/output.rs`, its derivatives in [`crate::outputs`].

use syn::Token;
use syn::parse::ParseStream;

use super::{Expr, Name, expect, expected, kw, name};
use crate::span::Span;

/// `output NAME: EXPR;`
#[derive(Clone, Debug)]
pub struct OutputDecl {
    /// Doc comments (units, as for params).
    pub docs: Vec<String>,
    /// The `output` keyword's span.
    pub keyword: Span,
    /// The output's name.
    pub name: Name,
    /// The measured expression (scalar or vector).
    pub value: Expr,
}

/// Parses an `output` item after its doc comments.
pub(crate) fn parse_output(input: ParseStream<'_>, docs: Vec<String>) -> syn::Result<OutputDecl> {
    let keyword = Span::new(input.parse::<kw::output>()?.span);
    let name = name(input, "the output's name after `output`")?;
    expect::<Token![:]>(input, "`:`: an output is `output name: expression;`")?;
    let value: Expr = input.parse()?;
    if !input.peek(Token![;]) {
        // error: expected an operator or `;`, found `==`
        return Err(expected(
            input,
            "an operator or `;` at the end of the output",
        ));
    }
    input.parse::<Token![;]>()?;
    Ok(OutputDecl {
        docs,
        keyword,
        name,
        value,
    })
}
