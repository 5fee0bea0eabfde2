//! Generates the solvers of the benchmark mechanisms into OUT_DIR with
//! kinema-codegen's build-script path: the two models from models/ and the
//! serial chains from kinema-model's generator (N = 200 and 1000 only with
//! the `large` feature: they take a while to compile).

use std::path::Path;

#[path = "src/param_chain.rs"]
mod param_chain;

fn main() {
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    for (file, out) in [
        ("slider_crank.kin", "slider_crank.rs"),
        ("four_bar.kin", "four_bar.rs"),
    ] {
        if let Err(e) = kinema_codegen::build::generate(models.join(file), out) {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
    let mut chains = vec![2, 10, 50, 100];
    if std::env::var_os("CARGO_FEATURE_LARGE").is_some() {
        chains.extend([200, 1000]);
    }
    let Some(out_dir) = std::env::var_os("OUT_DIR") else {
        eprintln!("OUT_DIR is not set");
        std::process::exit(1);
    };
    for n in chains {
        let text = kinema_model::chain::chain_kin(n);
        let source = kinema_codegen::build::derive_source(&text, &format!("chain{n}.kin"))
            .map(|d| kinema_codegen::generate_source(&d, &kinema_codegen::Config::default()));
        match source {
            Ok(source) => {
                let path = Path::new(&out_dir).join(format!("chain{n}.rs"));
                if let Err(e) = std::fs::write(&path, source) {
                    eprintln!("{}: {e}", path.display());
                    std::process::exit(1);
                }
            }
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
    }
    // Inverse dynamics (benches/dynamics.rs): the slider-crank with inertia,
    // and the chain with inertia and gravity (N = 1000 with the
    // `large-dynamics` feature).
    let dynamics =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/dynamics/slider_crank.kin");
    if let Err(e) = kinema_codegen::build::generate(&dynamics, "slider_crank_dynamics.rs") {
        eprintln!("{e}");
        std::process::exit(1);
    }
    let mut dynamic_chains = vec![10];
    if std::env::var_os("CARGO_FEATURE_LARGE_DYNAMICS").is_some() {
        dynamic_chains.push(1000);
    }
    for n in dynamic_chains {
        let text = kinema_model::chain::chain_kin_dynamics(n);
        let name = format!("chain{n}_dynamics");
        let source = kinema_codegen::build::derive_source(&text, &format!("{name}.kin"))
            .map(|d| kinema_codegen::generate_source(&d, &kinema_codegen::Config::default()));
        let path = Path::new(&out_dir).join(format!("{name}.rs"));
        match source.map(|s| std::fs::write(&path, s)) {
            Ok(Ok(())) => {}
            Ok(Err(e)) => {
                eprintln!("{}: {e}", path.display());
                std::process::exit(1);
            }
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
    }
    // Forward dynamics (benches/forward.rs): the lead's benchmark
    // mechanisms (own copies in tests/forward_backends until the models
    // directory has them).
    let forward = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/forward_backends");
    for name in ["fd_slider_crank", "fd_chain10", "fd_chain100"] {
        let file = forward.join(format!("{name}.kin"));
        if let Err(e) = kinema_codegen::build::generate(&file, format!("{name}.rs")) {
            eprintln!("{e}");
            std::process::exit(1);
        }
        println!("cargo::rerun-if-changed=../../tests/forward_backends/{name}.kin");
    }
    // Parameter sensitivities (benches/sensitivity.rs): the slider-crank
    // and the chain N = 50 with params, every param's sensitivities
    // generated.
    let sensitivity = kinema_codegen::Config {
        sensitivity: kinema_codegen::SensitivityParams::All,
        ..kinema_codegen::Config::default()
    };
    let generated = kinema_codegen::build::generate_with(
        models.join("slider_crank.kin"),
        "slider_crank_sensitivity.rs",
        &sensitivity,
    )
    .map(|_| ())
    .map_err(|e| e.to_string())
    .and_then(|()| {
        let text = param_chain::chain_kin_params(50);
        let d = kinema_codegen::build::derive_source(&text, "chain50_params.kin")
            .map_err(|e| e.to_string())?;
        let source = kinema_codegen::generate_source(&d, &sensitivity);
        let path = Path::new(&out_dir).join("chain50_sensitivity.rs");
        std::fs::write(&path, source).map_err(|e| format!("{}: {e}", path.display()))
    });
    if let Err(e) = generated {
        eprintln!("{e}");
        std::process::exit(1);
    }
    println!("cargo::rerun-if-changed=src/param_chain.rs");
    println!("cargo::rerun-if-changed=../../tests/dynamics/slider_crank.kin");
    println!("cargo::rerun-if-changed=build.rs");
}
