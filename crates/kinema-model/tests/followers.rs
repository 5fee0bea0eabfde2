//! The follower constraints (`point_follower`, `cam_follower`,
//! `flat_follower`) and the coordinates of their own they need, checked at
//! 100 random off-manifold states each:
//!
//! - Φ against the definition, evaluated here with the curve written as a
//!   Rust closure (independently of the library, which only writes Φ);
//! - Φ_q against central differences of Φ (h = 1e-6);
//! - γ against a directional difference of Φ_q q̇:
//!   γ = −d/dε [Φ_q(q + ε q̇) q̇] (no t in these rows), and ν = 0;
//! - for the point-follower, γ also against Haug's closed form
//!   (docs/src/constraints.md, `point_follower`).
//!
//! Plus snapshots of each derivation.

use kinema_model::{Derivation, derive_str};

type V = [f64; 2];

fn rot(phi: f64, s: V) -> V {
    let (c, sn) = (phi.cos(), phi.sin());
    [c * s[0] - sn * s[1], sn * s[0] + c * s[1]]
}
fn add(u: V, v: V) -> V {
    [u[0] + v[0], u[1] + v[1]]
}
fn sub(u: V, v: V) -> V {
    [u[0] - v[0], u[1] - v[1]]
}
fn sc(c: f64, u: V) -> V {
    [c * u[0], c * u[1]]
}
fn cross(u: V, v: V) -> f64 {
    u[0] * v[1] - u[1] * v[0]
}
fn dot(u: V, v: V) -> f64 {
    u[0] * v[0] + u[1] * v[1]
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// Curve A (in the language and in Rust, with its derivatives):
/// c(u) = (p0 cos u + p1 u, p2 sin u + p3 u²).
const CURVE_A: &str = "(p0 * cos(u) + p1 * u, p2 * sin(u) + p3 * u * u)";
fn curve_a(p: &[f64], u: f64) -> [V; 3] {
    [
        [p[0] * u.cos() + p[1] * u, p[2] * u.sin() + p[3] * u * u],
        [-p[0] * u.sin() + p[1], p[2] * u.cos() + 2.0 * p[3] * u],
        [-p[0] * u.cos(), -p[2] * u.sin() + 2.0 * p[3]],
    ]
}
/// Curve B: c(v) = (p4 + p5 cos v, p6 sin v + p7 v³).
const CURVE_B: &str = "(p4 + p5 * cos(v), p6 * sin(v) + p7 * powi(v, 3))";
fn curve_b(p: &[f64], v: f64) -> [V; 3] {
    [
        [p[4] + p[5] * v.cos(), p[6] * v.sin() + p[7] * v.powi(3)],
        [-p[5] * v.sin(), p[6] * v.cos() + 3.0 * p[7] * v * v],
        [-p[5] * v.cos(), -p[6] * v.sin() + 6.0 * p[7] * v],
    ]
}

const NPARAMS: usize = 10;

/// A model with bodies `bi`, `bj`, coordinates `a1`, `a2`, curves
/// `bi.ca(u)`, `bj.cb(v)` and `ground.cg(u)` (curve A on ground), the
/// follower `call` named `c`, and fillers up to NDOF = 0.
fn model(call: &str, rows: usize) -> (String, Derivation) {
    let mut src = String::from("mechanism T {\n");
    for k in 0..NPARAMS {
        src += &format!("    param p{k} = {};\n", 0.5 + k as f64 * 0.1);
    }
    src += "    body bi { guess: (0, 0, 0) }\n    body bj { guess: (0, 0, 0) }\n";
    src += "    coord a1 { guess: 0.1 }\n    coord a2;\n";
    src += &format!("    curve bi.ca(u) = {CURVE_A};\n");
    src += &format!("    curve bj.cb(v) = {CURVE_B};\n");
    src += &format!("    curve ground.cg(u) = {CURVE_A};\n");
    src += &format!("    constraint c: {call};\n");
    let coords = [
        "bi.x", "bi.y", "bi.phi", "bj.x", "bj.y", "bj.phi", "a1", "a2",
    ];
    for (k, c) in coords.iter().enumerate().take(8 - rows) {
        src += &format!("    driver fill{k}: {c} == t;\n");
    }
    src += "}\n";
    match derive_str(&src) {
        Ok(d) => (src, d),
        Err(e) => panic!("{}\n{src}", e.render(&src, "t.kin")),
    }
}

/// q = [x_i, y_i, φ_i, x_j, y_j, φ_j, α_1, α_2].
struct State {
    q: Vec<f64>,
    qd: Vec<f64>,
    p: Vec<f64>,
}

/// Checks rows `c.*` of `d` at 100 random states: Φ against `phi(state)`,
/// Φ_q and γ against differences.
fn check(name: &str, d: &Derivation, phi: impl Fn(&State) -> Vec<f64>) {
    let idx: Vec<usize> = d
        .rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.equation == "c")
        .map(|(i, _)| i)
        .collect();
    let nc = d.coordinates.len();
    assert_eq!(
        nc, 8,
        "{name}: the coordinates of their own follow the bodies'"
    );
    assert_eq!(d.coordinates[6].name, "a1");
    assert_eq!(d.coordinates[7].name, "a2");
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ (name.len() as u64 * 7919));
    let t = 0.3;
    for _ in 0..100 {
        let s = State {
            q: (0..nc).map(|_| rng.range(-2.0, 2.0)).collect(),
            qd: (0..nc).map(|_| rng.range(-2.0, 2.0)).collect(),
            p: (0..NPARAMS).map(|_| rng.range(0.3, 1.5)).collect(),
        };
        let at = |q: &[f64]| d.eval_vec(&d.phi, q, &s.qd, t, &s.p);
        let jac_at = |q: &[f64]| d.eval_dense(&d.phi_q, q, &s.qd, t, &s.p);
        let f = at(&s.q);
        let want = phi(&s);
        assert_eq!(idx.len(), want.len(), "{name}: rows");
        for (r, &i) in idx.iter().enumerate() {
            close(name, "Phi", f[i], want[r], 1e-12);
        }
        // Φ_q: central differences of Φ.
        let jac = jac_at(&s.q);
        let h = 1e-6;
        for c in 0..nc {
            let (mut qp, mut qm) = (s.q.clone(), s.q.clone());
            qp[c] += h;
            qm[c] -= h;
            let (fp, fm) = (at(&qp), at(&qm));
            for &i in &idx {
                close(name, "Phi_q", jac[i][c], (fp[i] - fm[i]) / (2.0 * h), 1e-7);
            }
        }
        // γ = −d/dε [Φ_q(q + ε q̇) q̇]; ν = 0.
        let eps = 1e-6;
        let shifted = |e: f64| -> Vec<f64> {
            let q: Vec<f64> = s.q.iter().zip(&s.qd).map(|(q, v)| q + e * v).collect();
            let j = jac_at(&q);
            j.iter()
                .map(|row| row.iter().zip(&s.qd).map(|(a, b)| a * b).sum())
                .collect()
        };
        let (gp, gm) = (shifted(eps), shifted(-eps));
        let gamma = d.eval_vec(&d.gamma, &s.q, &s.qd, t, &s.p);
        let nu = d.eval_vec(&d.nu, &s.q, &s.qd, t, &s.p);
        for &i in &idx {
            close(
                name,
                "gamma",
                gamma[i],
                -(gp[i] - gm[i]) / (2.0 * eps),
                1e-6,
            );
            close(name, "nu", nu[i], 0.0, 0.0);
        }
    }
}

