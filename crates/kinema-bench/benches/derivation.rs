//! Time to get from model text to something that runs, on the serial chain:
//! parse + check + derive, the derivation alone (lowering to expressions,
//! Φ_q, ν, γ: what the peers' derivation times measure), then tape
//! compilation (runnable with no compiler), and the code generator's own
//! work (what `mechanism!` does at expansion) at N = 200.
//!
//! `cargo bench -p kinema-bench --bench derivation`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kinema_model::{Derivation, Derived, Parsed, Source};

fn derive(text: &str) -> Derived {
    Derived::from_source(Source::new("chain.kin", text)).unwrap_or_else(|e| panic!("{e}"))
}

fn derivation(c: &mut Criterion) {
    let mut group = c.benchmark_group("derivation");
    group.sample_size(10);
    for n in [10usize, 200, 1000] {
        let text = kinema_model::chain::chain_kin(n);
        group.bench_with_input(
            BenchmarkId::new("text to derivation", n),
            &text,
            |b, text| {
                b.iter(|| derive(black_box(text)).derivation().phi.len());
            },
        );
        let checked = Parsed::from_source(Source::new("chain.kin", text.as_str()))
            .and_then(|m| m.check())
            .unwrap_or_else(|e| panic!("{e}"));
        let checked = checked.model();
        group.bench_with_input(
            BenchmarkId::new("checked model to derivation", n),
            &checked,
            |b, checked| {
                b.iter(|| Derivation::new(black_box(checked)).map_or(0, |d| d.phi.len()));
            },
        );
        let d = derive(&text);
        group.bench_with_input(
            BenchmarkId::new("text to runnable tapes", n),
            &text,
            |b, text| {
                b.iter(|| kinema::Model::from_derived(derive(black_box(text))).system());
            },
        );
        if n == 200 {
            let options = kinema_codegen::Config::default();
            group.bench_function(BenchmarkId::new("codegen expand", n), |b| {
                b.iter(|| kinema_codegen::expand(black_box(d.derivation()), &options).is_empty());
            });
        }
    }
    group.finish();
}

criterion_group!(benches, derivation);
criterion_main!(benches);
