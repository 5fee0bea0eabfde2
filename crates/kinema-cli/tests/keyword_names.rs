//! Names in model files may be any identifier, Rust keywords included:
//! `tests/cli/models/keyword_names.kin` is the slider-crank of
//! `models/slider_crank.kin` with bodies `box`, `type` and `gear`, params
//! `ref`, `move`, `fn`, a point `box.ref` and a driver `loop`. It runs
//! through the tape (`kinema run`, the same numbers as the slider-crank),
//! through `mechanism!`, and `kinema codegen` prints the library's Rust
//! source of it (params become raw identifiers such as `r#fn`), which the
//! repository's tests/ui.rs compiles and runs.

use std::path::Path;

mod common;
use common::*;

/// The model, from the repository root where the binary runs.
const MODEL: &str = "crates/kinema-cli/tests/cli/models/keyword_names.kin";

kinema::mechanism!(file = "tests/cli/models/keyword_names.kin");

/// Runs `model` for half a second in 40 steps; the CSV.
fn run(dir: &TempDir, model: &str, out: &str) -> Result<Csv, Box<dyn std::error::Error>> {
    let out = dir.path(out);
    let o = kinema(&[
        "run", model, "--steps", "40", "--t-end", "0.5", "--out", &out,
    ]);
    assert_status(&o, 0);
    Csv::read(&out)
}

#[test]
fn kinema_run_gives_the_slider_crank() -> Result<(), Box<dyn std::error::Error>> {
    let dir = TempDir::new("keywords");
    let names = run(&dir, MODEL, "names.csv")?;
    let reference = run(&dir, "models/slider_crank.kin", "reference.csv")?;
    assert_eq!(
        &names.header[..4],
        ["t", "box.x", "box.y", "box.phi"],
        "columns are named after the bodies"
    );
    assert!(names.header.contains(&"type.phi_dot".to_string()));
    assert!(names.header.contains(&"gear.x_ddot".to_string()));
    assert_eq!(names.rows.len(), reference.rows.len());
    // t and the body columns (the named points and outputs differ: the
    // reference has more); the point `box.ref` is the reference's `crank.o`.
    let body_columns = 1 + 3 * 9;
    let (r, c) = (
        names.column("box.ref.x_ddot")?,
        reference.column("crank.o.x_ddot")?,
    );
    for (a, b) in names.rows.iter().zip(&reference.rows) {
        assert!((a[r] - b[c]).abs() <= 1e-12 * (1.0 + b[c].abs()));
        for (x, y) in a.iter().zip(b).take(body_columns) {
            assert!((x - y).abs() <= 1e-12 * (1.0 + y.abs()), "{x} != {y}");
        }
    }
    Ok(())
}

/// The slider's position in closed form: crank 0.3 and rod 1 pinned at
/// their midpoints' ends, crank angle φ = π/4 + ω t.
fn slider_x(omega: f64, t: f64) -> f64 {
    let phi = std::f64::consts::FRAC_PI_4 + omega * t;
    0.3 * phi.cos() + (1.0 - (0.3 * phi.sin()).powi(2)).sqrt()
}

#[test]
fn the_macro_takes_keyword_names() -> Result<(), kinema::Error> {
    use kinema::System;
    let mechanism = Keywords::default();
    assert_eq!(mechanism.r#ref, 0.3);
    let omega = mechanism.r#fn;
    let mut solver = mechanism.solver(kinema::Options::default())?;
    let times: Vec<f64> = (0..=8).map(|k| f64::from(k) / 16.0).collect();
    let trajectory = solver.run(&times)?;
    assert_eq!(solver.system().len(), 9);
    for state in trajectory.iter() {
        let x = state.q()[6];
        assert!((x - slider_x(omega, state.t())).abs() < 1e-9, "{x}");
    }
    Ok(())
}

/// `kinema codegen` prints the library's `Model::rust_source` of the model
/// (whose compiling and running tests/ui.rs checks, in the trybuild
/// project the macro's errors already build), params as raw identifiers.
#[test]
fn kinema_codegen_prints_the_models_source() {
    let o = kinema(&["codegen", MODEL]);
    assert_status(&o, 0);
    let code = stdout(&o);
    for raw in ["pub r#ref: f64", "pub r#move: f64", "pub r#fn: f64"] {
        assert!(code.contains(raw), "{raw} in\n{code}");
    }
    let model = match kinema::Model::from_file(Path::new(ROOT).join(MODEL)) {
        Ok(m) => m,
        Err(e) => panic!("{MODEL}: {e}"),
    };
    assert_eq!(code.trim_end(), model.rust_source().trim_end());
}
