//! The generated source of the benchmark slider-crank, pinned (formatted with
//! prettyplease), and structural properties every generated file must have.

use kinema_codegen::{Config, SensitivityParams, build::source_for_file, expand};

fn model(name: &str) -> String {
    format!("{}/../../models/{name}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn slider_crank_source() {
    let source =
        source_for_file(model("slider_crank.kin"), &Config::default()).expect("model derives");
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
        let source = source_for_file(model(file), &Config::default()).expect("model derives");
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
    let options = Config {
        runtime: syn::parse_quote!(::kinema_runtime),
        ..Config::default()
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

/// The longest operator chains in one statement of `tokens` (groups are
/// searched too): (additive operators, multiplicative operators between two
/// additive ones). Each chain of n operators nests n deep when parsed.
fn longest_operator_chains(tokens: proc_macro2::TokenStream) -> (usize, usize) {
    use proc_macro2::TokenTree;
    let (mut additive, mut multiplicative) = (0, 0);
    let mut stack = vec![tokens];
    while let Some(tokens) = stack.pop() {
        let (mut sum, mut product) = (0, 0);
        for tree in tokens {
            match tree {
                TokenTree::Punct(p) if matches!(p.as_char(), '+' | '-') => {
                    sum += 1;
                    product = 0;
                    additive = additive.max(sum);
                }
                TokenTree::Punct(p) if matches!(p.as_char(), '*' | '/') => {
                    product += 1;
                    multiplicative = multiplicative.max(product);
                }
                TokenTree::Punct(p) if matches!(p.as_char(), ';' | '=' | ',') => {
                    (sum, product) = (0, 0);
                }
                TokenTree::Group(g) => stack.push(g.stream()),
                _ => {}
            }
        }
    }
    (additive, multiplicative)
}

/// Long sums and products are emitted as chains of partial results bound
/// in turn, so no statement is deep enough to overflow rustc's or
/// prettyplease's stack (both recurse on the nesting of an operator chain:
/// a 20 000-term sum emitted as one expression overflowed both). 1 000
/// terms keep the debug-build test short; BENCHMARKS.md has the 20 000-term
/// model through `kinema codegen` and `mechanism!`.
#[test]
fn long_sums_and_products_are_emitted_in_bounded_chains() {
    let terms: Vec<String> = (1..=1_000)
        .map(|k| format!("sin({k} * b.y) / {}", k * k))
        .collect();
    let factors: Vec<String> = (1..=40).map(|k| format!("(b.y + {k})")).collect();
    let text = format!(
        "mechanism Big {{\n    body b {{ guess: (0.1, 0.2, 0) }}\n    \
         constraint sum: b.x == 1e-3 * ({});\n    \
         constraint product: b.phi == 1e-300 * {};\n    \
         driver drive: b.y == t;\n}}\n",
        terms.join(" + "),
        factors.join(" * ")
    );
    let derivation = kinema_codegen::build::derive_source(&text, "big.kin").expect("model derives");
    let tokens = expand(&derivation, &Config::default());
    // Chains of 32 operands (a leading sign may add one operator); without
    // the partial results these would be 1 000 and 40 long.
    let longest = longest_operator_chains(tokens);
    assert!(
        (31..=34).contains(&longest.0) && (31..=34).contains(&longest.1),
        "longest operator chains {longest:?}"
    );
    let source = kinema_codegen::generate_source(&derivation, &Config::default());
    assert!(source.contains("impl ::kinema::__private::System for Big"));
}

/// Names the model language accepts but Rust spells differently — a raw
/// mechanism name, a keyword as a parameter — and a derivation constant
/// that overflowed (a squared length `pow(p0, 1.157e308)`: merged exponents
/// overflow to ∞) generate source instead of panicking (fuzz findings F6
/// and F7).
#[test]
fn raw_names_and_overflowed_exponents_generate() {
    let raw = "mechanism r#e {\n    param r#type = 2;\n    body b { guess: (1, 0, 0) }\n    \
               constraint c: b.x == r#type;\n    constraint d: b.phi == 0;\n    \
               driver drive: b.y == t;\n}\n";
    let derivation = kinema_codegen::build::derive_source(raw, "raw.kin").expect("model derives");
    let source = kinema_codegen::generate_source(&derivation, &Config::default());
    // `r#e` is the name `e` (a raw identifier in a model is its plain name).
    assert!(source.contains("pub struct e "), "{source}");
    assert!(source.contains("pub r#type: f64"), "{source}");

    let overflowing = "mechanism u {\n    param p0 = 1;\n    \
                       body b0 { guess: (0, 3.14, 3.14) }\n    body b1 { guess: (5, 6, 3) }\n    \
                       joint e0: revolute(b0(p0, 13), ground(5, 14));\n    \
                       constraint e1: abs_angle(b0, 139);\n    \
                       joint e2: revolute_revolute(b0(p0, 0), b1(p0, -p0), pow(p0, 1.157e308));\n    \
                       driver e3: abs_x(b1(0, 0), t);\n    driver e4: abs_angle(b1, 2 * t);\n}\n";
    let derivation =
        kinema_codegen::build::derive_source(overflowing, "inf.kin").expect("model derives");
    let source = kinema_codegen::generate_source(&derivation, &Config::default());
    assert!(source.contains("powf(f64::INFINITY)"), "{source}");
}

/// The slider-crank with `sensitivity = ["l1", "l2"]`: what is added to
/// its generated source (everything else is as without it), pinned — the
/// parameter columns' constants and the `SensitivitySystem`.
#[test]
fn slider_crank_sensitivity_source() {
    let plain =
        source_for_file(model("slider_crank.kin"), &Config::default()).expect("model derives");
    let options = Config {
        sensitivity: SensitivityParams::Named(vec!["l1".into(), "l2".into()]),
        ..Config::default()
    };
    let source = source_for_file(model("slider_crank.kin"), &options).expect("model derives");
    // The added lines, in order: the source without them is the plain one.
    let plain_lines: Vec<&str> = plain.lines().collect();
    let mut added = Vec::new();
    let mut k = 0;
    for line in source.lines() {
        if plain_lines.get(k) == Some(&line) {
            k += 1;
        } else {
            added.push(line);
        }
    }
    assert_eq!(
        k,
        plain_lines.len(),
        "every line of the plain source is kept"
    );
    let added = added.join("\n");
    assert!(added.contains("pub const PARAM_L1: usize = 0;"), "{added}");
    assert!(added.contains("pub const PARAM_L2: usize = 1;"), "{added}");
    assert!(!added.contains("PARAM_OMEGA"), "{added}");
    insta::assert_snapshot!(added);
}

/// With every param's sensitivities the generated code still neither
/// allocates nor panics by construction.
#[test]
fn sensitivity_code_neither_allocates_nor_panics_by_construction() {
    let options = Config {
        sensitivity: SensitivityParams::All,
        ..Config::default()
    };
    for file in ["slider_crank.kin", "four_bar.kin", "parabola_follower.kin"] {
        let source = source_for_file(model(file), &options).expect("model derives");
        assert!(source.contains("SensitivitySystem for"), "{file}");
        for forbidden in [
            "Vec", "vec!", "Box", "unwrap()", "expect(", "panic!", "String", "format!",
        ] {
            assert!(
                !source.contains(forbidden),
                "{file}: generated code contains `{forbidden}`"
            );
        }
    }
}

/// A name that is not a param: the build script's error names the model's
/// params; the macro's is a `compile_error!` saying the same.
#[test]
fn unknown_sensitivity_params_are_errors() {
    let options = Config {
        sensitivity: SensitivityParams::Named(vec!["l9".into()]),
        ..Config::default()
    };
    let err = source_for_file(model("slider_crank.kin"), &options)
        .expect_err("l9 is not a param")
        .to_string();
    assert!(err.contains("no param named `l9`"), "{err}");
    assert!(err.contains("l1, l2, omega"), "{err}");
    let tokens = kinema_codegen::expand_macro(
        format!(
            "file = {:?}, sensitivity = [\"crank\"]",
            model("slider_crank.kin")
        )
        .parse()
        .expect("tokens"),
    )
    .to_string();
    assert!(tokens.contains("compile_error"), "{tokens}");
    assert!(
        tokens.contains("`crank` is a body, not a param"),
        "{tokens}"
    );
    let tokens = kinema_codegen::expand_macro(
        format!("file = {:?}, sensitivity = some", model("slider_crank.kin"))
            .parse()
            .expect("tokens"),
    )
    .to_string();
    assert!(tokens.contains("expected `all`"), "{tokens}");
}

/// The values every param's stages share are written by `prepare` once
/// each — in several functions when the bodies are split past
/// `chunk_nodes` — and every one written is read by some stage.
#[test]
fn shared_sensitivity_values_are_written_once_and_read() {
    for chunk_nodes in [usize::MAX, 8] {
        let options = Config {
            sensitivity: SensitivityParams::All,
            chunk_nodes,
            ..Config::default()
        };
        let source = source_for_file(model("slider_crank.kin"), &options).expect("model derives");
        let len: usize = source
            .split("shared: [f64; ")
            .nth(1)
            .and_then(|rest| rest.split(']').next())
            .and_then(|n| n.parse().ok())
            .expect("a `shared` field");
        assert!(len > 10, "{len} shared values");
        let prepares = source.matches("fn __kinema_sensitivity_prepare_").count();
        assert_eq!(
            prepares > 1,
            chunk_nodes == 8,
            "{prepares} prepare functions"
        );
        for k in 0..len {
            let write = format!("scratch.shared[{k}] =");
            assert_eq!(source.matches(&write).count(), 1, "{write}");
            let read = format!("scratch.shared[{k}]");
            assert!(source.matches(&read).count() > 1, "{read} is never read");
        }
    }
}
