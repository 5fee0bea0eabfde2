//! The Strider walking linkage from its model file (`crates/kinema-bench/models/strider.kin`),
//! positions over one crank turn in 360 steps, as the pylinkage peer
//! (`benches/peers/bench_strider.py`) times it:
//! `cargo run --release -p kinema-bench --example strider [-- REPS]`.
//!
//! Prints the medians of (a) text → one turn (read the file, parse, check,
//! derive, compile the tapes, assemble, 360 steps), (b) one turn alone
//! (a fresh solver from the loaded model, assembly and 360 steps), with
//! positions only and with the full analysis.

use std::time::Instant;

use kinema::{Model, Options};

const STEPS: u32 = 360;

fn turn(model: &Model, options: Options) -> f64 {
    let mut solver = model.solver(options).unwrap_or_else(|e| panic!("{e}"));
    let mut acc = 0.0;
    for k in 0..=STEPS {
        let t = f64::from(k) / f64::from(STEPS);
        acc += solver.step(t).unwrap_or_else(|e| panic!("{e}")).q()[0];
    }
    acc
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let reps: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(50);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/strider.kin");
    let mut sink = 0.0;
    for (label, options) in [
        (
            "positions only",
            Options::default().with_positions_only(true),
        ),
        ("full analysis", Options::default()),
    ] {
        let (mut whole, mut alone) = (Vec::new(), Vec::new());
        for _ in 0..reps {
            let start = Instant::now();
            let model = Model::from_file(path).unwrap_or_else(|e| panic!("{e}"));
            sink += turn(&model, options);
            whole.push(start.elapsed().as_secs_f64());
            let start = Instant::now();
            sink += turn(&model, options);
            alone.push(start.elapsed().as_secs_f64());
        }
        let (whole, alone) = (median(whole), median(alone));
        println!(
            "{label}: text -> one turn {:.3} ms; one turn {:.3} ms ({:.3} µs per step)",
            whole * 1e3,
            alone * 1e3,
            alone * 1e6 / f64::from(STEPS + 1)
        );
    }
    eprintln!("{sink}");
}
