//! The serial chain of BENCHMARKS.md as model text: N unit links, the first
//! pinned to ground at the origin, each next one pinned to the tip of the
//! previous one, every link driven by an absolute angle
//! `φ_k = π/4 + 0.3 sin(2πt + k)`; the guess is the exact configuration at
//! t = 0. Rows: all revolutes first, then all drivers (kinematic rows come
//! first in every derivation).

use std::fmt::Write as _;

/// The N-body serial chain as `.kin` text (N ≥ 1; 0 gives an empty,
/// invalid mechanism).
#[must_use]
pub fn chain_kin(n: usize) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "/// Serial chain of {n} unit links (benchmark `chain{n}`), generated."
    );
    let _ = writeln!(s, "mechanism Chain{n} {{");
    let (mut px, mut py) = (0.0f64, 0.0f64);
    for k in 1..=n {
        let phi = std::f64::consts::FRAC_PI_4 + 0.3 * (k as f64).sin();
        let (c, sn) = (phi.cos(), phi.sin());
        let _ = writeln!(
            s,
            "    body b{k} {{ guess: ({:?}, {:?}, {:?}) }}",
            px + 0.5 * c,
            py + 0.5 * sn,
            phi
        );
        px += c;
        py += sn;
    }
    for k in 1..=n {
        if k == 1 {
            let _ = writeln!(s, "    joint pin1: revolute(b1(-0.5, 0), ground(0, 0));");
        } else {
            let _ = writeln!(
                s,
                "    joint pin{k}: revolute(b{}(0.5, 0), b{k}(-0.5, 0));",
                k - 1
            );
        }
    }
    for k in 1..=n {
        let _ = writeln!(
            s,
            "    driver angle{k}: abs_angle(b{k}, pi / 4 + 0.3 * sin(2 * pi * t + {k}));"
        );
    }
    s.push_str("}\n");
    s
}

/// [`chain_kin`] with inertia (unit mass, J = 1/12 about the link's
/// middle) and gravity: the benchmark of inverse dynamics.
#[must_use]
pub fn chain_kin_dynamics(n: usize) -> String {
    let text = chain_kin(n);
    let mut out = String::with_capacity(text.len() + 40 * n);
    for line in text.lines() {
        if line.starts_with("    body ") {
            if let Some(head) = line.strip_suffix(" }") {
                let _ = writeln!(out, "{head}, mass: 1, inertia: 1 / 12 }}");
                continue;
            }
        } else if line == "}" {
            let _ = writeln!(out, "    gravity = (0, -9.81);");
        }
        let _ = writeln!(out, "{line}");
    }
    out
}

/// The forward-dynamics benchmark `fd_chainN` (BENCHMARKS.md, issue 17): N
/// identical uniform links (length 1, mass 1, J = 1/12 about the middle,
/// frames at the link middles), link 1 pinned to ground at the origin at its
/// left end, link k's right end pinned to link k+1's left end, gravity
/// (0, −9.81), no drivers. The guesses are the start itself: every link
/// along +x, collinear and horizontal (released from rest by forward
/// dynamics). N ≥ 1; 0 gives an empty, invalid mechanism.
#[must_use]
pub fn pendulum_chain_kin(n: usize) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "/// Pendulum chain of {n} unit links released from horizontal \
         (benchmark `fd_chain{n}`), generated."
    );
    let _ = writeln!(s, "mechanism PendulumChain{n} {{");
    for k in 1..=n {
        let _ = writeln!(
            s,
            "    body b{k} {{ guess: ({:?}, 0, 0), mass: 1, inertia: 1 / 12 }}",
            k as f64 - 0.5
        );
    }
    let _ = writeln!(s, "    gravity = (0, -9.81);");
    for k in 1..=n {
        if k == 1 {
            let _ = writeln!(s, "    joint pin1: revolute(b1(-0.5, 0), ground(0, 0));");
        } else {
            let _ = writeln!(
                s,
                "    joint pin{k}: revolute(b{}(0.5, 0), b{k}(-0.5, 0));",
                k - 1
            );
        }
    }
    s.push_str("}\n");
    s
}
