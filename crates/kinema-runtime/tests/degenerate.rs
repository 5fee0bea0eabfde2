//! Degenerate systems (issue 42): a system without coordinates (Φ_q is
//! 0 × 0) and a 1 × 1 one run without a singular configuration and without
//! a "failed" diagnosis; the rank rule answers for both sizes; a system
//! that reports a function outside its domain (`System::undefined`) stops
//! the run before the step that would cross it, at the point, whether it
//! is a time of the grid or lies between two.

use kinema_runtime::diagnose::{dependency, rank};
use kinema_runtime::{Domain, Error, Solver, System, Undefined};

/// n = 0 (no coordinates) or n = 1: Φ = k q − sin t, or Φ = q − 1/(t − c)
/// when `pole` is `Some(c)` (reporting its pole through
/// `System::undefined`).
struct Tiny {
    n: usize,
    k: f64,
    pole: Option<f64>,
    pattern: Vec<(u32, u32)>,
}

impl Tiny {
    fn new(n: usize, k: f64, pole: Option<f64>) -> Tiny {
        Tiny {
            n,
            k,
            pole,
            pattern: (0..n).map(|_| (0, 0)).collect(),
        }
    }

    fn driver(&self, t: f64) -> f64 {
        match self.pole {
            Some(c) => 1.0 / (t - c),
            None => t.sin(),
        }
    }

    fn driver_rate(&self, t: f64) -> f64 {
        match self.pole {
            Some(c) => -1.0 / ((t - c) * (t - c)),
            None => t.cos(),
        }
    }

    fn driver_acceleration(&self, t: f64) -> f64 {
        match self.pole {
            Some(c) => 2.0 / ((t - c) * (t - c) * (t - c)),
            None => -t.sin(),
        }
    }
}

impl System for Tiny {
    type Scratch = ();

    fn scratch(&self) {}

    fn len(&self) -> usize {
        self.n
    }

    fn coordinate_name(&self, _: usize) -> &str {
        "x"
    }

    fn equation_name(&self, _: usize) -> &str {
        "drive"
    }

    fn initial_guess(&self, q: &mut [f64]) {
        q.fill(0.0);
    }

    fn jacobian_pattern(&self) -> &[(u32, u32)] {
        &self.pattern
    }

    fn undefined(&self, (): &mut (), _: &[f64], t: f64, t_error: f64) -> Option<Undefined> {
        let c = self.pole?;
        // The divisor t − c within 16 bounds of 0 (as the tapes decide).
        ((t - c).abs() <= 16.0 * t_error.abs()).then_some(Undefined {
            equation: 0,
            function: "division",
            domain: Domain::Pole,
            argument: t - c,
        })
    }

    fn phi(&self, (): &mut (), q: &[f64], t: f64, phi: &mut [f64]) {
        if let (Some(p), Some(&x)) = (phi.first_mut(), q.first()) {
            *p = self.k * x - self.driver(t);
        }
    }

    fn jacobian(&self, (): &mut (), _: &[f64], _: f64, values: &mut [f64]) {
        values.fill(self.k);
    }

    fn nu(&self, (): &mut (), _: &[f64], t: f64, nu: &mut [f64]) {
        nu.fill(self.driver_rate(t));
    }

    fn gamma(&self, (): &mut (), _: &[f64], _: &[f64], t: f64, gamma: &mut [f64]) {
        gamma.fill(self.driver_acceleration(t));
    }
}

fn grid(steps: usize) -> Vec<f64> {
    (0..=steps).map(|i| i as f64 / steps as f64).collect()
}

