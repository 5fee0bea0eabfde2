//! R HHT steps (h = 1 ms, from rest) of a forward-dynamics benchmark
//! mechanism, generated or tape, for callgrind: per-step instructions =
//! (Ir at 2R − Ir at R) / R, the set-up cancelling.
//!
//! `valgrind --tool=callgrind target/release/examples/fd_profile fd_chain100 generated 20`

use kinema::{ForwardSystem, Hht, HhtOptions};
use kinema_bench::{forward_model, generated_forward};

fn run<S: ForwardSystem>(system: S, q0: &[f64], steps: usize) {
    let qd0 = vec![0.0; q0.len()];
    let (mut hht, _) =
        Hht::new(system, q0, &qd0, 0.0, HhtOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let start = std::time::Instant::now();
    for _ in 0..steps {
        hht.step(1e-3).unwrap_or_else(|e| panic!("{e}"));
    }
    let s = hht.stats();
    eprintln!(
        "{steps} steps: {:.2?} per step, {} iterations, {} factorizations",
        start.elapsed() / steps.max(1) as u32,
        s.iterations,
        s.factorizations
    );
    std::hint::black_box(hht.q());
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("fd_chain100", String::as_str);
    let back = args.get(2).map_or("generated", String::as_str);
    let steps: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(20);
    let model = forward_model(name);
    let q0 = model.initial_configuration();
    if back == "tape" {
        let tape = model
            .forward_system()
            .unwrap_or_else(|| panic!("no inertia"));
        run(tape, &q0, steps);
        return;
    }
    match name {
        "fd_slider_crank" => run(
            generated_forward::fd_slider_crank::FdSliderCrank::default().forward(),
            &q0,
            steps,
        ),
        "fd_chain10" => run(
            generated_forward::fd_chain10::FdChain10::default().forward(),
            &q0,
            steps,
        ),
        _ => run(
            generated_forward::fd_chain100::FdChain100::default().forward(),
            &q0,
            steps,
        ),
    }
}
