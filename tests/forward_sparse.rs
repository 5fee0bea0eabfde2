//! The sparse side of the `ForwardSystem` contract: the `*_values` methods
//! HHT's sparse Newton matrix reads (in the order of `structure()`), on
//! generated code and on tapes, against the dense methods; the default
//! `*_values` (gathered from the dense methods) for a system that gives a
//! structure and nothing else; HHT's sparse path against its dense one;
//! and no allocation per step on the sparse path.

use kinema::{DenseScratch, ForwardStructure, ForwardSystem, Hht, HhtOptions, Model};

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

/// A system that forwards the dense methods and the structure of `S` and
/// nothing else: HHT reads its sparse values through the trait's default
/// `*_values` (gathered from the dense methods).
#[derive(Clone)]
struct DenseOnly<S>(S);

impl<S: ForwardSystem> ForwardSystem for DenseOnly<S> {
    fn coords(&self) -> usize {
        self.0.coords()
    }
    fn rows(&self) -> usize {
        self.0.rows()
    }
    fn coordinate_name(&self, i: usize) -> &str {
        self.0.coordinate_name(i)
    }
    fn equation_name(&self, i: usize) -> &str {
        self.0.equation_name(i)
    }
    fn initial_state(&mut self, q: &mut [f64], qd: &mut [f64]) {
        self.0.initial_state(q, qd);
    }
    fn phi(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
        self.0.phi(q, t, out);
    }
    fn jacobian(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
        self.0.jacobian(q, t, out);
    }
    fn nu(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
        self.0.nu(q, t, out);
    }
    fn gamma(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        self.0.gamma(q, qd, t, out);
    }
    fn mass(&mut self, q: &[f64], out: &mut [f64]) {
        self.0.mass(q, out);
    }
    fn applied(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        self.0.applied(q, qd, t, out);
    }
    fn applied_q(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        self.0.applied_q(q, qd, t, out);
    }
    fn applied_qd(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        self.0.applied_qd(q, qd, t, out);
    }
    fn constraint_hessian(&mut self, q: &[f64], lambda: &[f64], t: f64, out: &mut [f64]) {
        self.0.constraint_hessian(q, lambda, t, out);
    }
    fn structure(&self) -> Option<ForwardStructure> {
        self.0.structure()
    }
}

/// A state off the configuration manifold, every velocity nonzero, and a
/// λ with every entry different.
fn moving_state(q0: &[f64], m: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let q = q0
        .iter()
        .enumerate()
        .map(|(i, v)| v + 0.01 * (i as f64 + 1.0).sin())
        .collect();
    let qd = (0..q0.len())
        .map(|i| 0.5 * (i as f64 + 0.5).cos())
        .collect();
    let lambda = (0..m).map(|i| 1.0 + 0.3 * i as f64).collect();
    (q, qd, lambda)
}

/// The four sparse matrices of `s` at one state: each `*_values` output
/// scattered dense (repeats adding up), and the dense method's matrix.
fn sparse_and_dense<S: ForwardSystem>(
    s: &mut S,
    (q, qd, lambda): (&[f64], &[f64], &[f64]),
) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let (n, m) = (s.coords(), s.rows());
    let st = s.structure().expect("a structure");
    let t = 0.37;
    let mut out = Vec::new();
    for (k, positions) in [&st.jacobian, &st.applied_q, &st.applied_qd, &st.hessian]
        .into_iter()
        .enumerate()
    {
        let rows = if k == 0 { m } else { n };
        let mut buffer = vec![f64::NAN; rows * n];
        let mut values = vec![f64::NAN; positions.len()];
        let dense = DenseScratch {
            buffer: &mut buffer,
            cols: n,
            positions,
        };
        match k {
            0 => s.jacobian_values(q, t, dense, &mut values),
            1 => s.applied_q_values(q, qd, t, dense, &mut values),
            2 => s.applied_qd_values(q, qd, t, dense, &mut values),
            _ => s.constraint_hessian_values(q, lambda, t, dense, &mut values),
        }
        let mut scattered = vec![f64::NAN; rows * n];
        DenseScratch::scatter(&values, positions, (rows, n), &mut scattered);
        let mut full = vec![f64::NAN; rows * n];
        match k {
            0 => s.jacobian(q, t, &mut full),
            1 => s.applied_q(q, qd, t, &mut full),
            2 => s.applied_qd(q, qd, t, &mut full),
            _ => s.constraint_hessian(q, lambda, t, &mut full),
        }
        out.push((values, scattered, full));
    }
    out
}

const NAMES: [&str; 4] = ["Φ_q", "∂Q_A/∂q", "∂Q_A/∂q̇", "∂(Φ_qᵀλ)/∂q"];

