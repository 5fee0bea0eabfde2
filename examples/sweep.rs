//! A design sweep on every core: 10 000 slider-crank variants (crank and
//! rod lengths), each run over 1000 steps of one crank turn, reporting the
//! stroke of the slider — once on one thread, once on all, with the wall
//! times and their ratio (the figure BENCHMARKS.md quotes).
//!
//! `cargo run --release --example sweep [-- ROWS STEPS]`

use std::time::Instant;

use kinema::Model;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let rows: usize = args.next().map_or(Ok(10_000), |a| a.parse())?;
    let steps: usize = args.next().map_or(Ok(1000), |a| a.parse())?;
    let model = Model::from_file(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/slider_crank.kin"
    ))?;
    let table: Vec<[f64; 2]> = (0..rows)
        .map(|k| {
            let s = k as f64 / rows as f64;
            [0.2 + 0.15 * s, 0.9 + 0.4 * s]
        })
        .collect();
    let times: Vec<f64> = (0..=steps).map(|k| k as f64 / steps as f64).collect();
    let slider_x = 6;

    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let mut walls = Vec::new();
    for threads in [1, cores] {
        let sweep = model.sweep(&["l1", "l2"])?.with_threads(threads);
        let start = Instant::now();
        let strokes = sweep.map(&table, |_, solver| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for &t in &times {
                let x = solver.step(t)?.q()[slider_x];
                lo = lo.min(x);
                hi = hi.max(x);
            }
            Ok(hi - lo)
        });
        let wall = start.elapsed().as_secs_f64();
        let failed = strokes.iter().filter(|s| s.is_err()).count();
        let mean = strokes.iter().flatten().sum::<f64>() / (rows - failed).max(1) as f64;
        println!(
            "{threads} thread(s): {rows} variants × {steps} steps in {wall:.2} s \
             ({:.2} µs per step), mean stroke {mean:.6} m, {failed} failed",
            wall / (rows * (steps + 1)) as f64 * 1e6
        );
        walls.push(wall);
    }
    if let [one, all] = walls[..] {
        println!("wall time on {cores} cores / on 1: {:.3}", all / one);
    }
    Ok(())
}
