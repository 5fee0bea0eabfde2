//! One small bad model per validation rule in `tests/ui/`, named after the
//! mistake; the exact rendered diagnostics of each are an insta snapshot.
//! A model that passes with warnings renders its warnings.

use std::path::PathBuf;

fn render(name: &str, src: &str) -> String {
    let file = format!("ui/{name}.kin");
    match kinema_model::check_str(src) {
        Ok(model) => {
            let w = model.warnings.render(src, &file);
            format!("(accepted)\n{w}")
        }
        Err(d) => d.render(src, &file),
    }
}

#[test]
fn ui() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/ui");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .map(|rd| {
            rd.filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter_map(|n| n.strip_suffix(".kin").map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    names.sort_unstable();
    assert!(names.len() >= 30, "ui cases missing: {names:?}");
    for name in names {
        let src = std::fs::read_to_string(dir.join(format!("{name}.kin"))).unwrap_or_default();
        insta::assert_snapshot!(format!("ui__{name}"), render(&name, &src));
    }
}

/// The same errors through the proc-macro door: one combined `syn::Error`
/// with one message per error.
#[test]
fn syn_error_is_combined() {
    let src = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/ui/multiple_errors.kin"),
    )
    .unwrap_or_default();
    let tokens: proc_macro2::TokenStream = src.parse().unwrap_or_default();
    let model = kinema_model::ParsedModel::parse_tokens(tokens).unwrap_or_else(|e| panic!("{e}"));
    let diagnostics = model.check().err().unwrap_or_default();
    let n = diagnostics.error_count();
    assert!(n >= 5, "{diagnostics}");
    let messages: Vec<String> = diagnostics
        .into_syn_error()
        .into_iter()
        .map(|e| e.to_string())
        .collect();
    assert_eq!(messages.len(), n);
    assert!(
        messages[0].starts_with("duplicate name `L`"),
        "{messages:?}"
    );
}
