//! Forward dynamics through the tape back end on the benchmark mechanisms
//! of issue 17 (BENCHMARKS.md, benches/peers/README.md §6):
//! `fd_slider_crank`, `fd_chain10`, `fd_chain100`, released from rest,
//! HHT-α (α = −0.1, modified Newton, the library's defaults) at h = 1e-3
//! over t ∈ [0, 1]: 1000 steps. Timed: the 1000 steps (the start — the
//! consistency projections and the initial q̈, λ — is not), per step. The
//! peers' scripts time the same span (bench_exudyn.py).
//!
//! `cargo bench -p kinema-bench --bench forward_tape`

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use kinema::forward::TapeForward;
use kinema::{Hht, HhtOptions, Model};

/// The step and the number of steps of the benchmark.
const H: f64 = 1e-3;
const STEPS: u32 = 1000;

/// A benchmark model by name.
fn model(name: &str) -> Model {
    let loaded = if name == "fd_slider_crank" {
        Model::from_file(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/models/fd_slider_crank.kin"
        ))
    } else {
        let n = name
            .strip_prefix("fd_chain")
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("unknown model {name}"));
        Model::from_source(
            &kinema_model::chain::pendulum_chain_kin(n),
            &format!("{name}.kin"),
        )
    };
    loaded.unwrap_or_else(|e| panic!("{e}"))
}

/// HHT at the start of the run, from rest.
fn start(system: &TapeForward, q0: &[f64]) -> Hht<TapeForward> {
    let qd0 = vec![0.0; q0.len()];
    Hht::new(system.clone(), q0, &qd0, 0.0, HhtOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .0
}

fn run(hht: &mut Hht<TapeForward>) {
    for _ in 0..STEPS {
        hht.step(black_box(H)).unwrap_or_else(|e| panic!("{e}"));
    }
}

fn forward_tape(c: &mut Criterion) {
    for name in ["fd_slider_crank", "fd_chain10", "fd_chain100"] {
        let m = model(name);
        let system = m
            .forward_system()
            .unwrap_or_else(|| panic!("{name}: no inertia"));
        let q0 = m.initial_configuration();
        // One run for the statistics the table quotes.
        let mut hht = start(&system, &q0);
        run(&mut hht);
        let s = hht.stats();
        eprintln!(
            "{name}: {} coordinates, {} steps to t = {}: Newton iterations {} ({:.2} per step), \
             factorizations {}",
            q0.len(),
            s.steps,
            hht.t(),
            s.iterations,
            s.iterations as f64 / s.steps as f64,
            s.factorizations
        );
        let mut group = c.benchmark_group(format!("forward_tape/{name}"));
        group.sample_size(10);
        if name == "fd_chain100" {
            group.warm_up_time(Duration::from_millis(100));
            group.measurement_time(Duration::from_secs(75));
        }
        group.bench_function("hht_step", |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let mut hht = start(&system, &q0);
                    let t0 = Instant::now();
                    run(&mut hht);
                    total += t0.elapsed();
                    black_box(hht.q());
                }
                total / STEPS
            });
        });
        group.finish();
    }
}

criterion_group!(benches, forward_tape);
criterion_main!(benches);
