//! Source spans that work for both front doors: a `.kin` file parsed from text
//! (line and column come from proc-macro2's `span-locations`) and the tokens of
//! a `mechanism! { … }` invocation (spans are compiler spans).

use proc_macro2::{Punct, Spacing, TokenStream, TokenTree};

/// A range of source tokens: the first token's span and the last token's span.
///
/// Storing both ends (instead of joining them) works on stable compilers in a
/// proc-macro, exactly like `syn::Error::new_spanned` does.
#[derive(Clone, Copy, Debug)]
pub struct Span {
    lo: proc_macro2::Span,
    hi: proc_macro2::Span,
}

impl Span {
    /// A span covering a single token.
    #[must_use]
    pub fn new(span: proc_macro2::Span) -> Self {
        Span { lo: span, hi: span }
    }

    /// A span from the first token `lo` to the last token `hi` (inclusive).
    #[must_use]
    pub fn range(lo: proc_macro2::Span, hi: proc_macro2::Span) -> Self {
        Span { lo, hi }
    }

    /// The span from the start of `self` to the end of `other`.
    #[must_use]
    pub fn to(self, other: Span) -> Self {
        Span {
            lo: self.lo,
            hi: other.hi,
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
    pub fn start(self) -> proc_macro2::LineColumn {
        self.lo.start()
    }

    /// End (exclusive) of the span in the text it was parsed from.
    #[must_use]
    pub fn end(self) -> proc_macro2::LineColumn {
        self.hi.end()
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
