//! The sensitivity systems solved at solved states (issue 40): with q, q̇,
//! q̈ from Newton and the velocity and acceleration equations, s, ṡ, s̈
//! from Φ_q and the derived right-hand sides must be the central
//! differences of the solutions at p ± h — for mechanisms whose position
//! needs Newton (the four-bar, Jansen's linkage), a follower, and the
//! results (the four-bar's coupler point and transmission angle).
//!
//! The solver here is a plain dense one (nalgebra's LU) written for the
//! test: the point is the derivation, not the runtime's solver.

use std::path::PathBuf;

use kinema_model::{Derivation, Sensitivities, derive_str};
use nalgebra::{DMatrix, DVector};

/// The solved state at params `p` and time `t`, with each param's
/// sensitivities.
struct Solved {
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    /// Results (y, ẏ, ÿ) per result column, flattened.
    results: Vec<f64>,
}

fn load(name: &str) -> (Derivation, Sensitivities) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(name);
    let src = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut d = derive_str(&src).unwrap_or_else(|e| panic!("{}", e.render(&src, name)));
    let names: Vec<String> = d.params.iter().map(|p| p.name.clone()).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let s = d.sensitivities(&names).unwrap_or_else(|e| panic!("{e}"));
    (d, s)
}

fn jacobian(d: &Derivation, q: &[f64], t: f64, p: &[f64]) -> DMatrix<f64> {
    let dense = d.eval_dense(&d.phi_q, q, &[], t, p);
    DMatrix::from_fn(dense.len(), d.nc(), |i, j| dense[i][j])
}

fn solve(a: &DMatrix<f64>, b: &[f64]) -> Vec<f64> {
    a.clone()
        .lu()
        .solve(&DVector::from_column_slice(b))
        .unwrap_or_else(|| panic!("singular Φ_q"))
        .iter()
        .copied()
        .collect()
}

/// Newton from `q0`, then velocity and acceleration.
fn solve_state(d: &Derivation, q0: &[f64], t: f64, p: &[f64]) -> Solved {
    let mut q = q0.to_vec();
    for _ in 0..50 {
        let phi = d.eval_vec(&d.phi, &q, &[], t, p);
        if phi.iter().all(|v| v.abs() < 1e-14) {
            break;
        }
        let dq = solve(&jacobian(d, &q, t, p), &phi);
        q.iter_mut().zip(dq).for_each(|(a, b)| *a -= b);
    }
    let phi = d.eval_vec(&d.phi, &q, &[], t, p);
    assert!(
        phi.iter().all(|v| v.abs() < 1e-12),
        "no convergence: {phi:?}"
    );
    let jq = jacobian(d, &q, t, p);
    let qd = solve(&jq, &d.eval_vec(&d.nu, &q, &[], t, p));
    let qdd = solve(&jq, &d.eval_vec(&d.gamma, &q, &qd, t, p));
    let results = d
        .outputs
        .iter()
        .flat_map(|o| {
            let at = |e| d.eval(e, &q, &qd, t, p);
            let jq: f64 = o
                .jacobian
                .iter()
                .map(|&(k, e)| at(e) * qdd[k as usize])
                .sum();
            [at(o.value), at(o.velocity), jq + at(o.acceleration)]
        })
        .collect();
    Solved {
        q,
        qd,
        qdd,
        results,
    }
}

/// Follows the branch of the guess from t = 0 to `t` in small steps.
fn solve_at(d: &Derivation, t: f64, p: &[f64]) -> Solved {
    let mut state = solve_state(d, &d.guess_values(), 0.0, p);
    let steps = (t / 0.01).ceil().max(1.0) as usize;
    for k in 1..=steps {
        let tk = t * k as f64 / steps as f64;
        state = solve_state(d, &state.q, tk, p);
    }
    state
}

