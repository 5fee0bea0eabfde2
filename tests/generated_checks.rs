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
mod gap {
    kinema::mechanism!(file = "tests/kinks/gap.kin");
}
mod jansen {
    kinema::mechanism!(file = "models/jansen.kin");
}

use kinema::{Auto, Options, Outputs, Precision, PrecisionScope, Solver, State, System};

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

/// The rows of `system` at `times` whose results are at a kink, with the
/// column's name and the function (the runtime's `Outputs::output_kink`).
fn output_kinks<S: Outputs>(system: S, times: &[f64]) -> Vec<(usize, String, &'static str)> {
    let mut solver = Solver::<S, Auto>::with_options(system, Options::default())
        .unwrap_or_else(|e| panic!("solver: {e}"));
    let mut scratch = solver.system().scratch();
    let mut out = Vec::new();
    for (k, &t) in times.iter().enumerate() {
        let state = solver
            .step(t)
            .unwrap_or_else(|e| panic!("t = {t}: {e}"))
            .clone();
        let size = solver.model_size();
        let system = solver.system();
        if let Some(kink) = system.output_kink(&mut scratch, &state, size) {
            out.push((k, system.output_name(kink.column).to_owned(), kink.function));
        }
    }
    out
}

#[test]
fn a_generated_result_column_at_its_kink_is_flagged_as_on_the_tape() {
    // gap = |x| with x = t − 0.3: its rate jumps at 0.3 (0.1 · 3 is
    // 0.3 + 5.6e-17, x there is roundoff).
    let times: Vec<f64> = (0..=8).map(|k| f64::from(k) * 0.1).collect();
    let generated = output_kinks(gap::Gap::default(), &times);
    assert_eq!(generated, [(3, "gap".to_owned(), "sqrt")]);
    assert_eq!(
        generated,
        output_kinks(tape_system("tests/kinks/gap.kin"), &times)
    );
}

/// Φ's error bounds of `a` and `b` at q, t: the largest difference
/// relative to the larger bound.
fn bounds_differ<A: System, B: System>(a: &A, b: &B, q: &[f64], t: f64) -> f64 {
    let n = a.len();
    let (mut x, mut y) = (vec![f64::NAN; n], vec![f64::NAN; n]);
    assert!(a.phi_error_bounds(&mut a.scratch(), q, t, 1e-13, 1.0, &mut x));
    assert!(b.phi_error_bounds(&mut b.scratch(), q, t, 1e-13, 1.0, &mut y));
    x.iter()
        .zip(&y)
        .map(|(u, v)| {
            assert!(u.is_finite() && *u > 0.0 && v.is_finite(), "{x:?} vs {y:?}");
            (u - v).abs() / u.max(*v)
        })
        .fold(0.0, f64::max)
}

/// The rules are kept twice (the runtime's `roundoff` for generated code,
/// kinema-expr's tape analysis for the tape back end): at a state of each
/// model, both bound every equation alike: up to the unit roundoff a
/// tape's register copies add (1e-5 of a bound of 1e-13 on Jansen's
/// linkage), where a rule of one that the other lacks moves a bound by a
/// factor.
#[test]
fn generated_and_tape_error_bounds_agree() {
    agree(&four_bar::FourBar::default(), "models/four_bar.kin");
    agree(&jansen::Jansen::default(), "models/jansen.kin");
    agree(&at_origin::AtOrigin::default(), "tests/kinks/at_origin.kin");
}

/// The bounds of `generated` and of the model file at `path` at a state
/// near the guess.
fn agree<G: System>(generated: &G, path: &str) {
    let tape = tape_system(path);
    let mut q = vec![0.0; tape.len()];
    tape.initial_guess(&mut q);
    // Away from the guess's round numbers.
    for (k, x) in q.iter_mut().enumerate() {
        *x += 0.01 * (k as f64 + 1.0).sqrt();
    }
    let d = bounds_differ(generated, &tape, &q, 0.37);
    assert!(d < 1e-3, "{path}: bounds differ by {d:e}");
}
