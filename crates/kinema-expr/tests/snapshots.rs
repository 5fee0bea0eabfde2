//! Printed derivatives of textbook expressions, pinned with insta. The
//! numbers behind these strings are checked elsewhere (properties.rs); these
//! snapshots pin the canonical forms and the printer.

use std::fmt::Write;

use kinema_expr::{Arena, ExprId, SymId};

/// One coordinate named `name` at index `i`, with its velocity `name_dot`.
fn coord(a: &mut Arena, name: &str, i: u32) -> (ExprId, SymId, ExprId) {
    let e = a.coordinate(name, i);
    let v = a.velocity(&format!("{name}_dot"), i);
    (e, a.symbol_of(e).expect("symbol"), v)
}

fn derivatives(a: &mut Arena, e: ExprId, wrt: &[SymId]) -> String {
    let mut out = format!("f = {}\n", a.display(e));
    for &s in wrt {
        let d = a.diff(e, s);
        let name = a.symbol(s).name.clone();
        let _ = writeln!(out, "df/d{name} = {}", a.display(d));
    }
    out
}

#[test]
fn textbook_derivatives() {
    let mut a = Arena::new();
    let x = a.coordinate("x", 0);
    let y = a.coordinate("y", 1);
    let sx = a.symbol_of(x).expect("symbol");
    let sy = a.symbol_of(y).expect("symbol");
    let mut text = String::new();

    // Product rule: x² sin x
    let x2 = a.powi(x, 2);
    let s = a.sin(x);
    let e = a.mul(x2, s);
    text += &derivatives(&mut a, e, &[sx]);
    // Quotient rule: (x + 1)/(x − 1)
    let one = a.one();
    let n = a.add(x, one);
    let d = a.sub(x, one);
    let e = a.div(n, d);
    text += &derivatives(&mut a, e, &[sx]);
    // Chain rule: ln(cos x)
    let c = a.cos(x);
    let e = a.ln(c);
    text += &derivatives(&mut a, e, &[sx]);
    // Distance: sqrt(x² + y²)
    let y2 = a.powi(y, 2);
    let r2 = a.add(x2, y2);
    let e = a.sqrt(r2);
    text += &derivatives(&mut a, e, &[sx, sy]);
    // Angle: atan2(y, x)
    let e = a.atan2(y, x);
    text += &derivatives(&mut a, e, &[sx, sy]);
    // exp(−x²/2)
    let h = a.scale(-0.5, x2);
    let e = a.exp(h);
    text += &derivatives(&mut a, e, &[sx]);
    // tan x, and the smooth step from 0 to 1 over [0, 2]
    let e = a.tan(x);
    text += &derivatives(&mut a, e, &[sx]);
    let (z, two) = (a.zero(), a.num(2.0));
    let e = a.step(x, z, z, two, one);
    text += &derivatives(&mut a, e, &[sx]);
    // x^y (non-constant exponent)
    let e = a.pow(x, y);
    text += &derivatives(&mut a, e, &[sx, sy]);
    insta::assert_snapshot!(text);
}

/// `r + A(φ)·s'` for body coordinates (x, y, φ) and a body-fixed point s'.
fn global_point(a: &mut Arena, q: [ExprId; 3], s: [ExprId; 2]) -> [ExprId; 2] {
    let (c, sn) = (a.cos(q[2]), a.sin(q[2]));
    let xc = a.mul(s[0], c);
    let ys = a.mul(s[1], sn);
    let xs = a.mul(s[0], sn);
    let yc = a.mul(s[1], c);
    let gx = a.sub(xc, ys);
    let gy = a.add(xs, yc);
    [a.add(q[0], gx), a.add(q[1], gy)]
}

/// The revolute joint of two bodies, Φ = r_i + A_i s'_i − r_j − A_j s'_j,
/// with its Jacobian, ν and γ = −(Φ_q q̇)_q q̇ built by directional derivatives.
fn revolute(a: &mut Arena, si: [ExprId; 2], sj: [ExprId; 2]) -> String {
    let names = ["x1", "y1", "phi1", "x2", "y2", "phi2"];
    let mut q = Vec::new();
    let mut syms = Vec::new();
    let mut seeds = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let (e, s, v) = coord(a, name, i as u32);
        q.push(e);
        syms.push(s);
        seeds.push((s, v));
    }
    let pi = global_point(a, [q[0], q[1], q[2]], si);
    let pj = global_point(a, [q[3], q[4], q[5]], sj);
    let phi = [a.sub(pi[0], pj[0]), a.sub(pi[1], pj[1])];
    let jac = a.jacobian(&phi, &syms);
    let v = a.seeds(&seeds);
    let mut text = String::new();
    for (k, &p) in phi.iter().enumerate() {
        let _ = writeln!(text, "Phi[{k}] = {}", a.display(p));
    }
    for e in &jac.entries {
        let _ = writeln!(
            text,
            "Phi_q[{}, {}] = {}",
            e.row,
            names[e.col as usize],
            a.display(e.expr)
        );
    }
    for (k, &p) in phi.iter().enumerate() {
        let w = a.directional(p, v);
        let wq = a.directional(w, v);
        let gamma = a.neg(wq);
        let _ = writeln!(text, "gamma[{k}] = {}", a.display(gamma));
    }
    text
}

#[test]
fn revolute_joint_of_two_bodies_numeric_points() {
    // docs/src/constraints.md, the slider-crank, rows 3–4: crank (0.15, 0) to rod (−0.5, 0).
    let mut a = Arena::new();
    let si = [a.num(0.15), a.zero()];
    let sj = [a.num(-0.5), a.zero()];
    insta::assert_snapshot!(revolute(&mut a, si, sj));
}

#[test]
fn revolute_joint_of_two_bodies_symbolic_points() {
    let mut a = Arena::new();
    let si = [a.parameter("ax", 0), a.parameter("ay", 1)];
    let sj = [a.parameter("bx", 2), a.parameter("by", 3)];
    insta::assert_snapshot!(revolute(&mut a, si, sj));
}