fn close(name: &str, what: &str, got: f64, want: f64, rel: f64) {
    let tol = rel * want.abs().max(1.0);
    assert!(
        (got - want).abs() <= tol,
        "{name}: {what}: engine {got:e}, expected {want:e}"
    );
}

fn ri(s: &State) -> V {
    [s.q[0], s.q[1]]
}
fn rj(s: &State) -> V {
    [s.q[3], s.q[4]]
}

#[test]
fn point_follower_on_a_moving_curve() {
    // Pin on bi at (p8, p9), curve B on bj at a2.
    let (_, d) = model("point_follower(bi(p8, p9), bj.cb, a2)", 2);
    check("point_follower", &d, |s| {
        let pin = add(ri(s), rot(s.q[2], [s.p[8], s.p[9]]));
        let c = add(rj(s), rot(s.q[5], curve_b(&s.p, s.q[7])[0]));
        sub(pin, c).to_vec()
    });
    // γ against docs/src/constraints.md (`point_follower`, i the pin's body, j the curve's):
    // γ = A_i s'_i φ̇_i² − A_j c' φ̇_j² + 2φ̇_j α̇ B_j c'_α + α̇² A_j c'_αα
    let mut rng = Rng(7);
    for _ in 0..100 {
        let q: Vec<f64> = (0..8).map(|_| rng.range(-2.0, 2.0)).collect();
        let qd: Vec<f64> = (0..8).map(|_| rng.range(-2.0, 2.0)).collect();
        let p: Vec<f64> = (0..NPARAMS).map(|_| rng.range(0.3, 1.5)).collect();
        let [c, ca, caa] = curve_b(&p, q[7]);
        let (wi, wj, ad) = (qd[2], qd[5], qd[7]);
        let bj = |v: V| rot(q[5], [-v[1], v[0]]);
        let want = add(
            add(
                sub(
                    sc(wi * wi, rot(q[2], [p[8], p[9]])),
                    sc(wj * wj, rot(q[5], c)),
                ),
                sc(2.0 * wj * ad, bj(ca)),
            ),
            sc(ad * ad, rot(q[5], caa)),
        );
        let gamma = d.eval_vec(&d.gamma, &q, &qd, 0.0, &p);
        let rows: Vec<usize> = (0..d.rows.len())
            .filter(|&i| d.rows[i].equation == "c")
            .collect();
        assert_eq!(d.rows[rows[0]].name, "c.x");
        assert_eq!(d.rows[rows[1]].name, "c.y");
        close(
            "point_follower",
            "gamma (PF)",
            gamma[rows[0]],
            want[0],
            1e-12,
        );
        close(
            "point_follower",
            "gamma (PF)",
            gamma[rows[1]],
            want[1],
            1e-12,
        );
    }
}

