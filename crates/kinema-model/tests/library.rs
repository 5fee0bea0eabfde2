//! Every library constraint against the closed forms of docs/src/constraints.md, at
//! 100 random off-manifold states (q, q̇, t, params) each: Φ_q, ν and γ from
//! the engine must equal the closed forms to 1e-12 relative.
//!
//! The closed forms below are transcribed from the document, independently of
//! the library code (which only writes Φ).

use kinema_model::{Derivation, derive_str};

type V = [f64; 2];

fn a(phi: f64, s: V) -> V {
    let (c, sn) = (phi.cos(), phi.sin());
    [c * s[0] - sn * s[1], sn * s[0] + c * s[1]]
}
/// B s = ∂(A s)/∂φ = R A s.
fn b(phi: f64, s: V) -> V {
    let (c, sn) = (phi.cos(), phi.sin());
    [-sn * s[0] - c * s[1], c * s[0] - sn * s[1]]
}
fn r(u: V) -> V {
    [-u[1], u[0]]
}
fn dot(u: V, v: V) -> f64 {
    u[0] * v[0] + u[1] * v[1]
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
fn unit(u: V) -> V {
    sc(1.0 / dot(u, u).sqrt(), u)
}

/// A random state: q, q̇ of two bodies, t, and the params.
struct State {
    q: [f64; 6],
    qd: [f64; 6],
    t: f64,
    p: Vec<f64>,
}

impl State {
    fn ri(&self) -> V {
        [self.q[0], self.q[1]]
    }
    fn rj(&self) -> V {
        [self.q[3], self.q[4]]
    }
    fn phii(&self) -> f64 {
        self.q[2]
    }
    fn phij(&self) -> f64 {
        self.q[5]
    }
    fn rdi(&self) -> V {
        [self.qd[0], self.qd[1]]
    }
    fn rdj(&self) -> V {
        [self.qd[3], self.qd[4]]
    }
    fn wi(&self) -> f64 {
        self.qd[2]
    }
    fn wj(&self) -> f64 {
        self.qd[5]
    }
    fn v(&self, k: usize) -> V {
        [self.p[k], self.p[k + 1]]
    }
    /// f(t) = p_k + p_{k+1} t + p_{k+2} t² and its derivatives (driven);
    /// or the constant p_k (kinematic).
    fn f(&self, k: usize, driven: bool) -> (f64, f64, f64) {
        if driven {
            let (c0, c1, c2) = (self.p[k], self.p[k + 1], self.p[k + 2]);
            (
                c0 + c1 * self.t + c2 * self.t * self.t,
                c1 + 2.0 * c2 * self.t,
                2.0 * c2,
            )
        } else {
            (self.p[k], 0.0, 0.0)
        }
    }
    /// Point on body i with local s: r_i + A_i s, and its velocity.
    fn pi(&self, s: V) -> (V, V) {
        (
            add(self.ri(), a(self.phii(), s)),
            add(self.rdi(), sc(self.wi(), b(self.phii(), s))),
        )
    }
    fn pj(&self, s: V) -> (V, V) {
        (
            add(self.rj(), a(self.phij(), s)),
            add(self.rdj(), sc(self.wj(), b(self.phij(), s))),
        )
    }
    /// w_ij = A_j s_j φ̇_j² − A_i s_i φ̇_i²
    fn w(&self, si: V, sj: V) -> V {
        sub(
            sc(self.wj() * self.wj(), a(self.phij(), sj)),
            sc(self.wi() * self.wi(), a(self.phii(), si)),
        )
    }
}

/// Expected (Φ_q rows over [x_i, y_i, φ_i, x_j, y_j, φ_j], ν, γ).
type Expected = (Vec<[f64; 6]>, Vec<f64>, Vec<f64>);

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

/// The f(t) text for params starting at `k`.
fn f_text(k: usize, driven: bool) -> String {
    if driven {
        format!("(p{k} + p{} * t + p{} * t * t)", k + 1, k + 2)
    } else {
        format!("p{k}")
    }
}

/// Builds a two-body model with the constraint `call` (rows rows) named `c`
/// plus filler constraints to reach NDOF = 0, derives it, and compares at 100
/// random states. `positive` lists params drawn in [0.5, 2] (radii).
fn run(
    name: &str,
    call: &str,
    rows: usize,
    driven: bool,
    nparams: usize,
    positive: &[usize],
    expected: impl Fn(&State) -> Expected,
) {
    let mut src = String::from("mechanism T {\n");
    for k in 0..nparams {
        src += &format!("    param p{k} = {};\n", 0.5 + k as f64 * 0.1);
    }
    src += "    body bi { guess: (0, 0, 0) }\n    body bj { guess: (0, 0, 0) }\n";
    let kw = if driven { "driver" } else { "constraint" };
    src += &format!("    {kw} c: {call};\n");
    let coords = ["bi.x", "bi.y", "bi.phi", "bj.x", "bj.y", "bj.phi"];
    for (k, c) in coords.iter().enumerate().take(6 - rows) {
        src += &format!("    constraint fill{k}: {c} == 0;\n");
    }
    src += "}\n";
    let d: Derivation = match derive_str(&src) {
        Ok(d) => d,
        Err(e) => panic!("{name}: {}\n{src}", e.render(&src, "t.kin")),
    };
    let idx: Vec<usize> = d
        .rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.equation == "c")
        .map(|(i, _)| i)
        .collect();
    assert_eq!(idx.len(), rows, "{name}");
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ (name.len() as u64 * 7919));
    for _ in 0..100 {
        let mut s = State {
            q: [0.0; 6],
            qd: [0.0; 6],
            t: rng.range(-2.0, 2.0),
            p: (0..nparams).map(|_| rng.range(-2.0, 2.0)).collect(),
        };
        for k in 0..6 {
            s.q[k] = rng.range(-3.0, 3.0);
            s.qd[k] = rng.range(-3.0, 3.0);
        }
        for &k in positive {
            s.p[k] = rng.range(0.5, 2.0);
        }
        let (eq, en, eg) = expected(&s);
        let jac = d.eval_dense(&d.phi_q, &s.q, &s.qd, s.t, &s.p);
        let nu = d.eval_vec(&d.nu, &s.q, &s.qd, s.t, &s.p);
        let gamma = d.eval_vec(&d.gamma, &s.q, &s.qd, s.t, &s.p);
        for (r, &i) in idx.iter().enumerate() {
            for c in 0..6 {
                close(name, "Phi_q", jac[i][c], eq[r][c]);
            }
            close(name, "nu", nu[i], en[r]);
            close(name, "gamma", gamma[i], eg[r]);
        }
    }
}

