//! Per-step cost of the benchmark mechanisms (BENCHMARKS.md): each sample
//! runs the whole grid t_k = k/1000, k = 0…1000 (assembly + 1000 steps) like
//! the peers; divide the reported time by 1001 for the time per step.
//!
//! `cargo bench -p kinema-runtime --bench steps`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use kinema_runtime::handwritten::{Chain, FourBar, SliderCrank};
use kinema_runtime::{
    DenseLu, DynDenseLu, LinearSolver, LinearSolverFor, Options, Solver, SparseLu, System,
};
use std::hint::black_box;
use std::time::Duration;

const STEPS: usize = 1001;

fn modes() -> [(&'static str, Options); 2] {
    [
        ("same_algorithm", Options::same_algorithm()),
        ("default", Options::default()),
    ]
}

/// Assembly at t = 0 and 1000 steps; panics on failure (benchmarks only).
fn run_grid<S: System, L: LinearSolver>(solver: &mut Solver<S, L>) {
    let mut ok = solver.assemble(0.0).is_ok();
    for k in 1..STEPS {
        ok &= solver
            .step(k as f64 / 1000.0)
            .map(|s| black_box(s.qdd()[0]))
            .is_ok();
    }
    assert!(ok, "the benchmark mechanism failed");
}

fn bench_mechanism<S: System + Clone, L: LinearSolverFor<S>>(
    c: &mut Criterion,
    group: &str,
    label: &str,
    system: &S,
) {
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(STEPS as u64));
    for (mode, options) in modes() {
        let Ok(mut solver) = Solver::<S, L>::with_options(system.clone(), options) else {
            panic!("setup failed");
        };
        g.bench_function(BenchmarkId::new(label, mode), |b| {
            b.iter(|| run_grid(&mut solver))
        });
    }
    g.finish();
}

fn small(c: &mut Criterion) {
    bench_mechanism::<_, DenseLu<9>>(c, "slider_crank", "DenseLu9", &SliderCrank::default());
    bench_mechanism::<_, DynDenseLu>(c, "slider_crank", "DynDenseLu", &SliderCrank::default());
    bench_mechanism::<_, DenseLu<9>>(c, "four_bar", "DenseLu9", &FourBar::default());
}

fn chains(c: &mut Criterion) {
    bench_mechanism::<_, DenseLu<30>>(c, "chain10", "DenseLu30", &Chain::new(10));
    bench_mechanism::<_, DynDenseLu>(c, "chain10", "DynDenseLu", &Chain::new(10));
    bench_mechanism::<_, SparseLu>(c, "chain10", "SparseLu", &Chain::new(10));
    bench_mechanism::<_, SparseLu>(c, "chain100", "SparseLu", &Chain::new(100));
    bench_mechanism::<_, SparseLu>(c, "chain1000", "SparseLu", &Chain::new(1000));
}

criterion_group! {
    name = small_group;
    config = Criterion::default().measurement_time(Duration::from_secs(4)).sample_size(30);
    targets = small
}
criterion_group! {
    name = chain_group;
    config = Criterion::default().measurement_time(Duration::from_secs(8)).sample_size(10);
    targets = chains
}
criterion_main!(small_group, chain_group);
