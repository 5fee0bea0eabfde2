//! `kinema run --backend jit|tape`: the compiled model (the default) and
//! the interpreter write the same CSV byte for byte, also for a model whose
//! tapes are compiled in chunks (the chain N = 200), without a note.

mod common;

use common::{ROOT, TempDir, TestResult, assert_status, kinema, stderr};

fn run(dir: &TempDir, model: &str, backend: Option<&str>, out: &str) -> (String, String) {
    let path = dir.path(out);
    let mut args = vec!["run", model, "--steps", "200", "--out", &path];
    if let Some(b) = backend {
        args.extend(["--backend", b]);
    }
    let o = kinema(&args);
    assert_status(&o, 0);
    let csv = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    (csv, stderr(&o))
}

#[test]
fn jit_and_tape_write_the_same_results() -> TestResult {
    let dir = TempDir::new("cli_backend_same");
    for model in [
        "models/slider_crank.kin",
        "models/four_bar.kin",
        "models/chain10.kin",
        "tests/singular/six_bar.kin",
    ] {
        let model = format!("{ROOT}/{model}");
        let (default, note) = run(&dir, &model, None, "default.csv");
        let (jit, _) = run(&dir, &model, Some("jit"), "jit.csv");
        let (tape, _) = run(&dir, &model, Some("tape"), "tape.csv");
        assert!(!note.contains("tape interpreter"), "{model}: {note}");
        assert_eq!(default, jit, "{model}: the default is the JIT");
        assert_eq!(jit, tape, "{model}: jit vs tape");
        assert!(jit.lines().count() > 200, "{model}");
    }
    Ok(())
}

#[test]
fn a_chain_compiled_in_chunks_runs_on_the_jit_byte_for_byte() -> TestResult {
    // The chain N = 200 (once over the JIT's bound, now compiled in
    // chunks): no note, and the same CSV as the tape's.
    let dir = TempDir::new("cli_backend_large");
    let model = dir.path("chain200.kin");
    std::fs::write(&model, kinema::lang::chain::chain_kin(200))?;
    let (jit, note) = run(&dir, &model, Some("jit"), "jit.csv");
    assert!(!note.contains("running on the tape interpreter"), "{note}");
    let (tape, quiet) = run(&dir, &model, Some("tape"), "tape.csv");
    assert!(!quiet.contains("tape interpreter"), "{quiet}");
    assert_eq!(jit, tape);
    Ok(())
}
