//! Parameter sensitivities of inverse dynamics (issue 40): ∂λ/∂p and the
//! sensitivities of every reaction and driver effort, computed after each
//! step with the step's factorization, against central finite differences
//! of whole runs' dynamics columns ([`DynamicsColumns`]):
//! (run(p(1 + h)) − run(p(1 − h))) / (2 h p), h = 1e-6, to 1e-6 relative to
//! each column's largest magnitude over the run. Models with inertia,
//! gravity and forces: the dynamics tests' slider-crank (a gas force that
//! reads q̇), and the IFToMM pendulum, four-bar and Andrews' mechanism of
//! `models/` given a driver (they are forward-dynamics benchmarks: driven,
//! their runs are kinematic with inverse dynamics). Also: zero allocations
//! per step, and the errors.

use std::path::PathBuf;

use kinema_runtime::{Auto, Options, Solver};
use kinema_tape::dynamics::DynamicsColumns;
use kinema_tape::{Backend, Model, TapeSystem};

#[path = "../../kinema-runtime/tests/common/counting.rs"]
mod counting;
use counting::allocations;

/// The relative step of the finite differences.
const H: f64 = 1e-6;
/// The agreement asked for.
const TOLERANCE: f64 = 1e-6;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The model of file `rel` with `driver` added before its closing brace.
fn driven(rel: &str, driver: &str) -> Model {
    let src = read(rel);
    let end = src.rfind('}').expect("a closing brace");
    let src = format!("{}    {driver}\n}}\n", &src[..end]);
    Model::from_source(&src, rel).unwrap_or_else(|e| panic!("{rel}: {}", e.render()))
}

