//! Snapshots of the rendered errors for bad ADM input and refused analyses.

#![allow(clippy::unwrap_used)] // tests: a failure should stop the test

mod common;

use kinema_adm::{Analysis, Model, Source, check_kinematic};

/// The errors of the crate's file `name`, rendered as the command line
/// shows them.
fn error(name: &str) -> String {
    let source = common::source(name);
    match Model::parse(&source) {
        Ok(_) => panic!("{name} was accepted"),
        Err(e) => common::render(&source, e),
    }
}

#[test]
fn malformed_json() {
    insta::assert_snapshot!("bad_json", error("bad_json.adm"));
}

#[test]
fn malformed_number() {
    insta::assert_snapshot!("bad_number", error("bad_number.adm"));
}

#[test]
fn unknown_constraint_type() {
    insta::assert_snapshot!("bad_type", error("bad_type.adm"));
}

#[test]
fn body_that_does_not_exist() {
    let e = error("bad_body.adm");
    assert!(e.contains(
        "constraint \"rev_crank_rod\" (id 3): field \"body2\": body 7 does not exist (the model has 3 bodies)"
    ));
    insta::assert_snapshot!("bad_body", e);
}

#[test]
fn fun_that_does_not_parse() {
    insta::assert_snapshot!("bad_fun", error("bad_fun.adm"));
}

/// A `fun` whose value is undefined whatever the time (a divisor that is
/// identically zero, a constant that overflows, `log` of zero) is refused at
/// the offending operator inside the field, each one, as the `.kin` checker
/// would refuse the imported model (hostile-input issue, item 7; fuzz F11).
#[test]
fn fun_undefined_whatever_the_time() {
    let e = error("undefined_fun.adm");
    assert_eq!(
        e.matches("is undefined whatever the time").count(),
        4,
        "{e}"
    );
    insta::assert_snapshot!("undefined_fun", e);
}

/// A rack-and-pinion whose rolling row's constant L + R2 (θ1 − θ2 + 3π/2)
/// overflows is refused at
/// R2 (fuzz run 2: 391 imported models refused at "this constant is
/// infinite" in text the user never wrote).
#[test]
fn rack_pinion_scale_that_overflows() {
    let e = error("rack_scale_overflow.adm");
    assert!(
        e.contains("field \"R2\": the rolling row's constant |sQ1 - sP1| + R2 (theta1 - theta2 + 3 pi / 2) is larger than the largest number"),
        "{e}"
    );
    assert!(e.contains("rack_scale_overflow.adm:9:"), "{e}");
    // Its rolling angle's constant θ1 − θ2 likewise, at theta2.
    let e = error("rack_angle_overflow.adm");
    assert!(
        e.contains("field \"theta2\": theta1 - theta2 is larger than the largest number"),
        "{e}"
    );
}

#[test]
fn missing_and_malformed_fields() {
    insta::assert_snapshot!("bad_fields", error("bad_fields.adm"));
}

#[test]
fn unreadable_file() {
    let e = Model::read(std::path::Path::new("no/such/model.adm")).unwrap_err();
    let e = e.render();
    assert!(
        e.starts_with("error: cannot read model file `no/such/model.adm`: "),
        "{e}"
    );
    assert!(e.contains(" --> no/such/model.adm\n"), "{e}");
}

#[test]
fn refusals() {
    let free = Model::parse(&common::source("free_pendulum.adm")).unwrap();
    let refusal = check_kinematic(&free, &Analysis::default()).unwrap_err();
    insta::assert_snapshot!("refuse_ndof", refusal.to_string());
    let crank = Model::parse(&common::source("slider_crank.adm")).unwrap();
    let dynamics = Analysis::parse(&common::source("dynamics.acf")).unwrap();
    let refusal = check_kinematic(&crank, &dynamics).unwrap_err();
    insta::assert_snapshot!("refuse_dynamics", refusal.to_string());
}

#[test]
fn garbage_never_panics() {
    // Truncations and byte-level damage of a real-looking file: every prefix
    // must give a model or an error, never a panic.
    let text = common::read("absolute_pendulum.adm");
    let chars: Vec<char> = text.chars().collect();
    for end in 0..chars.len() {
        let prefix: String = chars[..end].iter().collect();
        let _ = Model::parse(&Source::new("prefix.adm", prefix.as_str()));
        let _ = Analysis::parse(&Source::new("prefix.acf", prefix.as_str()));
    }
    for (i, c) in chars.iter().enumerate().step_by(3) {
        for replacement in ['"', '{', ']', ',', '^', '(', '\\', 'é', '\t'] {
            if *c == replacement {
                continue;
            }
            let mut damaged = chars.clone();
            damaged[i] = replacement;
            let damaged: String = damaged.into_iter().collect();
            let source = Source::new("damaged.adm", damaged);
            if let Err(e) = Model::parse(&source) {
                assert!(!common::render(&source, e).is_empty());
            }
        }
    }
}

/// A negative or non-finite `mass` or `jbar` is refused at its field, as
/// the `.kin` checker would refuse the imported inertia (fuzz run of stop
/// 13: `adm-emitted-kin-rejected`, "an inertia is -1").
#[test]
fn negative_mass_or_inertia() {
    let text = common::read("absolute_pendulum.adm");
    for (field, bad) in [("mass", "-2"), ("jbar", "-1"), ("jbar", "-1e-300")] {
        let needle = format!("\"{field}\"");
        let at = text.find(&needle).unwrap_or_else(|| panic!("no {field}"));
        let start = at + needle.len() + text[at + needle.len()..].find(':').unwrap() + 1;
        let end = start + text[start..].find([',', '\n', '}']).unwrap();
        let edited = format!("{} {bad}{}", &text[..start], &text[end..]);
        let source = Source::new("bad_inertia.adm", edited);
        let e = match Model::parse(&source) {
            Ok(_) => panic!("{field} = {bad} was accepted"),
            Err(e) => common::render(&source, e),
        };
        assert!(
            e.contains(&format!("field \"{field}\": expected a finite number ≥ 0")),
            "{e}"
        );
    }
}
