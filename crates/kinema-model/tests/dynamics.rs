//! The dynamics derivation: Q_A of every force element against its
//! definition evaluated by hand, and ∂Q_A/∂q, ∂Q_A/∂q̇ against central
//! finite differences of Q_A, element by element.

use kinema_model::{Derivation, derive_str};

/// Two free-ish bodies, fully driven (NDOF = 0 is a rule of the language),
/// with one force element `force`.
fn model(force: &str) -> Derivation {
    let src = format!(
        "mechanism M {{
            param k = 30;
            gravity = (0.3, -9.81);
            body a {{ mass: 2, inertia: 0.5, guess: (0.4, 0.2, 0.3) }}
            body b {{ guess: (1.1, -0.3, -0.6), inertia: 0.7, mass: 3 }}
            {force}
            driver ax: a.x == 0.4 + t;
            driver ay: a.y == 0.2;
            driver ap: a.phi == t;
            driver bx: b.x == 1;
            driver by: b.y == t;
            driver bp: b.phi == 2 * t;
        }}"
    );
    match derive_str(&src) {
        Ok(d) => d,
        Err(e) => panic!("{}", e.render(&src, "m.kin")),
    }
}

const Q: [f64; 6] = [0.37, -0.21, 0.83, 1.12, 0.44, -0.58];
const QD: [f64; 6] = [0.9, -1.3, 2.1, -0.4, 0.75, -1.6];
const T: f64 = 0.63;

fn applied(d: &Derivation, q: &[f64], qd: &[f64]) -> Vec<f64> {
    let dy = d
        .dynamics
        .as_ref()
        .expect("a model with forces has dynamics");
    d.eval_vec(&dy.applied, q, qd, T, &d.param_values())
}

