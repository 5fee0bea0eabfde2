//! Hostile but valid models through the `kinema` binary: a product of 800
//! coordinates checks, runs and derives in linear size; a driver that makes
//! the velocities overflow is named as the cause of a non-finite γ; times in
//! run-time errors print short.

use std::path::PathBuf;
use std::process::{Command, Output};

/// A model file in a fresh temporary directory (removed on drop).
struct Model {
    dir: PathBuf,
    path: PathBuf,
}

impl Model {
    fn new(name: &str, text: &str) -> Model {
        let dir =
            std::env::temp_dir().join(format!("kinema-hostile-expr-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let path = dir.join(format!("{name}.kin"));
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
        Model { dir, path }
    }

    fn run(&self, args: &[&str]) -> Output {
        let mut all: Vec<String> = args.iter().map(|s| (*s).to_owned()).collect();
        all.insert(1, self.path.display().to_string());
        Command::new(env!("CARGO_BIN_EXE_kinema"))
            .args(&all)
            .current_dir(&self.dir)
            .output()
            .unwrap_or_else(|e| panic!("cannot run kinema: {e}"))
    }
}

impl Drop for Model {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `n` bodies on the x axis, bodies 2..n driven, and one constraint: the
/// product of all n x coordinates is 1.
fn product_model(n: usize) -> String {
    let mut s = String::from("mechanism Product {\n");
    for i in 1..=n {
        s.push_str(&format!("    body b{i} {{ guess: (1, 0, 0) }}\n"));
    }
    for i in 1..=n {
        s.push_str(&format!(
            "    constraint y{i}: b{i}.y == 0;\n    constraint r{i}: b{i}.phi == 0;\n"
        ));
    }
    for i in 2..=n {
        s.push_str(&format!("    driver d{i}: b{i}.x == 1 + 0.001 * t;\n"));
    }
    let factors: Vec<String> = (1..=n).map(|i| format!("b{i}.x")).collect();
    s.push_str(&format!(
        "    constraint prod: {} == 1;\n}}\n",
        factors.join(" * ")
    ));
    s
}

#[test]
fn a_product_of_800_coordinates_checks_runs_and_derives() {
    let m = Model::new("product", &product_model(800));
    let o = m.run(&["check"]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}\n{err}");
    assert!(out.contains("ok: `Product` assembles"), "{out}");
    // b1.x = 1 / Π_{i≥2} (1 + 0.001 t): at t = 1, 1.001^-799.
    let o = m.run(&["run", "--t-end", "1", "--steps", "2", "--out", "-"]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let last = out.lines().last().unwrap_or_default();
    let b1x: f64 = last
        .split(',')
        .nth(1)
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no b1.x in {last}"));
    let want = 1.001f64.powi(-799);
    assert!((b1x - want).abs() < 1e-9, "{b1x} vs {want}");
    // The derivation text stays small: the second derivatives of the
    // product go to one shared program instead of n² printed trees.
    let o = m.run(&["derive"]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(out.len() < 4_000_000, "{} bytes", out.len());
    assert!(out.contains("shared program"));
}

#[test]
fn a_driver_that_overflows_the_velocities_is_named_with_a_short_time() {
    // b.x = exp(1000 t): ẋ = 1000 exp(1000 t) passes 1.3e154 at t ≈ 0.348,
    // where ẋ² overflows in γ of `c` (2e-300 ẋ², finite by itself). The
    // motion is followed through internal sub-steps up to there.
    let m = Model::new(
        "fast",
        "mechanism Fast {\n    body b { guess: (1, 0, 0) }\n    \
         constraint c: b.y == 1e-300 * b.x * b.x;\n    constraint d: b.phi == 0;\n    \
         driver spin: b.x == exp(1000 * t);\n}\n",
    );
    let o = m.run(&["run", "--t-end", "1", "--steps", "20", "--out", "-"]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("non-finite γ at t = 0.34"), "{err}");
    assert!(
        err.contains("c, because the velocities overflow it: q̇ of b.x = "),
        "{err}"
    );
    assert!(err.contains("e154, from ν of spin = "), "{err}");
}

/// A crank driven by exp(1000 t) turns millions of times between output
/// times: no sub-step follows it, and the failure says so instead of
/// "did not converge" with a tiny residual.
#[test]
fn a_motion_too_fast_to_follow_is_named_as_such() {
    let m = Model::new(
        "spin",
        "mechanism Spin {\n    param l1 = 0.3;\n    param l2 = 1.0;\n    \
         body crank { guess: (0.1, 0.1, 0.8) }\n    body rod { guess: (0.6, 0.1, -0.2) }\n    \
         body slider { guess: (1.2, 0.0, 0.0) }\n    \
         joint pivot: revolute(ground(0, 0), crank(-l1 / 2, 0));\n    \
         joint pin: revolute(crank(l1 / 2, 0), rod(-l2 / 2, 0));\n    \
         joint wrist: revolute(rod(l2 / 2, 0), slider(0, 0));\n    \
         constraint on_axis: slider.y == 0;\n    constraint no_turn: slider.phi == 0;\n    \
         driver spin: crank.phi == exp(1000 * t);\n}\n",
    );
    let o = m.run(&["run", "--t-end", "1", "--steps", "20", "--out", "-"]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot follow the motion from t = "), "{err}");
    assert!(!err.contains("did not converge"), "{err}");
}
