//! Prints the generated source of a model file: `cargo run -p kinema-codegen --example show -- models/x.kin`.
fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "models/slider_crank.kin".into());
    match kinema_codegen::build::source_for_file(&path, &kinema_codegen::Options::default()) {
        Ok(s) => print!("{s}"),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    }
}
