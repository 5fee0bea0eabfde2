//! `Options::positions_only`: the same positions as the full analysis, on
//! every back end (generated code, tapes), with ν and γ never evaluated.

use std::cell::Cell;

use kinema::{Auto, Options, Solver, System, Trajectory};

mod generated {
    pub mod slider_crank {
        kinema::mechanism!(file = "models/slider_crank.kin");
    }
    pub mod four_bar {
        kinema::mechanism!(file = "models/four_bar.kin");
    }
    pub mod chain10 {
        kinema::mechanism!(file = "models/chain10.kin");
    }
}

/// 401 times over [0, 2]: two crank revolutions.
fn grid() -> Vec<f64> {
    (0..=400).map(|k| f64::from(k) / 200.0).collect()
}

fn run<S: System>(system: S, options: Options) -> Trajectory {
    let mut solver =
        Solver::<S, Auto>::with_options(system, options).unwrap_or_else(|e| panic!("solver: {e}"));
    solver
        .run(&grid())
        .unwrap_or_else(|e| panic!("analysis failed: {e}"))
}

fn model(path: &str) -> kinema::Model {
    kinema::Model::from_file(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Largest |q_a − q_b| / (1 + |q|) over the grid: on regular rows, and on
/// rows flagged near singular (interpolated between regular states on
/// either side, with slopes that differ: the rates, or backward
/// differences).
fn position_gap(a: &Trajectory, b: &Trajectory) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let (mut regular, mut flagged) = (0.0f64, 0.0f64);
    for (sa, sb) in a.iter().zip(b.iter()) {
        assert_eq!(sa.t(), sb.t());
        assert_eq!(sa.near_singular(), sb.near_singular(), "t = {}", sa.t());
        let worst = if sa.near_singular() {
            &mut flagged
        } else {
            &mut regular
        };
        for (u, v) in sa.q().iter().zip(sb.q()) {
            *worst = worst.max((u - v).abs() / (1.0 + u.abs().max(v.abs())));
        }
    }
    (regular, flagged)
}

/// Both option sets (kinema's defaults and the peers' loop), each with and
/// without positions only: the positions agree to Newton's tolerance.
fn assert_positions_agree<S: System + Clone>(what: &str, system: &S) -> [Trajectory; 2] {
    let mut only = Vec::new();
    for base in [Options::default(), Options::same_algorithm()] {
        let full = run(system.clone(), base);
        let positions = run(system.clone(), base.with_positions_only(true));
        let (regular, flagged) = position_gap(&full, &positions);
        assert!(regular <= 1e-10, "{what}: positions differ by {regular:e}");
        assert!(
            flagged <= 1e-4,
            "{what}: flagged rows differ by {flagged:e}"
        );
        // The same bifurcations, at nearly the same times (positions only
        // locates them with estimated rates: to 2e-4 on the change point;
        // it may also record the near-singular approach as a toggle).
        let bifurcations = |t: &Trajectory| -> Vec<f64> {
            t.events()
                .iter()
                .filter(|e| e.kind == kinema::SingularKind::Bifurcation)
                .map(|e| e.t)
                .collect()
        };
        let (a, b) = (bifurcations(&full), bifurcations(&positions));
        assert_eq!(a.len(), b.len(), "{what}: {a:?} against {b:?}");
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() <= 1e-3,
                "{what}: bifurcation at {x} against {y}"
            );
        }
        only.push(positions);
    }
    let [a, b] = <[Trajectory; 2]>::try_from(only).unwrap_or_else(|_| unreachable!());
    [a, b]
}

#[test]
fn tape_positions_are_those_of_the_full_analysis() {
    for path in [
        "models/slider_crank.kin",
        "models/four_bar.kin",
        "models/chain10.kin",
        "models/pendulum.kin",
        "models/parabola_follower.kin",
        "models/slider_crank_translational.kin",
        "models/scotch_yoke.kin",
        "models/eccentric_cam.kin",
        "models/roller_cam.kin",
        // Singular configurations passed on the analytic continuation.
        "tests/singular/change_point.kin",
        "tests/singular/parallelogram.kin",
        "tests/singular/six_bar.kin",
    ] {
        assert_positions_agree(path, &model(path).system());
    }
}

