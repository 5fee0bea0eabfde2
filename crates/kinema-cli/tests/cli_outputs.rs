//! Named points and outputs through the `kinema` binary: the CSV columns
//! after the body columns, `--columns`, `kinema derive`, `--plot`, and
//! simEngine2D `vis.points` imported as named points.

use std::path::Path;

mod common;
use common::*;

/// A point's position, velocity and acceleration from its body's columns,
/// by the textbook formulas r + A s′, ṙ + B s′ φ̇, r̈ + B s′ φ̈ − A s′ φ̇².
fn point_from_body(
    csv: &Csv,
    row: &[f64],
    body: &str,
    s: [f64; 2],
) -> Result<[[f64; 2]; 3], String> {
    let get = |n: &str| csv.column(&format!("{body}.{n}")).map(|c| row[c]);
    let (phi, w, a) = (get("phi")?, get("phi_dot")?, get("phi_ddot")?);
    let (sn, cs) = phi.sin_cos();
    let rot = [cs * s[0] - sn * s[1], sn * s[0] + cs * s[1]];
    let b = [-sn * s[0] - cs * s[1], cs * s[0] - sn * s[1]];
    Ok([
        [get("x")? + rot[0], get("y")? + rot[1]],
        [get("x_dot")? + b[0] * w, get("y_dot")? + b[1] * w],
        [
            get("x_ddot")? + b[0] * a - rot[0] * w * w,
            get("y_ddot")? + b[1] * a - rot[1] * w * w,
        ],
    ])
}

