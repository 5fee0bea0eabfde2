//! The follower models through the `kinema` program: coordinates of their
//! own in the CSV (after the bodies', with `_dot` and `_ddot` columns), in
//! `kinema check` and `kinema derive`, and the flat-faced follower's
//! closed form read back from the CSV.

use std::f64::consts::{FRAC_PI_2, PI};

mod common;
use common::*;

#[test]
fn csv_columns_follow_the_bodies() -> TestResult {
    let o = kinema(&[
        "run",
        "models/roller_cam.kin",
        "--steps",
        "10",
        "--out",
        "-",
    ]);
    assert_status(&o, 0);
    let csv = Csv::parse(&stdout(&o))?;
    let names = [
        "cam.x",
        "cam.y",
        "cam.phi",
        "follower.x",
        "follower.y",
        "follower.phi",
        "a",
        "b",
    ];
    let mut want = vec!["t".to_string()];
    for suffix in ["", "_dot", "_ddot"] {
        want.extend(names.iter().map(|n| format!("{n}{suffix}")));
    }
    assert_eq!(csv.header, want);
    assert_eq!(csv.rows.len(), 11);
    Ok(())
}

#[test]
fn eccentric_cam_csv_is_the_closed_form() -> TestResult {
    // y = e sin θ + R, α = π/2 − θ, θ = ωt (e = 0.2, R = 0.5, ω = 2π).
    let dir = TempDir::new("followers");
    let out = dir.path("cam.csv");
    let o = kinema(&[
        "run",
        "models/eccentric_cam.kin",
        "--steps",
        "100",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    assert!(stdout(&o).contains("7 coordinates"), "{}", stdout(&o));
    let csv = Csv::read(&out)?;
    let (t, y, yd, ydd) = (
        csv.column("t")?,
        csv.column("follower.y")?,
        csv.column("follower.y_dot")?,
        csv.column("follower.y_ddot")?,
    );
    let (a, ad, add) = (
        csv.column("alpha")?,
        csv.column("alpha_dot")?,
        csv.column("alpha_ddot")?,
    );
    let w = 2.0 * PI;
    for row in &csv.rows {
        let th = w * row[t];
        let close = |got: f64, want: f64| {
            assert!(
                (got - want).abs() <= 1e-10 * (1.0 + want.abs()),
                "t = {}: {got} vs {want}",
                row[t]
            );
        };
        close(row[y], 0.2 * th.sin() + 0.5);
        close(row[yd], 0.2 * w * th.cos());
        close(row[ydd], -0.2 * w * w * th.sin());
        close(row[a], FRAC_PI_2 - th);
        close(row[ad], -w);
        close(row[add], 0.0);
    }
    Ok(())
}

#[test]
fn check_and_derive_show_the_coordinates() {
    let o = kinema(&["check", "models/roller_cam.kin"]);
    assert_status(&o, 0);
    let text = stdout(&o);
    assert!(
        text.contains("2 coordinates of their own, after the bodies' in q: a, b"),
        "{text}"
    );
    assert!(text.contains("nc = 8"), "{text}");
    let o = kinema(&["derive", "models/scotch_yoke.kin"]);
    assert_status(&o, 0);
    let text = stdout(&o);
    assert!(text.contains("q[6] s = 0 (0)"), "{text}");
    assert!(
        text.contains("[4] pin.x (kinematic, joint point_follower)"),
        "{text}"
    );
}

#[test]
fn a_follower_error_is_rendered_at_its_place() -> TestResult {
    let dir = TempDir::new("followers-bad");
    let bad = dir.path("bad.kin");
    std::fs::write(
        &bad,
        "mechanism M {\n    body a;\n    body b;\n    coord s;\n    curve b.slot(u) = (0, u);\n    joint j: point_follower(a(0, 0), a.slot, s);\n}\n",
    )?;
    let o = kinema(&["check", &bad]);
    assert_status(&o, 2);
    let err = stderr(&o);
    assert!(err.contains("body `a` has no curve `slot`"), "{err}");
    assert!(err.contains("bad.kin:6:40"), "{err}");
    assert!(err.contains("write `b.slot`"), "{err}");
    Ok(())
}

#[test]
fn columns_select_bodies_and_coordinates_of_their_own() -> TestResult {
    // `cam` is the cam's three coordinates only (a coordinate of its own
    // belongs to no body); `a` is the coordinate.
    let o = kinema(&[
        "run",
        "models/roller_cam.kin",
        "--steps",
        "2",
        "--columns",
        "cam,a",
        "--out",
        "-",
    ]);
    assert_status(&o, 0);
    let csv = Csv::parse(&stdout(&o))?;
    let mut want = vec!["t".to_string()];
    for suffix in ["", "_dot", "_ddot"] {
        want.extend(
            ["cam.x", "cam.y", "cam.phi", "a"]
                .iter()
                .map(|n| format!("{n}{suffix}")),
        );
    }
    assert_eq!(csv.header, want);
    Ok(())
}
