//! Parameter sensitivities on the tape back end (issue 40) against central
//! finite differences of whole runs: for every kinematic model of
//! `models/` and every param, ∂q/∂p, ∂q̇/∂p, ∂q̈/∂p and the result
//! columns' sensitivities computed after each step with the step's
//! factorization must equal (run(p(1 + h)) − run(p(1 − h))) / (2 h p),
//! h = 1e-6, to 1e-6 relative (each column scaled by its largest
//! magnitude over the run, so that a zero crossing is not a failure).

use std::path::PathBuf;

use kinema_runtime::{Auto, Options, Outputs, Solver};
use kinema_tape::{Backend, Model, TapeSystem};

/// The relative step of the finite differences.
const H: f64 = 1e-6;
/// The agreement asked for.
const TOLERANCE: f64 = 1e-6;

fn model(name: &str) -> Model {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(name);
    Model::from_file(&path).unwrap_or_else(|e| panic!("{name}: {}", e.render()))
}

/// Per time: q, q̇, q̈, then y, ẏ, ÿ, flattened.
type Run = Vec<Vec<f64>>;

fn row(solver: &Solver<TapeSystem, Auto>, scratch: &mut Vec<f64>) -> Vec<f64> {
    let state = solver.state().expect("a state after a step");
    let mut out = [Vec::new(), Vec::new(), Vec::new()];
    let m = solver.system().output_len();
    for o in &mut out {
        o.resize(m, 0.0);
    }
    solver.system().outputs_of(scratch, state, &mut out);
    let mut r = Vec::new();
    for v in [state.q(), state.qd(), state.qdd()] {
        r.extend_from_slice(v);
    }
    for v in &out {
        r.extend_from_slice(v);
    }
    r
}

/// A whole run with param `param` set to `value`, converged to roundoff
/// (the update test decides: the differences divide the error by 2 h p).
fn run(model: &Model, param: &str, value: f64, times: &[f64]) -> Run {
    let mut system = model.system();
    system.set_param(param, value).expect("a param");
    let options = Options {
        residual_tolerance: 1e-16,
        ..Options::default()
    };
    let mut solver = Solver::<TapeSystem, Auto>::with_options(system, options).expect("solver");
    let mut scratch = Vec::new();
    times
        .iter()
        .map(|&t| {
            solver
                .step(t)
                .unwrap_or_else(|e| panic!("{param} = {value}: {e}"));
            row(&solver, &mut scratch)
        })
        .collect()
}

/// The worst relative disagreement over every param, column and time.
fn worst(name: &str, backend: Backend, times: &[f64]) -> f64 {
    let model = model(name).with_backend(backend);
    let d = model.derivation();
    let names: Vec<String> = d.params.iter().map(|p| p.name.clone()).collect();
    let values = d.param_values();
    let mut sens = model
        .sensitivity_to_every_param()
        .unwrap_or_else(|e| panic!("{e}"));
    // Every param, in declaration order.
    assert_eq!(sens.params(), &names[..]);
    let mut solver = model.solver(Options::default()).expect("solver");
    // computed[t][k]: param k's sensitivities at times[t], laid out as a
    // row of `run`.
    let mut computed: Vec<Vec<Vec<f64>>> = Vec::new();
    for &t in times {
        solver
            .step(t)
            .unwrap_or_else(|e| panic!("{name} at t = {t}: {e}"));
        sens.compute(&mut solver).unwrap_or_else(|e| panic!("{e}"));
        let per_param = (0..names.len())
            .map(|k| {
                let mut r = Vec::new();
                for v in sens.coordinates(k) {
                    r.extend_from_slice(v);
                }
                for v in sens.outputs(k) {
                    r.extend_from_slice(v);
                }
                r
            })
            .collect();
        computed.push(per_param);
    }
    let mut worst = (0.0f64, String::new());
    for (k, (param, &p)) in names.iter().zip(&values).enumerate() {
        let step = if p == 0.0 { H } else { H * p.abs() };
        let plus = run(&model, param, p + step, times);
        let minus = run(&model, param, p - step, times);
        let fd: Vec<Vec<f64>> = plus
            .iter()
            .zip(&minus)
            .map(|(a, b)| {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| (x - y) / (2.0 * step))
                    .collect()
            })
            .collect();
        let width = fd[0].len();
        assert_eq!(computed[0][k].len(), width, "{name}: row width");
        for j in 0..width {
            let scale = (0..times.len())
                .map(|i| fd[i][j].abs().max(computed[i][k][j].abs()))
                .fold(0.0, f64::max);
            for i in 0..times.len() {
                let (a, f) = (computed[i][k][j], fd[i][j]);
                assert!(
                    a.is_finite(),
                    "{name}: ∂/∂{param} column {j} at t = {}",
                    times[i]
                );
                // The differences' own rounding noise: the runs' values are
                // right to a few ulps of the row's largest value (the
                // intermediate terms' size), divided by 2 h p. It matters only for
                // a column p barely moves (a structural zero).
                let magnitude = plus[i].iter().fold(1.0, |m: f64, v| m.max(v.abs()));
                let noise = 16.0 * f64::EPSILON * magnitude / (2.0 * step);
                let err = ((a - f).abs() - noise).max(0.0) / scale.max(f64::MIN_POSITIVE);
                assert!(
                    err <= TOLERANCE,
                    "{name}: ∂/∂{param} column {j} at t = {}: computed {a}, differences {f} \
                     (relative {err:e})",
                    times[i]
                );
                // What is reported: the plain relative disagreement.
                let raw = (a - f).abs() / scale.max(f64::MIN_POSITIVE);
                // (over the columns p moves: a structural zero's scale is
                // the differences' noise)
                if scale > 1e-6 && raw > worst.0 {
                    worst = (
                        raw,
                        format!("∂/∂{param} column {j} at t = {}: {a} vs {f}", times[i]),
                    );
                }
            }
        }
    }
    println!(
        "{name} ({backend:?}): worst relative disagreement {:e} ({})",
        worst.0, worst.1
    );
    worst.0
}

