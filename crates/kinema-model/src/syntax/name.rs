//! Names in the syntax tree: text and span, from a parsed identifier or
//! placed by another front end.

use syn::Ident;
use syn::ext::IdentExt;

use crate::span::Span;

/// A name as written (a param, body, point, equation, function, field…):
/// its text, a raw identifier's `r#` removed, and where it is.
///
/// Parsed names carry their token's span; a tree built by another front
/// end (the simEngine2D importer) gives each name the place in its own
/// file that the name comes from ([`Span::at`]), so that every message
/// points there.
#[derive(Clone, Debug)]
pub struct Name {
    text: String,
    span: Span,
}

impl Name {
    /// The name `text` at `span`.
    #[must_use]
    pub fn new(text: impl Into<String>, span: Span) -> Name {
        Name {
            text: text.into(),
            span,
        }
    }

    /// The name's text.
    #[must_use]
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Where the name is written.
    #[must_use]
    pub fn span(&self) -> Span {
        self.span
    }
}

impl From<Ident> for Name {
    /// A parsed identifier, `r#` removed.
    fn from(ident: Ident) -> Name {
        let ident = ident.unraw();
        Name::new(ident.to_string(), Span::new(ident.span()))
    }
}

impl std::fmt::Display for Name {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.text)
    }
}

impl PartialEq<str> for Name {
    fn eq(&self, other: &str) -> bool {
        self.text == other
    }
}

impl PartialEq<&str> for Name {
    fn eq(&self, other: &&str) -> bool {
        self.text == *other
    }
}
