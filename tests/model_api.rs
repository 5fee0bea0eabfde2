//! The embedder's API of the tape back end: `Model::solver()` like a
//! generated mechanism's, and model errors as `kinema::Error` (so `?` works
//! in a `main() -> Result<(), kinema::Error>`), carrying the report: the
//! diagnostics as data with the source they point into.

use kinema::{Error, Model, Options, Report};

const PENDULUM: &str = "mechanism Pendulum {
    param l = 1.0;
    body bar { guess: (0.5, 0.8, 1.0) }
    joint pin: revolute(ground(0, 0), bar(-l, 0));
    driver swing: bar.phi == 4 * t * t;
}";

fn run(source: &str, file: &str, t: f64) -> Result<Vec<f64>, Error> {
    let model = Model::from_source(source, file)?;
    let mut solver = model.solver(Options::default())?;
    Ok(solver.step(t)?.q().to_vec())
}

#[test]
fn a_model_runs_through_its_own_solver() -> Result<(), Error> {
    let q = run(PENDULUM, "pendulum.kin", 0.5)?;
    // φ = 4t² = 1 at t = 0.5; the bar's centre is at l (cos φ, sin φ).
    assert!((q[2] - 1.0).abs() < 1e-12);
    assert!((q[0] - 1f64.cos()).abs() < 1e-12);
    assert!((q[1] - 1f64.sin()).abs() < 1e-12);
    Ok(())
}

#[test]
fn model_errors_are_kinema_errors_with_their_diagnostics() {
    let bad = PENDULUM.replace("bar(-l, 0)", "bra(-l, 0)");
    let Err(Error::Model(e)) = run(&bad, "bad.kin", 0.5) else {
        panic!("an unknown body must be a model error");
    };
    assert_eq!(e.source().name(), "bad.kin");
    assert_eq!(e.error_count(), 1);
    let first = &e.entries()[0];
    assert_eq!(first.severity, kinema::lang::Severity::Error);
    assert!(first.message.contains("bra"), "{}", first.message);
    // Line 4, column of `bra` (1-based), as the rendered text says.
    let column = bad
        .lines()
        .nth(3)
        .and_then(|l| l.find("bra"))
        .map(|c| c + 1);
    assert_eq!(first.at(), column.map(|c| (4, c)));
    let (line, col) = first.at().unwrap_or_default();
    let rendered = e.render();
    assert!(
        rendered.contains(&format!("bad.kin:{line}:{col}")),
        "{rendered}"
    );
    // The error's text is the rendered diagnostics.
    assert_eq!(Error::Model(e.clone()).to_string(), rendered.trim_end());
}

#[test]
fn an_unreadable_file_is_a_model_error_without_position() {
    let result: Result<Model, Report> = Model::from_file("tests/no such model.kin");
    let Err(e) = result else {
        panic!("a missing file must not load");
    };
    assert_eq!(e.source().name(), "tests/no such model.kin");
    assert_eq!(e.entries().len(), 1);
    assert_eq!(e.entries()[0].at(), None);
    assert!(e.render().starts_with("error: cannot read model file"));
    assert!(matches!(Error::from(e), Error::Model(_)));
}
