//! The background JIT's compile time on a chain: `cargo run --release -p
//! kinema-bench --example jit_compile [N] [jit|tape]` prints, per round,
//! the tapes' compilation (building the system to `wait_for_jit`) and the
//! folded LU's (building a solver after it, which compiles at once), for
//! peak memory under `/usr/bin/time -v` (`tape`: the same without the JIT).
use std::time::Instant;

use kinema::{Auto, Backend, Options, Solver};

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1000);
    let backend = match args.next().as_deref() {
        Some("tape") => Backend::Tape,
        _ => Backend::Jit,
    };
    let text = kinema_model::chain::chain_kin(n);
    let model = kinema::Model::from_source(&text, "chain")
        .unwrap_or_else(|e| panic!("{e}"))
        .with_backend(backend);
    for _ in 0..3 {
        let t0 = Instant::now();
        let system = model.system();
        let ran = system.wait_for_jit();
        let t1 = Instant::now();
        let solver: Solver<_, Auto> =
            Solver::with_options(system, Options::default()).unwrap_or_else(|e| panic!("{e}"));
        let t2 = Instant::now();
        let lu = match solver.linear_solver() {
            Auto::Folded(lu) if lu.has_compiled_factor() && lu.has_compiled_solves() => {
                "folded, compiled"
            }
            Auto::Folded(_) => "folded, interpreted",
            Auto::Sparse(_) => "sparse",
            Auto::Dense(_) => "dense",
        };
        println!(
            "chain N = {n}: {ran:?}: tapes {:?}, solver with its LU ({lu}) {:?}",
            t1 - t0,
            t2 - t1
        );
    }
}
