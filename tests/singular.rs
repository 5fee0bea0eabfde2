//! Singular configurations (issue 12): mechanisms with closed forms, run at
//! grids from 7 to 3600 steps per turn through generated code, the tape and
//! (where one exists) a hand-written system. Every grid must give the same
//! branch, no spikes, no 2π jumps between rows and the same events.

use std::f64::consts::{FRAC_PI_4, PI, TAU};

use kinema::{Auto, Error, Options, SingularKind, Solver, System, Trajectory};
use kinema_runtime::handwritten::FourBar;

mod generated {
    pub mod change_point {
        kinema::mechanism!(file = "tests/singular/change_point.kin");
    }
    pub mod parallelogram {
        kinema::mechanism!(file = "tests/singular/parallelogram.kin");
    }
    pub mod dead_point {
        kinema::mechanism!(file = "tests/singular/dead_point.kin");
    }
    pub mod long_pendulum {
        kinema::mechanism!(file = "tests/singular/long_pendulum.kin");
    }
    pub mod slider_crank {
        kinema::mechanism!(file = "models/slider_crank.kin");
    }
    pub mod six_bar {
        kinema::mechanism!(file = "tests/singular/six_bar.kin");
    }
}

const GRIDS: [usize; 4] = [7, 36, 360, 3600];

/// `steps_per_turn · turns + 1` times over `turns` seconds (ω = 2π).
fn grid(steps_per_turn: usize, turns: usize) -> Vec<f64> {
    let n = steps_per_turn * turns;
    (0..=n)
        .map(|k| k as f64 * turns as f64 / n as f64)
        .collect()
}

fn run<S: System>(system: S, times: &[f64]) -> Result<Trajectory, Error> {
    Solver::<S, Auto>::with_options(system, Options::default())?.run(times)
}

fn tape(path: &str) -> kinema::TapeSystem {
    kinema::Model::from_file(path)
        .unwrap_or_else(|e| panic!("{e}"))
        .system()
}

/// Angle difference wrapped to (−π, π].
fn wrap(d: f64) -> f64 {
    let r = d.rem_euclid(TAU);
    if r > PI { r - TAU } else { r }
}

/// Four-bar with crank l1 from O = (0, 0), coupler l2, rocker l3 from
/// D = (l0, 0), crank angle θ: the body coordinates (midpoint frames, x′
/// along the links, the rocker's from D to B) with B on side `s` (±1) of
/// the line A → D.
fn four_bar(l: [f64; 4], theta: f64, s: f64) -> [f64; 9] {
    let [l1, l2, l3, l0] = l;
    let a = [l1 * theta.cos(), l1 * theta.sin()];
    let (dx, dy) = (l0 - a[0], -a[1]);
    let r = dx.hypot(dy);
    let along = (l2 * l2 - l3 * l3 + r * r) / (2.0 * r);
    let h = (l2 * l2 - along * along).max(0.0).sqrt();
    let (ex, ey) = (dx / r, dy / r);
    let b = [
        a[0] + along * ex - s * h * ey,
        a[1] + along * ey + s * h * ex,
    ];
    [
        a[0] / 2.0,
        a[1] / 2.0,
        theta,
        (a[0] + b[0]) / 2.0,
        (a[1] + b[1]) / 2.0,
        (b[1] - a[1]).atan2(b[0] - a[0]),
        (b[0] + l0) / 2.0,
        b[1] / 2.0,
        b[1].atan2(b[0] - l0),
    ]
}

const CHANGE_POINT: [f64; 4] = [1.0, 3.0, 2.5, 1.5];

/// The change point's analytic branch: elbow side +1 at the start (as the
/// model's guess), flipping at each fold (θ = 2πk, t = k − 1/8).
fn change_point_exact(t: f64) -> [f64; 9] {
    let folds = (t + 0.125).floor();
    let s = if folds as i64 % 2 == 0 { 1.0 } else { -1.0 };
    four_bar(CHANGE_POINT, FRAC_PI_4 + TAU * t, s)
}

