//! A model's size does not change its answer: the same mechanism drawn in
//! metres, in micrometres or at 10⁻¹⁴ is solved to the same relative
//! accuracy, on every path (Newton with the full analysis, positions only,
//! linkages placed in closed form, generated code).
//!
//! Newton's residual tolerance is absolute (10⁻¹²); before it was scaled
//! to the model (`RowTolerance` in kinema-runtime), a slider-crank 10⁻¹²
//! long passed the test at its initial guess and printed the guess as the
//! solution.

use kinema::{Auto, Options, Solver, System, Trajectory};

mod generated {
    /// The slider-crank at 10⁻¹² (`tests/scale/tiny_slider_crank.kin`).
    pub mod tiny_slider_crank {
        kinema::mechanism!(file = "tests/scale/tiny_slider_crank.kin");
    }
}

/// A slider-crank and a four-bar whose rocker is a squared-distance
/// constraint (an equation in length², not length), every length and
/// every guess times `s`.
fn mechanism(s: f64) -> String {
    format!(
        "mechanism Scaled {{
    param s = {s:e};
    param l1 = 0.3 * s;
    param l2 = 1.0 * s;
    param l3 = 0.8 * s;
    param l0 = 1.0 * s;

    body crank   {{ guess: (0.1 * {s:e}, 0.1 * {s:e}, 0.8) }}
    body rod     {{ guess: (0.7 * {s:e}, 0.1 * {s:e}, -0.2) }}
    body slider  {{ guess: (1.2 * {s:e}, 0.0, 0.0) }}
    body coupler {{ guess: (0.6 * {s:e}, 0.5 * {s:e}, 0.6) }}

    joint pivot: revolute(crank(-l1 / 2, 0), ground(0, 0));
    joint pin:   revolute(crank(l1 / 2, 0), rod(-l2 / 2, 0));
    joint wrist: revolute(rod(l2 / 2, 0), slider(0, 0));
    constraint on_axis: abs_y(slider(0, 0), 0);
    constraint no_turn: abs_angle(slider, 0);
    joint a: revolute(crank(l1 / 2, 0), coupler(-l2 / 2, 0));
    constraint rocker: dot(coupler(l2 / 2, 0) - (l0, 0), coupler(l2 / 2, 0) - (l0, 0)) == l3 * l3;
    driver crank_angle: crank.phi == pi / 4 + 2 * pi * t;
}}
"
    )
}

/// 73 times over one crank revolution.
fn grid() -> Vec<f64> {
    (0..=72).map(|k| f64::from(k) / 72.0).collect()
}

fn run<S: System>(system: S, options: Options) -> Trajectory {
    Solver::<S, Auto>::with_options(system, options)
        .unwrap_or_else(|e| panic!("solver: {e}"))
        .run(&grid())
        .unwrap_or_else(|e| panic!("analysis: {e}"))
}

fn tape(s: f64) -> kinema::TapeSystem {
    kinema::Model::from_source(&mechanism(s), "scaled.kin")
        .unwrap_or_else(|e| panic!("{e}"))
        .system()
}

/// Largest gap between `small`, divided by its size `s`, and `unit` (the
/// same mechanism at size 1), relative to 1 + |unit| per entry: positions
/// and (unless `positions_only`) velocities and accelerations; the angles
/// compared as they are. Both trajectories' coordinates are named alike.
fn gap(small: &Trajectory, unit: &Trajectory, s: f64, system: &impl System, rates: bool) -> f64 {
    assert_eq!(small.len(), unit.len());
    let mut worst = 0.0f64;
    for (a, b) in small.iter().zip(unit.iter()) {
        let mut levels = vec![(a.q(), b.q())];
        if rates {
            levels.extend([(a.qd(), b.qd()), (a.qdd(), b.qdd())]);
        }
        for (x, y) in levels {
            for (i, (&u, &v)) in x.iter().zip(y).enumerate() {
                let size = if system.coordinate_name(i).ends_with(".phi") {
                    1.0
                } else {
                    s
                };
                worst = worst.max((u / size - v).abs() / (1.0 + v.abs()));
            }
        }
    }
    worst
}

#[test]
fn a_mechanism_solves_alike_at_every_size() {
    let unit = run(tape(1.0), Options::default());
    let unit_positions = run(tape(1.0), Options::default().with_positions_only(true));
    for k in [-15, -12, -9, -6, -3, 3, 6] {
        let s = 10f64.powi(k);
        let system = tape(s);
        let full = run(tape(s), Options::default());
        let worst = gap(&full, &unit, s, &system, true);
        assert!(
            worst < 1e-9,
            "size 1e{k}: the full analysis is {worst:e} off"
        );
        let positions = run(tape(s), Options::default().with_positions_only(true));
        let worst = gap(&positions, &unit_positions, s, &system, false);
        assert!(worst < 1e-9, "size 1e{k}: positions only are {worst:e} off");
        // The peers' loop has no update test: it needs the residual test
        // to be reachable, which the scaled test is below size 1 (larger,
        // the absolute 1e-12 is below the squared-distance row's roundoff,
        // for kinema as for the peers).
        if k < 0 {
            let same = run(tape(s), Options::same_algorithm());
            let worst = gap(&same, &unit, s, &system, true);
            assert!(worst < 1e-9, "size 1e{k}: the peers' loop is {worst:e} off");
        }
    }
}

