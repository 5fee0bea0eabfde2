//! `kinema`: the command line of kinema — check, run, derive, codegen and
//! import planar mechanisms. See `kinema --help` and the README.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