/// Checks a trajectory against a closed form: positions (angles modulo
/// 2π) to 1e-8, velocities to 1e-5 and accelerations to 1e-3 (1e-4 and
/// 1e-2 on rows flagged near singular), relative to 1 + |value| (the closed form differentiated by central differences), no
/// angle jumping by more than π between rows.
fn assert_matches<const N: usize>(
    what: &str,
    trajectory: &Trajectory,
    exact: impl Fn(f64) -> [f64; N],
) {
    let d = 1e-5;
    let mut previous: Option<&kinema::State> = None;
    for state in trajectory.iter() {
        let t = state.t();
        let (q0, qm, qp) = (exact(t), exact(t - d), exact(t + d));
        for i in 0..N {
            let angle = i % 3 == 2;
            let diff = |a: f64, b: f64| if angle { wrap(a - b) } else { a - b };
            let q = state.q()[i];
            assert!(
                diff(q, q0[i]).abs() < 1e-8,
                "{what}: q[{i}] at t = {t}: {q} vs {} (flagged: {}, {:?})",
                q0[i],
                state.near_singular(),
                state.stats()
            );
            let qd = diff(qp[i], qm[i]) / (2.0 * d);
            let qdd = (diff(qp[i], q0[i]) - diff(q0[i], qm[i])) / (d * d);
            let (v, a) = (state.qd()[i], state.qdd()[i]);
            // Flagged rows hold the branch's limits, extrapolated from the
            // last solved sub-step: looser.
            let (tv, ta) = if state.near_singular() {
                (1e-4, 1e-2)
            } else {
                (1e-5, 1e-3)
            };
            assert!(
                (v - qd).abs() < tv * (1.0 + qd.abs()),
                "{what}: qd[{i}] at t = {t}: {v} vs {qd} (flagged: {})",
                state.near_singular()
            );
            assert!(
                (a - qdd).abs() < ta * (1.0 + qdd.abs()),
                "{what}: qdd[{i}] at t = {t}: {a} vs {qdd} (flagged: {})",
                state.near_singular()
            );
            if let Some(p) = previous
                && angle
            {
                let jump = (q - p.q()[i]).abs();
                assert!(jump < PI, "{what}: q[{i}] jumps by {jump} before t = {t}");
            }
        }
        previous = Some(state);
    }
}

/// Events must be `expected` (kind, time) to 1e-8.
fn assert_events(what: &str, trajectory: &Trajectory, expected: &[(SingularKind, f64)]) {
    let events = trajectory.events();
    let found: Vec<(SingularKind, f64)> = events.iter().map(|e| (e.kind, e.t)).collect();
    assert_eq!(found.len(), expected.len(), "{what}: {events:#?}");
    for ((kind, t), (k, te)) in found.iter().zip(expected) {
        assert_eq!(kind, k, "{what}: {events:#?}");
        assert!((t - te).abs() < 1e-8, "{what}: event at {t}, expected {te}");
    }
}

#[test]
fn change_point_four_bar_keeps_its_branch_on_every_grid_and_back_end() {
    let expected = [
        (SingularKind::Bifurcation, 0.875),
        (SingularKind::Bifurcation, 1.875),
    ];
    for steps in GRIDS {
        let times = grid(steps, 2);
        let generated = generated::change_point::ChangePoint::default()
            .solver(Options::default())
            .and_then(|mut s| s.run(&times))
            .unwrap_or_else(|e| panic!("generated, {steps} steps per turn: {e}"));
        let taped = run(tape("tests/singular/change_point.kin"), &times)
            .unwrap_or_else(|e| panic!("tape, {steps} steps per turn: {e}"));
        let hand = FourBar {
            crank: 1.0,
            coupler: 3.0,
            rocker: 2.5,
            ground: 1.5,
            guess: [0.35, 0.35, 0.79, 2.2, 1.0, 0.2, 2.6, 0.6, 0.5],
            ..FourBar::default()
        };
        let hand = run(hand, &times)
            .unwrap_or_else(|e| panic!("hand-written, {steps} steps per turn: {e}"));
        for (what, trajectory) in [
            ("generated", &generated),
            ("tape", &taped),
            ("hand-written", &hand),
        ] {
            let what = format!("{what}, {steps} steps per turn");
            assert_matches(&what, trajectory, change_point_exact);
            assert_events(&what, trajectory, &expected);
        }
    }
}

/// The six-bar's dyad pin C (on the crank, (1, 0.3) from O in its frame),
/// ground pin G and link lengths (tests/singular/six_bar.kin).
const SIX_BAR_C: [f64; 2] = [1.0, 0.3];
const SIX_BAR_G: [f64; 2] = [-2.0, -1.0];
const SIX_BAR_A: f64 = 1.6;

/// When the dyad is straight: the crank points C away from G, t = k + t*.
fn six_bar_straight() -> f64 {
    let theta = (-SIX_BAR_G[1]).atan2(-SIX_BAR_G[0]) - SIX_BAR_C[1].atan2(SIX_BAR_C[0]);
    (theta - FRAC_PI_4).rem_euclid(TAU) / TAU
}

