//! `Options::closed_form`: linkages of cranks and dyads placed in closed
//! form when only positions are asked for, with the positions, branches
//! and singular configurations Newton finds.

use kinema::{Auto, Backend, Error, Options, SingularKind, Solver, System, TapeSystem, Trajectory};

fn system(path: &str) -> TapeSystem {
    let source = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    system_of(&source, path)
}

fn system_of(source: &str, name: &str) -> TapeSystem {
    kinema::Model::from_source(source, name)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .with_backend(Backend::Tape)
        .system()
}

/// A pendulum pinned to ground, its angle driven by an equation.
const SWING: &str = "mechanism Swing {
    body bar { guess: (1, 0, 0) }
    joint pin: revolute(bar(-1, 0), ground(0, 0));
    driver swing: 2 * bar.phi == 8 * powi(t, 2) - 1;
}";

/// `n + 1` times over [0, `end`].
fn grid(n: usize, end: f64) -> Vec<f64> {
    (0..=n).map(|k| k as f64 * end / n as f64).collect()
}

fn positions(closed_form: bool) -> Options {
    Options::default()
        .with_positions_only(true)
        .with_closed_form(closed_form)
}

fn run(system: TapeSystem, options: Options, times: &[f64]) -> Result<Trajectory, Error> {
    Solver::<_, Auto>::with_options(system, options)?.run(times)
}

/// Largest |q_a − q_b| / (1 + |q|) over two runs of the same grid.
fn gap(a: &Trajectory, b: &Trajectory) -> f64 {
    assert_eq!(a.len(), b.len());
    let mut worst = 0.0f64;
    for (sa, sb) in a.iter().zip(b.iter()) {
        assert_eq!(sa.t(), sb.t());
        for (u, v) in sa.q().iter().zip(sb.q()) {
            worst = worst.max((u - v).abs() / (1.0 + u.abs().max(v.abs())));
        }
    }
    worst
}

fn closed_form_rows(t: &Trajectory) -> usize {
    t.iter().filter(|s| s.stats().closed_form).count()
}

#[test]
fn linkages_are_placed_in_closed_form_where_newton_puts_them() {
    for (path, steps, end) in [
        ("models/four_bar.kin", 400, 2.0),
        ("models/jansen.kin", 360, 1.0),
        ("crates/kinema-bench/models/strider.kin", 360, 1.0),
        ("models/chain10.kin", 200, 1.0),
        // A driver written as an equation (from rest: the second step's
        // estimated rates miss the acceleration).
        ("swing", 100, 1.0),
        // Pinned to ground by `abs_x` and `abs_y` of one point.
        ("models/pendulum.kin", 100, 1.0),
        // A coarse grid: 36 steps a turn.
        ("models/jansen.kin", 36, 1.0),
    ] {
        let times = grid(steps, end);
        let what = format!("{path}, {steps} steps");
        let system = || {
            if path == "swing" {
                system_of(SWING, path)
            } else {
                system(path)
            }
        };
        assert!(system().linkage().is_some(), "{what}: no linkage");
        let closed = run(system(), positions(true), &times).unwrap_or_else(|e| panic!("{e}"));
        let newton = run(system(), positions(false), &times).unwrap_or_else(|e| panic!("{e}"));
        let full = run(system(), Options::default(), &times).unwrap_or_else(|e| panic!("{e}"));
        let (to_newton, to_full) = (gap(&closed, &newton), gap(&closed, &full));
        assert!(to_newton <= 1e-10, "{what}: {to_newton:e} from Newton");
        assert!(
            to_full <= 1e-10,
            "{what}: {to_full:e} from the full analysis"
        );
        // Every step but the first after assembly (its estimated rates are
        // a backward difference of nothing: the branch test needs a
        // history), and no row without it elsewhere.
        let placed = closed_form_rows(&closed);
        assert!(placed + 3 >= steps && placed < steps, "{what}: {placed}");
        assert_eq!(closed_form_rows(&newton), 0, "{what}");
        assert!(closed.events().is_empty(), "{what}: {:?}", closed.events());
        for s in closed.iter().filter(|s| s.stats().closed_form) {
            let stats = s.stats();
            assert_eq!(stats.iterations, 0);
            assert!(stats.residual <= 1e-12, "{what}: {}", stats.residual);
        }
    }
}

#[test]
fn only_revolutes_and_driven_angles_have_a_closed_form() {
    for path in [
        "models/slider_crank.kin",
        "models/slider_crank_translational.kin",
        "models/scotch_yoke.kin",
        "models/eccentric_cam.kin",
        "models/roller_cam.kin",
        "models/parabola_follower.kin",
    ] {
        assert!(system(path).linkage().is_none(), "{path}");
    }
    // Written as equations instead of library joints: Newton solves it.
    let model = kinema::Model::from_source(
        "mechanism M {
            body crank { guess: (0, 0, 0) }
            constraint px: crank.x == 0;
            constraint py: crank.y == 0;
            driver turn: crank.phi == t;
        }",
        "m.kin",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(model.system().linkage().is_none());
    // abs_x alone, or with abs_y of another point, or driven: not a pin.
    for constraints in [
        "constraint px: abs_x(bar(-1, 0), 0); driver spin: abs_angle(bar, t);",
        "constraint px: abs_x(bar(-1, 0), 0); constraint py: abs_y(bar(1, 0), 0);
         driver spin: abs_angle(bar, t);",
        "constraint px: abs_x(bar(-1, 0), t); constraint py: abs_y(bar(-1, 0), 0);
         driver spin: abs_angle(bar, t);",
    ] {
        let source = format!("mechanism M {{ body bar {{ guess: (1, 0, 0) }} {constraints} }}");
        let system = kinema::Model::from_source(&source, "m.kin")
            .map(|m| m.system())
            .ok();
        assert!(
            system.is_none_or(|s| s.linkage().is_none()),
            "{constraints}"
        );
    }
}

