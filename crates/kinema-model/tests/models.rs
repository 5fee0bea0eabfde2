//! The models of `models/`: DOF reports, derivation snapshots, and the worked
//! examples of docs/src/constraints.md (the slider-crank and the pendulum).

use std::path::PathBuf;

use kinema_model::{Derivation, derive_str};

fn models_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn load(name: &str) -> (String, Derivation) {
    let path = models_dir().join(name);
    let src = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    match derive_str(&src) {
        Ok(d) => (src, d),
        Err(e) => panic!("{}", e.render(&src, name)),
    }
}

fn dof(name: &str) -> String {
    load(name).1.dof.to_string()
}

#[test]
fn dof_reports() {
    let expect = [
        (
            "pendulum.kin",
            "nc = 3, kinematic equations = 2, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "slider_crank.kin",
            "nc = 9, kinematic equations = 8, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "slider_crank_translational.kin",
            "nc = 9, kinematic equations = 8, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "four_bar.kin",
            "nc = 9, kinematic equations = 8, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "jansen.kin",
            "nc = 21, kinematic equations = 20, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "parabola_follower.kin",
            "nc = 6, kinematic equations = 5, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "chain10.kin",
            "nc = 30, kinematic equations = 20, drivers = 10, KDOF = 10, NDOF = 0",
        ),
        // Followers: the coordinates of their own count in nc.
        (
            "scotch_yoke.kin",
            "nc = 7, kinematic equations = 6, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "eccentric_cam.kin",
            "nc = 7, kinematic equations = 6, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "roller_cam.kin",
            "nc = 8, kinematic equations = 7, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "path_generation.kin",
            "nc = 9, kinematic equations = 8, drivers = 1, KDOF = 1, NDOF = 0",
        ),
        (
            "function_generation.kin",
            "nc = 9, kinematic equations = 8, drivers = 1, KDOF = 1, NDOF = 0",
        ),
    ];
    for (name, want) in expect {
        assert_eq!(dof(name), want, "{name}");
    }
    // Every model in models/ is listed above.
    let mut listed: Vec<&str> = expect.iter().map(|(n, _)| *n).collect();
    listed.sort_unstable();
    let mut found: Vec<String> = std::fs::read_dir(models_dir())
        .map(|rd| {
            rd.filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".kin"))
                .collect()
        })
        .unwrap_or_default();
    found.sort_unstable();
    assert_eq!(found, listed);
}

#[test]
fn chain10_is_generated() {
    let text = std::fs::read_to_string(models_dir().join("chain10.kin")).unwrap_or_default();
    assert_eq!(text, kinema_model::chain::chain_kin(10));
}

#[test]
fn benchmark_structure() {
    // nnz(Phi_q) of benches/peers/README.md.
    assert_eq!(load("slider_crank.kin").1.phi_q.entries.len(), 21);
    assert_eq!(load("four_bar.kin").1.phi_q.entries.len(), 25);
    let n = 10;
    assert_eq!(load("chain10.kin").1.phi_q.entries.len(), 9 * n - 4);
}

#[test]
fn slider_crank_derivation() {
    insta::assert_snapshot!(load("slider_crank.kin").1.render());
}

#[test]
fn four_bar_derivation() {
    insta::assert_snapshot!(load("four_bar.kin").1.render());
}

// ---------------------------------------------------------------- worked examples

// Textbook elimination reads best with indices.
#[allow(clippy::needless_range_loop)]
/// Solves the dense system `a x = b` by Gaussian elimination with partial
/// pivoting.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .unwrap_or(k);
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    x
}

/// Position, velocity and acceleration at time t from the model's guess.
/// (q, ν, q̇, γ, q̈)
type Analysis = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

fn analyse(d: &Derivation, t: f64) -> Analysis {
    let p = d.param_values();
    let mut q = d.guess_values();
    let zero = vec![0.0; q.len()];
    for _ in 0..50 {
        let phi = d.eval_vec(&d.phi, &q, &zero, t, &p);
        if phi.iter().all(|v| v.abs() < 1e-14) {
            break;
        }
        let jac = d.eval_dense(&d.phi_q, &q, &zero, t, &p);
        let dq = solve(jac, phi.iter().map(|v| -v).collect());
        for (qi, dqi) in q.iter_mut().zip(dq) {
            *qi += dqi;
        }
    }
    let phi = d.eval_vec(&d.phi, &q, &zero, t, &p);
    assert!(
        phi.iter().all(|v| v.abs() < 1e-12),
        "no convergence: {phi:?}"
    );
    let jac = d.eval_dense(&d.phi_q, &q, &zero, t, &p);
    let nu = d.eval_vec(&d.nu, &q, &zero, t, &p);
    let qd = solve(jac.clone(), nu.clone());
    let gamma = d.eval_vec(&d.gamma, &q, &qd, t, &p);
    let qdd = solve(jac, gamma.clone());
    (q, nu, qd, gamma, qdd)
}

fn assert_close(what: &str, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!((g - w).abs() < 1e-6, "{what}[{i}]: got {g}, want {w}");
    }
}