/// The six-bar's analytic branch: the four-bar as built, the dyad's elbow
/// E on side +1 of C → G at the start, crossing over at each straightening.
fn six_bar_exact(t: f64) -> [f64; 15] {
    let theta = FRAC_PI_4 + TAU * t;
    let fb = four_bar([1.0, 3.0, 2.5, 2.8], theta, 1.0);
    let crossings = (t - six_bar_straight()).floor() + 1.0;
    let side = if crossings as i64 % 2 == 0 { 1.0 } else { -1.0 };
    let (sn, cs) = theta.sin_cos();
    let c = [
        cs * SIX_BAR_C[0] - sn * SIX_BAR_C[1],
        sn * SIX_BAR_C[0] + cs * SIX_BAR_C[1],
    ];
    let g = SIX_BAR_G;
    let (g_len, c_len) = (g[0].hypot(g[1]), SIX_BAR_C[0].hypot(SIX_BAR_C[1]));
    let (a, b) = (SIX_BAR_A, g_len + c_len - SIX_BAR_A);
    let (dx, dy) = (g[0] - c[0], g[1] - c[1]);
    let r = dx.hypot(dy);
    // Near the straightening a + b − r is a difference of nearly equal
    // numbers; from the angle Δ between OC and OG it is exact:
    // (a + b)² − r² = 2|OG||OC|(1 + cos Δ) = 4|OG||OC| cos²(Δ/2). Heron's
    // product then gives the elbow's distance h from the line C → G.
    let delta = theta + SIX_BAR_C[1].atan2(SIX_BAR_C[0]) - g[1].atan2(g[0]);
    let gap = 4.0 * g_len * c_len * (0.5 * delta).cos().powi(2) / (a + b + r);
    let along = a - gap * (b + r - a) / (2.0 * r);
    let h = (gap * (b + r - a) * (a + r - b) * (a + r + b))
        .max(0.0)
        .sqrt()
        / (2.0 * r);
    let (ex, ey) = (dx / r, dy / r);
    let e = [
        c[0] + along * ex - side * h * ey,
        c[1] + along * ey + side * h * ex,
    ];
    let mut q = [0.0; 15];
    q[..9].copy_from_slice(&fb);
    q[9..].copy_from_slice(&[
        (c[0] + e[0]) / 2.0,
        (c[1] + e[1]) / 2.0,
        (e[1] - c[1]).atan2(e[0] - c[0]),
        (g[0] + e[0]) / 2.0,
        (g[1] + e[1]) / 2.0,
        (e[1] - g[1]).atan2(e[0] - g[0]),
    ]);
    q
}

#[test]
fn six_bar_dyad_straightening_mid_turn_crosses_over_on_every_grid_and_back_end() {
    let t_star = six_bar_straight();
    let expected = [
        (SingularKind::Bifurcation, t_star),
        (SingularKind::Bifurcation, t_star + 1.0),
    ];
    for steps in GRIDS {
        let times = grid(steps, 2);
        let generated = generated::six_bar::SixBar::default()
            .solver(Options::default())
            .and_then(|mut s| s.run(&times))
            .unwrap_or_else(|e| panic!("generated, {steps} steps per turn: {e}"));
        let taped = run(tape("tests/singular/six_bar.kin"), &times)
            .unwrap_or_else(|e| panic!("tape, {steps} steps per turn: {e}"));
        for (what, trajectory) in [("generated", &generated), ("tape", &taped)] {
            let what = format!("{what}, {steps} steps per turn");
            assert_matches(&what, trajectory, six_bar_exact);
            assert_events(&what, trajectory, &expected);
            // The straight dyad's load passes through O: the dyad's pins
            // and the crank's pivot, not the driver nor the four-bar.
            for event in trajectory.events() {
                assert_eq!(
                    event.dependency.equations,
                    ["o.x", "o.y", "c.x", "c.y", "e.x", "e.y", "g.x", "g.y"],
                    "{what}: {event:?}"
                );
            }
        }
    }
}

