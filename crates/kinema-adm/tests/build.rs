//! `build` (the model made straight from the ADM data, for `kinema run`)
//! against `to_kin` (the `.kin` text of `kinema import`, parsed back): the
//! same derivation on every model, and messages that point into the ADM
//! file.

#![allow(clippy::unwrap_used)] // tests: a failure should stop the test

mod common;

use kinema_adm::{Model, Source, build, parsed, to_kin};
use kinema_model::{Derivation, ParsedModel};

/// The derivation of `model` both ways: everything it holds (the arena,
/// every row, Φ_q, ν, γ, outputs, dynamics) and its rendering are equal.
fn same_derivation(name: &str, model: &Model) {
    let text = to_kin(model);
    let printed = ParsedModel::parse_str(&text)
        .and_then(|m| m.check())
        .unwrap_or_else(|d| panic!("{name}: printed:\n{}", d.render(&text, name)));
    let built = build(model)
        .check()
        .unwrap_or_else(|d| panic!("{name}: built: {d:?}"));
    let printed = Derivation::new(&printed).unwrap();
    let built = Derivation::new(&built).unwrap();
    assert_eq!(built.render(), printed.render(), "{name}");
    assert_eq!(format!("{built:?}"), format!("{printed:?}"), "{name}");
    assert_eq!(
        built.dynamics.is_some(),
        kinema_adm::dynamics::has_dynamics(model)
    );
}

#[test]
fn built_and_printed_models_derive_the_same() {
    for name in [
        "absolute_pendulum.adm",
        "four_bar.adm",
        "rack_pinion.adm",
        "rack_pinion_tilting.adm",
        "slider_crank.adm",
        "translational.adm",
        "free_pendulum.adm",
    ] {
        let m = Model::parse(&common::source(name)).unwrap();
        same_derivation(name, &m);
    }
}

/// Every `.adm` of ../shared/simengine2d, kinematic and dynamic.
#[test]
fn real_files_build_as_they_print() {
    let Some(paths) = common::shared_models() else {
        return;
    };
    let mut dynamic = 0;
    for path in &paths {
        let m = Model::read(path).unwrap().0;
        dynamic += usize::from(kinema_adm::dynamics::has_dynamics(&m));
        same_derivation(&path.display().to_string(), &m);
    }
    assert!(paths.len() >= 10, "{} files", paths.len());
    assert!(dynamic >= 3, "{dynamic} models with dynamics");
}

/// Functions whose `fun` strings cover every node kind of the `fun`
/// language, with exponents that are and are not integers, negative
/// numbers, `log10`, and dynamics (forces of every kind).
#[test]
fn every_fun_node_builds_as_it_prints() {
    let adm = r#"{
  "name": "funs",
  "gravity": [0, -9.81],
  "bodies": [
    { "name": "gear", "id": 1, "mass": 2, "jbar": 0.5, "q0": [1, 0, 0], "qd0": [0, 0, 0] },
    { "name": "box", "id": 2, "mass": 1, "jbar": 0.1, "q0": [2, 0, 0], "qd0": [0, 0, 0],
      "vis": { "points": [[0.5, -0.25], [1, 1]] } } ],
  "constraints": [
    { "name": "x", "id": 1, "type": "AbsoluteX", "body1": 1, "sP1": [-1, 0.5], "fun": "-2^-2 + t^2 - t.^(1/2)" },
    { "name": "y", "id": 2, "type": "AbsoluteY", "body1": 1, "sP1": [-1, 0], "fun": "log10(2 + t) * log(3 + t) / atan2(t, 2)" },
    { "name": "a", "id": 3, "type": "AbsoluteAngle", "body1": 1, "fun": "-(sin(t) - -cos(2*pi*t)) + power(t, 3) + abs(-t)" },
    { "name": "rp", "id": 5, "type": "RackPinion", "body1": 1, "body2": 2, "sP1": [0, 0], "sQ1": [1, 0.5],
      "sP2": [0.25, 0], "R2": 0.3, "theta1": -0.2, "theta2": 0.1 } ],
  "forces": [
    { "name": "push", "id": 1, "type": "PointForce", "body1": 2, "sP1": [0.1, 0], "frame": "GRF", "funX": "sin(t)", "funY": "-1" },
    { "name": "pull", "id": 2, "type": "PointForce", "body1": 1, "sP1": [0, 0.1], "frame": "LRF", "funX": "1", "funY": "t^3" },
    { "name": "twist", "id": 3, "type": "Torque", "body1": 1, "fun": "exp(-t)" },
    { "name": "spring", "id": 4, "type": "RSDA1", "body1": 2, "k": 10, "c": 0.5, "theta0": -0.1, "fun": "0" },
    { "name": "spring 2", "id": 5, "type": "RSDA2", "body1": 1, "body2": 2, "k": 3, "c": 0, "theta0": 0.2, "fun": "sqrt(1 + t)" } ]
}"#;
    let m = Model::parse(&Source::new("funs.adm", adm)).unwrap();
    assert!(kinema_adm::dynamics::has_dynamics(&m));
    same_derivation("funs.adm", &m);
}

/// A message of kinema-model about an ADM model names the ADM file's line
/// and column of the value it is about and shows that line. The reader
/// refuses everything the checker would (an undefined `fun`, a body joined
/// to itself, …: the fuzzer holds it to that), so the derivation's own
/// error stands in: an equation whose derivatives outgrow a small budget,
/// reported at the equation's name — the constraint's `"name"` value.
#[test]
fn model_errors_point_into_the_adm_file() {
    let adm = r#"{
  "name": "grounded",
  "bodies": [ { "name": "gear", "id": 1, "q0": [0, 0, 0] } ],
  "constraints": [
    { "name": "x", "id": 1, "type": "AbsoluteX", "body1": 1, "sP1": [0, 0], "fun": "0" },
    { "name": "y", "id": 2, "type": "AbsoluteY", "body1": 1, "sP1": [0, 0], "fun": "0" },
    { "name": "big", "id": 3, "type": "AbsoluteAngle", "body1": 1, "fun": "sin(sin(sin(sin(t))))" }
  ]
}"#;
    let source = Source::new("grounded.adm", adm);
    let m = Model::parse(&source).unwrap();
    let checked = parsed(&m, source).check().unwrap();
    assert_eq!(checked.source().name(), "grounded.adm");
    let d = Derivation::with_budget(checked.model(), 20).unwrap_err();
    let text = d.render(adm, "grounded.adm");
    println!("{text}");
    // `"big"`: line 7, column 15 (1-based).
    assert!(text.contains("--> grounded.adm:7:15"), "{text}");
    assert!(
        text.contains(r#"7 |     { "name": "big", "id": 3,"#),
        "{text}"
    );
    assert!(!text.contains(".kin"), "{text}");
}
