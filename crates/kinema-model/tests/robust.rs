//! Robustness: deep or huge input never overflows a small stack, and no
//! input makes the crate panic.

use kinema_model::{Derivation, check_str, derive_str};

/// Runs `f` on a thread with a 2 MiB stack (the default test-thread size).
fn small_stack(f: impl FnOnce() + Send + 'static) {
    let handle = std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(f)
        .unwrap_or_else(|e| panic!("spawn: {e}"));
    assert!(handle.join().is_ok(), "the thread panicked or overflowed");
}

#[test]
fn huge_user_equation() {
    small_stack(|| {
        let n = 100_000;
        let mut src = String::from(
            "mechanism Big { body bar { guess: (1, 0, 0) }\n joint pin: revolute(bar(-1, 0), ground(0, 0));\n driver swing: bar.phi == 0",
        );
        for k in 0..n {
            src.push_str(&format!(" + 1e-9 * sin(t + {k})"));
        }
        src.push_str(";\n}\n");
        let d = derive_str(&src).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.dof.ndof(), 0);
        // A long left-leaning chain of products and negations too.
        let mut src = String::from(
            "mechanism Deep { body bar { guess: (1, 0, 0) }\n joint pin: revolute(bar(-1, 0), ground(0, 0));\n driver swing: bar.phi == t",
        );
        for _ in 0..n {
            src.push_str(" * 1");
        }
        src.push_str(" + ");
        for _ in 0..n {
            src.push('-');
        }
        src.push_str("t;\n}\n");
        let d: Derivation = derive_str(&src).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.rows.len(), 3);
    });
}

#[test]
fn deep_nesting_is_an_error_not_a_crash() {
    small_stack(|| {
        for depth in [100, 127, 128, 129, 1_000, 100_000] {
            let src = format!(
                "mechanism Deep {{ body bar; joint pin: revolute(bar(-1, 0), ground(0, 0));\n driver swing: bar.phi == {}t{};\n}}",
                "(".repeat(depth),
                ")".repeat(depth)
            );
            let r = check_str(&src);
            if depth < 127 {
                assert!(r.is_ok(), "depth {depth}");
            } else if depth > 128 {
                assert!(r.is_err(), "depth {depth}");
            }
        }
    });
}

/// A tiny deterministic fuzzer: mutations of every model in models/ and of
/// the UI cases must give a result or diagnostics (rendered), never a panic.
#[test]
fn mutations_never_panic() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut sources = Vec::new();
    for dir in [root.join("../../models"), root.join("tests/ui")] {
        if let Ok(rd) = std::fs::read_dir(dir) {
            for e in rd.filter_map(Result::ok) {
                if let Ok(s) = std::fs::read_to_string(e.path())
                    && s.len() < 20_000
                {
                    sources.push(s);
                }
            }
        }
    }
    sources.sort();
    assert!(!sources.is_empty());
    let pieces = [
        "",
        "(",
        ")",
        "{",
        "}",
        ";",
        ",",
        ".",
        "==",
        "=",
        "-",
        "*",
        "/",
        "+",
        "t",
        "pi",
        "ground",
        "1e999",
        "0",
        "x",
        "phi",
        "2f32",
        "body",
        "param",
        "driver",
        "joint",
        "revolute(",
        "abs_angle",
        "#",
        "\"",
        "'",
        "/*",
        "é",
        "\u{0}",
        "1.",
        "..",
        "::",
    ];
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut next = |m: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % m as u64) as usize
    };
    for round in 0..3000 {
        let src = &sources[round % sources.len()];
        let chars: Vec<char> = src.chars().collect();
        let mut out: Vec<char> = chars.clone();
        for _ in 0..1 + next(3) {
            if out.is_empty() {
                break;
            }
            let at = next(out.len());
            match next(3) {
                0 => {
                    out.remove(at);
                }
                1 => {
                    let p = pieces[next(pieces.len())];
                    for (k, c) in p.chars().enumerate() {
                        out.insert(at + k, c);
                    }
                }
                _ => {
                    let to = (at + next(20)).min(out.len());
                    out.drain(at..to);
                }
            }
        }
        let text: String = out.into_iter().collect();
        match derive_str(&text) {
            Ok(d) => {
                let _ = d.render();
            }
            Err(e) => {
                let _ = e.render(&text, "fuzz.kin");
                let _ = e.to_syn_error();
            }
        }
    }
}