fn close(name: &str, what: &str, got: f64, want: f64) {
    let tol = 1e-12 * want.abs().max(1.0);
    assert!(
        (got - want).abs() <= tol,
        "{name}: {what}: engine {got:e}, closed form {want:e}"
    );
}

fn row(i: [f64; 3], j: [f64; 3]) -> [f64; 6] {
    [i[0], i[1], i[2], j[0], j[1], j[2]]
}

// ---------------------------------------------------------------- §1

#[test]
fn abs_x_and_abs_y() {
    for driven in [false, true] {
        let f = f_text(2, driven);
        run(
            "AX",
            &format!("abs_x(bi(p0, p1), {f})"),
            1,
            driven,
            5,
            &[],
            |s| {
                let sp = s.v(0);
                let (_, fd, fdd) = s.f(2, driven);
                let phi = s.phii();
                let g = a(phi, sp)[0] * s.wi() * s.wi() + fdd;
                (
                    vec![row([1.0, 0.0, b(phi, sp)[0]], [0.0; 3])],
                    vec![fd],
                    vec![g],
                )
            },
        );
        run(
            "AY",
            &format!("abs_y(bi(p0, p1), {f})"),
            1,
            driven,
            5,
            &[],
            |s| {
                let sp = s.v(0);
                let (_, fd, fdd) = s.f(2, driven);
                let phi = s.phii();
                let g = a(phi, sp)[1] * s.wi() * s.wi() + fdd;
                (
                    vec![row([0.0, 1.0, b(phi, sp)[1]], [0.0; 3])],
                    vec![fd],
                    vec![g],
                )
            },
        );
    }
}

