//! Typed diagnostics: singular configurations, redundant equations,
//! non-convergence, non-finite values, bad time grids and setups.

use kinema_runtime::handwritten::{FourBar, SliderCrank};
use kinema_runtime::{
    DenseLu, Error, LinalgError, Options, Quantity, SingularKind, Solver, SparseLu, System,
};

fn grid() -> Vec<f64> {
    (0..=1000).map(|k| k as f64 / 1000.0).collect()
}

/// Slider-crank whose rod is as long as its crank: at crank angle π/2
/// (t = 0.125) the rod folds back over the crank, the slider reaches the
/// pivot and Φ_q loses rank (det Φ_q = cos φ₂ cos φ₃ with φ₂ = −π/2).
fn isosceles_slider_crank() -> SliderCrank {
    SliderCrank {
        rod: 0.3,
        guess: [0.1, 0.1, 0.8, 0.32, 0.1, -0.8, 0.42, 0.0, 0.0],
        ..SliderCrank::default()
    }
}

/// At t = 0.125 two branches cross: the rod folds back over the crank
/// (slider at the pivot, x = 0), or keeps crossing it (x = 2 r cos φ₁, the
/// analytic continuation); likewise at t = 0.625. The run keeps the
/// analytic branch, reports both bifurcations located to 1e-8 with the
/// dependent equations and free coordinates;
/// with `stop_at_singular` it stops there instead.
#[test]
fn bifurcation_of_an_isosceles_slider_crank_is_passed_and_reported() -> Result<(), Error> {
    for options in [Options::default(), Options::same_algorithm()] {
        let mut solver =
            Solver::<SliderCrank, DenseLu<9>>::with_options(isosceles_slider_crank(), options)?;
        let trajectory = solver.run(&grid())?;
        let events = trajectory.events();
        // φ₁ = π/2 and 3π/2 in the turn.
        assert_eq!(events.len(), 2, "{events:?}");
        for (event, t_star) in events.iter().zip([0.125, 0.625]) {
            assert_eq!(event.kind, SingularKind::Bifurcation);
            assert!((event.t - t_star).abs() < 1e-8, "{event}");
            assert_eq!(
                event.dependency.equations,
                ["pivot.y", "pin.y", "wrist.y", "on_axis"]
            );
            assert_eq!(
                event.dependency.coordinates,
                ["rod.x", "rod.phi", "slider.x"]
            );
        }
        assert!(
            events[0].to_string().starts_with("bifurcation at t = 0.12"),
            "{}",
            events[0]
        );
        // The analytic continuation: slider x = 2 r cos φ₁ on every row,
        // velocity its derivative.
        for state in trajectory.iter() {
            let phi = state.q()[2];
            let x = 2.0 * 0.3 * phi.cos();
            let xd = -2.0 * 0.3 * phi.sin() * state.qd()[2];
            assert!(
                (state.q()[6] - x).abs() < 1e-9,
                "t = {}: x = {}",
                state.t(),
                state.q()[6]
            );
            assert!(
                (state.qd()[6] - xd).abs() < 1e-6,
                "t = {}: ẋ = {} vs {xd}",
                state.t(),
                state.qd()[6]
            );
        }

        let mut solver = Solver::<SliderCrank, DenseLu<9>>::with_options(
            isosceles_slider_crank(),
            options.with_stop_at_singular(true),
        )?;
        let err = solver.run(&grid()).err();
        let Some(Error::SingularConfiguration { event }) = &err else {
            panic!("expected a stop, got {err:?}");
        };
        assert!((event.t - 0.125).abs() < 1e-8, "{event}");
        // The grid lands on the singular time: its row is the branch limit,
        // flagged, and the last one kept.
        let last = solver.state().map(|s| (s.t(), s.near_singular()));
        assert_eq!(last, Some((0.125, true)));
    }
    Ok(())
}

