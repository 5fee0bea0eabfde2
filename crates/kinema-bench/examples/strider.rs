//! The Strider walking linkage from its model file (`crates/kinema-bench/models/strider.kin`),
//! positions over one crank turn in 360 steps, as the pylinkage peer
//! (`benches/peers/bench_strider.py`) times it:
//! `cargo run --release -p kinema-bench --example strider [-- REPS]`.
//!
//! Prints the medians of (a) text → one turn (read the file, parse, check,
//! derive, compile the tapes, assemble, 360 steps), (b) one turn alone
//! (a fresh solver from the loaded model, assembly and 360 steps), with
//! positions only and with the full analysis; then (c) one turn of a
//! solver kept between turns (`reset`, assembly and 360 steps, its native
//! code ready: pylinkage's `step_fast` is compiled once too), positions
//! only with and without the closed form (`Options::closed_form`).

use std::time::Instant;

use kinema::{Auto, Model, Options, Solver};

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
    let model = Model::from_file(path).unwrap_or_else(|e| panic!("{e}"));
    for closed_form in [true, false] {
        let options = Options::default()
            .with_positions_only(true)
            .with_closed_form(closed_form);
        let mut solver: Solver<_, Auto> =
            Solver::with_options(model.system(), options).unwrap_or_else(|e| panic!("{e}"));
        solver.system().wait_for_jit();
        let mut times = Vec::new();
        let mut placed = 0;
        for _ in 0..reps.max(1) {
            let start = Instant::now();
            solver.reset();
            placed = 0;
            for k in 0..=STEPS {
                let t = f64::from(k) / f64::from(STEPS);
                let state = solver.step(t).unwrap_or_else(|e| panic!("{e}"));
                sink += state.q()[0];
                placed += usize::from(state.stats().closed_form);
            }
            times.push(start.elapsed().as_secs_f64());
        }
        let turn = median(times);
        println!(
            "positions only, solver kept ({:?}), closed form {closed_form}: one turn {:.4} ms ({:.3} µs per step), {placed} of {STEPS} steps placed",
            solver.system().backend(),
            turn * 1e3,
            turn * 1e6 / f64::from(STEPS + 1),
        );
    }
    eprintln!("{sink}");
}
