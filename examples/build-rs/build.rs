//! Generates `OUT_DIR/pendulum.rs` from the model file; Cargo reruns this
//! when the model changes.

fn main() {
    if let Err(e) = kinema_codegen::build::generate("../../models/pendulum.kin", "pendulum.rs") {
        // The rendered diagnostics point at file:line:col in the model.
        eprintln!("{e}");
        std::process::exit(1);
    }
}