/// A non-Grashof four-bar (crank 0.8, coupler 0.4, rocker 0.6, ground 1)
/// whose driven crank cannot pass cos φ₁ = 0.4: coupler and rocker become
/// collinear (a dead point) at t* = (acos 0.4 − π/4) / 2π ≈ 0.0595050.
#[test]
fn dead_point_of_a_four_bar_is_located_in_time() -> Result<(), Error> {
    let four_bar = FourBar {
        crank: 0.8,
        coupler: 0.4,
        rocker: 0.6,
        guess: [0.28, 0.28, 0.8, 0.7, 0.6, -0.3, 0.9, 0.3, 1.9],
        ..FourBar::default()
    };
    let t_star = (0.4_f64.acos() - std::f64::consts::FRAC_PI_4) / (2.0 * std::f64::consts::PI);
    for options in [Options::default(), Options::same_algorithm()] {
        let mut solver = Solver::<FourBar, DenseLu<9>>::with_options(four_bar.clone(), options)?;
        let err = solver.run(&grid()).err();
        let Some(Error::Singular { t, dependency }) = &err else {
            panic!("expected a lock-up, got {err:?}");
        };
        assert!(
            (t - t_star).abs() < 1e-8,
            "lock-up at {t}, expected {t_star}"
        );
        // At the located time Φ_q is within the threshold (equilibrated
        // condition ≥ 10⁴), if not yet numerically rank deficient.
        assert!(dependency.rank.is_some_and(|r| r >= 8), "{dependency}");
        assert!(
            dependency.condition.is_some_and(|c| c >= 1e4),
            "{dependency}"
        );
        assert_eq!(dependency.redundant, ["crank_angle"], "{dependency}");
        assert!(
            dependency.equations.iter().any(|e| e == "b.x"),
            "{dependency}"
        );
    }
    Ok(())
}

/// The slider-crank with its `on_axis` equation y₃ = 0 replaced by a second
/// copy of `no_turn` (2 φ₃ = 0): n equations still, but two are dependent and
/// the slider may leave the axis.
struct Redundant(SliderCrank);

const REDUNDANT_PATTERN: [(u32, u32); 21] = {
    let mut p = [(0, 0); 21];
    let base = [
        (0, 0),
        (0, 2),
        (1, 1),
        (1, 2),
        (2, 0),
        (2, 2),
        (2, 3),
        (2, 5),
        (3, 1),
        (3, 2),
        (3, 4),
        (3, 5),
        (4, 3),
        (4, 5),
        (4, 6),
        (5, 4),
        (5, 5),
        (5, 7),
        (6, 8),
        (7, 8),
        (8, 2),
    ];
    let mut i = 0;
    while i < 21 {
        p[i] = base[i];
        i += 1;
    }
    p
};

impl System for Redundant {
    type Scratch = ();
    fn scratch(&self) {}
    fn len(&self) -> usize {
        9
    }
    fn coordinate_name(&self, i: usize) -> &str {
        self.0.coordinate_name(i)
    }
    fn equation_name(&self, i: usize) -> &str {
        if i == 6 {
            "no_turn_again"
        } else {
            self.0.equation_name(i)
        }
    }
    fn initial_guess(&self, q: &mut [f64]) {
        self.0.initial_guess(q);
    }
    fn jacobian_pattern(&self) -> &[(u32, u32)] {
        &REDUNDANT_PATTERN
    }
    fn phi(&self, scratch: &mut (), q: &[f64], t: f64, phi: &mut [f64]) {
        self.0.phi(scratch, q, t, phi);
        phi[6] = 2.0 * q[8];
    }
    fn jacobian(&self, scratch: &mut (), q: &[f64], t: f64, values: &mut [f64]) {
        self.0.jacobian(scratch, q, t, values);
        values[18] = 2.0;
    }
    fn nu(&self, scratch: &mut (), q: &[f64], t: f64, nu: &mut [f64]) {
        self.0.nu(scratch, q, t, nu);
    }
    fn gamma(&self, scratch: &mut (), q: &[f64], qd: &[f64], t: f64, gamma: &mut [f64]) {
        self.0.gamma(scratch, q, qd, t, gamma);
    }
}