#[test]
fn generated_code_solves_a_tiny_mechanism() {
    let s = 1e-12;
    let system = generated::tiny_slider_crank::TinySliderCrank::default();
    let tiny = run(system, Options::default());
    let unit = run(
        kinema::Model::from_file("models/slider_crank.kin")
            .unwrap_or_else(|e| panic!("{e}"))
            .system(),
        Options::default(),
    );
    let worst = gap(
        &tiny,
        &unit,
        s,
        &generated::tiny_slider_crank::TinySliderCrank::default(),
        true,
    );
    assert!(worst < 1e-9, "generated code at 1e-12 is {worst:e} off");
}

/// The benchmark four-bar (`models/four_bar.kin`), every length and guess
/// times `s`: a linkage, which positions only place in closed form.
fn four_bar(s: f64) -> kinema::TapeSystem {
    let source = format!(
        "mechanism FourBar {{
    param l1 = 0.3 * {s:e};
    param l2 = 1.0 * {s:e};
    param l3 = 0.8 * {s:e};
    param l0 = 1.0 * {s:e};
    body crank   {{ guess: (0.1 * {s:e}, 0.1 * {s:e}, 0.8) }}
    body coupler {{ guess: (0.6 * {s:e}, 0.5 * {s:e}, 0.6) }}
    body rocker  {{ guess: (1.0 * {s:e}, 0.4 * {s:e}, 1.5) }}
    joint o: revolute(crank(-l1 / 2, 0), ground(0, 0));
    joint a: revolute(crank(l1 / 2, 0), coupler(-l2 / 2, 0));
    joint b: revolute(coupler(l2 / 2, 0), rocker(l3 / 2, 0));
    joint d: revolute(rocker(-l3 / 2, 0), ground(l0, 0));
    driver crank_angle: abs_angle(crank, pi / 4 + 2 * pi * t);
}}
"
    );
    kinema::Model::from_source(&source, "four_bar.kin")
        .unwrap_or_else(|e| panic!("{e}"))
        .system()
}

/// A linkage placed in closed form passes the same scaled residual test as
/// Newton: the four-bar at 10⁻¹², positions only, placed and accurate.
#[test]
fn a_tiny_linkage_is_placed_alike() {
    let options = Options::default().with_positions_only(true);
    let unit = run(four_bar(1.0), options);
    for k in [-12, -6] {
        let s = 10f64.powi(k);
        let system = four_bar(s);
        let tiny = run(four_bar(s), options);
        let worst = gap(&tiny, &unit, s, &system, false);
        assert!(worst < 1e-9, "size 1e{k}: {worst:e} off");
        let placed = tiny.iter().filter(|s| s.stats().closed_form).count();
        let unit_placed = unit.iter().filter(|s| s.stats().closed_form).count();
        assert!(placed > 0, "size 1e{k}: nothing placed in closed form");
        assert_eq!(placed, unit_placed, "size 1e{k}");
    }
}

/// The kink checks' rounding floor follows the model's size: a norm that
/// is 0.8e-12 long in a model 1e-12 long is no kink (it was flagged when
/// every coordinate counted as uncertain by a unit roundoff of 1), and a
/// norm that is zero but for roundoff still is one at that size.
#[test]
fn kinks_are_judged_at_the_model_size() {
    let model = kinema::Model::from_file("tests/scale/tiny_slider_crank.kin")
        .unwrap_or_else(|e| panic!("{e}"));
    let mut solver = Solver::<_, Auto>::with_options(model.system(), Options::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let mut scratch = solver.system().scratch();
    for t in grid() {
        let state = solver.step(t).unwrap_or_else(|e| panic!("{e}")).clone();
        assert!(state.kink().is_none(), "t = {t}");
        let size = solver.model_size();
        assert!((1e-12..=2e-12).contains(&size), "size {size:e}");
        let kink = solver.system().output_kink(&mut scratch, &state, size);
        assert!(kink.is_none(), "t = {t}: {kink:?}");
    }
    // tests/kinks/at_origin.kin at 1e-12: the tip held at the origin.
    let source = "mechanism AtOrigin {
        body bar { guess: (0.3e-12, -0.2e-12, 0) }
        joint tip: bar(0.5e-12, 0) == norm(bar(0.5e-12, 0)) * (2, 5);
        driver turn: bar.phi == t;
    }";
    let system = kinema::Model::from_source(source, "at_origin.kin")
        .unwrap_or_else(|e| panic!("{e}"))
        .system();
    let mut solver = Solver::<_, Auto>::with_options(system, Options::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let state = solver.step(0.0).unwrap_or_else(|e| panic!("{e}"));
    assert!(state.q()[0].abs() > 0.49e-12, "{:?}", state.q());
    let kink = state.kink().expect("the tip at the origin is flagged");
    assert_eq!(kink.function, "sqrt");
}
