//! Linear solvers alone: the dense kernel against nalgebra's LU on the
//! slider-crank Jacobian, and dense against sparse on chain Jacobians of
//! growing size (where `Auto` switches).
//!
//! `cargo bench -p kinema-runtime --bench linalg`

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kinema_runtime::handwritten::{Chain, SliderCrank};
use kinema_runtime::{DenseLu, DynDenseLu, LinearSolver, SparseLu, System};
use nalgebra::{SMatrix, SVector};
use std::hint::black_box;
use std::time::Duration;

fn jacobian<S: System>(system: &mut S) -> (Vec<(u32, u32)>, Vec<f64>) {
    let mut q = vec![0.0; system.len()];
    system.initial_guess(&mut q);
    let pattern = system.jacobian_pattern().to_vec();
    let mut values = vec![0.0; pattern.len()];
    system.jacobian(&mut system.scratch(), &q, 0.0, &mut values);
    (pattern, values)
}

/// Factor + two solves, the velocity/acceleration part of a step.
fn factor_and_solve<L: LinearSolver>(lu: &mut L, values: &[f64], rhs: &mut [f64]) {
    let ok = lu.factor(values, 1e-10).is_ok()
        && lu.solve_in_place(rhs).is_ok()
        && lu.solve_in_place(rhs).is_ok();
    assert!(ok);
}

fn slider_crank_9x9(c: &mut Criterion) {
    let (pattern, values) = jacobian(&mut SliderCrank::default());
    let mut g = c.benchmark_group("lu9_factor_and_2_solves");
    let rhs0: Vec<f64> = (0..9).map(|i| 1.0 + i as f64).collect();
    if let Ok(mut lu) = DenseLu::<9>::analyze(9, &pattern) {
        g.bench_function("DenseLu9", |b| {
            b.iter(|| {
                let mut rhs = rhs0.clone();
                factor_and_solve(&mut lu, black_box(&values), &mut rhs);
                rhs
            })
        });
    }
    g.bench_function("nalgebra_SMatrix_lu", |b| {
        b.iter(|| {
            let mut a = SMatrix::<f64, 9, 9>::zeros();
            for (&(r, c), &v) in pattern.iter().zip(black_box(&values)) {
                a[(r as usize, c as usize)] = v;
            }
            let lu = a.lu();
            let mut rhs = SVector::<f64, 9>::from_column_slice(&rhs0);
            let ok = lu.solve_mut(&mut rhs) && lu.solve_mut(&mut rhs);
            assert!(ok);
            rhs
        })
    });
    g.finish();
}

fn dense_vs_sparse(c: &mut Criterion) {
    let mut g = c.benchmark_group("chain_factor_and_2_solves");
    for links in [5, 10, 15, 20, 30, 50] {
        let n = 3 * links;
        let (pattern, values) = jacobian(&mut Chain::new(links));
        let rhs0: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        if let Ok(mut lu) = DynDenseLu::analyze(n, &pattern) {
            g.bench_function(BenchmarkId::new("DynDenseLu", n), |b| {
                b.iter(|| {
                    let mut rhs = rhs0.clone();
                    factor_and_solve(&mut lu, black_box(&values), &mut rhs);
                    rhs
                })
            });
        }
        if let Ok(mut lu) = SparseLu::analyze(n, &pattern) {
            g.bench_function(BenchmarkId::new("SparseLu", n), |b| {
                b.iter(|| {
                    let mut rhs = rhs0.clone();
                    factor_and_solve(&mut lu, black_box(&values), &mut rhs);
                    rhs
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(2)).warm_up_time(Duration::from_millis(500));
    targets = slider_crank_9x9, dense_vs_sparse
}
criterion_main!(benches);
