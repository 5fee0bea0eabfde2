//! The macro's and the code generator's compile-time contracts, in one
//! trybuild project (one build of the dependencies, not one per test
//! crate):
//! - one compile-fail case per `mechanism!` error, each pinned with the
//!   `.stderr` rustc prints: the span must underline the offending token
//!   (refresh deliberately with `TRYBUILD=overwrite cargo test --test ui`);
//! - the Rust source of a runtime-loaded model (`Model::rust_source`, what
//!   `kinema codegen` prints — crates/kinema-cli/tests/keyword_names.rs
//!   checks it prints exactly that) compiles and runs, Rust keywords as
//!   names included.

use std::path::Path;

/// The slider-crank with bodies, params and a driver named after Rust
/// keywords (`box`, `ref`, `fn`, `loop`, …), shared with the CLI's tests.
const KEYWORD_MODEL: &str = "crates/kinema-cli/tests/cli/models/keyword_names.kin";

/// A `main` for the generated code: runs it against the slider's closed form.
const MAIN: &str = r#"
fn main() {
    use kinema::System;
    let mechanism = Keywords::default();
    let omega = mechanism.r#fn;
    let mut solver = match mechanism.solver(kinema::Options::default()) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    };
    let times: Vec<f64> = (0..=8).map(|k| f64::from(k) / 16.0).collect();
    let trajectory = match solver.run(&times) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    assert_eq!(solver.system().len(), 9);
    for state in trajectory.iter() {
        let phi = std::f64::consts::FRAC_PI_4 + omega * state.t();
        let expected = 0.3 * phi.cos() + (1.0 - (0.3 * phi.sin()).powi(2)).sqrt();
        assert!((state.q()[6] - expected).abs() < 1e-9);
    }
}
"#;

#[test]
fn macro_errors_and_generated_code() {
    let model = match kinema::Model::from_file(KEYWORD_MODEL) {
        Ok(m) => m,
        Err(e) => panic!("{KEYWORD_MODEL}: {e}"),
    };
    let code = model.rust_source();
    for raw in ["pub r#ref: f64", "pub r#move: f64", "pub r#fn: f64"] {
        assert!(code.contains(raw), "{raw} in\n{code}");
    }
    // trybuild keeps the path: a fixed place under target/, not a temp dir.
    let file = Path::new(env!("CARGO_TARGET_TMPDIR")).join("keyword_names_codegen.rs");
    if let Err(e) = std::fs::write(&file, format!("{code}\n{MAIN}")) {
        panic!("cannot write {}: {e}", file.display());
    }
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
    t.pass(&file);
}
