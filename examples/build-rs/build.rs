//! Generates `OUT_DIR/pendulum.rs` from the model file; Cargo reruns this
//! when the model changes.

fn main() {
    if let Err(e) = kinema_codegen::build::generate("../../models/pendulum.kin", "pendulum.rs") {
        // The rendered diagnostics point at file:line:col in the model.
        eprintln!("{e}");
        std::process::exit(1);
    }
    // The chain of ten links with its evaluation methods split into chunks
    // of a few nodes (as a 1000-body model's are at the default size), for
    // the test that chunked code computes what one body does, to the bit.
    let chunked = kinema_codegen::Config {
        chunk_nodes: 24,
        ..kinema_codegen::Config::default()
    };
    if let Err(e) = kinema_codegen::build::generate_with(
        "../../models/chain10.kin",
        "chain10_chunked.rs",
        &chunked,
    ) {
        eprintln!("{e}");
        std::process::exit(1);
    }
}
