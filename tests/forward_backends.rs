//! Forward dynamics on generated code (`mechanism!`) against the tape back
//! end on the same model files: every matrix the integrators read agrees
//! entry by entry at a moving state, and HHT-α and the accurate mode give
//! the same trajectory to 1e-12; generated steps do not allocate (a
//! counting allocator, as in tests/forward_alloc.rs). The models are the
//! lead's forward-dynamics benchmark mechanisms fd_slider_crank (no
//! driver; 3 bodies, NDOF = 1) and fd_chain10 (NDOF = 10).

use kinema::{Accurate, ForwardSystem, Hht, HhtOptions, Model};

mod fd_slider_crank {
    kinema::mechanism!(file = "tests/forward_backends/fd_slider_crank.kin");
}
mod fd_chain10 {
    kinema::mechanism!(file = "tests/forward_backends/fd_chain10.kin");
}

use fd_chain10::FdChain10;
use fd_slider_crank::FdSliderCrank;

const SLIDER_CRANK: &str = include_str!("forward_backends/fd_slider_crank.kin");
const CHAIN10: &str = include_str!("forward_backends/fd_chain10.kin");

#[path = "../crates/kinema-runtime/tests/common/counting.rs"]
mod counting;
use counting::allocations;

fn model(src: &str) -> Model {
    Model::from_source(src, "test.kin").unwrap_or_else(|e| panic!("{e}"))
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Every method of the two systems at one state, compared; returns the
/// largest difference relative to the largest entry of each quantity.
fn compare_at<A: ForwardSystem, B: ForwardSystem>(a: &mut A, b: &mut B, q: &[f64], qd: &[f64]) {
    let (n, m) = (a.coords(), a.rows());
    assert_eq!((n, m), (b.coords(), b.rows()));
    for i in 0..n {
        assert_eq!(a.coordinate_name(i), b.coordinate_name(i));
    }
    for i in 0..m {
        assert_eq!(a.equation_name(i), b.equation_name(i));
    }
    let t = 0.37;
    let lambda: Vec<f64> = (0..m).map(|i| 1.0 + 0.3 * i as f64).collect();
    let mut x = vec![f64::NAN; n * n];
    let mut y = vec![f64::NAN; n * n];
    type Eval<'a, S> = &'a dyn Fn(&mut S, &mut [f64]);
    let mut check = |name: &str, len: usize, fa: Eval<'_, A>, fb: Eval<'_, B>| {
        let (x, y) = (&mut x[..len], &mut y[..len]);
        x.fill(f64::NAN);
        y.fill(f64::NAN);
        fa(a, x);
        fb(b, y);
        let scale = x.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
        let d = max_diff(x, y);
        assert!(
            d <= 1e-14 * scale,
            "{name}: differ by {d:e} (scale {scale})"
        );
        assert!(x.iter().all(|v| v.is_finite()), "{name}: not finite");
    };
    check("phi", m, &|s, o| s.phi(q, t, o), &|s, o| s.phi(q, t, o));
    check("jacobian", m * n, &|s, o| s.jacobian(q, t, o), &|s, o| {
        s.jacobian(q, t, o);
    });
    check("nu", m, &|s, o| s.nu(q, t, o), &|s, o| s.nu(q, t, o));
    check("gamma", m, &|s, o| s.gamma(q, qd, t, o), &|s, o| {
        s.gamma(q, qd, t, o);
    });
    check("mass", n, &|s, o| s.mass(q, o), &|s, o| s.mass(q, o));
    check("applied", n, &|s, o| s.applied(q, qd, t, o), &|s, o| {
        s.applied(q, qd, t, o);
    });
    check(
        "applied_q",
        n * n,
        &|s, o| s.applied_q(q, qd, t, o),
        &|s, o| {
            s.applied_q(q, qd, t, o);
        },
    );
    check(
        "applied_qd",
        n * n,
        &|s, o| s.applied_qd(q, qd, t, o),
        &|s, o| {
            s.applied_qd(q, qd, t, o);
        },
    );
    check(
        "constraint_hessian",
        n * n,
        &|s, o| s.constraint_hessian(q, &lambda, t, o),
        &|s, o| s.constraint_hessian(q, &lambda, t, o),
    );
}

/// A state off the configuration manifold, with every velocity nonzero.
fn moving_state(n: usize, q0: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let q = q0
        .iter()
        .enumerate()
        .map(|(i, v)| v + 0.01 * (i as f64 + 1.0).sin())
        .collect();
    let qd = (0..n).map(|i| 0.5 * (i as f64 + 0.5).cos()).collect();
    (q, qd)
}

#[test]
fn slider_crank_matrices_agree() {
    let m = model(SLIDER_CRANK);
    let mut tape = m.forward_system().expect("inertia");
    let mut generated = FdSliderCrank::default().forward();
    let (q, qd) = moving_state(9, &m.initial_configuration());
    compare_at(&mut generated, &mut tape, &q, &qd);
}

#[test]
fn chain10_matrices_agree() {
    let m = model(CHAIN10);
    let mut tape = m.forward_system().expect("inertia");
    let mut generated = FdChain10::default().forward();
    let (q, qd) = moving_state(30, &m.initial_configuration());
    compare_at(&mut generated, &mut tape, &q, &qd);
}

/// HHT-α (α = −0.1, h = 1 ms, 1000 steps) and the accurate mode from rest,
/// generated against tape: q, q̇, λ at t = 1 to 1e-12.
fn trajectories_agree<G: ForwardSystem + Clone, T: ForwardSystem + Clone>(
    generated: G,
    tape: T,
    q0: &[f64],
) {
    let qd0 = vec![0.0; q0.len()];
    let options = HhtOptions::default();
    let (mut a, _) = Hht::new(generated.clone(), q0, &qd0, 0.0, options).expect("start");
    let (mut b, _) = Hht::new(tape.clone(), q0, &qd0, 0.0, options).expect("start");
    for _ in 0..1000 {
        a.step(1e-3).expect("generated step");
        b.step(1e-3).expect("tape step");
    }
    assert!((a.t() - 1.0).abs() < 1e-12 && a.t() == b.t());
    assert!(max_diff(a.q(), b.q()) <= 1e-12, "HHT q");
    assert!(max_diff(a.qd(), b.qd()) <= 1e-12, "HHT q̇");
    let scale = b.lambda().iter().fold(1.0_f64, |s, v| s.max(v.abs()));
    assert!(max_diff(a.lambda(), b.lambda()) <= 1e-12 * scale, "HHT λ");
    // The motion is real: the mechanism fell.
    assert!(max_diff(a.q(), q0) > 0.1);
    assert_eq!(a.stats(), b.stats());

    let mut a = Accurate::new(generated, q0, &qd0, 0.0, 1e-10).expect("start");
    let mut b = Accurate::new(tape, q0, &qd0, 0.0, 1e-10).expect("start");
    a.advance_to(1.0).expect("generated");
    b.advance_to(1.0).expect("tape");
    assert!(max_diff(a.q(), b.q()) <= 1e-12, "accurate q");
    assert!(max_diff(a.qd(), b.qd()) <= 1e-12, "accurate q̇");
}

#[test]
fn slider_crank_trajectories_agree() {
    let m = model(SLIDER_CRANK);
    let tape = m.forward_system().expect("inertia");
    trajectories_agree(
        FdSliderCrank::default().forward(),
        tape,
        &m.initial_configuration(),
    );
}

#[test]
fn chain10_trajectories_agree() {
    let m = model(CHAIN10);
    let tape = m.forward_system().expect("inertia");
    trajectories_agree(
        FdChain10::default().forward(),
        tape,
        &m.initial_configuration(),
    );
}

#[test]
fn generated_steps_do_not_allocate() {
    let m = model(SLIDER_CRANK);
    let q0 = m.initial_configuration();
    let qd0 = vec![0.0; q0.len()];
    let sys = FdSliderCrank::default().forward();
    let (mut hht, _) = Hht::new(sys.clone(), &q0, &qd0, 0.0, HhtOptions::default()).expect("start");
    hht.step(1e-3).expect("first step");
    let before = allocations();
    for _ in 0..200 {
        hht.step(1e-3).expect("step");
    }
    hht.advance_to(0.5, 1e-3).expect("advance");
    let hht_allocations = allocations() - before;

    let mut acc = Accurate::new(sys, hht.q(), hht.qd(), hht.t(), 1e-9).expect("start");
    acc.advance_to(0.55).expect("first");
    let before = allocations();
    for k in 1..=20 {
        acc.advance_to(0.55 + 0.01 * f64::from(k)).expect("advance");
    }
    let accurate_allocations = allocations() - before;
    // The counter counts.
    let before = allocations();
    let probe = std::hint::black_box(vec![1u8; 16]);
    assert!(allocations() > before && probe.len() == 16);
    assert_eq!(hht_allocations, 0, "HHT steps allocated");
    assert_eq!(accurate_allocations, 0, "accurate steps allocated");
}

/// HHT's sparse factorization of Newton's matrix (fixed pattern from
/// `ForwardSystem::structure`, the runtime's sparse LU) against the dense
/// one, on both back ends of the chain: the same Newton iterations and the
/// same motion to rounding.
#[test]
fn sparse_newton_matrix_matches_dense() {
    let m = model(CHAIN10);
    let q0 = m.initial_configuration();
    let qd0 = vec![0.0; q0.len()];
    let tape = m.forward_system().expect("inertia");
    let generated = FdChain10::default().forward();
    // The two back ends give the same structure, in the same order (their
    // `*_values` methods are read by position).
    let (a, b) = (
        generated.structure().expect("generated structure"),
        tape.structure().expect("tape structure"),
    );
    assert_eq!(a, b);
    assert!(!a.hessian.is_empty() && !a.jacobian.is_empty());
    let run = |sparse_from: usize, tape_backend: bool| {
        let options = HhtOptions {
            sparse_from,
            ..HhtOptions::default()
        };
        let (q, stats) = if tape_backend {
            let (mut h, _) = Hht::new(tape.clone(), &q0, &qd0, 0.0, options).expect("start");
            h.advance_to(1.0, 1e-3).expect("run");
            (h.q().to_vec(), h.stats())
        } else {
            let (mut h, _) = Hht::new(generated.clone(), &q0, &qd0, 0.0, options).expect("start");
            h.advance_to(1.0, 1e-3).expect("run");
            (h.q().to_vec(), h.stats())
        };
        (q, stats)
    };
    let (dense, dense_stats) = run(usize::MAX, false);
    for tape_backend in [false, true] {
        let (sparse, stats) = run(0, tape_backend);
        let d = max_diff(&dense, &sparse);
        eprintln!("sparse (tape {tape_backend}) against dense: {d:e}, {stats:?} / {dense_stats:?}");
        assert!(d <= 1e-9, "sparse against dense: {d:e}");
        assert_eq!(stats.steps, dense_stats.steps);
    }
    assert!(max_diff(&dense, &q0) > 0.1);
}
