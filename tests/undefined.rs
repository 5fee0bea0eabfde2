//! Drivers undefined at an instant (issue 42): a driver whose function of
//! time leaves its domain or has a pole — `atan2(f, f)`, `1 / f`, `ln f`,
//! `sqrt f`, `tan` — at a time of the grid or between two, stops the run
//! with `Error::Undefined` naming the equation, the function and the
//! time, never with "cannot follow the motion" or a bare non-finite value.

use kinema::{Domain, Error, Model, Options};
use proptest::prelude::*;

/// What a generated driver applies to f(t), which is 0 at the time `c`
/// (positive before it where the function needs a positive argument).
#[derive(Clone, Copy, Debug)]
enum Kind {
    Atan2,
    Reciprocal,
    Ln,
    Sqrt,
    Tan,
}

impl Kind {
    /// The driver's right-hand side with f = k (c − t), and the function
    /// the error must name.
    fn driver(self, k: f64, c: f64) -> (String, &'static str) {
        let f = format!("{k:?} * ({c:?} - t)");
        match self {
            Kind::Atan2 => (format!("atan2({f}, {f})"), "atan2"),
            Kind::Reciprocal => (format!("1 / ({f})"), "division"),
            Kind::Ln => (format!("ln({f})"), "ln"),
            Kind::Sqrt => (format!("sqrt({f})"), "sqrt"),
            // tan(π/4 (2 − f)): its pole at f = 0, the next ones at
            // f = ±4, beyond |f| ≤ 3 on [0, 1] (π/2 (1 − f) had one at
            // f = 2, which k = 3 reaches before the crossing: CI seed
            // 37b7683b, kept in undefined.proptest-regressions).
            Kind::Tan => (format!("tan(pi / 4 * (2 - {f}))"), "tan"),
        }
    }
}

/// A pendulum driven in angle, or a slider driven along x, by `rhs`.
fn model(pendulum: bool, rhs: &str) -> String {
    if pendulum {
        format!(
            "mechanism Swing {{\n    body bar {{ guess: (0.5, 0, 0) }}\n    \
             joint pivot: revolute(ground(0, 0), bar(-0.5, 0));\n    \
             driver swing: bar.phi == {rhs};\n}}\n"
        )
    } else {
        format!(
            "mechanism Slide {{\n    body block {{ guess: (0, 0, 0) }}\n    \
             constraint rail: block.y == 0;\n    constraint level: block.phi == 0;\n    \
             driver swing: block.x == {rhs};\n}}\n"
        )
    }
}

/// The run over `times` and the error that stopped it.
fn failure(source: &str, times: &[f64]) -> Option<Error> {
    let model = Model::from_source(source, "generated.kin").unwrap_or_else(|e| panic!("{e}"));
    let mut solver = model
        .solver(Options::default())
        .unwrap_or_else(|e| panic!("{e}"));
    times.iter().find_map(|&t| solver.step(t).err())
}

fn kinds() -> impl Strategy<Value = Kind> {
    prop_oneof![
        Just(Kind::Atan2),
        Just(Kind::Reciprocal),
        Just(Kind::Ln),
        Just(Kind::Sqrt),
        Just(Kind::Tan),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// f crosses 0 at grid time `at` (`between` false) or at a fraction
    /// `frac` of the step after it: the failure names `swing`, the
    /// function, and a time within roundoff of the crossing.
    #[test]
    fn an_undefined_driver_is_named_with_its_function_and_time(
        kind in kinds(),
        pendulum in any::<bool>(),
        steps in 5usize..40,
        at in 1usize..5,
        between in any::<bool>(),
        frac in 0.2f64..0.8,
        k in prop_oneof![Just(1.0), Just(0.5), Just(3.0)],
    ) {
        let times: Vec<f64> = (0..=steps).map(|i| i as f64 / steps as f64).collect();
        let c = if between {
            (at as f64 + frac) / steps as f64
        } else {
            times[at]
        };
        let (rhs, function) = kind.driver(k, c);
        let source = model(pendulum, &rhs);
        let e = failure(&source, &times);
        let Some(Error::Undefined { t, equation, function: named, domain, .. }) = &e else {
            panic!("{source}\nexpected an undefined equation, got {e:?}");
        };
        prop_assert_eq!(equation.as_str(), "swing", "{}", source);
        prop_assert_eq!(*named, function, "{}", source);
        // The crossing within roundoff of t (f's own rounding: c and k·c).
        prop_assert!((t - c).abs() <= 1e-12, "{source}\nat t = {t}, crossing at {c}");
        let expected = match kind {
            Kind::Atan2 => vec![Domain::NoAngle],
            Kind::Reciprocal | Kind::Tan => vec![Domain::Pole],
            Kind::Ln => vec![Domain::Pole, Domain::Outside],
            Kind::Sqrt => vec![Domain::Edge, Domain::Outside],
        };
        prop_assert!(expected.contains(domain), "{source}\n{domain:?}");
        let text = e.as_ref().map(ToString::to_string).unwrap_or_default();
        prop_assert!(text.starts_with("equation `swing` is "), "{}", text);
        prop_assert!(!text.contains("cannot follow"), "{}", text);
    }
}

/// The states before the crossing are solved as usual: the check does not
/// stop a driver that stays in its domain (ln of a positive f, √ of one,
/// 1/f away from its pole), over many steps near the edge.
#[test]
fn drivers_that_stay_in_their_domains_run() {
    let times: Vec<f64> = (0..=200).map(|i| f64::from(i) / 200.0).collect();
    for rhs in [
        "ln(t + 1e-3)",
        "sqrt(t + 1e-6)",
        "1 / (t + 1e-3)",
        "atan2(t + 1e-9, t)",
        "tan(t)",
        "acos(t / 1.001)",
        // acos touches -1 at t = (π − 0.5)/4 between two grid times and comes
        // back: the edge is touched, not left.
        "acos(cos(4 * t + 0.5))",
    ] {
        let source = model(false, rhs);
        assert_eq!(failure(&source, &times), None, "{rhs}");
    }
}

/// An unbounded driver names the driver and the time, and the message
/// reads so.
#[test]
fn an_unbounded_driver_names_itself_and_the_time() {
    let times = [0.0, 0.25, 0.5, 0.75, 1.0];
    let e = failure(&model(true, "1 / (t - 0.5)"), &times).expect("a failure");
    assert_eq!(
        e.to_string(),
        "equation `swing` is unbounded at t = 0.5: division by 0 (the divisor is 0)"
    );
    let e = failure(&model(true, "atan2(t, t)"), &times).expect("a failure");
    assert_eq!(
        e.to_string(),
        "equation `swing` is undefined at t = 0: atan2(0, 0) has no angle"
    );
}
