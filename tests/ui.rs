//! One compile-fail case per `mechanism!` error, each pinned with the
//! `.stderr` rustc prints: the span must underline the offending token.
//! Refresh deliberately with `TRYBUILD=overwrite cargo test --test ui`.

#[test]
fn macro_errors() {
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
}
