//! The Rust side of the Python package's overhead measurement (BENCHMARKS.md,
//! "Python (issue 41)"): a 1000-step run of a model file with everything
//! `kinema.Model.run` computes per output row (the state, the result
//! columns, the singular, kink and precision checks, the row kept in one
//! `Vec<f64>`), on the JIT back end once compiled; prints the median of
//! `RUNS` runs. `cargo run --release -p kinema-bench --example py_overhead
//! [MODEL] [STEPS] [RUNS]`.
use std::time::Instant;

use kinema::{Auto, Options, Outputs, PrecisionScope, Solver, System};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "models/slider_crank.kin".to_owned());
    let steps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1000);
    let runs: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(21);
    let model = kinema::Model::from_file(&path)?;
    let system = model.system();
    system.wait_for_jit();
    let times: Vec<f64> = (0..=steps)
        .map(|k| {
            if k == steps {
                1.0
            } else {
                k as f64 / steps as f64
            }
        })
        .collect();
    let mut seconds = Vec::with_capacity(runs);
    let mut rows = 0;
    for _ in 0..runs {
        let start = Instant::now();
        let mut solver = Solver::<_, Auto>::with_options(system.clone(), Options::default())?;
        let m = solver.system().output_len();
        let mut results = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
        let mut scratch = solver.system().scratch();
        let mut values: Vec<f64> = Vec::new();
        let mut flagged = 0usize;
        for (k, &t) in times.iter().enumerate() {
            solver.step(t)?;
            let Some(state) = solver.state() else {
                continue;
            };
            let size = solver.model_size();
            flagged += usize::from(state.near_singular()) + usize::from(state.kink().is_some());
            let scope = if k == 0 {
                PrecisionScope::All
            } else {
                PrecisionScope::Timed
            };
            flagged += usize::from(
                solver
                    .system()
                    .imprecision(&mut scratch, state, size, scope)
                    .is_some(),
            );
            solver
                .system()
                .outputs_of(&mut scratch, state, &mut results);
            flagged += usize::from(
                solver
                    .system()
                    .output_kink(&mut scratch, state, size)
                    .is_some(),
            );
            values.push(state.t());
            for v in [state.q(), state.qd(), state.qdd()] {
                values.extend_from_slice(v);
            }
            for v in &results {
                values.extend_from_slice(v);
            }
        }
        let events = solver.close_events().len();
        seconds.push(start.elapsed().as_secs_f64());
        rows = values.len();
        std::hint::black_box((values, flagged, events));
    }
    seconds.sort_by(f64::total_cmp);
    println!(
        "{path}: {steps} steps, {rows} values, median of {runs} runs {:.3} ms (min {:.3} ms)",
        seconds[runs / 2] * 1e3,
        seconds[0] * 1e3
    );
    Ok(())
}
