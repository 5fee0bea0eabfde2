//! Source spans that work for both front doors: a `.kin` file parsed from text
//! (line and column come from proc-macro2's `span-locations`) and the tokens of
//! a `mechanism! { … }` invocation (spans are compiler spans).

use proc_macro2::{LineColumn, Punct, Spacing, TokenStream, TokenTree};

/// A range of source tokens: the first token's span and the last token's span.
///
/// Storing both ends (instead of joining them) works on stable compilers in a
/// proc-macro, exactly like `syn::Error::new_spanned` does.
///
/// Text that never became tokens (a character the lexer rejects, invalid
/// UTF-8, a bracket nested too deeply) has no proc-macro2 span; such a span
/// carries its line and column explicitly ([`Span::at`]).
#[derive(Clone, Copy, Debug)]
pub struct Span {
    lo: proc_macro2::Span,
    hi: proc_macro2::Span,
    /// Explicit start and end, when the span does not come from tokens.
    at: Option<(LineColumn, LineColumn)>,
}

impl Span {
    /// A span covering a single token.
    #[must_use]
    pub fn new(span: proc_macro2::Span) -> Self {
        Span {
            lo: span,
            hi: span,
            at: None,
        }
    }

    /// A span from the first token `lo` to the last token `hi` (inclusive).
    #[must_use]
    pub fn range(lo: proc_macro2::Span, hi: proc_macro2::Span) -> Self {
        Span { lo, hi, at: None }
    }

    /// A span at an explicit place in the text (line 1-based, column 0-based
    /// in characters; `end` exclusive), for text that has no tokens. Its
    /// proc-macro2 spans are the call site.
    #[must_use]
    pub fn at(start: LineColumn, end: LineColumn) -> Self {
        let call_site = proc_macro2::Span::call_site();
        Span {
            lo: call_site,
            hi: call_site,
            at: Some((start, end)),
        }
    }

    /// The span from the start of `self` to the end of `other`.
    #[must_use]
    pub fn to(self, other: Span) -> Self {
        let at = match (self.at, other.at) {
            (None, None) => None,
            _ => Some((self.start(), other.end())),
        };
        Span {
            lo: self.lo,
            hi: other.hi,
            at,
        }
    }

    /// The span of the first token.
    #[must_use]
    pub fn lo(self) -> proc_macro2::Span {
        self.lo
    }

    /// The span of the last token.
    #[must_use]
    pub fn hi(self) -> proc_macro2::Span {
        self.hi
    }

    /// Start (line 1-based, column 0-based in characters) of the span in the
    /// text it was parsed from.
    #[must_use]
    pub fn start(self) -> LineColumn {
        match self.at {
            Some((start, _)) => start,
            None => self.lo.start(),
        }
    }

    /// End (exclusive) of the span in the text it was parsed from.
    #[must_use]
    pub fn end(self) -> LineColumn {
        match self.at {
            Some((_, end)) => end,
            None => self.hi.end(),
        }
    }

    /// Two tokens carrying the two ends of the span, for
    /// `syn::Error::new_spanned`.
    pub(crate) fn tokens(self) -> TokenStream {
        let mut a = Punct::new('*', Spacing::Alone);
        a.set_span(self.lo);
        let mut b = Punct::new('*', Spacing::Alone);
        b.set_span(self.hi);
        [TokenTree::Punct(a), TokenTree::Punct(b)]
            .into_iter()
            .collect()
    }
}

impl From<proc_macro2::Span> for Span {
    fn from(span: proc_macro2::Span) -> Self {
        Span::new(span)
    }
}
