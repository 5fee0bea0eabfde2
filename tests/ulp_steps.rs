//! Steps shorter than the resolution of t: a schedule that puts two output
//! times an ulp apart (a target time and a grid time computed two ways, as
//! `kinema fit`'s schedules do) must be followed, neither spun on nor
//! refused, on every path of the step: positions only or not, at a regular
//! state and at a singular one.

use std::sync::mpsc;
use std::time::Duration;

use kinema::{Auto, Options, Solver, Trajectory};

fn tape(path: &str) -> kinema::TapeSystem {
    kinema::Model::from_file(path)
        .unwrap_or_else(|e| panic!("{e}"))
        .system()
}

/// The run of `path` over `times` on another thread: a spin fails the
/// test instead of hanging it.
fn run_within(path: &'static str, options: Options, times: Vec<f64>) -> Trajectory {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let result = Solver::<_, Auto>::with_options(tape(path), options)
            .and_then(|mut s| s.run(&times))
            .map_err(|e| e.to_string());
        let _ = tx.send(result);
    });
    rx.recv_timeout(Duration::from_secs(120))
        .unwrap_or_else(|_| panic!("{path}: no answer within 120 s (a spin)"))
        .unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn steps_of_an_ulp_are_followed_at_regular_and_singular_states() {
    // 36 steps per turn: the change-point four-bar's bifurcation at
    // t = 0.875 (and 1.875) is on the grid.
    let grid: Vec<f64> = (0..=72).map(|k| f64::from(k) / 36.0).collect();
    let doubled: Vec<f64> = grid.iter().flat_map(|&t| [t, t.next_up()]).collect();
    for path in [
        "tests/singular/change_point.kin",
        "models/slider_crank.kin",
        "models/four_bar.kin",
    ] {
        for positions_only in [false, true] {
            let what = format!("{path}, positions only {positions_only}");
            let options = Options::default().with_positions_only(positions_only);
            let plain = run_within(path, options, grid.clone());
            let ulps = run_within(path, options, doubled.clone());
            assert_eq!(ulps.len(), doubled.len(), "{what}");
            // Every grid time's row as on the plain grid, and its twin an
            // ulp later within Newton's tolerance of it.
            for (k, row) in plain.iter().enumerate() {
                for twin in [ulps.get(2 * k), ulps.get(2 * k + 1)] {
                    let twin = twin.unwrap_or_else(|| panic!("{what}: row {k}"));
                    for (a, b) in row.q().iter().zip(twin.q()) {
                        assert!(
                            (a - b).abs() <= 1e-8 * (1.0 + a.abs()),
                            "{what}: t = {}: {a} vs {b}",
                            row.t()
                        );
                    }
                }
            }
            let events = |t: &Trajectory| -> Vec<(kinema::SingularKind, f64)> {
                t.events().iter().map(|e| (e.kind, e.t)).collect()
            };
            let (a, b) = (events(&plain), events(&ulps));
            assert_eq!(a.len(), b.len(), "{what}: {a:?} vs {b:?}");
            for ((ka, ta), (kb, tb)) in a.iter().zip(&b) {
                assert!(ka == kb && (ta - tb).abs() < 1e-6, "{what}: {a:?} vs {b:?}");
            }
        }
    }
}

/// The IFToMM A01 pendulum released from horizontal: forward dynamics
/// through HHT-α and the accurate mode, to output times each followed by
/// the next representable one: the twin rows equal their grid time's to
/// the integrator's own change over an ulp.
#[test]
fn forward_dynamics_follows_output_times_an_ulp_apart() {
    let model = kinema::Model::from_file("models/iftomm/a01_pendulum.kin")
        .unwrap_or_else(|e| panic!("{e}"));
    let q0 = model.initial_configuration();
    let qd0 = vec![0.0; q0.len()];
    let system = || {
        model
            .forward_system()
            .unwrap_or_else(|| panic!("no dynamics"))
    };
    let (mut hht, _) = kinema::Hht::new(system(), &q0, &qd0, 0.0, kinema::HhtOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let mut accurate =
        kinema::Accurate::new(system(), &q0, &qd0, 0.0, 1e-10).unwrap_or_else(|e| panic!("{e}"));
    for k in 1..=20 {
        let t = f64::from(k) * 0.05;
        hht.advance_to(t, 0.01)
            .unwrap_or_else(|e| panic!("HHT to {t}: {e}"));
        accurate
            .advance_to(t)
            .unwrap_or_else(|e| panic!("accurate to {t}: {e}"));
        let (q_hht, q_acc) = (hht.q()[2], accurate.q()[2]);
        hht.advance_to(t.next_up(), 0.01)
            .unwrap_or_else(|e| panic!("HHT to {t} + ulp: {e}"));
        accurate
            .advance_to(t.next_up())
            .unwrap_or_else(|e| panic!("accurate to {t} + ulp: {e}"));
        assert!((hht.q()[2] - q_hht).abs() <= 1e-12, "HHT at {t}");
        assert!((accurate.q()[2] - q_acc).abs() <= 1e-12, "accurate at {t}");
    }
}
