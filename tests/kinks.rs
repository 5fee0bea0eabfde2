//! Solutions at a kink (fuzz finding F16): a model whose solution puts the
//! argument of `norm`, `abs`, … at the function's kink within roundoff has
//! derivatives there that are the rounding errors'. The state is flagged
//! (`State::kink`) with the equation and the function; solutions away from
//! a kink are not.

use kinema::{Kink, Model, Options, State, System};

fn model(path: &str) -> Model {
    Model::from_file(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The states at `times` (as far as the run gets) and the error that
/// stopped it, if any.
fn run(model: &Model, times: &[f64]) -> (Vec<State>, Option<kinema::Error>) {
    run_with(model, times, Options::default())
}

fn run_with(model: &Model, times: &[f64], options: Options) -> (Vec<State>, Option<kinema::Error>) {
    let mut solver = model.solver(options).unwrap_or_else(|e| panic!("{e}"));
    let mut states = Vec::new();
    for &t in times {
        match solver.step(t) {
            Ok(s) => states.push(s.clone()),
            Err(e) => return (states, Some(e)),
        }
    }
    (states, None)
}

fn equation(model: &Model, kink: Kink) -> String {
    let system = model.system();
    kink.equation
        .map_or_else(String::new, |e| system.equation_name(e).to_owned())
}

#[test]
fn a_solution_on_the_kink_of_a_norm_is_flagged_with_its_equation() {
    let m = model("tests/kinks/at_origin.kin");
    let (states, _) = run(&m, &[0.0]);
    let s = states.first().expect("assembly succeeds");
    // The tip is at the origin but for roundoff.
    assert!(
        s.q()[0].abs() > 0.49 && s.q()[1].abs() < 1e-14,
        "{:?}",
        s.q()
    );
    let kink = s.kink().expect("the state is flagged");
    assert_eq!(kink.function, "sqrt");
    assert!(equation(&m, kink).starts_with("tip."), "{kink:?}");
}

#[test]
fn a_norm_away_from_its_kink_is_never_flagged() {
    let m = model("tests/kinks/ring.kin");
    let times: Vec<f64> = (0..=200).map(|k| k as f64 * 0.05).collect();
    let (states, error) = run(&m, &times);
    assert!(error.is_none(), "{error:?}");
    assert_eq!(states.len(), times.len());
    for s in &states {
        assert_eq!(s.kink(), None, "t = {}", s.t());
        let r = s.q()[0].hypot(s.q()[1]);
        assert!((r - 1.0).abs() < 1e-12);
    }
}

#[test]
fn a_coordinate_crossing_the_kink_of_abs_is_flagged_there_only() {
    // x + |x|/2 = t − 0.3: x = 2 (t − 0.3) before, (t − 0.3)/1.5 after.
    // 0.1 · 3 is 0.3 + 5.6e-17: x there is roundoff, on the kink.
    let m = model("tests/kinks/fold.kin");
    let times: Vec<f64> = (0..=8).map(|k| k as f64 * 0.1).collect();
    let (states, error) = run(&m, &times);
    assert!(error.is_none(), "{error:?}");
    let flagged: Vec<usize> = (0..states.len())
        .filter(|&k| states[k].kink().is_some())
        .collect();
    assert_eq!(flagged, [3]);
    let kink = states[3].kink().expect("flagged above");
    assert_eq!(
        (kink.function, equation(&m, kink).as_str()),
        ("abs", "slide")
    );
    // With positions only, q̇ and q̈ are differences: nothing to flag; and
    // the motion is followed through the kink (finding F17: the
    // differences across it pointed the wrong way, and the refinement
    // never passed the branch test).
    let only = Options::default().with_positions_only(true);
    let (positions, error) = run_with(&m, &times, only);
    assert!(error.is_none(), "{error:?}");
    assert_eq!(positions.len(), times.len());
    for s in &positions {
        assert_eq!(s.kink(), None);
        let d = s.t() - 0.3;
        let x = if d < 0.0 { 2.0 * d } else { d / 1.5 };
        assert!((s.q()[0] - x).abs() < 1e-12, "t = {}: {}", s.t(), s.q()[0]);
    }
    // Away from it the rates are the closed form's, on either side.
    for s in states.iter().filter(|s| s.kink().is_none()) {
        let rate = if s.t() < 0.3 { 2.0 } else { 1.0 / 1.5 };
        assert!(
            (s.qd()[0] - rate).abs() < 1e-12,
            "t = {}: {}",
            s.t(),
            s.qd()[0]
        );
    }
}

#[test]
fn a_result_column_through_its_kink_is_flagged_there_only() {
    // gap = |x| with x = t − 0.3: its rate jumps from −1 to 1 at 0.3
    // (0.1 · 3 is 0.3 + 5.6e-17, x there is roundoff). Φ has no kink.
    let m = model("tests/kinks/gap.kin");
    let system = m.system();
    let mut scratch = system.scratch();
    let times: Vec<f64> = (0..=8).map(|k| k as f64 * 0.1).collect();
    let (states, error) = run(&m, &times);
    assert!(error.is_none(), "{error:?}");
    let mut flagged = Vec::new();
    for (k, s) in states.iter().enumerate() {
        assert_eq!(s.kink(), None);
        if let Some(kink) = system.output_kink(&mut scratch, s, 1.0) {
            assert_eq!(kink.function, "sqrt");
            assert_eq!(kinema::Outputs::output_name(&system, kink.column), "gap");
            flagged.push(k);
        }
    }
    assert_eq!(flagged, [3]);
    // The rows of a norm away from its kink are not.
    let m = model("models/slider_crank.kin");
    let system = m.system();
    let (states, _) = run(&m, &times);
    assert!(
        states
            .iter()
            .all(|s| system.output_kink(&mut scratch, s, 1.0).is_none())
    );
}
