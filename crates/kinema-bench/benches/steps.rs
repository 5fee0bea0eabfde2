//! Per-step time of kinematic analysis on the benchmark mechanisms, every
//! back end, in two modes:
//! - `same`: exactly the peers' loop (Options::same_algorithm);
//! - `default`: kinema's defaults (predictor, full Newton).
//!
//! Each measurement runs the whole grid t_k = k/1000, k = 0..=1000 (1001
//! analyses, from the initial guess), as the peers do, and reports the time
//! per step (total / 1001), so criterion's figures compare directly with
//! BENCHMARKS.md.
//!
//! `cargo bench -p kinema-bench --bench steps` (add `--features large` for
//! N = 200 and 1000).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{
    BenchmarkGroup, Criterion, criterion_group, criterion_main, measurement::WallTime,
};
use kinema::{LinearSolver, Options, Solver, System};
use kinema_bench::{generated, grid, handwritten, steps, tape};

fn per_step<S: System, L: LinearSolver>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    id: &str,
    mut solver: Solver<S, L>,
) {
    let times = grid();
    let analyses = kinema_index::u32_of(times.len(), "the analyses per iteration");
    group.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let start = Instant::now();
                black_box(steps(&mut solver, black_box(&times)));
                total += start.elapsed();
            }
            total / analyses
        });
    });
}

fn modes() -> [(&'static str, Options); 2] {
    [
        ("same", Options::same_algorithm()),
        ("default", Options::default()),
    ]
}

/// One benchmark group per mechanism: generated, tape and JIT (and
/// hand-written where given), each in both modes.
macro_rules! mechanism {
    ($c:expr, $name:literal, $generated:expr, $samples:expr $(, $hand:expr)?) => {{
        let mut group = $c.benchmark_group(concat!("step/", $name));
        group.sample_size($samples);
        for (mode, options) in modes() {
            per_step(&mut group, &format!("generated/{mode}"), $generated.solver(options).unwrap_or_else(|e| panic!("{e}")));
            per_step(&mut group, &format!("tape/{mode}"), kinema_bench::solver(tape($name), options));
            // Above the JIT's size bounds `Backend::Jit` runs the tape: no row.
            if let Some(system) = kinema_bench::jit_if_compiled($name) {
                per_step(&mut group, &format!("jit/{mode}"), kinema_bench::solver(system, options));
            }
            $(per_step(&mut group, &format!("handwritten/{mode}"), kinema_bench::solver($hand, options));)?
        }
        group.finish();
    }};
}

fn small(c: &mut Criterion) {
    mechanism!(
        c,
        "slider_crank",
        generated::slider_crank::SliderCrank::default(),
        30,
        handwritten::SliderCrank::default()
    );
    mechanism!(
        c,
        "four_bar",
        generated::four_bar::FourBar::default(),
        30,
        handwritten::FourBar::default()
    );
    mechanism!(c, "chain2", generated::chain2::Chain2::default(), 30);
    mechanism!(
        c,
        "chain10",
        generated::chain10::Chain10::default(),
        30,
        handwritten::Chain::new(10)
    );
    mechanism!(c, "chain50", generated::chain50::Chain50::default(), 20);
    mechanism!(c, "chain100", generated::chain100::Chain100::default(), 10);
}

#[cfg(feature = "large")]
fn large(c: &mut Criterion) {
    mechanism!(c, "chain200", generated::chain200::Chain200::default(), 10);
    mechanism!(
        c,
        "chain1000",
        generated::chain1000::Chain1000::default(),
        10,
        handwritten::Chain::new(1000)
    );
}

#[cfg(not(feature = "large"))]
fn large(_: &mut Criterion) {}

criterion_group!(benches, small, large);
criterion_main!(benches);