#[test]
fn generated_positions_are_those_of_the_full_analysis_and_the_tapes() {
    fn both<S: System + Clone>(what: &str, system: &S, path: &str) {
        let generated = assert_positions_agree(what, system);
        let tape = assert_positions_agree(path, &model(path).system());
        for (g, t) in generated.iter().zip(&tape) {
            let (regular, flagged) = position_gap(g, t);
            assert!(
                regular.max(flagged) <= 1e-12,
                "{what}: generated against tape {regular:e}, {flagged:e}"
            );
        }
    }
    both(
        "generated slider-crank",
        &generated::slider_crank::SliderCrank::default(),
        "models/slider_crank.kin",
    );
    both(
        "generated four-bar",
        &generated::four_bar::FourBar::default(),
        "models/four_bar.kin",
    );
    both(
        "generated chain N = 10",
        &generated::chain10::Chain10::default(),
        "models/chain10.kin",
    );
}

/// A system that counts the evaluations the solver asks of it.
#[derive(Clone)]
struct Counting<S> {
    inner: S,
    jacobians: Cell<usize>,
    rates: Cell<usize>,
}

impl<S: System> System for Counting<S> {
    type Scratch = S::Scratch;
    fn scratch(&self) -> S::Scratch {
        self.inner.scratch()
    }
    fn len(&self) -> usize {
        self.inner.len()
    }
    fn coordinate_name(&self, i: usize) -> &str {
        self.inner.coordinate_name(i)
    }
    fn equation_name(&self, i: usize) -> &str {
        self.inner.equation_name(i)
    }
    fn initial_guess(&self, q: &mut [f64]) {
        self.inner.initial_guess(q);
    }
    fn jacobian_pattern(&self) -> &[(u32, u32)] {
        self.inner.jacobian_pattern()
    }
    fn phi(&self, scratch: &mut S::Scratch, q: &[f64], t: f64, phi: &mut [f64]) {
        self.inner.phi(scratch, q, t, phi);
    }
    fn jacobian(&self, scratch: &mut S::Scratch, q: &[f64], t: f64, values: &mut [f64]) {
        self.jacobians.set(self.jacobians.get() + 1);
        self.inner.jacobian(scratch, q, t, values);
    }
    fn phi_and_jacobian(
        &self,
        scratch: &mut S::Scratch,
        q: &[f64],
        t: f64,
        phi: &mut [f64],
        values: &mut [f64],
    ) {
        self.jacobians.set(self.jacobians.get() + 1);
        self.inner.phi_and_jacobian(scratch, q, t, phi, values);
    }
    fn nu(&self, scratch: &mut S::Scratch, q: &[f64], t: f64, nu: &mut [f64]) {
        self.rates.set(self.rates.get() + 1);
        self.inner.nu(scratch, q, t, nu);
    }
    fn gamma(&self, scratch: &mut S::Scratch, q: &[f64], qd: &[f64], t: f64, gamma: &mut [f64]) {
        self.rates.set(self.rates.get() + 1);
        self.inner.gamma(scratch, q, qd, t, gamma);
    }
}

#[test]
fn positions_only_never_evaluates_nu_or_gamma_and_factors_less() {
    let counting = |options: Options| {
        let system = Counting {
            inner: model("models/slider_crank.kin").system(),
            jacobians: Cell::new(0),
            rates: Cell::new(0),
        };
        let mut solver = Solver::<_, Auto>::with_options(system, options)
            .unwrap_or_else(|e| panic!("solver: {e}"));
        let trajectory = solver
            .run(&grid())
            .unwrap_or_else(|e| panic!("analysis failed: {e}"));
        let s = solver.system();
        (s.jacobians.get(), s.rates.get(), trajectory)
    };
    let base = Options::same_algorithm();
    let (full_jacobians, full_rates, full) = counting(base);
    let (jacobians, rates, positions) = counting(base.with_positions_only(true));
    assert_eq!(full_rates, 2 * grid().len(), "ν and γ once per state");
    assert_eq!(rates, 0, "positions only evaluates neither ν nor γ");
    // Full Newton evaluates Φ and Φ_q together at every iterate, the
    // converged one too: the same evaluations either way (the full
    // analysis then factors that Φ_q once more for the rates), and one at
    // the initial guess, where assembly measures the model's size for the
    // residual test.
    let updates: usize = positions.iter().map(|s| s.stats().iterations).sum();
    assert_eq!(jacobians, updates + grid().len() + 1);
    assert_eq!(full_jacobians, jacobians);
    // The same iterations: the peers' loop starts from the previous q
    // either way.
    let full_updates: usize = full.iter().map(|s| s.stats().iterations).sum();
    assert_eq!(full_updates, updates);
}

