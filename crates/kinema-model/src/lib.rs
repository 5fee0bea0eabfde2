//! kinema-model (draft; docs completed below).

pub mod check;
mod ctxt;
pub mod diagnostic;
pub mod span;
pub mod syntax;

pub use check::{CheckedModel, DofReport};
pub use diagnostic::{Diagnostic, Diagnostics, Severity};
pub use span::Span;
