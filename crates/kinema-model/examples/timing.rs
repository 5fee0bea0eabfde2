//! Times the phases on the N-body chain: `cargo run --release -p kinema-model --example timing -- 1000`.
use std::time::Instant;

fn main() {
    let n = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000);
    let text = kinema_model::chain::chain_kin(n);
    for _ in 0..3 {
        let t0 = Instant::now();
        // The front door's phases one at a time.
        let model = kinema_model::Parsed::from_source(kinema_model::Source::new(
            "chain.kin",
            text.as_str(),
        ));
        let t1 = Instant::now();
        let checked = model.and_then(|m| m.check());
        let t2 = Instant::now();
        let rows = checked
            .and_then(|c| c.derive())
            .map_or(0, |d| d.derivation().phi.len());
        let t3 = Instant::now();
        println!(
            "n = {n}: parse {:?}, check {:?}, derive {:?}, total {:?} ({rows} rows)",
            t1 - t0,
            t2 - t1,
            t3 - t2,
            t3 - t0
        );
    }
}
