//! `kinema run --columns`: which quantities the CSV holds — the library's
//! [`kinema::columns::Selection`], its errors usage errors (exit 2).

pub use kinema::columns::Selection;

use super::Failure;

impl From<kinema::columns::ColumnError> for Failure {
    fn from(e: kinema::columns::ColumnError) -> Failure {
        Failure::usage(e)
    }
}