#[test]
fn abs_angle() {
    for driven in [false, true] {
        let f = f_text(0, driven);
        run(
            "AA",
            &format!("abs_angle(bj, {f})"),
            1,
            driven,
            3,
            &[],
            |s| {
                let (_, fd, fdd) = s.f(0, driven);
                (vec![row([0.0; 3], [0.0, 0.0, 1.0])], vec![fd], vec![fdd])
            },
        );
    }
}

#[test]
fn abs_distance() {
    for driven in [false, true] {
        let f = f_text(4, driven);
        run(
            "AD",
            &format!("abs_distance(bi(p0, p1), (p2, p3), {f})"),
            1,
            driven,
            7,
            &[],
            |s| {
                let sp = s.v(0);
                let c = s.v(2);
                let (cc, cd, cdd) = s.f(4, driven);
                let (p, pd) = s.pi(sp);
                let h = sub(p, c);
                let phi = s.phii();
                let jq = row([2.0 * h[0], 2.0 * h[1], 2.0 * dot(h, b(phi, sp))], [0.0; 3]);
                let nu = 2.0 * cc * cd;
                let g = -2.0 * dot(pd, pd)
                    + 2.0 * s.wi() * s.wi() * dot(h, a(phi, sp))
                    + 2.0 * (cd * cd + cc * cdd);
                (vec![jq], vec![nu], vec![g])
            },
        );
    }
}

// ---------------------------------------------------------------- §2

#[test]
fn rel_x_rel_y() {
    for driven in [false, true] {
        let f = f_text(4, driven);
        for (k, nm) in [(0usize, "RX"), (1, "RY")] {
            let call = format!(
                "{}(bi(p0, p1), bj(p2, p3), {f})",
                if k == 0 { "rel_x" } else { "rel_y" }
            );
            run(nm, &call, 1, driven, 7, &[], |s| {
                let (si, sj) = (s.v(0), s.v(2));
                let (_, fd, fdd) = s.f(4, driven);
                let mut ei = [0.0; 3];
                let mut ej = [0.0; 3];
                ei[k] = -1.0;
                ej[k] = 1.0;
                ei[2] = -b(s.phii(), si)[k];
                ej[2] = b(s.phij(), sj)[k];
                (vec![row(ei, ej)], vec![fd], vec![s.w(si, sj)[k] + fdd])
            });
        }
    }
}

#[test]
fn rel_angle() {
    for driven in [false, true] {
        let f = f_text(0, driven);
        run(
            "RA",
            &format!("rel_angle(bi, bj, {f})"),
            1,
            driven,
            3,
            &[],
            |s| {
                let (_, fd, fdd) = s.f(0, driven);
                (
                    vec![row([0.0, 0.0, -1.0], [0.0, 0.0, 1.0])],
                    vec![fd],
                    vec![fdd],
                )
            },
        );
    }
}

/// RD / RR / D share Φ = dᵀd − f with f = C² (RD, RR) or f (D).
fn distance_expected(s: &State, squared: bool, driven: bool) -> Expected {
    let (si, sj) = (s.v(0), s.v(2));
    let (pi, pdi) = s.pi(si);
    let (pj, pdj) = s.pj(sj);
    let d = sub(pj, pi);
    let dd = sub(pdj, pdi);
    let (c, cd, cdd) = s.f(4, driven);
    let (nu, extra) = if squared {
        (2.0 * c * cd, 2.0 * (cd * cd + c * cdd))
    } else {
        (cd, cdd)
    };
    let jq = row(
        [-2.0 * d[0], -2.0 * d[1], -2.0 * dot(d, b(s.phii(), si))],
        [2.0 * d[0], 2.0 * d[1], 2.0 * dot(d, b(s.phij(), sj))],
    );
    let g = -2.0 * dot(dd, dd) + 2.0 * dot(d, s.w(si, sj)) + extra;
    (vec![jq], vec![nu], vec![g])
}

