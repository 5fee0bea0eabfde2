//! Parameter sweeps: every row gives what a run of that row alone gives,
//! bit for bit and in row order, whatever the number of threads.

use kinema::sweep::{ParamError, shard};
use kinema::{Auto, Model, Solver};

fn slider_crank() -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/slider_crank.kin");
    Model::from_file(path).expect("the slider-crank model derives")
}

fn grid(steps: usize) -> Vec<f64> {
    (0..=steps).map(|k| k as f64 / steps as f64).collect()
}

/// Crank and rod lengths that all assemble from the model's guess.
fn rows(n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|k| {
            let s = k as f64 / n as f64;
            [0.2 + 0.15 * s, 0.9 + 0.4 * s]
        })
        .collect()
}

#[test]
fn each_row_matches_a_run_of_its_own_in_row_order() {
    let model = slider_crank();
    let times = grid(50);
    let rows = rows(24);
    for threads in [1, 2, 3] {
        let sweep = model
            .sweep(&["l1", "l2"])
            .expect("known parameters")
            .with_threads(threads);
        let results = sweep.run(&rows, &times);
        assert_eq!(results.len(), rows.len());
        for (row, result) in rows.iter().zip(results) {
            let mut system = model.system();
            system.set_param("l1", row[0]).expect("l1 is a parameter");
            system.set_param("l2", row[1]).expect("l2 is a parameter");
            let alone = Solver::<_, Auto>::new(system)
                .expect("solver")
                .run(&times)
                .expect("the row runs alone");
            assert_eq!(
                result.expect("the row runs in the sweep"),
                alone,
                "row {row:?}"
            );
        }
    }
}

#[test]
fn a_failing_row_fails_alone() {
    let model = slider_crank();
    // A rod shorter than the crank cannot close the loop at every angle.
    let rows = [[0.3, 1.0], [0.3, 0.1], [0.25, 1.1]];
    let results = model
        .sweep(&["l1", "l2"])
        .expect("known")
        .run(&rows, &grid(40));
    assert!(results[0].is_ok());
    assert!(results[1].is_err());
    assert!(results[2].is_ok());
}

#[test]
fn names_and_row_widths_are_checked() {
    let model = slider_crank();
    let err = model
        .sweep(&["l1", "crank"])
        .map(|_| ())
        .expect_err("unknown name");
    assert_eq!(
        err.to_string(),
        "unknown parameter `crank`; the model's parameters are: l1, l2, omega"
    );
    assert!(matches!(
        model.sweep(&["l1", "l1"]).map(|_| ()),
        Err(ParamError::Duplicate { .. })
    ));
    let sweep = model.sweep(&["l1", "l2"]).expect("known");
    let results = sweep.run(&[vec![0.3], vec![0.3, 1.0]], &grid(4));
    let message = results[0]
        .as_ref()
        .map(|_| ())
        .expect_err("short row")
        .to_string();
    assert!(
        message.contains("parameter row has length 1, expected 2"),
        "{message}"
    );
    assert!(results[1].is_ok());
}

#[test]
fn shards_concatenate_to_the_whole_sweep() {
    let model = slider_crank();
    let rows = rows(10);
    let times = grid(10);
    let sweep = model.sweep(&["l1", "l2"]).expect("known");
    let whole = sweep.run(&rows, &times);
    let mut parts = Vec::new();
    for part in 1..=3 {
        let range = shard(rows.len(), part, 3).expect("valid part");
        parts.extend(sweep.run(&rows[range], &times));
    }
    assert_eq!(parts, whole);
}
