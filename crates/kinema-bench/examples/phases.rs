//! Where the time of the N = 1000 derivation goes, and text → first step on
//! each back end of a model file: `cargo run --release -p kinema-bench
//! --example phases [N]`.
use std::time::Instant;

use kinema::{Backend, Options, Solver};

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1000);
    let text = kinema_model::chain::chain_kin(n);
    for _ in 0..5 {
        let t0 = Instant::now();
        let ts: proc_macro2::TokenStream = text.parse().expect("lexes");
        let t1 = Instant::now();
        let model = kinema_model::Parsed::from_source(kinema_model::Source::new(
            "chain.kin",
            text.as_str(),
        ))
        .expect("parses");
        let t2 = Instant::now();
        let checked = model.check().expect("checks");
        let t3 = Instant::now();
        let d = checked.derive().expect("derives");
        let t4 = Instant::now();
        let model = kinema::Model::from_derived(d);
        drop(ts);
        let mut line = format!(
            "N = {n}: lex {:?}  parse(incl. lex) {:?}  check {:?}  derive {:?}",
            t1 - t0,
            t2 - t1,
            t3 - t2,
            t4 - t3,
        );
        for backend in [Backend::Tape, Backend::Jit] {
            let t5 = Instant::now();
            let system = model.clone().with_backend(backend).system();
            let t6 = Instant::now();
            let used = system.backend();
            let mut solver = Solver::<_, kinema::Auto>::with_options(system, Options::default())
                .expect("solver");
            solver.step(0.0).expect("first step");
            let t7 = Instant::now();
            line += &format!(
                "  | {backend:?} (runs {used:?}): system {:?}, solver + first step {:?}, text → first step {:?}",
                t6 - t5,
                t7 - t6,
                (t4 - t0) - (t1 - t0) + (t7 - t5)
            );
        }
        if let Some(why) = model.system().jit_fallback() {
            line += &format!("  | JIT fallback: {why}");
        }
        println!("{line}");
    }
}
