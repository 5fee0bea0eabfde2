//! kinema in the peers' loop ("same algorithm") reproduces the peers: the same
//! mean Newton updates per step, and trajectories that agree with the peers'
//! checkpoints (benches/peers/reference/) to 1e-12 relative — the small
//! mechanisms through generated code and tapes, the long chains through
//! tapes (no compile step needed). The chain at N = 1000 is compared at the
//! peers' own spread (AGREEMENT.md: the peers disagree among themselves by up
//! to 4.4e-12 there).

use kinema::{Options, System};
use kinema_bench::{Run, generated, run_grid, solver, tape};

/// (header, rows) of a reference trajectory.
fn reference(name: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let path = format!(
        "{}/../../benches/peers/reference/traj_{name}.csv",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap_or_default()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or_else(|e| panic!("{path}: {x}: {e}")))
                .collect()
        })
        .collect();
    (header, rows)
}

/// Worst |kinema − peer| / max(|peer|, 1) over the reference's columns.
fn spread(name: &str, run: &Run) -> f64 {
    let (header, rows) = reference(name);
    assert_eq!(rows.len(), run.checkpoints.len(), "{name}: checkpoints");
    let mut worst = 0.0f64;
    for (row, c) in rows.iter().zip(&run.checkpoints) {
        let (t, q, qd, qdd) = (c.t, &c.q, &c.qd, &c.qdd);
        assert!((row[0] - t).abs() < 1e-15, "{name}: time {} vs {t}", row[0]);
        for (col, want) in header.iter().zip(row).skip(1) {
            let (vec, index) = if let Some(i) = col.strip_prefix("qdd") {
                (qdd, i)
            } else if let Some(i) = col.strip_prefix("qd") {
                (qd, i)
            } else if let Some(i) = col.strip_prefix('q') {
                (q, i)
            } else {
                panic!("{name}: column {col}");
            };
            let i: usize = index.parse().unwrap_or_else(|e| panic!("{col}: {e}"));
            let got = vec[i];
            worst = worst.max((got - want).abs() / want.abs().max(1.0));
        }
    }
    worst
}

fn check<S: System>(name: &str, system: S, updates: f64, tol: f64) {
    check_run(
        name,
        &run_grid(&mut solver(system, Options::same_algorithm())),
        updates,
        tol,
    );
}

/// A generated mechanism through its own `solver()` (the generated LU).
macro_rules! check_generated {
    ($name:literal, $system:expr, $updates:expr, $tol:expr) => {{
        let mut s = $system
            .solver(Options::same_algorithm())
            .unwrap_or_else(|e| panic!("{e}"));
        check_run($name, &run_grid(&mut s), $updates, $tol);
        assert_eq!(
            s.linear_solver().fallback_count(),
            0,
            "{}: the generated pivot order needed the fallback",
            $name
        );
        // And through the runtime's automatic choice.
        check($name, $system, $updates, $tol);
    }};
}

fn check_run(name: &str, run: &Run, updates: f64, tol: f64) {
    assert!(
        (run.mean_updates - updates).abs() < 5e-4,
        "{name}: {} Newton updates per step, the peers take {updates}",
        run.mean_updates
    );
    let d = spread(name, run);
    assert!(d <= tol, "{name}: differs from the peers by {d:e}");
}

#[test]
fn slider_crank() {
    check_generated!(
        "slider_crank",
        generated::slider_crank::SliderCrank::default(),
        2.762,
        1e-12
    );
    check("slider_crank", tape("slider_crank"), 2.762, 1e-12);
}

#[test]
fn four_bar() {
    check_generated!(
        "four_bar",
        generated::four_bar::FourBar::default(),
        3.000,
        1e-12
    );
    check("four_bar", tape("four_bar"), 3.000, 1e-12);
}

#[test]
fn chains() {
    check_generated!("chain2", generated::chain2::Chain2::default(), 1.998, 1e-12);
    check_generated!(
        "chain10",
        generated::chain10::Chain10::default(),
        1.998,
        1e-12
    );
    check_generated!(
        "chain50",
        generated::chain50::Chain50::default(),
        1.998,
        1e-12
    );

    check("chain50", tape("chain50"), 1.998, 1e-12);
}

#[test]
fn long_chains_through_tapes() {
    check("chain200", tape("chain200"), 1.998, 1e-12);
    check("chain1000", tape("chain1000"), 1.998, 5e-12);
}
