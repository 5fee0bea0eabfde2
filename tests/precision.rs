//! Equations that their own arithmetic does not determine
//! (`TapeSystem::imprecision`): a driver whose argument is beyond f64's
//! precision is flagged at every state where it costs six digits, and no
//! model of the repository, evaluated as written, ever is.

use kinema::{Imprecision, Model, ModelSolver, Options, PrecisionScope, State};

/// A bar pinned at its end, its angle driven by `drive` (of t).
fn pendulum(drive: &str) -> Model {
    let source = format!(
        "mechanism Driven {{
            param L = 1;
            body bar {{ guess: (L, 0, 0) }}
            constraint pivot_x: abs_x(bar(-L, 0), 0);
            constraint pivot_y: abs_y(bar(-L, 0), 0);
            driver swing: bar.phi == {drive};
        }}"
    );
    Model::from_source(&source, "driven.kin").unwrap_or_else(|e| panic!("{e}"))
}

/// Each state of `model` at `times` (all must solve), with its
/// imprecision.
fn run(model: &Model, times: &[f64]) -> Vec<(State, Option<Imprecision>)> {
    let mut solver: ModelSolver = model
        .solver(Options::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let mut scratch = Vec::new();
    let mut out = Vec::new();
    for &t in times {
        let state = solver
            .step(t)
            .unwrap_or_else(|e| panic!("t = {t}: {e}"))
            .clone();
        let size = solver.model_size();
        let imprecision =
            solver
                .system()
                .imprecision(&mut scratch, &state, size, PrecisionScope::All);
        out.push((state, imprecision));
    }
    out
}

fn times(end: f64, steps: usize) -> Vec<f64> {
    (0..=steps).map(|k| end * k as f64 / steps as f64).collect()
}

#[test]
fn an_argument_beyond_precision_is_flagged_with_its_equation() {
    // 1e20 + t rounds to a multiple of 16384: the sine is of the rounding,
    // and the angle does not move with t at all.
    let model = pendulum("0.5 * sin(1e20 + t)");
    let states = run(&model, &times(1.0, 10));
    let first = states[0].0.q()[2];
    for (state, imprecision) in &states {
        assert_eq!(state.q()[2], first, "the rounding's constant angle");
        let i = imprecision.unwrap_or_else(|| panic!("t = {}: not flagged", state.t()));
        assert_eq!(
            kinema::System::equation_name(&model.system(), i.equation),
            "swing"
        );
        // The sine's whole range (2, times 0.5; the first-order bound is
        // 5e3), against coordinates of scale about 2.
        assert!(i.error > 0.99 && i.error < 1.01, "{i:?}");
        assert!(
            i.shift == i.error && i.scale > 1.0 && i.scale < 3.0,
            "{i:?}"
        );
    }
}

/// The timed scope checks the equations that read t alone: an equation
/// lost to rounding that does not read t is the full check's.
#[test]
fn the_timed_scope_reads_the_equations_that_read_t() {
    for (drive, timed) in [
        ("0.5 * sin(1e20 + t)", true),
        ("0.5 * sin(1e20 + L)", false),
    ] {
        let model = pendulum(drive);
        let mut solver: ModelSolver = model
            .solver(Options::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let state = solver.step(0.5).unwrap_or_else(|e| panic!("{e}")).clone();
        let size = solver.model_size();
        let mut scratch = Vec::new();
        let mut check = |scope| {
            solver
                .system()
                .imprecision(&mut scratch, &state, size, scope)
        };
        let all = check(PrecisionScope::All).expect("flagged");
        assert_eq!(
            check(PrecisionScope::Timed),
            timed.then_some(all),
            "{drive}"
        );
    }
}

/// The flag's line: an argument near 1e12 leaves the sine four digits
/// (uncertain by 1e-4), near 1e8 eight.
#[test]
fn an_argument_is_flagged_where_it_costs_six_digits_and_not_before() {
    for (drive, flagged) in [
        ("0.5 * sin(1e12 + t)", true),
        ("0.5 * sin(1e8 + t)", false),
        ("0.5 * sin(t)", false),
        ("0.5 * sin(1e5 * t)", false),
    ] {
        let model = pendulum(drive);
        // Steps short enough to follow sin(1e5 t).
        let states = run(&model, &times(1e-4, 20));
        for (state, imprecision) in &states {
            assert_eq!(
                imprecision.is_some(),
                flagged,
                "{drive} at t = {}: {imprecision:?}",
                state.t()
            );
        }
    }
}

/// The repository's models, the singular and kink cases among them, over
/// their motion: never flagged (a false alarm would teach users to ignore
/// the warning).
#[test]
fn no_model_evaluated_as_written_is_flagged() {
    let mut paths = Vec::new();
    for dir in ["models", "tests/kinks", "tests/scale", "tests/followers"] {
        for entry in std::fs::read_dir(dir).expect("the repository's models") {
            let path = entry.expect("a directory entry").path();
            if path.extension().is_some_and(|e| e == "kin") {
                paths.push(path);
            }
        }
    }
    paths.push("crates/kinema-bench/models/strider.kin".into());
    assert!(paths.len() >= 14, "{paths:?}");
    for path in paths {
        let model = Model::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut solver: ModelSolver = match model.solver(Options::default()) {
            Ok(s) => s,
            // Models with degrees of freedom are the dynamics tests'.
            Err(_) => continue,
        };
        let mut scratch = Vec::new();
        let mut checked = 0;
        for t in times(1.0, 50) {
            let Ok(state) = solver.step(t) else {
                // Kink models may stop where the motion ends; what came
                // before is checked.
                break;
            };
            let state = state.clone();
            let size = solver.model_size();
            let imprecision =
                solver
                    .system()
                    .imprecision(&mut scratch, &state, size, PrecisionScope::All);
            assert_eq!(imprecision, None, "{} at t = {t}", path.display());
            checked += 1;
        }
        assert!(checked > 0, "{}: no state", path.display());
    }
}