#[test]
fn rel_distance_revolute_revolute_and_d() {
    for driven in [false, true] {
        let f = f_text(4, driven);
        run(
            "RD",
            &format!("rel_distance(bi(p0, p1), bj(p2, p3), {f})"),
            1,
            driven,
            7,
            &[],
            |s| distance_expected(s, true, driven),
        );
        run(
            "D",
            &format!("d(bi(p0, p1), bj(p2, p3), {f})"),
            1,
            driven,
            7,
            &[],
            |s| distance_expected(s, false, driven),
        );
    }
    run(
        "RR",
        "revolute_revolute(bi(p0, p1), bj(p2, p3), p4)",
        1,
        false,
        5,
        &[],
        |s| distance_expected(s, true, false),
    );
}

#[test]
fn revolute() {
    let expected = |s: &State| -> Expected {
        let (si, sj) = (s.v(0), s.v(2));
        let (bi, bj) = (b(s.phii(), si), b(s.phij(), sj));
        let g = sub(
            sc(s.wi() * s.wi(), a(s.phii(), si)),
            sc(s.wj() * s.wj(), a(s.phij(), sj)),
        );
        (
            vec![
                row([1.0, 0.0, bi[0]], [-1.0, 0.0, -bj[0]]),
                row([0.0, 1.0, bi[1]], [0.0, -1.0, -bj[1]]),
            ],
            vec![0.0, 0.0],
            vec![g[0], g[1]],
        )
    };
    run(
        "REV",
        "revolute(bi(p0, p1), bj(p2, p3))",
        2,
        false,
        4,
        &[],
        expected,
    );
    // Named points give the same rows.
    let src = "mechanism T { param p0 = 1; param p1 = 2; param p2 = 3; param p3 = 4;
        body bi; body bj; point bi.a = (p0, p1); point bj.b = (p2, p3);
        joint c: revolute(bi.a, bj.b);
        constraint f0: bi.x == 0; constraint f1: bi.y == 0; constraint f2: bi.phi == 0;
        constraint f3: bj.phi == 0; }";
    let d = derive_str(src).unwrap_or_else(|e| panic!("{}", e.render(src, "t.kin")));
    let d2 = derive_str(
        "mechanism T { param p0 = 1; param p1 = 2; param p2 = 3; param p3 = 4;
        body bi; body bj; joint c: revolute(bi(p0, p1), bj(p2, p3));
        constraint f0: bi.x == 0; constraint f1: bi.y == 0; constraint f2: bi.phi == 0;
        constraint f3: bj.phi == 0; }",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let text = |d: &Derivation| {
        d.phi[..2]
            .iter()
            .map(|&e| d.arena.display(e).to_string())
            .collect::<Vec<_>>()
    };
    assert_eq!(text(&d), text(&d2));
}

#[test]
fn translational() {
    run(
        "TRA",
        "translational(bi(p0, p1), (p2, p3), bj(p4, p5), (p6, p7))",
        2,
        false,
        8,
        &[],
        |s| {
            let (si, vi, sj, vj) = (s.v(0), s.v(2), s.v(4), s.v(6));
            let (pi, _) = s.pi(si);
            let (pj, _) = s.pj(sj);
            let d = sub(pj, pi);
            let ui = a(s.phii(), vi);
            let ni = b(s.phii(), vi);
            let uj = a(s.phij(), vj);
            let rji = sub(s.rj(), s.ri());
            let rdji = sub(s.rdj(), s.rdi());
            let dw = s.wj() - s.wi();
            let row1 = row(
                [-ni[0], -ni[1], -dot(ui, d) - dot(vi, si)],
                [ni[0], ni[1], dot(ni, b(s.phij(), sj))],
            );
            let row2 = row([0.0, 0.0, -dot(ui, uj)], [0.0, 0.0, dot(ui, uj)]);
            let g1 = s.wi() * s.wi() * dot(ni, rji)
                + 2.0 * s.wi() * dot(ui, rdji)
                + dw * dw * dot(ni, a(s.phij(), sj));
            let g2 = dw * dw * dot(ni, uj);
            (vec![row1, row2], vec![0.0, 0.0], vec![g1, g2])
        },
    );
}

