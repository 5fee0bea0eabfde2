//! q at t = 1 of the forward-dynamics benchmarks (benches/peers/README.md
//! §6) from kinema's accurate mode at rtol 1e-11 — the reference the peers'
//! answers are checked against — and from HHT-α at the benchmark's step
//! (h = 1e-3, tape back end). Prints CSV rows `mech,source,q0,…` (numbers
//! that read back to the same double) and, on stderr, the gap between the
//! two; `benches/peers/reference/fd_q_t1.csv` is this output.
//!
//! `cargo run --release -p kinema-bench --example fd_reference > benches/peers/reference/fd_q_t1.csv`

use kinema::{Accurate, Hht, HhtOptions, Model};

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

fn row(name: &str, source: &str, q: &[f64]) {
    let numbers: Vec<String> = q.iter().map(|x| format!("{x:?}")).collect();
    println!("{name},{source},{}", numbers.join(","));
}

fn main() {
    // Rows have as many numbers as the mechanism has coordinates.
    println!("mech,source,q...");
    for name in ["fd_slider_crank", "fd_chain10", "fd_chain100"] {
        let m = model(name);
        let q0 = m.initial_configuration();
        let qd0 = vec![0.0; q0.len()];
        let system = || m.forward_system().unwrap_or_else(|| panic!("no inertia"));
        let start = std::time::Instant::now();
        let mut accurate =
            Accurate::new(system(), &q0, &qd0, 0.0, 1e-11).unwrap_or_else(|e| panic!("{e}"));
        accurate.advance_to(1.0).unwrap_or_else(|e| panic!("{e}"));
        let s = accurate.stats();
        eprintln!(
            "{name}: accurate rtol 1e-11: {} steps accepted, {} rejected, {:.1?}",
            s.accepted,
            s.rejected,
            start.elapsed()
        );
        let reference = accurate.q().to_vec();
        row(name, "kinema-accurate-1e-11", &reference);
        let (mut hht, _) = Hht::new(system(), &q0, &qd0, 0.0, HhtOptions::default())
            .unwrap_or_else(|e| panic!("{e}"));
        for _ in 0..1000 {
            hht.step(1e-3).unwrap_or_else(|e| panic!("{e}"));
        }
        row(name, "kinema-hht-tape", hht.q());
        let gap = hht
            .q()
            .iter()
            .zip(&reference)
            .fold(0.0_f64, |g, (a, b)| g.max((a - b).abs()));
        eprintln!("{name}: HHT h = 1e-3 against it: max |Δq| = {gap:.3e}");
    }
}
