//! Prints the generated source of a model file, or of the benchmark chain:
//! `cargo run -p kinema-codegen --example show -- models/x.kin` or `-- chain 200`.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let options = kinema_codegen::Config::default();
    let result = match args.as_slice() {
        [chain, n] if chain == "chain" => {
            let n: usize = n.parse().unwrap_or(10);
            let text = kinema_model::chain::chain_kin(n);
            kinema_codegen::build::derive_source(&text, &format!("chain{n}.kin"))
                .map(|d| kinema_codegen::generate_source(&d, &options))
        }
        [path] => kinema_codegen::build::source_for_file(path, &options),
        _ => kinema_codegen::build::source_for_file("models/slider_crank.kin", &options),
    };
    match result {
        Ok(s) => print!("{s}"),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    }
}
