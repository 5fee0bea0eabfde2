//! Generates `OUT_DIR/pendulum.rs` from the model file; Cargo reruns this
//! when the model changes.

fn main() {
    if let Err(e) = kinema_codegen::build::generate("../../models/pendulum.kin", "pendulum.rs") {
        // The rendered diagnostics point at file:line:col in the model.
        eprintln!("{e}");
        std::process::exit(1);
    }
    // The chain of ten links with its evaluation methods, initial guess and
    // LU solves split into chunks of a few nodes (as a 1000-body model's are
    // at the default size), and the four-bar, whose LU's factorization does
    // arithmetic, cut into chunks of three: for the tests that chunked code
    // computes what one body does, to the bit.
    for (model, output, chunk_nodes) in [
        ("../../models/chain10.kin", "chain10_chunked.rs", 24),
        ("../../models/four_bar.kin", "four_bar_chunked.rs", 3),
    ] {
        let chunked = kinema_codegen::Config {
            chunk_nodes,
            ..kinema_codegen::Config::default()
        };
        if let Err(e) = kinema_codegen::build::generate_with(model, output, &chunked) {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
