//! The cost of parameter sensitivities (issue 40) against a kinematic step,
//! on the generated slider-crank (params l1, l2, omega) and the chain
//! N = 50 with params (link length l, drivers' amplitude a;
//! `kinema_bench::chain_kin_params`), each generated with every param's
//! `SensitivitySystem`:
//!
//! - `generated/step`: one kinematic step (the grid t_k = k/1000,
//!   k = 0..=1000, from the initial guess, kinema's defaults; total / 1001,
//!   as benches/steps.rs measures);
//! - `generated/step+sensitivities`: the same run with
//!   `Solver::sensitivities` (every param) after each step, per step;
//! - `generated/sensitivities-same-state`: `Solver::sensitivities` alone,
//!   every param, again and again at one state (t = 0.37): a lower bound,
//!   as there the sensitivity scratch's sin and cos of the angles (keyed
//!   on the exact angle) are never recomputed. The cost per param is
//!   (`step+sensitivities` − `step`) / params;
//! - `jit/…`: the same through a model file on the JIT (the step native,
//!   the sensitivity tapes interpreted).
//!
//! The target: per param, the sensitivities cost ≤ 0.5× a step.
//! `cargo bench -p kinema-bench --bench sensitivity`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use kinema::{
    Backend, LinearSolver, Model, Options, Sensitivities, SensitivitySystem, Solver, System,
};
use kinema_bench::{generated_sensitivity, grid};

/// The time at which the sensitivities alone are measured.
const AT: f64 = 0.37;

/// Per step of the grid, optionally with `each` after every step.
fn per_step<S: System, L: LinearSolver>(
    c: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: &str,
    solver: &mut Solver<S, L>,
    mut each: impl FnMut(&mut Solver<S, L>),
) {
    let times = grid();
    let steps = kinema_index::u32_of(times.len(), "the steps per iteration");
    c.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                solver.reset();
                let start = Instant::now();
                for &t in black_box(&times) {
                    solver.step(t).unwrap_or_else(|e| panic!("{e}"));
                    each(solver);
                }
                total += start.elapsed();
            }
            total / steps
        });
    });
}

fn generated<S, L>(c: &mut Criterion, name: &str, mut solver: Solver<S, L>, samples: usize)
where
    S: System + SensitivitySystem,
    L: LinearSolver,
{
    let mut group = c.benchmark_group(format!("sensitivity/{name}"));
    group.sample_size(samples);
    let params = solver.system().param_count();
    println!("{name}: {params} params");
    let mut out = Sensitivities::new(solver.system());
    per_step(&mut group, "generated/step", &mut solver, |_| {});
    per_step(
        &mut group,
        "generated/step+sensitivities",
        &mut solver,
        |s| {
            s.sensitivities(&mut out).unwrap_or_else(|e| panic!("{e}"));
        },
    );
    solver.reset();
    for &t in grid().iter().take_while(|&&t| t <= AT) {
        solver.step(t).unwrap_or_else(|e| panic!("{e}"));
    }
    group.bench_function("generated/sensitivities-same-state", |b| {
        b.iter(|| {
            solver
                .sensitivities(black_box(&mut out))
                .unwrap_or_else(|e| panic!("{e}"));
        });
    });
    black_box(out.coordinates(0)[0][0]);
    group.finish();
}

fn jit(c: &mut Criterion, name: &str, model: Model, samples: usize) {
    let mut group = c.benchmark_group(format!("sensitivity/{name}"));
    group.sample_size(samples);
    let model = model.with_backend(Backend::Jit);
    let mut sens = model
        .sensitivity_to_every_param()
        .unwrap_or_else(|e| panic!("{e}"));
    let system = model.system();
    if system.wait_for_jit() != Backend::Jit {
        println!(
            "{name}: the JIT fell back ({:?}): no jit rows",
            system.jit_fallback()
        );
        return;
    }
    let mut solver = kinema_bench::solver(system, Options::default());
    per_step(&mut group, "jit/step", &mut solver, |_| {});
    per_step(&mut group, "jit/step+sensitivities", &mut solver, |s| {
        sens.compute(s).unwrap_or_else(|e| panic!("{e}"));
    });
    solver.reset();
    for &t in grid().iter().take_while(|&&t| t <= AT) {
        solver.step(t).unwrap_or_else(|e| panic!("{e}"));
    }
    group.bench_function("jit/sensitivities-same-state", |b| {
        b.iter(|| {
            sens.compute(black_box(&mut solver))
                .unwrap_or_else(|e| panic!("{e}"));
        });
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    let options = Options::default();
    let slider_crank = generated_sensitivity::slider_crank::SliderCrank::default()
        .solver(options)
        .unwrap_or_else(|e| panic!("{e}"));
    generated(c, "slider_crank", slider_crank, 30);
    let chain = generated_sensitivity::chain50::Chain50::default()
        .solver(options)
        .unwrap_or_else(|e| panic!("{e}"));
    generated(c, "chain50", chain, 20);
    let model =
        |text: &str, file: &str| Model::from_source(text, file).unwrap_or_else(|e| panic!("{e}"));
    jit(
        c,
        "slider_crank",
        model(
            &kinema_bench::model_text("slider_crank"),
            "slider_crank.kin",
        ),
        30,
    );
    jit(
        c,
        "chain50",
        model(&kinema_bench::chain_kin_params(50), "chain50_params.kin"),
        20,
    );
}

criterion_group!(sensitivity, benches);
criterion_main!(sensitivity);
