//! The cost of inverse dynamics against the kinematic step, on generated
//! solvers with inertia: the whole grid t_k = k/1000, k = 0..=1000, (a)
//! kinematics alone, (b) kinematics and inverse dynamics at every step
//! (one evaluation of M, Q_A and the reaction arms, one transposed solve
//! with the step's factorization, the reactions). Times per step.
//!
//! `cargo bench -p kinema-bench --bench dynamics` (add
//! `--features large-dynamics` for the chain N = 1000).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{
    BenchmarkGroup, Criterion, criterion_group, criterion_main, measurement::WallTime,
};
use kinema::{Dynamics, InverseDynamics, LinearSolver, Options, Solver};
use kinema_bench::{generated_dynamics, grid, steps};

fn with_dynamics<S: Dynamics, L: LinearSolver>(
    solver: &mut Solver<S, L>,
    id: &mut InverseDynamics,
    times: &[f64],
) -> f64 {
    solver.reset();
    let mut acc = 0.0;
    for &t in times {
        solver.step(t).unwrap_or_else(|e| panic!("{e}"));
        solver
            .inverse_dynamics(id)
            .unwrap_or_else(|e| panic!("{e}"));
        acc += id.lambda()[0];
    }
    acc
}

fn pair<S: Dynamics, L: LinearSolver>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    mut solver: Solver<S, L>,
) {
    let times = grid();
    let analyses = kinema_index::u32_of(times.len(), "the analyses per iteration");
    group.bench_function("kinematics", |b| {
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
    let mut id = InverseDynamics::new(solver.system());
    group.bench_function("kinematics+inverse_dynamics", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let start = Instant::now();
                black_box(with_dynamics(&mut solver, &mut id, black_box(&times)));
                total += start.elapsed();
            }
            total / analyses
        });
    });
}

fn dynamics(c: &mut Criterion) {
    let options = Options::default();
    let mut group = c.benchmark_group("dynamics/slider_crank");
    group.sample_size(30);
    pair(
        &mut group,
        generated_dynamics::slider_crank::SliderCrank::default()
            .solver(options)
            .unwrap_or_else(|e| panic!("{e}")),
    );
    group.finish();
    let mut group = c.benchmark_group("dynamics/chain10");
    group.sample_size(30);
    pair(
        &mut group,
        generated_dynamics::chain10::Chain10::default()
            .solver(options)
            .unwrap_or_else(|e| panic!("{e}")),
    );
    group.finish();
    #[cfg(feature = "large-dynamics")]
    {
        let mut group = c.benchmark_group("dynamics/chain1000");
        group.sample_size(10);
        pair(
            &mut group,
            generated_dynamics::chain1000::Chain1000::default()
                .solver(options)
                .unwrap_or_else(|e| panic!("{e}")),
        );
        group.finish();
    }
}

criterion_group!(benches, dynamics);
criterion_main!(benches);