#[test]
fn a_system_without_coordinates_runs_and_is_never_singular() {
    let mut solver = Solver::<_, kinema_runtime::Auto>::new(Tiny::new(0, 1.0, None))
        .unwrap_or_else(|e| panic!("{e}"));
    let trajectory = solver.run(&grid(3)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(trajectory.len(), 4);
    assert!(trajectory.events().is_empty(), "{:?}", trajectory.events());
    for s in trajectory.states() {
        assert!(!s.near_singular(), "t = {}", s.t());
        assert_eq!(s.stats().substeps, 0, "t = {}", s.t());
        assert!(s.q().is_empty());
    }
}

#[test]
fn a_one_by_one_system_runs_and_is_never_singular() {
    let system = Tiny::new(1, 2.0, None);
    let mut solver =
        Solver::<_, kinema_runtime::Auto>::new(system).unwrap_or_else(|e| panic!("{e}"));
    let trajectory = solver.run(&grid(10)).unwrap_or_else(|e| panic!("{e}"));
    assert!(trajectory.events().is_empty());
    for s in trajectory.states() {
        assert!(!s.near_singular());
        // x = sin t / 2, ẋ = cos t / 2.
        assert!((s.q()[0] - 0.5 * s.t().sin()).abs() < 1e-12);
        assert!((s.qd()[0] - 0.5 * s.t().cos()).abs() < 1e-12);
    }
}

#[test]
fn the_rank_rule_answers_for_empty_and_one_by_one_matrices() {
    let empty = rank(0, &[], &[], 1e-10).expect("a 0 × 0 matrix has a rank");
    assert_eq!((empty.rank, empty.dim, empty.condition), (0, 0, 1.0));
    assert!(!empty.near_singular(1e-10));
    let one = rank(1, &[(0, 0)], &[3.0], 1e-10).expect("a rank");
    assert_eq!((one.rank, one.dim, one.condition), (1, 1, 1.0));
    let zero = rank(1, &[(0, 0)], &[0.0], 1e-10).expect("a rank");
    assert_eq!((zero.rank, zero.dim), (0, 1));
    assert!(zero.near_singular(1e-10));
    // The dependency diagnosis: never "failed" for n = 0; the zero 1 × 1
    // names its equation and coordinate.
    let d = dependency(&Tiny::new(0, 1.0, None), &[], 1e-10);
    assert_eq!((d.rank, d.condition, d.dim), (Some(0), Some(1.0), 0));
    assert!(!d.to_string().contains("failed"), "{d}");
    let d = dependency(&Tiny::new(1, 0.0, None), &[0.0], 1e-10);
    assert_eq!(d.rank, Some(0));
    assert_eq!(d.equations, ["drive"]);
    assert_eq!(d.redundant, ["drive"]);
    assert_eq!(d.coordinates, ["x"]);
}

#[test]
fn a_pole_stops_the_run_at_its_time_on_and_between_grid_times() {
    for (c, expected) in [(0.5, 0.5), (0.55, 0.55), (0.0, 0.0)] {
        let mut solver = Solver::<_, kinema_runtime::Auto>::new(Tiny::new(1, 1.0, Some(c)))
            .unwrap_or_else(|e| panic!("{e}"));
        let e = solver.run(&grid(10)).expect_err("the pole stops the run");
        let Error::Undefined {
            t,
            ref equation,
            function,
            domain,
            ..
        } = e
        else {
            panic!("c = {c}: {e}");
        };
        assert!((t - expected).abs() <= 1e-12, "c = {c}: {e}");
        assert_eq!(
            (equation.as_str(), function, domain),
            ("drive", "division", Domain::Pole)
        );
        // The last good state is before the pole.
        if let Some(s) = solver.state() {
            assert!(s.t() < c, "c = {c}: state at {}", s.t());
        }
    }
    let mut solver = Solver::<_, kinema_runtime::Auto>::new(Tiny::new(1, 1.0, Some(0.5)))
        .unwrap_or_else(|e| panic!("{e}"));
    let e = solver.run(&grid(4)).expect_err("the pole stops the run");
    assert_eq!(
        e.to_string(),
        "equation `drive` is unbounded at t = 0.5: division by 0 (the divisor is 0)"
    );
}