fn from_file(rel: &str) -> Model {
    Model::from_file(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {}", e.render()))
}

/// The dynamics columns of a whole run with param `param` set to `value`,
/// converged to roundoff (the differences divide the error by 2 h p).
fn run(model: &Model, param: &str, value: f64, times: &[f64]) -> Vec<Vec<f64>> {
    let mut system = model.system();
    system.set_param(param, value).expect("a param");
    let rows = model.derivation().rows.len();
    let mut columns = DynamicsColumns::new(&system, rows, false).expect("dynamics");
    let options = Options {
        residual_tolerance: 1e-16,
        ..Options::default()
    };
    let mut solver = Solver::<TapeSystem, Auto>::with_options(system, options).expect("solver");
    times
        .iter()
        .map(|&t| {
            solver
                .step(t)
                .unwrap_or_else(|e| panic!("{param} = {value}: {e}"));
            columns
                .compute(&mut solver)
                .unwrap_or_else(|e| panic!("{param} = {value}: {e}"))
                .to_vec()
        })
        .collect()
}

/// The worst relative disagreement over the params `params` (every param
/// when empty), every dynamics column and time.
fn worst(name: &str, model: &Model, params: &[&str], times: &[f64]) -> f64 {
    let d = model.derivation();
    let all: Vec<String> = d.params.iter().map(|p| p.name.clone()).collect();
    let names: Vec<&str> = if params.is_empty() {
        all.iter().map(String::as_str).collect()
    } else {
        params.to_vec()
    };
    let values: Vec<f64> = names
        .iter()
        .map(|n| {
            let i = all.iter().position(|a| a == n).expect("a param");
            d.param_values()[i]
        })
        .collect();
    let mut sens = model.sensitivity(&names).unwrap_or_else(|e| panic!("{e}"));
    let mut dsens = model
        .dynamics_sensitivity(&sens)
        .unwrap_or_else(|e| panic!("{e}"))
        .expect("a model with dynamics");
    assert_eq!(dsens.params(), sens.params());
    let system = model.system();
    let width = DynamicsColumns::new(&system, model.derivation().rows.len(), false)
        .expect("dynamics")
        .names()
        .len();
    assert_eq!(dsens.width(), width, "{name}: the dynamics columns' count");
    let mut solver = model.solver(Options::default()).expect("solver");
    // computed[t][k]: param k's row at times[t].
    let mut computed: Vec<Vec<Vec<f64>>> = Vec::new();
    for &t in times {
        solver
            .step(t)
            .unwrap_or_else(|e| panic!("{name} at t = {t}: {e}"));
        sens.compute(&mut solver).unwrap_or_else(|e| panic!("{e}"));
        dsens
            .compute(&mut solver, &sens)
            .unwrap_or_else(|e| panic!("{name} at t = {t}: {e}"));
        computed.push(
            (0..names.len())
                .map(|k| dsens.columns(k).to_vec())
                .collect(),
        );
    }
    let column_names = DynamicsColumns::new(&system, model.derivation().rows.len(), false)
        .expect("dynamics")
        .names()
        .to_vec();
    let mut worst = (0.0f64, String::new());
    let mut moved = 0;
    let mut beyond_noise = 0.0f64;
    for (k, (param, &p)) in names.iter().zip(&values).enumerate() {
        let step = if p == 0.0 { H } else { H * p.abs() };
        let plus = run(model, param, p + step, times);
        let minus = run(model, param, p - step, times);
        for j in 0..width {
            let fd: Vec<f64> = (0..times.len())
                .map(|i| (plus[i][j] - minus[i][j]) / (2.0 * step))
                .collect();
            let scale = (0..times.len())
                .map(|i| fd[i].abs().max(computed[i][k][j].abs()))
                .fold(0.0, f64::max);
            // The differences' own rounding noise: the runs' values are
            // right to a few ulps of the row's largest value, divided by
            // 2 h p (it matters only for a column p barely moves, such as
            // a structural zero).
            let noise: Vec<f64> = plus
                .iter()
                .map(|row| {
                    let magnitude = row.iter().fold(1.0, |m: f64, v| m.max(v.abs()));
                    16.0 * f64::EPSILON * magnitude / (2.0 * step)
                })
                .collect();
            // A column p moves well above that noise (the differences are
            // right to 1e-6 of it): its plain disagreement is reported.
            let moves = scale > 1e6 * noise.iter().fold(0.0, |m: f64, &v| m.max(v));
            for i in 0..times.len() {
                let (a, f) = (computed[i][k][j], fd[i]);
                let what = format!(
                    "{name}: d({})/d({param}) at t = {}",
                    column_names[j], times[i]
                );
                assert!(a.is_finite(), "{what}: {a}");
                let err = ((a - f).abs() - noise[i]).max(0.0) / scale.max(f64::MIN_POSITIVE);
                assert!(
                    err <= TOLERANCE,
                    "{what}: computed {a}, differences {f} (relative {err:e})"
                );
                beyond_noise = beyond_noise.max(err);
                let raw = (a - f).abs() / scale.max(f64::MIN_POSITIVE);
                if moves && raw > worst.0 {
                    worst = (raw, format!("{what}: {a} vs {f}"));
                }
            }
            if moves {
                moved += 1;
            }
        }
    }
    // The comparison compares something: p moves many columns.
    assert!(moved > 0, "{name}: no column moves with the params");
    println!(
        "{name}: {} params × {width} columns; worst beyond the differences' noise {:.1e}; \
         over the {moved} columns the params move well above it, worst relative \
         disagreement {:.1e} ({})",
        names.len(),
        beyond_noise,
        worst.0,
        worst.1
    );
    worst.0
}

fn grid(n: usize, end: f64) -> Vec<f64> {
    (0..=n).map(|i| end * i as f64 / n as f64).collect()
}

/// The dynamics tests' slider-crank: inertia, gravity and a gas force
/// that reads the slider's velocity; lengths and the crank speed.
#[test]
fn slider_crank_efforts_and_reactions_match_differences() {
    let model = from_file("tests/dynamics/slider_crank.kin");
    worst("slider_crank (dynamics)", &model, &[], &grid(40, 1.0));
}

/// The IFToMM pendulum driven: its mass and length move every column.
#[test]
fn driven_pendulum_matches_differences() {
    let model = driven(
        "models/iftomm/a01_pendulum.kin",
        "driver swing: bob.phi == 0.8 * sin(3 * t) - 0.3 * t;",
    );
    worst("a01_pendulum (driven)", &model, &[], &grid(30, 1.5));
}

/// The IFToMM four-bar (N = 1) driven by its first crank, short of the
/// bars' alignment: l (geometry, masses' moments), m, and v0 (in the
/// driver).
#[test]
fn driven_iftomm_four_bar_matches_differences() {
    let model = driven(
        "models/iftomm/a02_four_bar_1.kin",
        "driver turn: crank0.phi == pi / 2 - v0 / l * t;",
    );
    for backend in [Backend::Tape, Backend::Jit] {
        let model = model.clone().with_backend(backend);
        worst(
            &format!("a02_four_bar_1 (driven, {backend:?})"),
            &model,
            &[],
            &grid(30, 1.0),
        );
    }
}

/// Andrews' mechanism driven by its crank: seven bodies, a spring and a
/// motor torque; every one of its params (masses, inertias, geometry,
/// the spring's, the start angles that only pick the branch).
#[test]
fn driven_andrews_matches_differences() {
    let model = driven(
        "models/iftomm/a03_andrews.kin",
        "driver turn: crank.phi == beta0 + 40 * t;",
    );
    worst("a03_andrews (driven)", &model, &[], &grid(20, 0.1));
}

/// A kinematic model has no dynamics columns, so no such sensitivities.
#[test]
fn a_kinematic_model_has_none() {
    let model = from_file("models/slider_crank.kin");
    let sens = model.sensitivity(&["l1"]).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        model
            .dynamics_sensitivity(&sens)
            .unwrap_or_else(|e| panic!("{e}"))
            .is_none()
    );
}