/// RT / RP row 1: n̂ᵀd − c with unit v̂.
fn rt_expected(s: &State, si: V, v: V, sj: V, cd: f64, cdd: f64) -> ([f64; 6], f64, f64) {
    let vh = unit(v);
    let (pi, _) = s.pi(si);
    let (pj, _) = s.pj(sj);
    let d = sub(pj, pi);
    let u = a(s.phii(), vh);
    let n = b(s.phii(), vh);
    let dw = s.wj() - s.wi();
    let jq = row(
        [-n[0], -n[1], -dot(u, d) - dot(vh, si)],
        [n[0], n[1], dot(n, b(s.phij(), sj))],
    );
    let g = s.wi() * s.wi() * dot(n, sub(s.rj(), s.ri()))
        + 2.0 * s.wi() * dot(u, sub(s.rdj(), s.rdi()))
        + dw * dw * dot(n, a(s.phij(), sj))
        + cdd;
    (jq, cd, g)
}

#[test]
fn revolute_translational() {
    for driven in [false, true] {
        let f = f_text(6, driven);
        run(
            "RT",
            &format!("revolute_translational(bi(p0, p1), (p2, p3), bj(p4, p5), {f})"),
            1,
            driven,
            9,
            &[],
            |s| {
                let (_, cd, cdd) = s.f(6, driven);
                let (jq, nu, g) = rt_expected(s, s.v(0), s.v(2), s.v(4), cd, cdd);
                (vec![jq], vec![nu], vec![g])
            },
        );
    }
}

#[test]
fn gear() {
    run(
        "GEAR",
        "gear(bi(p0, p1), bj(p2, p3), p4, p5, p6, p7)",
        1,
        false,
        8,
        &[4, 5],
        |s| {
            let (si, sj) = (s.v(0), s.v(2));
            let (ri, rj, thi, thj) = (s.p[4], s.p[5], s.p[6], s.p[7]);
            let ki = ri / (ri + rj);
            let kj = rj / (ri + rj);
            let alpha = ki * (s.phii() + thi) + kj * (s.phij() + thj);
            let e = [alpha.cos(), alpha.sin()];
            let ep = r(e);
            let (pi, pdi) = s.pi(si);
            let (pj, pdj) = s.pj(sj);
            let d = sub(pj, pi);
            let dd = sub(pdj, pdi);
            let ad = ki * s.wi() + kj * s.wj();
            let jq = row(
                [-ep[0], -ep[1], -dot(ep, b(s.phii(), si)) - ki * dot(e, d)],
                [ep[0], ep[1], dot(ep, b(s.phij(), sj)) - kj * dot(e, d)],
            );
            let g = dot(ep, s.w(si, sj)) + 2.0 * ad * dot(e, dd) + ad * ad * dot(ep, d);
            (vec![jq], vec![0.0], vec![g])
        },
    );
}

#[test]
fn rack_pinion() {
    run(
        "RP",
        "rack_pinion(bi(p0, p1), (p2, p3), bj(p4, p5), p6, p7)",
        2,
        false,
        8,
        &[6],
        |s| {
            let (si, v, sj, rp) = (s.v(0), s.v(2), s.v(4), s.p[6]);
            let (row1, _, g1) = rt_expected(s, si, v, sj, 0.0, 0.0);
            let vh = unit(v);
            let (pi, _) = s.pi(si);
            let (pj, _) = s.pj(sj);
            let d = sub(pj, pi);
            let u = a(s.phii(), vh);
            let n = b(s.phii(), vh);
            let dw = s.wj() - s.wi();
            let row2 = row(
                [-u[0], -u[1], dot(n, d) - dot(u, b(s.phii(), si)) - rp],
                [u[0], u[1], dot(u, b(s.phij(), sj)) + rp],
            );
            let g2 = s.wi() * s.wi() * dot(u, sub(s.rj(), s.ri()))
                - 2.0 * s.wi() * dot(n, sub(s.rdj(), s.rdi()))
                + dw * dw * dot(u, a(s.phij(), sj));
            (vec![row1, row2], vec![0.0, 0.0], vec![g1, g2])
        },
    );
}

