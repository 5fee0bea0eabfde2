//! A design sweep on every core: 10 000 slider-crank variants (crank and
//! rod lengths), each run over 1000 steps of one crank turn, reporting the
//! stroke of the slider — once on one thread, once on all, with the wall
//! times and their ratio (the figure BENCHMARKS.md quotes), and the CPU
//! time per step of each (Linux).
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
        let cpu_start = cpu_seconds();
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
        let cpu = cpu_seconds().zip(cpu_start).map(|(b, a)| b - a);
        let failed = strokes.iter().filter(|s| s.is_err()).count();
        let mean = strokes.iter().flatten().sum::<f64>() / (rows - failed).max(1) as f64;
        println!(
            "{threads} thread(s): {rows} variants × {steps} steps in {wall:.2} s \
             ({:.2} µs per step), mean stroke {mean:.6} m, {failed} failed{}",
            wall / (rows * (steps + 1)) as f64 * 1e6,
            cpu.map_or(String::new(), |c| format!(
                "; CPU time {c:.2} s ({:.2} µs per step), {:.0} % of {threads} core(s)",
                c / (rows * (steps + 1)) as f64 * 1e6,
                100.0 * c / wall / threads as f64
            ))
        );
        walls.push(wall);
    }
    if let [one, all] = walls[..] {
        println!("wall time on {cores} cores / on 1: {:.3}", all / one);
    }
    Ok(())
}

/// The process's CPU time (user + system) so far, from /proc/self/stat
/// (Linux; `None` elsewhere): on a machine shared with other work, the
/// wall-time ratio says as much about the others as about the sweep, while
/// CPU time per step shows whether the workers slow each other down.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name's closing parenthesis: utime and stime
    // are the 12th and 13th of them, in clock ticks (100 per second on
    // Linux).
    let rest = stat.rsplit_once(')')?.1;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i)?.parse::<f64>().ok();
    Some((ticks(11)? + ticks(12)?) / 100.0)
}