/// docs/src/constraints.md, the slider-crank, with rows 7–8 as TRA (the document's form) and as
/// y3 = 0, phi3 = 0 (the benchmark's form): same q, q̇, γ, q̈.
#[test]
// The expected values are the document's 6-digit figures, not constants.
#[allow(clippy::approx_constant)]
fn worked_example_slider_crank() {
    for model in ["slider_crank_translational.kin", "slider_crank.kin"] {
        let (_, d) = load(model);
        let (q, nu, qd, gamma, qdd) = analyse(&d, 0.0);
        assert_close(
            "q",
            &q,
            &[
                0.106066, 0.106066, 0.785398, 0.700753, 0.106066, -0.213756, 1.189373, 0.0, 0.0,
            ],
        );
        assert_close(
            "nu",
            &nu,
            &[
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                2.0 * std::f64::consts::PI,
            ],
        );
        assert_close(
            "qdot",
            &qd,
            &[
                -0.666432, 0.666432, 6.283185, -1.477529, 0.666432, -1.363906, -1.622193, 0.0, 0.0,
            ],
        );
        // Rows 1–6 are written body-minus-other as in the document.
        assert_close(
            "gamma",
            &gamma,
            &[
                -4.187319, -4.187319, 5.096270, 3.990010, 0.908951, -0.197308, 0.0, 0.0, 0.0,
            ],
        );
        assert_close(
            "qddot",
            &qdd,
            &[
                -4.187319, -4.187319, 0.0, -8.417467, -4.187319, 8.165867, -8.460297, 0.0, 0.0,
            ],
        );
        // Φ_q rows 1–6 at this state.
        let jac = d.eval_dense(&d.phi_q, &q, &qd, 0.0, &d.param_values());
        let want: [[f64; 9]; 6] = [
            [1.0, 0.0, 0.106066, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, -0.106066, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [1.0, 0.0, -0.106066, -1.0, 0.0, 0.106066, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.106066, 0.0, -1.0, 0.488621, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0, 0.0, 0.106066, -1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 1.0, 0.488621, 0.0, -1.0, 0.0],
        ];
        for (i, w) in want.iter().enumerate() {
            assert_close(&format!("Phi_q row {}", i + 1), &jac[i], w);
        }
    }
}

/// docs/src/constraints.md: the driven pendulum at t = 0.5.
#[test]
fn worked_example_pendulum() {
    let (_, d) = load("pendulum.kin");
    let (q, nu, qd, gamma, qdd) = analyse(&d, 0.5);
    assert_close("q", &q, &[0.540302, 0.841471, 1.0]);
    assert_close("nu", &nu, &[0.0, 0.0, 4.0]);
    assert_close("qdot", &qd, &[-3.365884, 2.161209, 4.0]);
    assert_close("gamma", &gamma, &[-8.644837, -13.463536, 8.0]);
    assert_close("qddot", &qdd, &[-15.376605, -9.141117, 8.0]);
    // Φ_q = [[1, 0, L sin φ], [0, 1, −L cos φ], [0, 0, 1]], det ≡ 1.
    let jac = d.eval_dense(&d.phi_q, &q, &qd, 0.5, &d.param_values());
    assert_close("Phi_q row 1", &jac[0], &[1.0, 0.0, 1f64.sin()]);
    assert_close("Phi_q row 2", &jac[1], &[0.0, 1.0, -1f64.cos()]);
    assert_close("Phi_q row 3", &jac[2], &[0.0, 0.0, 1.0]);
}

/// The parabola follower stays on its slot over a cycle (a smoke test of a
/// user-written constraint through the whole derivation).
#[test]
fn parabola_follower_moves() {
    let (_, d) = load("parabola_follower.kin");
    for k in 0..5 {
        let t = 0.1 * f64::from(k);
        let (q, _, qd, _, _) = analyse(&d, t);
        assert!(qd.iter().all(|v| v.is_finite()));
        // Tip on the parabola.
        let (x, y, phi) = (q[3], q[4], q[5]);
        let (px, py) = (x + 0.5 * phi.cos(), y + 0.5 * phi.sin());
        assert!((py - (0.2 * px * px - 0.5)).abs() < 1e-12);
    }
}

/// Doc comments are kept: `//!` at the top of a file and `///` on items.
#[test]
fn doc_comments() {
    let src = "//! A file-level comment.\n/// The mechanism.\nmechanism M {\n    //! Inside.\n    /// length\n    param L = 1;\n    /// the bar\n    body bar { guess: (1, 0, 0) }\n    /// pin\n    joint pin: revolute(bar(-L, 0), ground(0, 0));\n    /// motion\n    driver swing: bar.phi == t;\n}\n";
    let d = derive_str(src).unwrap_or_else(|e| panic!("{}", e.render(src, "m.kin")));
    assert_eq!(
        d.docs,
        ["A file-level comment.", "The mechanism.", "Inside."]
    );
    assert_eq!(d.params[0].docs, ["length"]);
    assert_eq!(d.body_docs[0], ["the bar"]);
    assert_eq!(d.rows[0].docs, ["pin"]);
    assert_eq!(d.rows[2].docs, ["motion"]);
}
