//! The forward-dynamics step on the lead's benchmark mechanisms
//! (BENCHMARKS.md): fd_slider_crank, fd_chain10 and fd_chain100, HHT-α
//! with α = −0.1 and h = 1 ms from rest at t = 0, generated (`{Name}Forward`
//! from the build script) and tape (`Model::forward_system`). Time per
//! step over the 1000 steps of the run (t ∈ [0, 1], as the peers are
//! timed). HHT factors Newton's matrix sparse from n + m ≥ 32 (the chains
//! N = 10 and 100; its pivots chosen and its elimination recorded in `Hht::new`,
//! outside the timer like the rest of the set-up); `generated-dense` there
//! is the dense factorization, for comparison (3 steps).
//!
//! `cargo bench -p kinema-bench --bench forward`

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{
    BenchmarkGroup, Criterion, criterion_group, criterion_main, measurement::WallTime,
};
use kinema::{ForwardSystem, Hht, HhtOptions};
use kinema_bench::{forward_model, generated_forward};

/// Time per step of `steps` HHT steps from rest at `q0` (the integrator's
/// set-up, consistency and index-1 start are outside the timer).
fn hht<S: ForwardSystem + Clone>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    (system, options): (&S, HhtOptions),
    q0: &[f64],
    steps: u32,
) {
    let qd0 = vec![0.0; q0.len()];
    group.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let (mut hht, _) = Hht::new(system.clone(), q0, &qd0, 0.0, options)
                    .unwrap_or_else(|e| panic!("{e}"));
                let start = Instant::now();
                for _ in 0..steps {
                    hht.step(1e-3).unwrap_or_else(|e| panic!("{e}"));
                }
                total += start.elapsed();
                black_box(hht.q());
            }
            total / steps
        });
    });
}

/// Both back ends of one mechanism.
fn pair<G: ForwardSystem + Clone>(c: &mut Criterion, name: &str, generated: &G, steps: u32) {
    let model = forward_model(name);
    let q0 = model.initial_configuration();
    let tape = model
        .forward_system()
        .unwrap_or_else(|| panic!("{name} has no inertia"));
    let mut group = c.benchmark_group(format!("forward/{name}"));
    group.sample_size(if q0.len() >= 100 { 10 } else { 20 });
    let options = HhtOptions::default();
    hht(&mut group, "generated", (generated, options), &q0, steps);
    hht(&mut group, "tape", (&tape, options), &q0, steps);
    if q0.len() >= 100 {
        // The dense Newton matrix, for comparison (a few steps: each
        // factors a dense (n + m)² matrix).
        let dense = HhtOptions {
            sparse_from: usize::MAX,
            ..options
        };
        hht(&mut group, "generated-dense", (generated, dense), &q0, 3);
    }
    group.finish();
}

fn forward(c: &mut Criterion) {
    pair(
        c,
        "fd_slider_crank",
        &generated_forward::fd_slider_crank::FdSliderCrank::default().forward(),
        1000,
    );
    pair(
        c,
        "fd_chain10",
        &generated_forward::fd_chain10::FdChain10::default().forward(),
        1000,
    );
    pair(
        c,
        "fd_chain100",
        &generated_forward::fd_chain100::FdChain100::default().forward(),
        1000,
    );
}

criterion_group!(benches, forward);
criterion_main!(benches);
