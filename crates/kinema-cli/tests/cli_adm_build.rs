//! `kinema run model.adm` builds the model straight from the ADM file
//! (kinema-adm's `build`, no `.kin` text in between): bodies named like
//! keywords run under their own names, and messages name the ADM file's
//! line and column.

mod common;
use common::*;

/// A pendulum `gear` pinned at the origin by its end (-1, 0), driven
/// φ = π/2 + 2πt, with `box` and `type` hung from it and held level; an
/// equation named `driver`.
const KEYWORDS: &str = r#"{
  "name": "keyword bodies",
  "bodies": [ { "name": "gear", "id": 1, "q0": [0, 1, 1.5] },
              { "name": "box", "id": 2, "q0": [0, 2, 0] },
              { "name": "type", "id": 3, "q0": [1, 2, 0] } ],
  "constraints": [
    { "name": "pin x", "id": 1, "type": "AbsoluteX", "body1": 1, "sP1": [-1, 0], "fun": "0" },
    { "name": "pin y", "id": 2, "type": "AbsoluteY", "body1": 1, "sP1": [-1, 0], "fun": "0" },
    { "name": "driver", "id": 3, "type": "AbsoluteAngle", "body1": 1, "fun": "pi/2 + 2*pi*t" },
    { "name": "hang", "id": 4, "type": "RevoluteJoint", "body1": 1, "sP1": [1, 0], "body2": 2, "sP2": [0, 0] },
    { "name": "level", "id": 5, "type": "AbsoluteAngle", "body1": 2, "fun": "0" },
    { "name": "next", "id": 6, "type": "RevoluteJoint", "body1": 2, "sP1": [1, 0], "body2": 3, "sP2": [0, 0] },
    { "name": "level 2", "id": 7, "type": "AbsoluteAngle", "body1": 3, "fun": "0" }
  ]
}"#;

#[test]
fn bodies_named_gear_box_type_import_and_run() -> TestResult {
    let dir = TempDir::new("adm-keywords");
    let adm = dir.path("keywords.adm");
    std::fs::write(&adm, KEYWORDS)?;
    let out = dir.path("keywords.csv");
    let o = kinema(&["run", &adm, "--steps", "20", "--out", &out]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    // The end of gear at the origin: r = A(φ)(1, 0) = (cos φ, sin φ), and
    // box's origin at gear's other end, 2(cos φ, sin φ); type 1 to its right.
    let mut worst = 0.0_f64;
    for row in &csv.rows {
        let get = |n: &str| csv.column(n).map(|c| row[c]);
        let (t, phi) = (get("t")?, get("gear.phi")?);
        let expected = std::f64::consts::FRAC_PI_2 + 2.0 * std::f64::consts::PI * t;
        worst = worst.max((phi - expected).abs());
        worst = worst.max((get("gear.x")? - phi.cos()).abs());
        worst = worst.max((get("gear.y")? - phi.sin()).abs());
        worst = worst.max((get("box.x")? - 2.0 * phi.cos()).abs());
        worst = worst.max((get("type.x")? - 2.0 * phi.cos() - 1.0).abs());
        worst = worst.max((get("type.y")? - 2.0 * phi.sin()).abs());
        worst = worst.max(get("box.phi")?.abs());
    }
    assert!(csv.rows.len() > 10, "{} rows", csv.rows.len());
    assert!(worst < 1e-9, "{worst:e}");

    // `kinema import` prints them under the same names.
    let o = kinema(&["import", &adm]);
    assert_status(&o, 0);
    let text = stdout(&o);
    for line in [
        "body gear {",
        "body box {",
        "body type {",
        "driver driver: abs_angle(gear,",
    ] {
        assert!(text.contains(line), "{line}:\n{text}");
    }
    Ok(())
}

/// Mistakes in an ADM file are reported at their JSON value, never at
/// text the user did not write.
#[test]
fn adm_errors_name_the_adm_line_and_column() -> TestResult {
    let dir = TempDir::new("adm-errors");
    let cases = [
        // An unknown body in a joint: the `body2` value of `hang`.
        (
            KEYWORDS.replace(r#""body2": 2,"#, r#""body2": 7,"#),
            "bad_body.adm:10:93",
            "body2",
        ),
        // A bad function string (a `(` unclosed), in `driver`.
        (
            KEYWORDS.replace(r#""fun": "pi/2 + 2*pi*t""#, r#""fun": "pi/2 + sin(2*pi*t""#),
            "bad_fun.adm:9:96",
            "fun",
        ),
    ];
    for (k, (text, place, what)) in cases.iter().enumerate() {
        let name = if k == 0 {
            "bad_body.adm"
        } else {
            "bad_fun.adm"
        };
        let adm = dir.path(name);
        std::fs::write(&adm, text)?;
        let o = kinema(&["run", &adm, "--steps", "5"]);
        assert_status(&o, 2);
        let err = stderr(&o);
        assert!(err.contains(place), "{place}:\n{err}");
        assert!(err.contains(what), "{what}:\n{err}");
        assert!(!err.contains(".kin"), "{err}");
    }
    Ok(())
}