/// Computing before a step, or with the sensitivities of other params, is
/// an error, not a panic.
#[test]
fn misuse_is_an_error() {
    let model = from_file("tests/dynamics/slider_crank.kin");
    let sens = model.sensitivity(&["l1"]).unwrap_or_else(|e| panic!("{e}"));
    let other = model.sensitivity(&["l2"]).unwrap_or_else(|e| panic!("{e}"));
    let mut dsens = model
        .dynamics_sensitivity(&sens)
        .unwrap_or_else(|e| panic!("{e}"))
        .expect("dynamics");
    let mut solver = model.solver(Options::default()).expect("solver");
    let e = dsens.compute(&mut solver, &sens).expect_err("no state yet");
    assert!(e.to_string().contains("factor"), "{e}");
    solver.step(0.0).expect("a step");
    let e = dsens
        .compute(&mut solver, &other)
        .expect_err("other params");
    assert!(e.to_string().contains("params of the sensitivity"), "{e}");
}

/// After each step, the sensitivities and their dynamics part allocate
/// nothing (both back ends; the slider-crank and the driven four-bar).
#[test]
fn steps_with_dynamics_sensitivities_do_not_allocate() {
    let models = [
        ("slider_crank", from_file("tests/dynamics/slider_crank.kin")),
        (
            "a02_four_bar_1",
            driven(
                "models/iftomm/a02_four_bar_1.kin",
                "driver turn: crank0.phi == pi / 2 - v0 / l * t;",
            ),
        ),
    ];
    for (name, model) in models {
        for backend in [Backend::Jit, Backend::Tape] {
            let model = model.clone().with_backend(backend);
            let mut sens = model
                .sensitivity_to_every_param()
                .unwrap_or_else(|e| panic!("{e}"));
            let mut dsens = model
                .dynamics_sensitivity(&sens)
                .unwrap_or_else(|e| panic!("{e}"))
                .expect("dynamics");
            let system = model.system();
            system.wait_for_jit();
            let mut solver = Solver::<_, Auto>::with_options(system, Options::default())
                .unwrap_or_else(|e| panic!("{e}"));
            let dt = 5e-3;
            let mut step = |k: u32| {
                solver
                    .step(f64::from(k) * dt)
                    .unwrap_or_else(|e| panic!("{e}"));
                sens.compute(&mut solver).unwrap_or_else(|e| panic!("{e}"));
                dsens
                    .compute(&mut solver, &sens)
                    .unwrap_or_else(|e| panic!("{e}"));
            };
            for k in 0..3 {
                step(k);
            }
            let before = allocations();
            for k in 3..150 {
                step(k);
            }
            let n = allocations() - before;
            assert_eq!(n, 0, "{name}, {backend:?}: {n} allocations in 147 steps");
        }
    }
}
