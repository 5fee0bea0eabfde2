//! Hostile input and the error output: any number of mistakes renders a
//! bounded report in linear time, a megabyte-long line renders a short
//! excerpt, and bytes that are not UTF-8 are located. Rendered text is an
//! insta snapshot.

use kinema_model::check_str;
use kinema_model::diagnostic::MAX_KEPT;

/// A model with `n` independent errors (one unknown name per driver).
fn many_errors(n: usize) -> String {
    let mut src = String::from("mechanism Many {\n    body bar;\n");
    for i in 0..n {
        src.push_str(&format!("    driver d{i}: bar.x == nobody{i} * t;\n"));
    }
    src.push_str("}\n");
    src
}

/// 20 000 errors (a quadratic renderer took 5 s for 16 000): every one is counted, the first [`MAX_KEPT`] are shown,
/// the rest are summed up, and the text stays small.
#[test]
fn many_errors_render_a_bounded_report() {
    let n = 20_000;
    let src = many_errors(n);
    let d = check_str(&src).err().unwrap_or_default();
    assert_eq!(d.error_count(), n);
    assert!(d.iter().count() <= 2 * MAX_KEPT);
    let text = d.render(&src, "many.kin");
    let shown = text.matches("error: unknown name `nobody").count();
    assert_eq!(shown, MAX_KEPT);
    assert!(text.len() < 100_000, "{} bytes", text.len());
    // The last error shown, and the summary.
    let tail = text
        .rfind("error: unknown name")
        .map_or(text.as_str(), |i| &text[i..]);
    insta::assert_snapshot!(tail);
}

/// Rendering is linear in the number of diagnostics: the lines are indexed
/// once, not searched from the start of the text for each diagnostic. Ten
/// times the errors may not cost a hundred times the time (a quadratic
/// renderer took 5 s for 16 000 errors); measured on the same machine in
/// the same process, with a wide margin for noise.
#[test]
fn rendering_is_linear() {
    let time = |n: usize| {
        let src = many_errors(n);
        let d = check_str(&src).err().unwrap_or_default();
        let start = std::time::Instant::now();
        let text = d.render(&src, "many.kin");
        assert!(!text.is_empty());
        start.elapsed().as_secs_f64()
    };
    // Warm up, then compare 2 000 with 20 000 errors.
    let _ = time(200);
    let small = time(2_000).max(1e-4);
    let large = time(20_000);
    assert!(
        large < 30.0 * small + 0.05,
        "2 000 errors: {small:.4} s, 20 000 errors: {large:.4} s"
    );
}

/// A 1 MB model on one line with an error at its end (a character the
/// lexer rejects, so that the test stays fast) renders a short excerpt
/// around the caret, cut between characters, the wide characters before the
/// caret counted as two columns.
#[test]
fn megabyte_line_renders_a_short_excerpt() {
    let mut src = String::from("mechanism Long { body bar; driver swing: bar.phi == t");
    while src.len() < 1_000_000 {
        src.push_str(" + 0 * t");
    }
    src.push_str(" + 長さ * 漢字é + `nobody; }\n");
    let d = check_str(&src).err().unwrap_or_default();
    let text = d.render(&src, "long.kin");
    assert!(text.len() < 2000, "{} bytes", text.len());
    insta::assert_snapshot!(text);
}

/// Bytes that are not UTF-8: line, column and byte offset of the first.
#[test]
fn invalid_utf8_is_located() {
    let bytes = b"mechanism Bad {\n    body bar;\n    driver d: bar.x == t; // caf\xE9\n}\n";
    let report = kinema_model::Source::from_bytes("latin1.kin", bytes.to_vec()).err();
    insta::assert_snapshot!(report.map(|r| r.render()).unwrap_or_default());
}

/// Brackets in comments and string-like text are not groups: a comment or a
/// doc comment full of them (an imported simEngine2D body named
/// `tan(abs(abs(…`, found by the fuzzer) checks; the same depth in code is
/// still refused at its 513th bracket.
#[test]
fn brackets_in_comments_do_not_count_towards_the_nesting_limit() {
    let deep = "(".repeat(600);
    let model = format!(
        "// {deep}\n/* {deep} /* nested */ */\nmechanism M {{\n    /// {deep}\n    body b;\n    \
         joint x: abs_x(b(0, 0), 0);\n    joint y: abs_y(b(0, 0), 0);\n    driver d: b.phi == t;\n}}\n"
    );
    if let Err(d) = check_str(&model) {
        panic!("{}", d.render(&model, "comments.kin"));
    }
    let code = format!("mechanism M {{ body b; driver d: b.phi == {deep}t; }}");
    let rendered = check_str(&code)
        .err()
        .map(|d| d.render(&code, "deep.kin"))
        .unwrap_or_default();
    assert!(
        rendered.contains("brackets nested too deeply"),
        "{rendered}"
    );
    assert!(rendered.contains("level 513"), "{rendered}");
}