#[test]
fn point_follower_on_ground() {
    let (_, d) = model("point_follower(bj(p8, p9), ground.cg, a1)", 2);
    check("point_follower_ground", &d, |s| {
        let pin = add(rj(s), rot(s.q[5], [s.p[8], s.p[9]]));
        sub(pin, curve_a(&s.p, s.q[6])[0]).to_vec()
    });
}

#[test]
fn cam_follower() {
    let (_, d) = model("cam_follower(bi.ca, a1, bj.cb, a2)", 3);
    let names: Vec<&str> = d
        .rows
        .iter()
        .filter(|r| r.equation == "c")
        .map(|r| r.name.as_str())
        .collect();
    assert_eq!(names, ["c.1", "c.2", "c.3"]);
    check("cam_follower", &d, |s| {
        let [ci, gi, _] = curve_a(&s.p, s.q[6]);
        let [cj, gj, _] = curve_b(&s.p, s.q[7]);
        let d = sub(add(ri(s), rot(s.q[2], ci)), add(rj(s), rot(s.q[5], cj)));
        let parallel = cross(rot(s.q[2], gi), rot(s.q[5], gj));
        vec![d[0], d[1], parallel]
    });
}

#[test]
fn flat_follower() {
    let (_, d) = model("flat_follower(bi.ca, a1, bj(p8, p9), (p4, p5))", 2);
    check("flat_follower", &d, |s| {
        let [c, g, _] = curve_a(&s.p, s.q[6]);
        let c = add(ri(s), rot(s.q[2], c));
        let t = rot(s.q[2], g);
        let p = add(rj(s), rot(s.q[5], [s.p[8], s.p[9]]));
        let v = [s.p[4], s.p[5]];
        let u = sc(1.0 / dot(v, v).sqrt(), rot(s.q[5], v));
        let n = [-u[1], u[0]];
        vec![dot(n, sub(c, p)), cross(t, u)]
    });
}