#[test]
fn results_follow_the_body_columns_and_match_the_point_formulas() -> TestResult {
    let dir = TempDir::new("outputs-csv");
    let out = dir.path("sc.csv");
    let o = kinema(&[
        "run",
        "models/slider_crank.kin",
        "--steps",
        "50",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    // Body columns first (1 + 27), then the results' three blocks.
    assert_eq!(csv.header[1], "crank.x");
    assert_eq!(csv.header[27], "slider.phi_ddot");
    assert_eq!(
        csv.header[28..],
        [
            "crank.o.x",
            "crank.o.y",
            "crank.pin.x",
            "crank.pin.y",
            "reach",
            "crank.o.x_dot",
            "crank.o.y_dot",
            "crank.pin.x_dot",
            "crank.pin.y_dot",
            "reach_dot",
            "crank.o.x_ddot",
            "crank.o.y_ddot",
            "crank.pin.x_ddot",
            "crank.pin.y_ddot",
            "reach_ddot",
        ]
    );
    let mut worst = 0.0_f64;
    for row in &csv.rows {
        let p = point_from_body(&csv, row, "crank", [0.15, 0.0])?;
        for (order, suffix) in ["", "_dot", "_ddot"].iter().enumerate() {
            for (i, c) in ["x", "y"].iter().enumerate() {
                let col = csv.column(&format!("crank.pin.{c}{suffix}"))?;
                worst = worst.max((row[col] - p[order][i]).abs());
            }
        }
    }
    assert!(worst < 1e-12, "{worst:e}");
    Ok(())
}

#[test]
fn columns_selects_quantities_in_block_order() -> TestResult {
    let o = kinema(&[
        "run",
        "models/four_bar.kin",
        "--steps",
        "4",
        "--out",
        "-",
        "--columns",
        "transmission,crank.phi,coupler.p",
    ]);
    assert_status(&o, 0);
    let csv = Csv::parse(&stdout(&o))?;
    assert_eq!(
        csv.header,
        [
            "t",
            "crank.phi",
            "crank.phi_dot",
            "crank.phi_ddot",
            "coupler.p.x",
            "coupler.p.y",
            "transmission",
            "coupler.p.x_dot",
            "coupler.p.y_dot",
            "transmission_dot",
            "coupler.p.x_ddot",
            "coupler.p.y_ddot",
            "transmission_ddot",
        ]
    );
    assert_eq!(csv.rows.len(), 5);
    // The same numbers as the full file.
    let full = kinema(&["run", "models/four_bar.kin", "--steps", "4", "--out", "-"]);
    let full = Csv::parse(&stdout(&full))?;
    for name in &csv.header {
        let (a, b) = (csv.column(name)?, full.column(name)?);
        for (r, s) in csv.rows.iter().zip(&full.rows) {
            assert_eq!(r[a].to_bits(), s[b].to_bits(), "{name}");
        }
    }
    let o = kinema(&[
        "run",
        "models/four_bar.kin",
        "--out",
        "-",
        "--columns",
        "bodies,foot",
    ]);
    assert_status(&o, 2);
    assert!(
        stderr(&o).contains("`foot` is not a column of this model"),
        "{}",
        stderr(&o)
    );
    Ok(())
}

#[test]
fn derive_prints_and_plot_draws_the_outputs() -> TestResult {
    let o = kinema(&["derive", "models/four_bar.kin"]);
    assert_status(&o, 0);
    let text = stdout(&o);
    assert!(
        text.contains("outputs (named points, then measures):"),
        "{text}"
    );
    assert!(text.contains("  transmission_ddot: "), "{text}");
    let dir = TempDir::new("outputs-plot");
    let svg = dir.path("fb.svg");
    let o = kinema(&[
        "run",
        "models/four_bar.kin",
        "--steps",
        "20",
        "--out",
        &dir.path("fb.csv"),
        "--plot",
        &svg,
    ]);
    assert_status(&o, 0);
    let svg = std::fs::read_to_string(&svg)?;
    assert!(svg.contains("Outputs against time"));
    assert!(
        svg.contains("\ntransmission\n"),
        "the legend names the output"
    );
    Ok(())
}

#[test]
fn an_output_naming_an_unknown_name_is_an_error_at_its_place() -> TestResult {
    let o = kinema(&[
        "check",
        "crates/kinema-model/tests/ui/output_unknown_name.kin",
    ]);
    assert_status(&o, 2);
    let err = stderr(&o);
    assert!(err.contains("error: unknown name `L2`"), "{err}");
    assert!(err.contains("output_unknown_name.kin:8:29"), "{err}");
    Ok(())
}

/// simEngine2D `vis.points` are named points `p1`, `p2`, … of their body:
/// `kinema run model.adm` writes their paths, as the engine's `plotPoint`.
#[test]
fn adm_vis_points_are_results() -> TestResult {
    let adm = Path::new(ROOT).join("../shared/simengine2d/sliderCrankKIN.adm");
    if !adm.exists() {
        eprintln!("skipped: {} is not here", adm.display());
        return Ok(());
    }
    let dir = TempDir::new("outputs-adm");
    let out = dir.path("adm.csv");
    let adm = adm.display().to_string();
    let o = kinema(&["run", &adm, "--out", &out, "--t-end", "1", "--steps", "20"]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    let mut worst = 0.0_f64;
    for row in &csv.rows {
        let p = point_from_body(&csv, row, "crank", [2.0, 0.0])?;
        for (order, suffix) in ["", "_dot", "_ddot"].iter().enumerate() {
            for (i, c) in ["x", "y"].iter().enumerate() {
                let col = csv.column(&format!("crank.p2.{c}{suffix}"))?;
                worst = worst.max((row[col] - p[order][i]).abs());
            }
        }
    }
    assert!(worst < 1e-11, "{worst:e}");
    assert!(csv.column("slider.p1.x_ddot").is_ok());
    Ok(())
}

/// `kinema derive --sensitivity`: after the derivation, Φ_p and the
/// right-hand sides for each param asked for (issue 40's first step);
/// a name that is not a param is a usage error naming the params.
#[test]
fn derive_prints_the_sensitivities_asked_for() {
    let o = kinema(&["derive", "models/four_bar.kin", "--sensitivity", "l1,l3"]);
    assert_status(&o, 0);
    let text = stdout(&o);
    let plain = stdout(&kinema(&["derive", "models/four_bar.kin"]));
    assert!(
        text.starts_with(&plain),
        "the derivation comes first, unchanged"
    );
    let rest = &text[plain.len()..];
    assert!(rest.contains("sensitivities of FourBar"), "{rest}");
    assert!(rest.contains("with respect to l1:"), "{rest}");
    assert!(rest.contains("with respect to l3:"), "{rest}");
    assert!(rest.contains("Phi_p (p = l3):"), "{rest}");
    assert!(!rest.contains("with respect to l2:"), "{rest}");

    let o = kinema(&["derive", "models/four_bar.kin", "--sensitivity", "crank"]);
    assert_status(&o, 2);
    let err = stderr(&o);
    assert!(err.contains("--sensitivity"), "{err}");
    assert!(err.contains("`crank` is a body, not a param"), "{err}");
    assert!(
        err.contains("l1, l2, l3"),
        "the error names the params: {err}"
    );
}
