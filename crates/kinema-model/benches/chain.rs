//! Parse + check + derive the serial chain of BENCHMARKS.md from text.
//! `cargo bench -p kinema-model`

use criterion::{Criterion, criterion_group, criterion_main};
use kinema_model::{Derived, Parsed, Source, chain::chain_kin};

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("chain");
    group.sample_size(20);
    for n in [10usize, 200, 1000] {
        let text = chain_kin(n);
        group.bench_function(format!("parse_check_derive/{n}"), |b| {
            b.iter(|| {
                let source = Source::new("chain.kin", std::hint::black_box(text.as_str()));
                Derived::from_source(source).map_or(0, |d| d.derivation().phi.len())
            });
        });
    }
    let text = chain_kin(1000);
    group.bench_function("parse_check/1000", |b| {
        b.iter(|| {
            Parsed::from_source(Source::new(
                "chain.kin",
                std::hint::black_box(text.as_str()),
            ))
            .and_then(Parsed::check)
            .is_ok()
        });
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
