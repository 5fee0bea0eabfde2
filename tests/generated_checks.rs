//! The runtime's checks on a generated system (`mechanism!`) against the
//! tape back end (`kinema::Model`) on the same model text: the static
//! equilibrium (q, λ, stability), the kink check (equation and function)
//! and the precision check (the imprecise equation flagged, a regular
//! model passed).

use kinema::Model;
use kinema::equilibrium::Stability;

mod pend_eql {
    kinema::mechanism!(file = "tests/generated_checks/pend_eql.kin");
}

const PEND_EQL: &str = include_str!("generated_checks/pend_eql.kin");

fn model(src: &str) -> Model {
    Model::from_source(src, "test.kin").unwrap_or_else(|e| panic!("{e}"))
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn a_generated_system_reaches_the_tapes_stable_equilibrium() {
    let tape = model(PEND_EQL)
        .equilibrium(0.0)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut forward = pend_eql::PendulumEQL::default().forward();
    let generated = kinema::equilibrium::equilibrium_from_start(&mut forward, 0.0)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(generated.stability, Stability::Stable);
    assert_eq!(generated.stability, tape.stability);
    assert!(
        max_diff(&generated.q, &tape.q) < 1e-12,
        "{:?} vs {:?}",
        generated.q,
        tape.q
    );
    assert!(
        max_diff(&generated.lambda, &tape.lambda) < 1e-9,
        "{:?} vs {:?}",
        generated.lambda,
        tape.lambda
    );
    assert!(max_diff(&generated.eigenvalues, &tape.eigenvalues) < 1e-9);
    // The stable root of V'(φ) = m g cos φ + k (φ − 1) (tests/equilibrium.rs),
    // not the unstable one near 1.6 that plain Newton reaches from the start.
    let phi = generated.q[2];
    assert!(
        (10.0 * 9.81 * phi.cos() + 25.0 * (phi - 1.0)).abs() < 1e-8 && phi > 3.0,
        "φ = {phi}"
    );
}

mod at_origin {
    kinema::mechanism!(file = "tests/kinks/at_origin.kin");
}
mod fold {
    kinema::mechanism!(file = "tests/kinks/fold.kin");
}
mod rounded_drive {
    kinema::mechanism!(file = "tests/precision/rounded_drive.kin");
}
mod four_bar {
    kinema::mechanism!(file = "models/four_bar.kin");
}

use kinema::{Auto, Options, Precision, PrecisionScope, Solver, State, System};

/// The states of `system` at `times` (all must solve), each with the
/// precision check at its scope (`All` on the first, `Timed` after, as
/// `kinema run` asks).
fn states<S: System>(system: S, times: &[f64]) -> Vec<(State, Option<kinema::Imprecision>)> {
    let mut solver = Solver::<S, Auto>::with_options(system, Options::default())
        .unwrap_or_else(|e| panic!("solver: {e}"));
    let mut precision = Precision::new(solver.system());
    let mut scratch = solver.system().scratch();
    let mut out = Vec::new();
    for (k, &t) in times.iter().enumerate() {
        let state = solver
            .step(t)
            .unwrap_or_else(|e| panic!("t = {t}: {e}"))
            .clone();
        let scope = if k == 0 {
            PrecisionScope::All
        } else {
            PrecisionScope::Timed
        };
        let size = solver.model_size();
        let imprecision = precision.check(solver.system(), &mut scratch, &state, size, scope);
        out.push((state, imprecision));
    }
    out
}

fn tape_system(path: &str) -> kinema::TapeSystem {
    Model::from_file(path)
        .unwrap_or_else(|e| panic!("{e}"))
        .system()
}

/// The kinks of the states (equation name and function) of both back ends.
fn kinks<S: System>(system: S, times: &[f64]) -> Vec<Option<(String, &'static str)>> {
    let names: Vec<String> = (0..system.len())
        .map(|i| system.equation_name(i).to_owned())
        .collect();
    states(system, times)
        .iter()
        .map(|(s, _)| {
            s.kink().map(|k| {
                (
                    k.equation.map_or_else(String::new, |e| names[e].clone()),
                    k.function,
                )
            })
        })
        .collect()
}

#[test]
fn a_generated_system_flags_the_tapes_kinks() {
    // The tip held at the origin but for roundoff: the norm's kink.
    let generated = kinks(at_origin::AtOrigin::default(), &[0.0]);
    let tape = kinks(tape_system("tests/kinks/at_origin.kin"), &[0.0]);
    let (equation, function) = generated[0]
        .clone()
        .expect("the generated state is flagged");
    assert_eq!(function, "sqrt");
    assert!(equation.starts_with("tip."), "{equation}");
    assert_eq!(generated, tape);
    // x + |x|/2 = t − 0.3 crosses the kink of abs at t = 0.3 only.
    let times: Vec<f64> = (0..=8).map(|k| f64::from(k) * 0.1).collect();
    let generated = kinks(fold::Fold::default(), &times);
    let tape = kinks(tape_system("tests/kinks/fold.kin"), &times);
    let flagged: Vec<usize> = (0..generated.len())
        .filter(|&k| generated[k].is_some())
        .collect();
    assert_eq!(flagged, [3]);
    assert_eq!(generated[3], Some(("slide".to_owned(), "abs")));
    assert_eq!(generated, tape);
}

#[test]
fn a_generated_system_flags_the_tapes_imprecise_equation_and_passes_a_regular_one() {
    let times: Vec<f64> = (0..=10).map(|k| f64::from(k) * 0.1).collect();
    let generated = states(rounded_drive::RoundedDrive::default(), &times);
    let tape = states(tape_system("tests/precision/rounded_drive.kin"), &times);
    let swing = 2; // pivot_x, pivot_y, swing
    for ((gs, g), (ts, t)) in generated.iter().zip(&tape) {
        let g = g.unwrap_or_else(|| panic!("t = {}: not flagged", gs.t()));
        let t = t.unwrap_or_else(|| panic!("t = {}: the tape's not flagged", ts.t()));
        assert_eq!((g.equation, t.equation), (swing, swing));
        // The same bound, up to the order of a few roundings.
        assert!(
            (g.shift - t.shift).abs() <= 1e-6 * t.shift,
            "{g:?} vs {t:?}"
        );
    }
    // And a regular model is never flagged, on either back end.
    let grid: Vec<f64> = (0..=50).map(|k| f64::from(k) * 0.02).collect();
    for (s, i) in states(four_bar::FourBar::default(), &grid) {
        assert_eq!(i, None, "t = {}", s.t());
    }
    for (s, i) in states(tape_system("models/four_bar.kin"), &grid) {
        assert_eq!(i, None, "t = {}", s.t());
    }
}