/// Values against dense matrices on both back ends and through the
/// default methods; generated against tape.
fn values_agree<G: ForwardSystem + Clone>(src: &str, generated: G) {
    let m = model(src);
    let tape = m.forward_system().expect("inertia");
    let (q, qd, lambda) = moving_state(&m.initial_configuration(), tape.rows());
    let at = (&q[..], &qd[..], &lambda[..]);
    let g = sparse_and_dense(&mut generated.clone(), at);
    let t = sparse_and_dense(&mut tape.clone(), at);
    let dg = sparse_and_dense(&mut DenseOnly(generated), at);
    let dt = sparse_and_dense(&mut DenseOnly(tape), at);
    let mut nonzero = 0;
    for (k, name) in NAMES.iter().enumerate() {
        for (which, x) in [
            ("generated", &g[k]),
            ("tape", &t[k]),
            ("default (generated)", &dg[k]),
            ("default (tape)", &dt[k]),
        ] {
            // The values, scattered, are the dense matrix, bit for bit.
            assert_eq!(x.1, x.2, "{which} {name}: values against the dense matrix");
            assert!(x.0.iter().all(|v| v.is_finite()), "{which} {name}");
        }
        // The default gives what the system's own method gives (its
        // repeated positions once, at the first).
        assert_eq!(dg[k].1, g[k].1, "{name}: default against generated");
        // Generated against tape: the same list of values to rounding.
        let scale = g[k].0.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
        for (a, b) in g[k].0.iter().zip(&t[k].0) {
            assert!((a - b).abs() <= 1e-14 * scale, "{name}: {a} against {b}");
        }
        assert_eq!(g[k].0.len(), t[k].0.len(), "{name}");
        nonzero += g[k].0.iter().filter(|v| **v != 0.0).count();
    }
    assert!(nonzero > 10, "the matrices are not all zero");
}

#[test]
fn slider_crank_values_agree_with_the_dense_matrices() {
    values_agree(SLIDER_CRANK, FdSliderCrank::default().forward());
}

#[test]
fn chain10_values_agree_with_the_dense_matrices() {
    values_agree(CHAIN10, FdChain10::default().forward());
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// q, q̇, λ and the counters after 1000 steps of 1 ms from rest.
fn run<S: ForwardSystem>(
    s: S,
    q0: &[f64],
    sparse_from: usize,
) -> (Vec<Vec<f64>>, kinema::integrate::HhtStats) {
    let qd0 = vec![0.0; q0.len()];
    let options = HhtOptions {
        sparse_from,
        ..HhtOptions::default()
    };
    let (mut h, _) = Hht::new(s, q0, &qd0, 0.0, options).expect("start");
    h.advance_to(1.0, 1e-3).expect("run");
    (
        vec![h.q().to_vec(), h.qd().to_vec(), h.lambda().to_vec()],
        h.stats(),
    )
}

/// HHT's sparse Newton matrix from the values (generated, tape, and the
/// default methods) against the dense Newton matrix: the same motion (q,
/// q̇) to 1e-12 relative, λ to Newton's tolerance on it, the same Newton
/// iterations.
#[test]
fn sparse_path_follows_the_dense_path() {
    let m = model(CHAIN10);
    let q0 = m.initial_configuration();
    let tape = m.forward_system().expect("inertia");
    let generated = FdChain10::default().forward();
    let (dense, dense_stats) = run(generated.clone(), &q0, usize::MAX);
    let runs = [
        ("generated", run(generated.clone(), &q0, 0)),
        ("tape", run(tape.clone(), &q0, 0)),
        ("default (generated)", run(DenseOnly(generated), &q0, 0)),
        ("default (tape)", run(DenseOnly(tape), &q0, 0)),
    ];
    for (name, (x, stats)) in &runs {
        // λ is held by Newton to √tolerance relative (HhtOptions::tolerance):
        // the two factorizations' rounding moves it within that.
        let lambda_tolerance = HhtOptions::default().tolerance.sqrt();
        for (k, (what, tolerance)) in [("q", 1e-12), ("q̇", 1e-12), ("λ", lambda_tolerance)]
            .into_iter()
            .enumerate()
        {
            let d = max_rel(&x[k], &dense[k]);
            eprintln!("{name}, sparse against dense, {what}: {d:e}");
            assert!(d <= tolerance, "{name} {what}: {d:e}");
        }
        assert_eq!(stats.steps, dense_stats.steps, "{name}");
        assert_eq!(stats.iterations, dense_stats.iterations, "{name}");
    }
    // The default methods build the very same matrix as the values.
    assert_eq!(runs[0].1, runs[2].1);
    assert!(max_rel(&dense[0], &q0) > 0.01, "the chain fell");
}

/// The sparse path allocates nothing per step, on generated code and on
/// tapes.
#[test]
fn sparse_steps_do_not_allocate() {
    let m = model(CHAIN10);
    let q0 = m.initial_configuration();
    let options = HhtOptions {
        sparse_from: 0,
        ..HhtOptions::default()
    };
    fn count<S: ForwardSystem>(s: S, q0: &[f64], options: HhtOptions) -> usize {
        let qd0 = vec![0.0; q0.len()];
        let (mut h, _) = Hht::new(s, q0, &qd0, 0.0, options).expect("start");
        // From the first step on: the sparse LU chose its pivots and
        // recorded its elimination in `Hht::new`.
        let before = allocations();
        for _ in 0..200 {
            h.step(1e-3).expect("step");
        }
        h.advance_to(0.5, 1e-3).expect("advance");
        allocations() - before
    }
    let generated = count(FdChain10::default().forward(), &q0, options);
    let tape = count(m.forward_system().expect("inertia"), &q0, options);
    assert_eq!(
        generated, 0,
        "generated: HHT steps on the sparse path allocated"
    );
    assert_eq!(tape, 0, "tape: HHT steps on the sparse path allocated");
    let before = allocations();
    let probe = std::hint::black_box(vec![1u8; 16]);
    assert!(
        allocations() > before && probe.len() == 16,
        "the counter counts"
    );
}