/// Q_A minus gravity (m g on x, y of each body).
fn force_only(d: &Derivation, q: &[f64], qd: &[f64]) -> Vec<f64> {
    let mut out = applied(d, q, qd);
    let g = [0.3, -9.81];
    for (k, m) in [2.0, 3.0].into_iter().enumerate() {
        out[3 * k] -= m * g[0];
        out[3 * k + 1] -= m * g[1];
    }
    out
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

fn check_derivatives(force: &str) {
    let d = model(force);
    let dy = d.dynamics.as_ref().expect("dynamics");
    let p = d.param_values();
    let jq = d.eval_dense(&dy.applied_q, &Q, &QD, T, &p);
    let jqd = d.eval_dense(&dy.applied_qd, &Q, &QD, T, &p);
    let h = 1e-6;
    let mut nonzero = 0;
    for k in 0..6 {
        for (which, jac) in [(0, &jq), (1, &jqd)] {
            let (mut qp, mut qm, mut vp, mut vm) = (Q, Q, QD, QD);
            if which == 0 {
                qp[k] += h;
                qm[k] -= h;
            } else {
                vp[k] += h;
                vm[k] -= h;
            }
            let fp = applied(&d, &qp, &vp);
            let fm = applied(&d, &qm, &vm);
            for i in 0..6 {
                let fd = (fp[i] - fm[i]) / (2.0 * h);
                let exact = jac[i][k];
                if exact != 0.0 {
                    nonzero += 1;
                }
                assert!(
                    close(exact, fd, 1e-7),
                    "{force}: d Q[{i}] / d {}[{k}] = {exact}, finite difference {fd}",
                    ["q", "qd"][which]
                );
            }
        }
    }
    assert!(nonzero > 0, "{force}: no derivative at all");
}

const ELEMENTS: [&str; 6] = [
    "force push: point_force(a(0.5, 0.1), (a.y * 3 + b.x_dot, sin(t) + a.phi_dot * a.phi));",
    "force local: point_force_local(b(-0.2, 0.3), (2 * b.phi, a.x_dot - t));",
    "force twist: torque(b, a.phi * b.phi_dot + cos(a.x));",
    "force ground_spring: rsda(ground, a, k, 4, 0.2, sin(t));",
    "force spring: rsda(a, b, 12, 1.5, -0.1);",
    "force strut: tsda(a(0.5, 0), b(-0.3, 0.1), 50, 3, 0.7, t);",
];

#[test]
fn derivatives_of_every_element_match_finite_differences() {
    for e in ELEMENTS {
        check_derivatives(e);
    }
    check_derivatives(&ELEMENTS.join("\n"));
}

fn rot(phi: f64, s: [f64; 2]) -> [f64; 2] {
    let (c, si) = (phi.cos(), phi.sin());
    [c * s[0] - si * s[1], si * s[0] + c * s[1]]
}

/// Q of a force F at local point s on body k: [F; (B s)ᵀ F].
fn point_q(q: &[f64], k: usize, s: [f64; 2], f: [f64; 2]) -> [f64; 3] {
    let bs = rot(q[3 * k + 2], [-s[1], s[0]]);
    [f[0], f[1], bs[0] * f[0] + bs[1] * f[1]]
}

#[test]
fn applied_forces_match_their_definitions() {
    let (q, qd, t) = (Q, QD, T);
    let mut want: Vec<[f64; 6]> = Vec::new();
    // point_force
    let f = [q[1] * 3.0 + qd[3], t.sin() + qd[2] * q[2]];
    let a = point_q(&q, 0, [0.5, 0.1], f);
    want.push([a[0], a[1], a[2], 0.0, 0.0, 0.0]);
    // point_force_local
    let f = rot(q[5], [2.0 * q[5], qd[0] - t]);
    let b = point_q(&q, 1, [-0.2, 0.3], f);
    want.push([0.0, 0.0, 0.0, b[0], b[1], b[2]]);
    // torque
    want.push([0.0, 0.0, 0.0, 0.0, 0.0, q[2] * qd[5] + q[0].cos()]);
    // rsda to ground (simEngine2D RSDA1: Q_i −= n)
    let n = 30.0 * (q[2] - 0.2) + 4.0 * qd[2] + t.sin();
    want.push([0.0, 0.0, -n, 0.0, 0.0, 0.0]);
    // rsda between bodies (RSDA2: Q_i += n, Q_j −= n)
    let n = 12.0 * (q[5] - q[2] + 0.1) + 1.5 * (qd[5] - qd[2]);
    want.push([0.0, 0.0, n, 0.0, 0.0, -n]);
    // tsda
    let pi = {
        let r = rot(q[2], [0.5, 0.0]);
        [q[0] + r[0], q[1] + r[1]]
    };
    let pj = {
        let r = rot(q[5], [-0.3, 0.1]);
        [q[3] + r[0], q[4] + r[1]]
    };
    let vel = |k: usize, s: [f64; 2]| {
        let bs = rot(q[3 * k + 2], [-s[1], s[0]]);
        [
            qd[3 * k] + bs[0] * qd[3 * k + 2],
            qd[3 * k + 1] + bs[1] * qd[3 * k + 2],
        ]
    };
    let d = [pj[0] - pi[0], pj[1] - pi[1]];
    let l = d[0].hypot(d[1]);
    let (vi, vj) = (vel(0, [0.5, 0.0]), vel(1, [-0.3, 0.1]));
    let ldot = (d[0] * (vj[0] - vi[0]) + d[1] * (vj[1] - vi[1])) / l;
    let n = 50.0 * (l - 0.7) + 3.0 * ldot + t;
    let u = [n * d[0] / l, n * d[1] / l];
    let a = point_q(&q, 0, [0.5, 0.0], u);
    let b = point_q(&q, 1, [-0.3, 0.1], [-u[0], -u[1]]);
    want.push([a[0], a[1], a[2], b[0], b[1], b[2]]);
    for (e, w) in ELEMENTS.iter().zip(&want) {
        let got = force_only(&model(e), &q, &qd);
        for i in 0..6 {
            assert!(
                close(got[i], w[i], 1e-13),
                "{e}: Q[{i}] = {}, by hand {}",
                got[i],
                w[i]
            );
        }
    }
}

#[test]
fn mass_matrix_and_gravity() {
    let d = model("");
    let dy = d.dynamics.as_ref().expect("inertia makes dynamics");
    let p = d.param_values();
    let m = d.eval_vec(&dy.mass, &Q, &QD, T, &p);
    assert_eq!(m, vec![2.0, 2.0, 0.5, 3.0, 3.0, 0.7]);
    let q = applied(&d, &Q, &QD);
    assert_eq!(
        q,
        vec![2.0 * 0.3, 2.0 * -9.81, 0.0, 3.0 * 0.3, 3.0 * -9.81, 0.0]
    );
}

#[test]
fn kinematic_models_have_no_dynamics() {
    let src = "mechanism P { body bar { guess: (1, 0, 0) }
        joint pin: revolute(bar(-1, 0), ground(0, 0));
        driver swing: bar.phi == t; }";
    let d = derive_str(src).unwrap_or_else(|e| panic!("{}", e.render(src, "p.kin")));
    assert!(d.dynamics.is_none());
}
