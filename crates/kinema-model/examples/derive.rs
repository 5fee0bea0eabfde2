//! Prints the derivation of a model file, or its diagnostics.
fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: derive MODEL.kin");
        std::process::exit(2);
    };
    let src = match std::fs::read_to_string(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(2);
        }
    };
    match kinema_model::derive_str(&src) {
        Ok(d) => print!("{}", d.render()),
        Err(diag) => {
            eprint!("{}", diag.render(&src, &path));
            std::process::exit(1);
        }
    }
}
