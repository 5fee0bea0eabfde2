//! Static equilibrium: pendEQL (a pendulum on a torsional spring, the
//! simEngine2D model written as `.kin`) has a stable equilibrium and an
//! unstable one between it and the start; plain Newton on the stationarity
//! equations lands on the unstable one, the descent must not.

use kinema::Model;
use kinema::equilibrium::{Stability, equilibrium_from};

const PEND_EQL: &str = "
mechanism PendulumEQL {
    body pend { guess: (-0.707106781186548, 0.707106781186548, 2.356194490192345), mass: 10, inertia: 10 }
    constraint absX_pend: abs_x(pend(-1, 0), 0);
    constraint absY_pend: abs_y(pend(-1, 0), 0);
    gravity = (0, -9.81);
    force RSDA: rsda(ground, pend, 25, 50, 1, 0);
}";

const M: f64 = 10.0;
const G: f64 = 9.81;
const K: f64 = 25.0;

/// V'(φ) of V = m g sin φ + ½ k (φ − 1)² (the centroid is at (cos φ, sin φ)).
fn dv(phi: f64) -> f64 {
    M * G * phi.cos() + K * (phi - 1.0)
}

fn d2v(phi: f64) -> f64 {
    -M * G * phi.sin() + K
}

fn bisect(mut a: f64, mut b: f64) -> f64 {
    assert!(dv(a) * dv(b) < 0.0);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if dv(a) * dv(m) <= 0.0 {
            b = m;
        } else {
            a = m;
        }
    }
    0.5 * (a + b)
}

#[test]
fn pend_eql_reaches_the_stable_equilibrium() -> Result<(), Box<dyn std::error::Error>> {
    let model = Model::from_source(PEND_EQL, "pendEQL.kin")?;
    let stable = bisect(3.0, 4.5);
    let unstable = bisect(1.0, 2.0);
    assert!(d2v(stable) > 0.0 && d2v(unstable) < 0.0);
    // Plain Newton on V'(φ) = 0 from the start goes to the unstable root.
    let mut phi: f64 = 2.356194490192345;
    for _ in 0..50 {
        phi -= dv(phi) / d2v(phi);
    }
    assert!((phi - unstable).abs() < 1e-12, "Newton: {phi}");

    let eq = model.equilibrium(0.0)?;
    assert_eq!(eq.stability, Stability::Stable);
    let p = eq.q[2];
    assert!((p - stable).abs() < 1e-9, "φ = {p}, stable root {stable}");
    assert!((eq.q[0] - p.cos()).abs() < 1e-9 && (eq.q[1] - p.sin()).abs() < 1e-9);
    // The reduced Hessian in the unit null direction (−sin φ, cos φ, 1)/√2.
    let h = d2v(stable) / 2.0;
    assert!(
        (eq.eigenvalues[0] - h).abs() < 1e-7 * h,
        "{:?} vs {h}",
        eq.eigenvalues
    );
    // λ: the pin carries the weight (Φ = x of the pin, y of the pin).
    assert!((eq.lambda[1] - (-M * G)).abs() < 1e-8, "{:?}", eq.lambda);
    Ok(())
}

#[test]
fn started_at_the_unstable_root_it_is_not_returned() -> Result<(), Box<dyn std::error::Error>> {
    let model = Model::from_source(PEND_EQL, "pendEQL.kin")?;
    let d = model.derivation();
    let unstable = bisect(1.0, 2.0);
    let start = [unstable.cos(), unstable.sin(), unstable];
    let eq = equilibrium_from(d, &d.param_values(), &start, 0.0)?;
    assert_eq!(eq.stability, Stability::Stable);
    assert!(
        (eq.q[2] - unstable).abs() > 0.5,
        "returned the unstable root {}",
        eq.q[2]
    );
    assert!(
        dv(eq.q[2]).abs() < 1e-7 && d2v(eq.q[2]) > 0.0,
        "φ = {}",
        eq.q[2]
    );
    Ok(())
}