/// The largest difference relative to the largest entry.
fn disagreement(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().chain(b).fold(0.0f64, |m, v| m.max(v.abs()));
    if scale < 1e-12 {
        return 0.0;
    }
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// s, ṡ, s̈ and the results' sensitivities from the derived right-hand
/// sides against central differences of solutions; the largest
/// disagreement.
fn check(name: &str, times: &[f64]) -> f64 {
    let (d, sens) = load(name);
    let p0 = d.param_values();
    let mut worst = 0.0f64;
    for &t in times {
        let x = solve_at(&d, t, &p0);
        let jq = jacobian(&d, &x.q, t, &p0);
        for ps in &sens.params {
            let k = ps.index;
            // The position level: Φ_q s = −Φ_p.
            let phi_p: Vec<f64> = d
                .eval_vec(&ps.phi_p, &x.q, &x.qd, t, &p0)
                .iter()
                .map(|v| -v)
                .collect();
            let s = solve(&jq, &phi_p);
            // Velocity: Φ_q ṡ = rhs([q; s], q̇).
            let qa = [x.q.as_slice(), &s].concat();
            let qda = [x.qd.as_slice(), &vec![0.0; d.nc()]].concat();
            let sd = solve(&jq, &d.eval_vec(&ps.velocity_rhs, &qa, &qda, t, &p0));
            // Acceleration: Φ_q s̈ = rhs([q; s], [q̇; ṡ]) − W q̈.
            let qda = [x.qd.as_slice(), &sd].concat();
            let mut rhs = d.eval_vec(&ps.acceleration_rhs, &qa, &qda, t, &p0);
            for en in &ps.acceleration_qdd.entries {
                rhs[en.row as usize] -= d.eval(en.expr, &qa, &qda, t, &p0) * x.qdd[en.col as usize];
            }
            let sdd = solve(&jq, &rhs);
            let results: Vec<f64> = ps
                .outputs
                .iter()
                .zip(&d.outputs)
                .flat_map(|(o, column)| {
                    let at = |e| d.eval(e, &qa, &qda, t, &p0);
                    let by_sdd: f64 = column
                        .jacobian
                        .iter()
                        .map(|&(j, e)| at(e) * sdd[j as usize])
                        .sum();
                    let by_qdd: f64 = o.qdd.iter().map(|&(j, e)| at(e) * x.qdd[j as usize]).sum();
                    [
                        at(o.value),
                        at(o.velocity),
                        by_sdd + by_qdd + at(o.acceleration),
                    ]
                })
                .collect();

            // Solutions at p ± h: Newton from the solution at p stays on
            // its branch; velocity and acceleration follow.
            let h = 1e-6 * if p0[k] == 0.0 { 1.0 } else { p0[k].abs() };
            let at = |sign: f64| {
                let mut p = p0.clone();
                p[k] += sign * h;
                solve_state(&d, &x.q, t, &p)
            };
            let (plus, minus) = (at(1.0), at(-1.0));
            let diff = |a: &[f64], b: &[f64]| -> Vec<f64> {
                a.iter().zip(b).map(|(a, b)| (a - b) / (2.0 * h)).collect()
            };
            for (what, exact, fd) in [
                ("s", &s, diff(&plus.q, &minus.q)),
                ("sdot", &sd, diff(&plus.qd, &minus.qd)),
                ("sddot", &sdd, diff(&plus.qdd, &minus.qdd)),
                ("results", &results, diff(&plus.results, &minus.results)),
            ] {
                assert!(
                    exact.iter().all(|v| v.is_finite()),
                    "{name} t = {t} {}: {what} {exact:?}",
                    ps.name
                );
                let e = disagreement(exact, &fd);
                worst = worst.max(e);
                assert!(
                    e < 1e-6,
                    "{name} t = {t} p = {}: {what} disagrees by {e:e}\n  derived {exact:?}\n  differences {fd:?}",
                    ps.name
                );
            }
        }
    }
    eprintln!("{name}: largest disagreement {worst:.1e}");
    worst
}

/// The four-bar's position needs Newton; its coupler point and
/// transmission angle are results.
#[test]
fn four_bar_sensitivities_are_derivatives_of_solutions() {
    check("four_bar.kin", &[0.0, 0.13, 0.41, 0.77]);
}

#[test]
fn slider_crank_sensitivities_are_derivatives_of_solutions() {
    check("slider_crank.kin", &[0.0, 0.3, 0.62]);
}

/// Fourteen params, eight loops of Newton.
#[test]
fn jansen_sensitivities_are_derivatives_of_solutions() {
    check("jansen.kin", &[0.0, 0.35]);
}

/// A follower: the contact parameters are coordinates of their own.
#[test]
fn roller_cam_sensitivities_are_derivatives_of_solutions() {
    check("roller_cam.kin", &[0.0, 0.21, 0.6]);
}
