//! Prints the N-body serial chain of BENCHMARKS.md as `.kin` text:
//! `cargo run -p kinema-model --example chain -- 10 > models/chain10.kin`.
fn main() {
    let n = std::env::args()
        .nth(1)
        .and_then(|s| s.parse::<usize>().ok())
        .unwrap_or(10);
    print!("{}", kinema_model::chain::chain_kin(n));
}
