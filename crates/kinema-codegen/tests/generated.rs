//! The generated source of the benchmark slider-crank, pinned (formatted with
//! prettyplease), and structural properties every generated file must have.

use kinema_codegen::{Options, build::source_for_file, expand};

fn model(name: &str) -> String {
    format!("{}/../../models/{name}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn slider_crank_source() {
    let source =
        source_for_file(model("slider_crank.kin"), &Options::default()).expect("model derives");
    insta::assert_snapshot!(source);
}

#[test]
fn generated_code_neither_allocates_nor_panics_by_construction() {
    for file in [
        "slider_crank.kin",
        "four_bar.kin",
        "chain10.kin",
        "parabola_follower.kin",
    ] {
        let source = source_for_file(model(file), &Options::default()).expect("model derives");
        for forbidden in [
            "Vec", "vec!", "Box", "unwrap()", "expect(", "panic!", "String", "format!",
        ] {
            assert!(
                !source.contains(forbidden),
                "{file}: generated code contains `{forbidden}`"
            );
        }
        // Slices are converted to fixed-size arrays once, so constant indices
        // are checked at compile time.
        assert!(source.contains("try_from(q) else"), "{file}");
    }
}

#[test]
fn runtime_path_is_configurable() {
    let derivation = kinema_codegen::build::derive_source(
        &std::fs::read_to_string(model("pendulum.kin")).expect("model file"),
        "pendulum.kin",
    )
    .expect("model derives");
    let options = Options {
        runtime: syn::parse_quote!(::kinema_runtime),
        ..Options::default()
    };
    let tokens = expand(&derivation, &options).to_string();
    assert!(tokens.contains(":: kinema_runtime :: System"));
    assert!(!tokens.contains("__private"));
}

#[test]
fn model_errors_render_with_file_line_and_column() {
    let err = kinema_codegen::build::derive_source(
        "mechanism M {\n    body b { guess: (0, 0, 0) }\n    driver d: c.phi == t;\n}\n",
        "bad.kin",
    )
    .expect_err("unknown body");
    let text = err.to_string();
    assert!(text.contains("bad.kin:3:15"), "{text}");
}
