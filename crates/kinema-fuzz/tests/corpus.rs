//! Replays the regression corpus (`corpus/kin`, `corpus/adm`, `corpus/fun`,
//! and `corpus/cli` when the `kinema` binary is built:
//! inputs the fuzzer found interesting) in process: none may panic or
//! violate an oracle, except findings on the known list (`known.txt`),
//! which are printed. Also checks that the generators stay deterministic
//! and useful.

#![allow(clippy::unwrap_used)] // tests: a failure should stop the test

use std::path::PathBuf;

use kinema_fuzz::generate::{self, Seeds};
use kinema_fuzz::rng::Rng;
use kinema_fuzz::verdict::{Known, Verdict, minimize, run_caught};
use kinema_fuzz::{Reach, Target};

fn corpus(target: Target) -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("corpus")
        .join(target.name());
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.sort();
    files
}

#[test]
fn corpus_replays_without_new_findings() {
    let known = Known::committed();
    let mut new = Vec::new();
    let mut replayed = 0;
    for target in Target::ALL {
        if target == Target::Cli && kinema_fuzz::cli::kinema_binary().is_none() {
            println!("NOTICE: no `kinema` binary built; the cli corpus is skipped");
            continue;
        }
        for file in corpus(target) {
            let data = std::fs::read(&file).unwrap();
            replayed += 1;
            let verdict = run_caught(target, &data);
            if let Some(sig) = verdict.signature() {
                if known.contains(target, &sig) {
                    println!("known finding in {}: {sig}", file.display());
                } else {
                    new.push(format!("{}: {}", file.display(), verdict.describe()));
                }
            }
        }
    }
    assert!(replayed > 0, "the corpus is empty");
    assert!(new.is_empty(), "findings:\n{}", new.join("\n\n"));
}

#[test]
fn generators_are_deterministic() {
    let seeds = Seeds::embedded();
    for target in Target::ALL {
        let run = |seed| {
            let mut rng = Rng::new(seed);
            (0..50)
                .map(|_| generate::input(target, &mut rng, &seeds))
                .collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7), "{}", target.name());
        assert_ne!(run(7), run(8), "{}", target.name());
    }
}

/// Grammar-generated inputs must mostly get past the parser and a fair
/// share must run: otherwise the generator has drifted from the language.
#[test]
fn generated_models_reach_the_runtime() {
    // (The `cli` target runs the same generators through the program.)
    for target in [Target::Kin, Target::Adm, Target::Fun] {
        let mut rng = Rng::new(3);
        let (mut parsed, mut ran, n) = (0, 0, 60);
        for _ in 0..n {
            let text = match target {
                Target::Kin => generate::kin::generate(&mut rng),
                Target::Adm | Target::Cli => generate::adm::generate(&mut rng),
                Target::Fun => generate::fun::generate(&mut rng),
            };
            match run_caught(target, text.as_bytes()) {
                Verdict::Clean(Reach::Parse) => {}
                Verdict::Clean(Reach::Ran) => {
                    parsed += 1;
                    ran += 1;
                }
                _ => parsed += 1,
            }
        }
        println!("{}: {parsed} of {n} parse, {ran} run", target.name());
        assert!(
            parsed * 10 >= n * 6,
            "{}: {parsed} of {n} parse",
            target.name()
        );
        assert!(ran * 10 >= n, "{}: {ran} of {n} run", target.name());
    }
}

#[test]
fn known_list_matches_prefixes_per_target() {
    let known = Known::parse("# comment\nkin panic at crates/x.rs\n* hang  # all targets\n");
    assert!(known.contains(Target::Kin, "panic at crates/x.rs:10"));
    assert!(!known.contains(Target::Adm, "panic at crates/x.rs:10"));
    assert!(known.contains(Target::Fun, "hang"));
    assert!(!known.contains(Target::Fun, "oom"));
}

#[test]
fn minimize_keeps_the_property_and_shrinks() {
    let input = b"line one\nline two\nthe bad line\nline four\n";
    let small = minimize(input, 500, &mut |d| {
        std::str::from_utf8(d).is_ok_and(|s| s.contains("bad"))
    });
    assert_eq!(small, b"bad");
}

#[test]
fn panics_are_caught_with_their_location() {
    let verdict = kinema_fuzz::verdict::catch(|| panic!("synthetic {}", 42));
    let Verdict::Panic {
        location, message, ..
    } = &verdict
    else {
        panic!("not caught as a panic: {verdict:?}");
    };
    assert!(
        location.starts_with("crates/kinema-fuzz/tests/corpus.rs:"),
        "{location}"
    );
    assert_eq!(message, "synthetic 42");
    let signature = verdict.signature().unwrap();
    assert!(signature.starts_with("panic at crates/kinema-fuzz/tests/corpus.rs:"));
    // The column is not part of the signature.
    assert_eq!(signature.matches(':').count(), 1, "{signature}");
    assert_eq!(run_caught(Target::Fun, b"t"), Verdict::Clean(Reach::Ran));
}

#[test]
#[ignore = "debugging aid"]
fn show_adm_parse_errors() {
    let mut rng = Rng::new(3);
    for _ in 0..60 {
        let text = generate::adm::generate(&mut rng);
        let adm = text.split('\0').next().unwrap();
        if let Err(e) = kinema_adm::Model::parse(&kinema_model::Source::new("x.adm", adm)) {
            println!("{}", e.to_string().lines().next().unwrap());
        }
    }
}

#[test]
#[ignore = "debugging aid"]
fn show_kin_outcomes() {
    let mut rng = Rng::new(3);
    for _ in 0..60 {
        let text = generate::kin::generate(&mut rng);
        match kinema::Model::from_source(&text, "x.kin") {
            Err(e) => println!("{}", e.render().lines().next().unwrap()),
            Ok(m) => {
                let mut s = kinema::Solver::<_, kinema::Auto>::new(m.system()).unwrap();
                match s.step(0.0) {
                    Ok(_) => println!("ran"),
                    Err(e) => println!(
                        "run: {}",
                        e.to_string().chars().take(90).collect::<String>()
                    ),
                }
            }
        }
    }
}

#[test]
fn signatures_of_dependencies_do_not_name_the_machine() {
    use kinema_fuzz::verdict::strip_column;
    assert_eq!(
        strip_column(
            "/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/nalgebra-0.35.0/src/linalg/svd.rs:746:65"
        ),
        "nalgebra-0.35.0/src/linalg/svd.rs:746"
    );
    assert_eq!(
        strip_column("crates/kinema-codegen/src/lib.rs:81:16"),
        "crates/kinema-codegen/src/lib.rs:81"
    );
}
