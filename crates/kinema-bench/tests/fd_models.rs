//! The forward-dynamics benchmark models (BENCHMARKS.md, issue 17) run:
//! `models/fd_slider_crank.kin` and `pendulum_chain_kin(n)` start
//! consistent (nothing to project), integrate with HHT at the benchmark's
//! step, and conserve energy in the accurate mode.

use kinema::{Accurate, Hht, HhtOptions, Model};

fn slider_crank() -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/fd_slider_crank.kin");
    Model::from_file(path).unwrap_or_else(|e| panic!("{e}"))
}

fn chain(n: usize) -> Model {
    let text = kinema_model::chain::pendulum_chain_kin(n);
    Model::from_source(&text, &format!("fd_chain{n}.kin")).unwrap_or_else(|e| panic!("{e}"))
}

/// HHT-α (α = −0.1) at h from rest to `steps · h`: (q, the start's
/// projection ‖Δq‖∞, Newton iterations).
fn hht(model: &Model, h: f64, steps: usize) -> (Vec<f64>, f64, usize) {
    let sys = model.forward_system().expect("the model has inertia");
    let q0 = model.initial_configuration();
    let qd0 = vec![0.0; q0.len()];
    let (mut hht, start) = Hht::new(sys, &q0, &qd0, 0.0, HhtOptions::default()).expect("start");
    for _ in 0..steps {
        hht.step(h).expect("step");
    }
    (hht.q().to_vec(), start.dq, hht.stats().iterations)
}

/// The accurate mode from rest to `t_end` at `rtol`, sampled at 20 times:
/// (q at the end, the largest |kinetic + potential − initial potential|,
/// the largest |potential − initial potential| as the scale).
fn accurate_energy(model: &Model, t_end: f64, rtol: f64) -> (Vec<f64>, f64, f64) {
    let mut sys = model.forward_system().expect("the model has inertia");
    let q0 = model.initial_configuration();
    let v0 = sys.gravity_potential(&q0);
    let qd0 = vec![0.0; q0.len()];
    let mut a = Accurate::new(sys, &q0, &qd0, 0.0, rtol).expect("start");
    let (mut drift, mut scale) = (0.0_f64, 0.0_f64);
    for k in 1..=20 {
        a.advance_to(t_end * f64::from(k) / 20.0).expect("step");
        let ke = a.kinetic_energy();
        let q = a.q().to_vec();
        let v = a.system_mut().gravity_potential(&q);
        drift = drift.max((ke + v - v0).abs());
        scale = scale.max((v - v0).abs());
    }
    (a.q().to_vec(), drift, scale)
}

#[test]
fn fd_slider_crank_starts_consistent_and_falls() {
    let m = slider_crank();
    let q0 = m.initial_configuration();
    // The crank at 45°, the slider at 0.3 cos 45° + √(1 − (0.3 sin 45°)²).
    let s = 0.3 * std::f64::consts::FRAC_1_SQRT_2;
    assert!((q0[2] - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
    assert!((q0[6] - (s + (1.0 - s * s).sqrt())).abs() < 1e-15, "{q0:?}");
    let (q, dq, iterations) = hht(&m, 1e-3, 1000);
    assert!(dq < 1e-14, "the start moved by {dq}");
    assert!(iterations >= 1000, "{iterations}");
    // Released from rest, gravity turns the crank down through -π/2.
    assert!(q[2] < -std::f64::consts::FRAC_PI_2, "{q:?}");
    let (qa, drift, scale) = accurate_energy(&m, 1.0, 1e-10);
    let diff = q
        .iter()
        .zip(&qa)
        .fold(0.0_f64, |d, (a, b)| d.max((a - b).abs()));
    eprintln!(
        "fd_slider_crank: |HHT − accurate| at t = 1: {diff:.3e}; energy drift {drift:.3e} of {scale:.3e}"
    );
    assert!(diff < 1e-3 && diff > 1e-9, "{diff}");
    assert!(drift < 1e-9 * scale, "{drift} of {scale}");
}

#[test]
fn pendulum_chain_text_is_the_benchmark() {
    let text = kinema_model::chain::pendulum_chain_kin(3);
    assert!(text.contains("joint pin1: revolute(b1(-0.5, 0), ground(0, 0));"));
    assert!(text.contains("joint pin3: revolute(b2(0.5, 0), b3(-0.5, 0));"));
    assert!(text.contains("body b3 { guess: (2.5, 0, 0), mass: 1, inertia: 1 / 12 }"));
    let m = chain(3);
    assert_eq!(
        m.initial_configuration(),
        [0.5, 0.0, 0.0, 1.5, 0.0, 0.0, 2.5, 0.0, 0.0]
    );
}

#[test]
fn fd_chain10_integrates_and_conserves_energy_in_the_accurate_mode() {
    let m = chain(10);
    let (q, dq, _) = hht(&m, 1e-3, 1000);
    assert!(dq == 0.0, "the start moved by {dq}");
    // The chain falls: its tip is below the pivot at t = 1.
    assert!(q[28] < -1.0, "{q:?}");
    let (qa, drift, scale) = accurate_energy(&m, 1.0, 1e-10);
    let diff = q
        .iter()
        .zip(&qa)
        .fold(0.0_f64, |d, (a, b)| d.max((a - b).abs()));
    eprintln!(
        "fd_chain10: |HHT − accurate| at t = 1: {diff:.3e}; energy drift {drift:.3e} of {scale:.3e}"
    );
    assert!(drift < 1e-9 * scale, "{drift} of {scale}");
}

#[test]
fn fd_chain100_integrates() {
    let m = chain(100);
    // A tenth of the benchmark's run (the dense LU of 500 unknowns is slow
    // unoptimized); the whole run is the bench's and the CLI's.
    let (q, dq, iterations) = hht(&m, 1e-3, 100);
    assert!(dq == 0.0, "the start moved by {dq}");
    assert!(iterations >= 100);
    // Every link is still a unit link attached to the previous one.
    for k in 1..100 {
        let (a, b) = (&q[3 * (k - 1)..3 * k], &q[3 * k..3 * k + 3]);
        let tip = (a[0] + 0.5 * a[2].cos(), a[1] + 0.5 * a[2].sin());
        let tail = (b[0] - 0.5 * b[2].cos(), b[1] - 0.5 * b[2].sin());
        assert!((tip.0 - tail.0).abs() < 1e-10 && (tip.1 - tail.1).abs() < 1e-10);
    }
    // The first link has fallen: free fall for 0.1 s is 0.049 m; the pinned
    // link turns down.
    assert!(q[1] < -1e-3, "{:?}", &q[..3]);
}