/// DP2 closed form (§4), also the translational-distance driver with a' = v̂.
fn dp2_expected(s: &State, si: V, ap: V, sj: V, fd: f64, fdd: f64) -> Expected {
    let (pi, _) = s.pi(si);
    let (pj, _) = s.pj(sj);
    let d = sub(pj, pi);
    let ai = a(s.phii(), ap);
    let bai = b(s.phii(), ap);
    let dw = s.wj() - s.wi();
    let jq = row(
        [-ai[0], -ai[1], dot(bai, d) - dot(ai, b(s.phii(), si))],
        [ai[0], ai[1], dot(ai, b(s.phij(), sj))],
    );
    let g = s.wi() * s.wi() * dot(ai, sub(s.rj(), s.ri()))
        - 2.0 * s.wi() * dot(bai, sub(s.rdj(), s.rdi()))
        + dw * dw * dot(ai, a(s.phij(), sj))
        + fdd;
    (vec![jq], vec![fd], vec![g])
}

#[test]
fn translational_distance() {
    for driven in [false, true] {
        let f = f_text(6, driven);
        run(
            "TD",
            &format!("translational_distance(bi(p0, p1), (p2, p3), bj(p4, p5), {f})"),
            1,
            driven,
            9,
            &[],
            |s| {
                let (_, fd, fdd) = s.f(6, driven);
                dp2_expected(s, s.v(0), unit(s.v(2)), s.v(4), fd, fdd)
            },
        );
    }
}

// ---------------------------------------------------------------- §4

#[test]
fn dp1() {
    for driven in [false, true] {
        let f = f_text(4, driven);
        run(
            "DP1",
            &format!("dp1(bi, (p0, p1), bj, (p2, p3), {f})"),
            1,
            driven,
            7,
            &[],
            |s| {
                let (ap, bp) = (s.v(0), s.v(2));
                let (_, fd, fdd) = s.f(4, driven);
                let ai = a(s.phii(), ap);
                let aj = a(s.phij(), bp);
                let kappa = dot(ai, b(s.phij(), bp));
                let dw = s.wj() - s.wi();
                (
                    vec![row([0.0, 0.0, -kappa], [0.0, 0.0, kappa])],
                    vec![fd],
                    vec![dw * dw * dot(ai, aj) + fdd],
                )
            },
        );
    }
}

#[test]
fn dp2() {
    for driven in [false, true] {
        let f = f_text(6, driven);
        run(
            "DP2",
            &format!("dp2(bi(p0, p1), (p2, p3), bj(p4, p5), {f})"),
            1,
            driven,
            9,
            &[],
            |s| {
                let (_, fd, fdd) = s.f(6, driven);
                dp2_expected(s, s.v(0), s.v(2), s.v(4), fd, fdd)
            },
        );
    }
}

#[test]
fn cd() {
    for driven in [false, true] {
        let f = f_text(6, driven);
        run(
            "CD",
            &format!("cd((p0, p1), bi(p2, p3), bj(p4, p5), {f})"),
            1,
            driven,
            9,
            &[],
            |s| {
                let (c, si, sj) = (s.v(0), s.v(2), s.v(4));
                let (_, fd, fdd) = s.f(6, driven);
                let jq = row(
                    [-c[0], -c[1], -dot(c, b(s.phii(), si))],
                    [c[0], c[1], dot(c, b(s.phij(), sj))],
                );
                (vec![jq], vec![fd], vec![dot(c, s.w(si, sj)) + fdd])
            },
        );
    }
}

/// Ground as body i: REV to ground and RX from a ground point.
#[test]
fn ground_variants() {
    run(
        "REVg",
        "revolute(bj(p0, p1), ground(p2, p3))",
        2,
        false,
        4,
        &[],
        |s| {
            let sj = s.v(0);
            let bj = b(s.phij(), sj);
            let g = sc(s.wj() * s.wj(), a(s.phij(), sj));
            (
                vec![
                    row([0.0; 3], [1.0, 0.0, bj[0]]),
                    row([0.0; 3], [0.0, 1.0, bj[1]]),
                ],
                vec![0.0, 0.0],
                vec![g[0], g[1]],
            )
        },
    );
    run(
        "RXg",
        "rel_x(ground(p0, p1), bj(p2, p3), p4)",
        1,
        false,
        5,
        &[],
        |s| {
            let sj = s.v(2);
            let g = s.wj() * s.wj() * a(s.phij(), sj)[0];
            (
                vec![row([0.0; 3], [1.0, 0.0, b(s.phij(), sj)[0]])],
                vec![0.0],
                vec![g],
            )
        },
    );
}
