//! Where the time of the N = 1000 derivation goes: `cargo run --release -p kinema-bench --example phases`.
use std::time::Instant;
fn main() {
    let text = kinema_model::chain::chain_kin(1000);
    for _ in 0..5 {
        let t0 = Instant::now();
        let ts: proc_macro2::TokenStream = text.parse().expect("lexes");
        let t1 = Instant::now();
        let model = kinema_model::ParsedModel::parse_str(&text).expect("parses");
        let t2 = Instant::now();
        let checked = model.check().expect("checks");
        let t3 = Instant::now();
        let d = kinema_model::Derivation::new(&checked).expect("derives");
        let t4 = Instant::now();
        let _sys = kinema::Model::from_derivation(d).system();
        let t5 = Instant::now();
        drop(ts);
        println!(
            "lex {:?}  parse(incl. lex) {:?}  check {:?}  derive {:?}  tapes {:?}",
            t1 - t0,
            t2 - t1,
            t3 - t2,
            t4 - t3,
            t5 - t4
        );
    }
}