fn grid(n: usize, end: f64) -> Vec<f64> {
    (0..=n).map(|i| end * i as f64 / n as f64).collect()
}

#[test]
fn slider_crank_matches_differences() {
    let w = worst("slider_crank.kin", Backend::Tape, &grid(40, 1.0));
    println!("slider_crank: worst relative disagreement {w:e}");
}

#[test]
fn four_bar_matches_differences_on_both_back_ends() {
    // Newton-solved positions; a named point and an output.
    for backend in [Backend::Tape, Backend::Jit] {
        let w = worst("four_bar.kin", backend, &grid(40, 1.0));
        println!("four_bar ({backend:?}): worst relative disagreement {w:e}");
    }
}

#[test]
fn every_kinematic_model_matches_differences() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("models/")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".kin"))
        .collect();
    names.sort();
    let mut checked = 0;
    for name in &names {
        let m = model(name);
        let d = m.derivation();
        if d.params.is_empty() || d.rows.len() != d.nc() {
            println!("{name}: skipped (no params, or not kinematic)");
            continue;
        }
        let w = worst(name, Backend::Tape, &grid(20, 0.5));
        println!("{name}: worst relative disagreement {w:e}");
        checked += 1;
    }
    assert!(checked >= 5, "only {checked} models checked");
}

#[test]
fn bad_names_name_the_params() {
    let m = model("slider_crank.kin");
    let e = m.sensitivity(&["l3"]).expect_err("no such param");
    let text = e.to_string();
    assert!(
        text.contains("l3") && text.contains("l1, l2, omega"),
        "{text}"
    );
    let e = m.sensitivity(&["crank"]).expect_err("a body");
    assert!(e.to_string().contains("is a body"), "{e}");
    let e = m.sensitivity(&["l1", "l1"]).expect_err("twice");
    assert!(e.to_string().contains("more than once"), "{e}");
}

#[test]
fn compute_before_a_step_is_an_error() {
    let m = model("slider_crank.kin");
    let mut sens = m.sensitivity(&["l1"]).expect("l1");
    let mut solver = m.solver(Options::default()).expect("solver");
    assert!(sens.compute(&mut solver).is_err());
}

/// The position level alone (`compute_positions`: one solve per param)
/// is the full computation's position level to the bit, the rates' levels
/// NaN, on a model with named points and outputs.
#[test]
fn the_position_level_alone_is_the_full_ones() {
    let m = model("four_bar.kin");
    let mut full = m.sensitivity_to_every_param().expect("params");
    let mut positions = m.sensitivity_to_every_param().expect("params");
    let mut solver = m.solver(Options::default()).expect("solver");
    solver.assemble(0.0).expect("assembles");
    for t in [0.1, 0.37, 0.8] {
        solver.step(t).expect("steps");
        full.compute(&mut solver).expect("full");
        positions.compute_positions(&mut solver).expect("positions");
        for k in 0..full.params().len() {
            assert_eq!(full.coordinates(k)[0], positions.coordinates(k)[0]);
            assert_eq!(full.outputs(k)[0], positions.outputs(k)[0]);
            assert!(full.coordinates(k)[1].iter().all(|x| x.is_finite()));
            for level in 1..3 {
                assert!(positions.coordinates(k)[level].iter().all(|x| x.is_nan()));
                assert!(positions.outputs(k)[level].iter().all(|x| x.is_nan()));
            }
        }
    }
    assert!(!m.derivation().outputs.is_empty());
}