#[test]
fn redundant_equations_are_named() -> Result<(), Error> {
    let mut solver = Solver::<Redundant, SparseLu>::new(Redundant(SliderCrank::default()))?;
    let err = solver.assemble(0.0).err();
    let Some(Error::Singular { t, dependency }) = &err else {
        panic!("expected redundant equations, got {err:?}");
    };
    assert_eq!(*t, 0.0);
    assert_eq!(dependency.rank, Some(8));
    assert_eq!(dependency.equations, ["no_turn_again", "no_turn"]);
    assert_eq!(dependency.redundant, ["no_turn"]);
    // With y₃ free the slider can rise, the rod turning about the crank pin.
    assert_eq!(
        dependency.coordinates,
        ["rod.x", "rod.y", "rod.phi", "slider.x", "slider.y"]
    );
    let message = err.map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.contains("equations no_turn_again, no_turn are dependent (rank 8 of 9"),
        "{message}"
    );
    assert!(
        message.contains("removing equation no_turn restores full rank"),
        "{message}"
    );
    Ok(())
}

#[test]
fn no_convergence_names_time_residual_and_worst_equation() -> Result<(), Error> {
    let options = Options {
        max_iterations: 1,
        ..Options::same_algorithm()
    };
    let mut solver =
        Solver::<SliderCrank, DenseLu<9>>::with_options(SliderCrank::default(), options)?;
    let err = solver.assemble(0.0).err();
    let Some(Error::NoConvergence {
        t,
        iterations,
        residual,
        worst_equation,
    }) = &err
    else {
        panic!("expected no convergence, got {err:?}");
    };
    assert_eq!((*t, *iterations), (0.0, 1));
    assert!(*residual > 1e-12);
    assert!(!worst_equation.is_empty());
    let message = err.map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.starts_with("position analysis did not converge at t = 0: ‖Φ‖∞ = "),
        "{message}"
    );
    Ok(())
}

/// A slider-crank whose γ, Jacobian entry ∂pin.y/∂rod.phi or ν is NaN from
/// t = 0.5 on.
struct Broken(SliderCrank, Poisoned);

#[derive(Clone, Copy, PartialEq)]
enum Poisoned {
    Gamma,
    Jacobian,
    Nu,
}

impl System for Broken {
    type Scratch = ();
    fn scratch(&self) {}
    fn len(&self) -> usize {
        9
    }
    fn coordinate_name(&self, i: usize) -> &str {
        self.0.coordinate_name(i)
    }
    fn equation_name(&self, i: usize) -> &str {
        self.0.equation_name(i)
    }
    fn initial_guess(&self, q: &mut [f64]) {
        self.0.initial_guess(q);
    }
    fn jacobian_pattern(&self) -> &[(u32, u32)] {
        self.0.jacobian_pattern()
    }
    fn phi(&self, scratch: &mut (), q: &[f64], t: f64, phi: &mut [f64]) {
        self.0.phi(scratch, q, t, phi);
    }
    fn jacobian(&self, scratch: &mut (), q: &[f64], t: f64, values: &mut [f64]) {
        self.0.jacobian(scratch, q, t, values);
        if self.1 == Poisoned::Jacobian && t >= 0.5 {
            values[11] = f64::NAN;
        }
    }
    fn nu(&self, scratch: &mut (), q: &[f64], t: f64, nu: &mut [f64]) {
        self.0.nu(scratch, q, t, nu);
        if self.1 == Poisoned::Nu && t >= 0.5 {
            nu[8] = f64::NAN;
        }
    }
    fn gamma(&self, scratch: &mut (), q: &[f64], qd: &[f64], t: f64, gamma: &mut [f64]) {
        self.0.gamma(scratch, q, qd, t, gamma);
        if self.1 == Poisoned::Gamma && t >= 0.5 {
            gamma[3] = f64::NAN;
        }
    }
}