/// The estimates in place of the rates: zero at assembly, the backward
/// difference after it, then the derivatives of the quadratic through the
/// last three positions (on the uniform grid, the three-point formulas).
#[test]
fn positions_only_rates_are_the_quadratics_derivatives() {
    let options = Options::default().with_positions_only(true);
    let positions = run(model("models/slider_crank.kin").system(), options);
    let states = positions.states();
    assert!(states[0].qd().iter().all(|&v| v == 0.0));
    let h = states[1].t() - states[0].t();
    for ((v, q1), q0) in states[1].qd().iter().zip(states[1].q()).zip(states[0].q()) {
        assert!((v - (q1 - q0) / h).abs() <= 1e-12 * (1.0 + v.abs()));
    }
    assert!(states[1].qdd().iter().all(|&a| a == 0.0));
    for w in states.windows(3) {
        let h = w[2].t() - w[1].t();
        for i in 0..w[2].q().len() {
            let (q, q1, q2) = (w[2].q()[i], w[1].q()[i], w[0].q()[i]);
            let v = (3.0 * q - 4.0 * q1 + q2) / (2.0 * h);
            let a = (q - 2.0 * q1 + q2) / (h * h);
            assert!(
                (w[2].qd()[i] - v).abs() <= 1e-9 * (1.0 + v.abs()),
                "t = {}",
                w[2].t()
            );
            assert!(
                (w[2].qdd()[i] - a).abs() <= 1e-7 * (1.0 + a.abs()),
                "t = {}",
                w[2].t()
            );
        }
    }
}

/// The quadratic's prediction is second order like the full analysis's
/// Taylor polynomial: on a fine grid (1000 steps a turn) one Newton update
/// per step, as with the rates solved (the backward difference needed
/// 1.88).
#[test]
fn positions_only_predicts_at_second_order() {
    let times: Vec<f64> = (0..=1000).map(|k| f64::from(k) / 1000.0).collect();
    let updates = |options: Options| {
        let mut solver = model("models/slider_crank.kin")
            .solver(options)
            .unwrap_or_else(|e| panic!("solver: {e}"));
        let run = solver.run(&times).unwrap_or_else(|e| panic!("{e}"));
        let total: usize = run.iter().skip(1).map(|s| s.stats().iterations).sum();
        total as f64 / 1000.0
    };
    let full = updates(Options::default());
    let positions = updates(Options::default().with_positions_only(true));
    assert!(full <= 1.01 && positions <= 1.05, "{full} {positions}");
}

/// A four-bar (a random one the closed-form tests drew) whose coupler
/// whips round between two steps of a 12-step grid: the estimated rates
/// lag that motion, and Newton from their prediction converged on the
/// other branch, det Φ_q changing sign; the flip was then located as a
/// bifurcation (at t = 0.375) and the run went on on the wrong branch. A
/// flip with estimated rates is now refined with solved ones, as the full
/// analysis refines the step: the same rows, no event.
#[test]
fn a_flip_seen_with_estimated_rates_is_refined_with_solved_ones() {
    const WHIP: &str = "mechanism Whip {
        body b0 { guess: (1.965940738880554e-1, 7.760482571249778e-1, 1.4746265428192498e0) }
        body b1 { guess: (-6.694818106128657e-1, 8.441817410772818e-1, 2.0129655294521847e0) }
        body b2 { guess: (-9.962263414612453e-1, 6.591944927764004e-2, 1.9935792761408777e-1) }
        joint j0: revolute(b0(-1.2272725913992506e0, -7.934206611781868e-1),
            ground(8.685038424439782e-1, -5.217389450400725e-1));
        driver turn: abs_angle(b0, 1.4746265428192498e0 + -6.4719584736680975e0 * t);
        joint a0_0: revolute(b1(-2.2225820985063556e0, -5.71136870763931e-1),
            b0(-1.6307387954087196e0, -7.612813090233893e-1));
        joint a0_1: revolute(b2(1.5068508848606137e0, -6.156215919165638e-1),
            ground(6.026974682276194e-1, -2.3909232828045024e-1));
        joint q0: revolute(b1(-1.7540373251857733e0, 2.10354331143338e-1),
            b2(6.91943682297907e-1, -1.0550207072327413e0));
    }";
    let model = kinema::Model::from_source(WHIP, "whip.kin").unwrap_or_else(|e| panic!("{e}"));
    let times: Vec<f64> = (0..=12).map(|k| f64::from(k) / 12.0).collect();
    let run = |options: Options| {
        model
            .solver(options)
            .unwrap_or_else(|e| panic!("{e}"))
            .run(&times)
            .unwrap_or_else(|e| panic!("{e}"))
    };
    let newton = Options::default().with_closed_form(false);
    let full = run(newton);
    for options in [
        newton.with_positions_only(true),
        Options::default().with_positions_only(true),
    ] {
        let positions = run(options);
        assert!(positions.events().is_empty(), "{:?}", positions.events());
        let (regular, flagged) = position_gap(&full, &positions);
        assert!(regular.max(flagged) <= 1e-10, "{regular:e} {flagged:e}");
    }
}