#[test]
fn dead_point_is_a_lock_up_located_to_a_microsecond_on_every_grid() {
    let t_star = (0.4_f64.acos() - FRAC_PI_4) / TAU;
    for steps in GRIDS {
        let times = grid(steps, 1);
        let last_good = times.iter().copied().rfind(|&t| t < t_star);
        let mut generated = generated::dead_point::DeadPoint::default()
            .solver(Options::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let mut taped = Solver::<_, Auto>::new(tape("tests/singular/dead_point.kin"))
            .unwrap_or_else(|e| panic!("{e}"));
        let results = [
            (
                "generated",
                generated.run(&times).err(),
                generated.state().map(|s| s.t()),
                generated.events().to_vec(),
            ),
            (
                "tape",
                taped.run(&times).err(),
                taped.state().map(|s| s.t()),
                taped.events().to_vec(),
            ),
        ];
        for (what, err, last, events) in results {
            let Some(Error::Singular { t, dependency }) = &err else {
                panic!("{what}, {steps} steps per turn: expected a lock-up, got {err:?}");
            };
            assert!(
                (t - t_star).abs() < 1e-6,
                "{what}, {steps} steps per turn: lock-up at {t}, expected {t_star}"
            );
            assert_eq!(
                last, last_good,
                "{what}, {steps}: the last good row is kept"
            );
            assert_eq!(
                dependency.redundant,
                ["crank_angle"],
                "{what}: {dependency}"
            );
            assert_eq!(events.len(), 1, "{what}: {events:?}");
            assert_eq!(events[0].kind, SingularKind::LockUp);
        }
    }
}

/// The parallelogram's analytic branch from the flat start: rocker parallel
/// to the crank, coupler parallel to the ground.
fn parallelogram_exact(t: f64) -> [f64; 9] {
    let th = TAU * t;
    let (c, s) = (th.cos(), th.sin());
    [
        0.5 * c,
        0.5 * s,
        th,
        1.0 + c,
        s,
        0.0,
        2.0 + 0.5 * c,
        0.5 * s,
        th,
    ]
}

#[test]
fn parallelogram_starting_flat_is_flagged_and_reported() {
    for steps in GRIDS {
        let times = grid(steps, 1);
        let taped = run(tape("tests/singular/parallelogram.kin"), &times)
            .unwrap_or_else(|e| panic!("tape, {steps} steps per turn: {e}"));
        let first = &taped[0];
        assert!(first.near_singular(), "the flat start is flagged");
        let events = taped.events();
        assert!(
            events.first().is_some_and(|e| e.t == 0.0),
            "{steps}: {events:#?}"
        );
        assert_eq!(events[0].kind, SingularKind::Toggle, "{steps}: {events:#?}");
        // The branch that leaves the flat start towards the guess: the
        // parallelogram, kept through the second flat position (θ = π).
        assert_matches(
            &format!("tape, {steps} steps per turn"),
            &taped,
            parallelogram_exact,
        );
    }
}

#[test]
fn rank_decisions_do_not_depend_on_units() {
    // Φ_q of a pendulum 10¹⁰ long is unit triangular: regular. It runs, and
    // the angle follows the driver φ = 4t².
    let times: Vec<f64> = (0..=100).map(|k| f64::from(k) / 100.0).collect();
    for trajectory in [
        run(generated::long_pendulum::LongPendulum::default(), &times),
        run(tape("tests/singular/long_pendulum.kin"), &times),
    ] {
        let trajectory = trajectory.unwrap_or_else(|e| panic!("{e}"));
        for state in trajectory.iter() {
            let t = state.t();
            assert!((state.q()[2] - 4.0 * t * t).abs() < 1e-12);
            assert!((state.qd()[2] - 8.0 * t).abs() < 1e-9);
            assert!(!state.near_singular());
        }
        assert!(trajectory.events().is_empty(), "{:?}", trajectory.events());
    }
    // Entries near 1e160 (their squares overflow): a result, never a panic.
    // Parameters are plain data: a struct literal names them all.
    let huge = generated::long_pendulum::LongPendulum { L: 1e160 };
    let _ = run(huge, &times);
}

/// A run that ends in a singular configuration (the parallelogram flat again
/// at θ = π, t = 0.5) does not call it a toggle: past the last time nothing
/// was computed. On every grid, both back ends.
#[test]
fn a_run_ending_at_a_singular_configuration_says_so() {
    for steps in GRIDS {
        let n = steps / 2 + steps % 2;
        let times: Vec<f64> = (0..=n).map(|k| 0.5 * k as f64 / n as f64).collect();
        let generated = generated::parallelogram::Parallelogram::default()
            .solver(Options::default())
            .and_then(|mut s| s.run(&times))
            .unwrap_or_else(|e| panic!("generated, {steps}: {e}"));
        let taped = run(tape("tests/singular/parallelogram.kin"), &times)
            .unwrap_or_else(|e| panic!("tape, {steps}: {e}"));
        for (what, trajectory) in [("generated", &generated), ("tape", &taped)] {
            let what = format!("{what}, {steps} steps per turn");
            assert_events(
                &what,
                trajectory,
                &[(SingularKind::Toggle, 0.0), (SingularKind::AtEnd, 0.5)],
            );
            let last = &trajectory[trajectory.len() - 1];
            assert!(last.near_singular(), "{what}: the last row is flagged");
            let shown = trajectory.events()[1].to_string();
            assert!(
                shown.starts_with("singular configuration at t = 0.5") && !shown.contains("toggle"),
                "{what}: {shown}"
            );
        }
    }
}

/// Output steps of many crank turns each (fuzz seed 16023: 100 turns a
/// step): Newton from the prediction may land on the mirror assembly
/// branch, det Φ_q changing sign with no singular configuration anywhere on
/// the way. Either the run stays on its branch (the slider where the closed
/// form puts it, no event) or it is refused, saying so, at the first step
/// that jumps — never a bifurcation reported at every step (what it was, at
/// a bisection's cost per step), never an answer from the other branch.
#[test]
fn steps_of_many_turns_stay_on_the_branch_or_are_refused_as_branch_jumps() {
    let slider_x = |t: f64| {
        let phi = FRAC_PI_4 + TAU * t;
        0.3 * phi.cos() + (1.0 - (0.3 * phi.sin()).powi(2)).sqrt()
    };
    let mut refused = 0;
    for turns_per_step in [7.5, 50.0, 100.0] {
        let times: Vec<f64> = (0..=20).map(|k| f64::from(k) * turns_per_step).collect();
        let generated = generated::slider_crank::SliderCrank::default()
            .solver(Options::default())
            .and_then(|mut s| s.run(&times));
        let taped = run(tape("models/slider_crank.kin"), &times);
        for (what, result) in [("generated", generated), ("tape", taped)] {
            let what = format!("{what}, {turns_per_step} turns a step");
            match result {
                Ok(trajectory) => {
                    assert!(
                        trajectory.events().is_empty(),
                        "{what}: {:?}",
                        trajectory.events()
                    );
                    for state in trajectory.iter() {
                        let x = state.q()[6];
                        // Far from t = 0, the crank angle itself carries
                        // roundoff of 2π t.
                        let tolerance = 1e-9 * (1.0 + state.t());
                        assert!((x - slider_x(state.t())).abs() < tolerance, "{what}: {x}");
                    }
                }
                Err(Error::BranchJump {
                    from,
                    t,
                    at,
                    condition,
                }) => {
                    refused += 1;
                    assert!(
                        times.windows(2).any(|w| w == [from, t]),
                        "{what}: {from}, {t}"
                    );
                    assert!(from < at && at < t, "{what}: at = {at}");
                    assert!(condition < 1e4, "{what}: {condition}");
                }
                Err(e) => panic!("{what}: {e}"),
            }
        }
    }
    assert!(refused > 0, "the fuzz finding's grid jumps branches");
}

/// The Newton variants a user may pick: the peers' loop (no predictor, full
/// Newton, residual tolerance only), modified Newton with and without the
/// predictor. Each must follow the branch like the defaults do (the quiet
/// steps that skip the branch test depend on how Newton started).
fn newton_modes() -> [(&'static str, Options); 3] {
    [
        ("same algorithm", Options::same_algorithm()),
        (
            "predictor, modified Newton",
            Options::default().with_modified_newton(true),
        ),
        (
            "modified Newton, no predictor",
            Options::default()
                .with_predictor(false)
                .with_modified_newton(true),
        ),
    ]
}

#[test]
fn every_newton_mode_keeps_the_branch_through_bifurcations() {
    let change_point = [
        (SingularKind::Bifurcation, 0.875),
        (SingularKind::Bifurcation, 1.875),
    ];
    let t_star = six_bar_straight();
    let six_bar = [
        (SingularKind::Bifurcation, t_star),
        (SingularKind::Bifurcation, t_star + 1.0),
    ];
    for (mode, options) in newton_modes() {
        for steps in GRIDS {
            let times = grid(steps, 2);
            let what = format!("change point, {mode}, {steps} steps per turn");
            let trajectory = generated::change_point::ChangePoint::default()
                .solver(options)
                .and_then(|mut s| s.run(&times))
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_matches(&what, &trajectory, change_point_exact);
            assert_events(&what, &trajectory, &change_point);

            let what = format!("six-bar, {mode}, {steps} steps per turn");
            let trajectory = generated::six_bar::SixBar::default()
                .solver(options)
                .and_then(|mut s| s.run(&times))
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_matches(&what, &trajectory, six_bar_exact);
            assert_events(&what, &trajectory, &six_bar);
        }
    }
}