#[test]
fn non_finite_values_are_reported_never_returned() -> Result<(), Error> {
    let mut solver =
        Solver::<Broken, DenseLu<9>>::new(Broken(SliderCrank::default(), Poisoned::Gamma))?;
    let err = solver.run(&grid()).err();
    assert_eq!(
        err,
        Some(Error::NonFinite {
            t: 0.5,
            quantity: Quantity::Gamma,
            name: "pin.y".into()
        })
    );
    assert_eq!(
        err.map(|e| e.to_string()).unwrap_or_default(),
        "non-finite γ at t = 0.5: pin.y"
    );

    // A NaN Jacobian entry, through every linear solver and both modes.
    for options in [Options::default(), Options::same_algorithm()] {
        let broken = || Broken(SliderCrank::default(), Poisoned::Jacobian);
        let nan_jacobian = Some(Error::NonFinite {
            t: 0.5,
            quantity: Quantity::Jacobian,
            name: "∂pin.y/∂rod.phi".into(),
        });
        let mut dense = Solver::<Broken, DenseLu<9>>::with_options(broken(), options)?;
        assert_eq!(dense.run(&grid()).err(), nan_jacobian);
        let mut sparse = Solver::<Broken, SparseLu>::with_options(broken(), options)?;
        assert_eq!(sparse.run(&grid()).err(), nan_jacobian);
    }

    // A NaN ν is named as such (not as the velocity it poisons).
    for options in [Options::default(), Options::same_algorithm()] {
        let mut solver = Solver::<Broken, DenseLu<9>>::with_options(
            Broken(SliderCrank::default(), Poisoned::Nu),
            options,
        )?;
        assert_eq!(
            solver.run(&grid()).err(),
            Some(Error::NonFinite {
                t: 0.5,
                quantity: Quantity::Nu,
                name: "crank_angle".into()
            })
        );
    }

    // A NaN parameter poisons Φ.
    let mut solver = Solver::<SliderCrank, DenseLu<9>>::new(SliderCrank {
        crank: f64::NAN,
        ..SliderCrank::default()
    })?;
    assert!(matches!(
        solver.assemble(0.0),
        Err(Error::NonFinite {
            quantity: Quantity::Phi,
            ..
        })
    ));
    Ok(())
}

#[test]
fn time_grids_must_be_non_empty_finite_and_increasing() -> Result<(), Error> {
    let mut solver = Solver::<SliderCrank, DenseLu<9>>::new(SliderCrank::default())?;
    assert_eq!(solver.run(&[]).err(), Some(Error::EmptyTimeGrid));
    assert_eq!(
        solver.run(&[0.0, 0.1, 0.1]).err(),
        Some(Error::NonIncreasingTime {
            index: 2,
            previous: 0.1,
            t: 0.1
        })
    );
    assert!(matches!(
        solver.run(&[0.0, f64::NAN]),
        Err(Error::NonIncreasingTime { index: 1, .. })
    ));
    assert_eq!(
        solver.assemble(f64::INFINITY).err(),
        Some(Error::NonFiniteTime { t: f64::INFINITY })
    );
    solver.step(0.5)?;
    let err = solver.step(0.25).err();
    assert_eq!(
        err.map(|e| e.to_string()).unwrap_or_default(),
        "times must increase: t = 0.25 (time index 0) follows t = 0.5"
    );
    Ok(())
}

#[test]
fn setups_of_the_wrong_size_are_rejected() {
    let err = Solver::<SliderCrank, DenseLu<8>>::new(SliderCrank::default()).err();
    assert_eq!(
        err,
        Some(Error::Setup(LinalgError::Dimension {
            what: "system dimension for DenseLu<N>",
            expected: 8,
            found: 9
        }))
    );
}