#[test]
fn derivations() {
    let small = |call: &str, curves: &str, rows: usize| {
        let mut src = String::from(
            "mechanism F {\n    param R = 0.5;\n    body cam;\n    body f;\n    coord a;\n    coord b;\n",
        );
        src += curves;
        src += &format!("    joint c: {call};\n");
        for (k, c) in ["cam.x", "cam.y", "cam.phi", "f.x", "f.y", "f.phi", "a", "b"]
            .iter()
            .enumerate()
            .take(8 - rows)
        {
            src += &format!("    driver d{k}: {c} == t;\n");
        }
        src += "}\n";
        match derive_str(&src) {
            Ok(d) => d.render(),
            Err(e) => panic!("{}", e.render(&src, "f.kin")),
        }
    };
    let circle = "    curve cam.disc(u) = (R * cos(u), R * sin(u));\n";
    let roller = "    curve f.roller(v) = (R * cos(v), R * sin(v));\n";
    insta::assert_snapshot!(
        "point_follower",
        small("point_follower(f(0, 0), cam.disc, a)", circle, 2)
    );
    insta::assert_snapshot!(
        "cam_follower",
        small(
            "cam_follower(cam.disc, a, f.roller, b)",
            &format!("{circle}{roller}"),
            3
        )
    );
    insta::assert_snapshot!(
        "flat_follower",
        small("flat_follower(cam.disc, a, f(0, 0), (1, 0))", circle, 2)
    );
}

/// Malformed coordinates, curves and follower calls are errors, never
/// panics; the accepted ones derive.
#[test]
fn malformed_items_are_errors() {
    let bad = [
        "coord",
        "coord ;",
        "coord x = 3;",
        "coord c { guess: }",
        "coord c { gues: 1 }",
        "coord c { guess: 1 } extra",
        "coord c { guess: 1, 2 }",
        "curve",
        "curve a",
        "curve a.",
        "curve a.c",
        "curve a.c = (1, 2);",
        "curve a.c() = (1, 2);",
        "curve a.c(u, v) = (u, v);",
        "curve a.c(1) = (1, 2);",
        "curve a.c(u) = ;",
        "curve a.c(u) = (u, u)",
        "curve a.c(pi) = (pi, pi);",
        "coord q; curve ground.c(u) = (u, u); joint j: point_follower(a(0, 0), ground.c, a);",
        "coord q; curve a.c(u) = (u, u); joint j: point_follower(a(0, 0), a.c, q);",
        "coord q; curve ground.c(u) = (u, u); joint j: cam_follower(ground.c, q, ground.c, q);",
        "coord q; joint j: point_follower(a(0, 0), q, q);",
        "coord q; curve ground.c(u) = (u, u); joint j: point_follower(a(0, 0), ground.c, q + 1);",
        "coord q; curve ground.c(u) = (u, u); joint j: point_follower(a(0, 0), ground.c);",
        "coord q; curve ground.c(u) = (u, u); joint j: point_follower(a(0, 0), ground.d, q);",
        "coord q; curve ground.c(u) = (u, u); joint j: point_follower(a(0, 0), (1, 2), q);",
        "coord q; curve ground.c(u) = (1 / (u - u), u); joint j: point_follower(a(0, 0), ground.c, q); constraint k: a.phi == 0; driver d: q == t;",
        "coord q; constraint k: abs_x(a(0, 0), q);",
        "coord q; param p = q;",
        "coord q; point a.p = (q, 0);",
        "coord q; body b { guess: (q, 0, 0) }",
    ];
    for item in bad {
        let src = format!("mechanism M {{\n    body a;\n    {item}\n}}\n");
        let Err(d) = derive_str(&src) else {
            panic!("accepted: {item}");
        };
        assert!(d.has_errors(), "{item}");
        let text = d.render(&src, "m.kin");
        assert!(text.contains("error"), "{item}: {text}");
    }
    // A curve's parameter may shadow a coordinate's name inside the curve.
    let src = "mechanism M {\n    body a;\n    coord q;\n    curve ground.c(q) = (q, 2 * q);\n    joint j: point_follower(a(0, 0), ground.c, q);\n    constraint k: a.phi == 0;\n    driver d: q == t;\n}\n";
    let d = derive_str(src).unwrap_or_else(|e| panic!("{}", e.render(src, "m.kin")));
    assert_eq!(d.dof.ndof(), 0);
}