/// The branch the guess assembles on is kept: the four-bar elbow-down.
#[test]
fn the_assembled_branch_is_kept() {
    let up = system("models/four_bar.kin");
    let times = grid(200, 1.0);
    let reference = run(up, positions(false), &times).unwrap_or_else(|e| panic!("{e}"));
    // Mirror the guess of coupler and rocker about the ground line.
    let source = std::fs::read_to_string("models/four_bar.kin").unwrap_or_else(|e| panic!("{e}"));
    let mirrored = source
        .replace("guess: (0.6, 0.5, 0.6)", "guess: (0.6, -0.3, -0.3)")
        .replace("guess: (1.0, 0.4, 1.5)", "guess: (1.0, -0.4, -1.5)");
    assert_ne!(mirrored, source);
    let down = kinema::Model::from_source(&mirrored, "four_bar_down.kin")
        .unwrap_or_else(|e| panic!("{e}"))
        .with_backend(Backend::Tape)
        .system();
    let closed = run(down.clone(), positions(true), &times).unwrap_or_else(|e| panic!("{e}"));
    let newton = run(down, positions(false), &times).unwrap_or_else(|e| panic!("{e}"));
    assert!(gap(&closed, &newton) <= 1e-10);
    assert_eq!(closed_form_rows(&closed), 199);
    // And it is the other branch: the rocker's y has the other sign.
    let sign = |t: &Trajectory| t.iter().map(|s| s.q()[7].signum()).sum::<f64>();
    assert!(sign(&closed) * sign(&reference) < 0.0);
}

/// Near a singular configuration Newton and its monitor take over: the
/// same events, positions and failures as without the closed form.
#[test]
fn singular_configurations_are_met_as_newton_meets_them() {
    for path in [
        "tests/singular/change_point.kin",
        "tests/singular/six_bar.kin",
        "tests/singular/parallelogram.kin",
        "tests/singular/dead_point.kin",
    ] {
        for steps in [7, 36, 360] {
            let what = format!("{path}, {steps} steps");
            let times = grid(steps, 2.0);
            let mut closed = Solver::<_, Auto>::with_options(system(path), positions(true))
                .unwrap_or_else(|e| panic!("{e}"));
            let mut newton = Solver::<_, Auto>::with_options(system(path), positions(false))
                .unwrap_or_else(|e| panic!("{e}"));
            let (a, b) = (closed.run(&times), newton.run(&times));
            match (&a, &b) {
                (Ok(a), Ok(b)) => {
                    assert!(gap(a, b) <= 1e-9, "{what}: {:e}", gap(a, b));
                    let kinds = |t: &Trajectory| -> Vec<(SingularKind, f64)> {
                        t.events().iter().map(|e| (e.kind, e.t)).collect()
                    };
                    let (ka, kb) = (kinds(a), kinds(b));
                    assert_eq!(ka.len(), kb.len(), "{what}: {ka:?} against {kb:?}");
                    for ((x, tx), (y, ty)) in ka.iter().zip(&kb) {
                        assert_eq!(x, y, "{what}");
                        assert!((tx - ty).abs() <= 1e-3, "{what}: {tx} against {ty}");
                    }
                    if path.contains("change_point") || path.contains("six_bar") {
                        assert!(!ka.is_empty(), "{what}: no event");
                        // On the fine grid nearly every row is placed.
                        let rows = closed_form_rows(a);
                        assert!(steps < 360 || rows > 340, "{what}: {rows} rows placed");
                    }
                }
                (Err(Error::Singular { t: ta, .. }), Err(Error::Singular { t: tb, .. })) => {
                    assert!((ta - tb).abs() < 1e-6, "{what}: {ta} against {tb}");
                    let (sa, sb) = (closed.state(), newton.state());
                    assert_eq!(sa.map(|s| s.t()), sb.map(|s| s.t()), "{what}");
                }
                _ => panic!("{what}: {a:?} against {b:?}"),
            }
        }
    }
}

/// A parameter changed between steps changes the placement: the step
/// after it is Newton's (the motion may jump), the next ones closed form
/// again, at the new lengths.
#[test]
fn a_changed_parameter_is_placed_at_its_new_value() {
    let times = grid(100, 0.5);
    let mut results = Vec::new();
    for closed_form in [true, false] {
        let mut solver =
            Solver::<_, Auto>::with_options(system("models/four_bar.kin"), positions(closed_form))
                .unwrap_or_else(|e| panic!("{e}"));
        let mut rows = Vec::new();
        for (k, &t) in times.iter().enumerate() {
            if k == 50 {
                assert!(solver.system_mut().set_param("l3", 0.85));
            }
            let state = solver.step(t).unwrap_or_else(|e| panic!("{e}"));
            rows.push((state.q().to_vec(), state.stats().closed_form));
        }
        results.push(rows);
    }
    let (closed, newton) = (&results[0], &results[1]);
    for (k, ((a, placed), (b, _))) in closed.iter().zip(newton).enumerate() {
        for (u, v) in a.iter().zip(b) {
            assert!((u - v).abs() <= 1e-10, "row {k}: {u} against {v}");
        }
        // Before the change every step after the first; the change's own
        // step is Newton's, and the few after it too, while the estimated
        // rates still span the jump (the branch test fails on them).
        if k < 50 {
            assert_eq!(*placed, k > 1, "row {k}");
        }
    }
    let after = closed[50..].iter().filter(|(_, placed)| *placed).count();
    assert!(
        !closed[50].1 && after >= 45,
        "{after} of 51 rows after the change"
    );
}
