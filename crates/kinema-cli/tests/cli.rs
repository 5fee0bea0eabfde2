//! The `kinema` binary, run as a user would: exit codes, the CSV of the
//! contract, closed-form results, rendered errors (insta snapshots in
//! `tests/cli/snapshots`), simEngine2D files.
//!
//! Fixtures: `models/*.kin`; `tests/cli/{bad,models,adm}`; the ADM test
//! files of `crates/kinema-adm/tests/data`; the real simEngine2D files in
//! `../shared/simengine2d` when present.

use std::f64::consts::{FRAC_PI_4, PI};
use std::path::{Path, PathBuf};
use std::process::Output;

use kinema::System;

mod common;
use common::*;

/// The header the contract prescribes for these coordinate names.
fn contract_header(names: &[String]) -> Vec<String> {
    let mut h = vec!["t".to_string()];
    for suffix in ["", "_dot", "_ddot"] {
        h.extend(names.iter().map(|n| format!("{n}{suffix}")));
    }
    h
}

fn coordinate_names(model: &kinema::Model) -> Vec<String> {
    model
        .derivation()
        .coordinates
        .iter()
        .map(|c| c.name.clone())
        .collect()
}

fn kin_models() -> Result<Vec<PathBuf>, Box<dyn std::error::Error>> {
    let mut models: Vec<PathBuf> = std::fs::read_dir(Path::new(ROOT).join("models"))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "kin"))
        .collect();
    models.sort();
    Ok(models)
}

fn snapshot(name: &str, text: &str) {
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path("cli/snapshots");
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| insta::assert_snapshot!(name, text));
}

// ------------------------------------------------------------------ models/

#[test]
fn every_model_runs_with_the_contract_csv() -> TestResult {
    let dir = TempDir::new("models");
    let models = kin_models()?;
    assert!(
        models.len() >= 5,
        "models/ holds the shipped models: {models:?}"
    );
    for model in models {
        let name = model.file_stem().and_then(|s| s.to_str()).ok_or("name")?;
        let out = dir.path(&format!("{name}.csv"));
        let o = kinema(&[
            "run",
            &model.display().to_string(),
            "--steps",
            "40",
            "--t-end",
            "0.5",
            "--out",
            &out,
        ]);
        assert_status(&o, 0);
        let summary = stdout(&o);
        assert!(
            summary.contains("40 equal steps from t = 0 to 0.5"),
            "{summary}"
        );
        assert!(summary.contains("worst residual"), "{summary}");
        assert!(
            !stderr(&o).contains('\u{1b}'),
            "no progress bar when stderr is not a terminal"
        );
        let csv = Csv::read(&out)?;
        let parsed = kinema::Model::from_file(&model)?;
        let expected = contract_header(&coordinate_names(&parsed));
        // The body columns keep their place; named points and outputs follow.
        assert_eq!(csv.header[..expected.len()], expected, "{name}");
        let results: Vec<String> = parsed
            .derivation()
            .outputs
            .iter()
            .map(|o| o.name.clone())
            .collect();
        assert_eq!(
            csv.header[expected.len()..],
            contract_header(&results)[1..],
            "{name}"
        );
        assert_eq!(csv.rows.len(), 41, "{name}: N steps give N + 1 rows");
        assert_eq!(csv.rows[0][0], 0.0);
        assert_eq!(csv.rows[40][0], 0.5, "the last row is exactly t-end");
        for (k, row) in csv.rows.iter().enumerate() {
            assert!(
                (row[0] - k as f64 * 0.5 / 40.0).abs() < 1e-15,
                "{name}: time of row {k}"
            );
        }
    }
    Ok(())
}

/// The slider-crank of models/slider_crank.kin in closed form: crank 0.3,
/// rod 1, frames at the link midpoints, φ1 = π/4 + 2πt, sin φ2 = −0.3 sin φ1,
/// x_B = 0.3 cos φ1 + cos φ2. Returns q, q̇, q̈ in the model's order
/// (crank, rod, slider; x, y, φ each).
fn slider_crank_closed_form(t: f64) -> [[f64; 9]; 3] {
    let w = 2.0 * PI;
    let p1 = FRAC_PI_4 + w * t;
    let (s1, c1) = p1.sin_cos();
    let s2 = -0.3 * s1;
    let c2 = (1.0 - s2 * s2).sqrt();
    let p2 = s2.atan2(c2);
    // c2 φ2' = −0.3 ω c1; differentiate again: −s2 φ2'² + c2 φ2'' = 0.3 ω² s1.
    let d2 = -0.3 * w * c1 / c2;
    let dd2 = (0.3 * w * w * s1 + s2 * d2 * d2) / c2;
    let q = [
        0.15 * c1,
        0.15 * s1,
        p1,
        0.3 * c1 + 0.5 * c2,
        0.3 * s1 + 0.5 * s2,
        p2,
        0.3 * c1 + c2,
        0.0,
        0.0,
    ];
    let qd = [
        -0.15 * s1 * w,
        0.15 * c1 * w,
        w,
        -0.3 * s1 * w - 0.5 * s2 * d2,
        0.3 * c1 * w + 0.5 * c2 * d2,
        d2,
        -0.3 * s1 * w - s2 * d2,
        0.0,
        0.0,
    ];
    let qdd = [
        -0.15 * c1 * w * w,
        -0.15 * s1 * w * w,
        0.0,
        -0.3 * c1 * w * w - 0.5 * c2 * d2 * d2 - 0.5 * s2 * dd2,
        -0.3 * s1 * w * w - 0.5 * s2 * d2 * d2 + 0.5 * c2 * dd2,
        dd2,
        -0.3 * c1 * w * w - c2 * d2 * d2 - s2 * dd2,
        0.0,
        0.0,
    ];
    [q, qd, qdd]
}

/// Compares a slider-crank CSV (any grid) with the closed form.
fn check_slider_crank(csv: &Csv, tolerance: f64) -> TestResult {
    let names = ["crank", "rod", "slider"];
    let mut worst = 0.0_f64;
    for row in &csv.rows {
        let exact = slider_crank_closed_form(row[0]);
        for (order, suffix) in ["", "_dot", "_ddot"].iter().enumerate() {
            for (b, body) in names.iter().enumerate() {
                for (c, comp) in ["x", "y", "phi"].iter().enumerate() {
                    let col = csv.column(&format!("{body}.{comp}{suffix}"))?;
                    let err = (row[col] - exact[order][3 * b + c]).abs();
                    worst = worst.max(err);
                    assert!(
                        err <= tolerance,
                        "t = {}: {body}.{comp}{suffix} = {} but the closed form gives {} (error {err:e})",
                        row[0],
                        row[col],
                        exact[order][3 * b + c]
                    );
                }
            }
        }
    }
    println!("slider-crank: worst error against the closed form {worst:.2e}");
    Ok(())
}

#[test]
fn slider_crank_csv_matches_the_closed_form() -> TestResult {
    let dir = TempDir::new("slider-crank");
    let out = dir.path("sc.csv");
    let o = kinema(&["run", "models/slider_crank.kin", "--out", &out]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    assert_eq!(csv.rows.len(), 101, "defaults: t-end 1, 100 steps");
    assert_eq!(csv.rows[100][0], 1.0);
    check_slider_crank(&csv, 1e-10)
}

#[test]
fn csv_to_standard_output_and_summary_to_standard_error() -> TestResult {
    let o = kinema(&["run", "models/pendulum.kin", "--steps", "4", "--out", "-"]);
    assert_status(&o, 0);
    let csv = Csv::parse(&stdout(&o))?;
    assert_eq!(
        csv.header,
        [
            "t",
            "bar.x",
            "bar.y",
            "bar.phi",
            "bar.x_dot",
            "bar.y_dot",
            "bar.phi_dot",
            "bar.x_ddot",
            "bar.y_ddot",
            "bar.phi_ddot"
        ]
    );
    assert_eq!(csv.rows.len(), 5);
    // φ = 4t², the bar's frame 1 from the pivot.
    for row in &csv.rows {
        let t = row[0];
        assert!((row[3] - 4.0 * t * t).abs() < 1e-12);
        assert!((row[1] - (4.0 * t * t).cos()).abs() < 1e-12);
        assert!((row[9] - 8.0).abs() < 1e-9);
    }
    assert!(
        stderr(&o).contains("wrote standard output (5 rows × 10 columns)"),
        "{}",
        stderr(&o)
    );
    Ok(())
}

#[test]
fn plot_writes_an_svg_report() -> TestResult {
    let dir = TempDir::new("plot");
    let (out, svg) = (dir.path("r.csv"), dir.path("motion.svg"));
    let o = kinema(&["run", "models/four_bar.kin", "--out", &out, "--plot", &svg]);
    assert_status(&o, 0);
    assert!(stdout(&o).contains("motion.svg"));
    let text = std::fs::read_to_string(&svg)?;
    assert!(text.starts_with("<svg"), "an SVG document");
    assert!(text.trim_end().ends_with("</svg>"));
    for expected in [
        "FourBar — kinematic analysis",
        "Mechanism at several instants",
        "Driven coordinates",
        "crank.phi",
        "x [m]",
        "velocity [rad/s]",
        "t [s]",
        "fixed point",
    ] {
        assert!(text.contains(expected), "the figure shows {expected:?}");
    }
    Ok(())
}

#[test]
fn derive_and_codegen_print_the_library_text() -> TestResult {
    let model = kinema::Model::from_file(Path::new(ROOT).join("models/four_bar.kin"))?;
    let o = kinema(&["derive", "models/four_bar.kin"]);
    assert_status(&o, 0);
    assert_eq!(stdout(&o).trim_end(), model.derivation_text().trim_end());
    let o = kinema(&["codegen", "models/four_bar.kin"]);
    assert_status(&o, 0);
    assert_eq!(stdout(&o).trim_end(), model.rust_source().trim_end());
    Ok(())
}

// ------------------------------------------------------------------ check

#[test]
fn check_reports_dof_assembly_and_rank() {
    let o = kinema(&["check", "models/slider_crank.kin"]);
    assert_status(&o, 0);
    let out = stdout(&o);
    for expected in [
        "mechanism `SliderCrank`, 3 bodies (crank, rod, slider)",
        "DOF: nc = 9, kinematic equations = 8, drivers = 1, KDOF = 1, NDOF = 0",
        "assembly at t = 0 from the guess: converged",
        "rank of Φ_q at the assembled configuration: 9 of 9 (full",
        "redundant equations: none",
    ] {
        assert!(out.contains(expected), "{expected:?} in\n{out}");
    }
}

#[test]
fn check_names_redundant_equations() {
    let o = kinema(&["check", "crates/kinema-cli/tests/cli/models/redundant.kin"]);
    assert_status(&o, 1);
    let out = stdout(&o);
    assert!(
        out.contains("rank of Φ_q where Newton stopped: 2 of 3"),
        "{out}"
    );
    assert!(
        out.contains("dependent equations: left, right, level"),
        "{out}"
    );
    assert!(out.contains("redundant equations: level"), "{out}");
    assert!(
        stderr(&o).contains("coordinates left free or unbounded: bar.x"),
        "{}",
        stderr(&o)
    );
}

// ------------------------------------------------------------------ failures

#[test]
fn lock_up_fails_with_status_1_naming_time_and_equations() -> TestResult {
    let dir = TempDir::new("lockup");
    let out = dir.path("l.csv");
    let o = kinema(&[
        "run",
        "crates/kinema-cli/tests/cli/models/lockup.kin",
        "--out",
        &out,
    ]);
    assert_status(&o, 1);
    let err = stderr(&o);
    assert!(
        err.starts_with(
            "error: lock-up, toggle position or redundant constraints at t = 0.3235987"
        ),
        "{err}"
    );
    assert!(err.contains("crank_angle"), "{err}");
    // The rows before the lock-up (t ≤ 0.32, every 0.01) are kept.
    let csv = Csv::read(&out)?;
    assert_eq!(csv.rows.len(), 33);
    assert!(
        err.contains("the 33 rows computed before the failure"),
        "{err}"
    );
    Ok(())
}

#[test]
fn bad_model_files_give_status_2_and_rendered_errors() -> TestResult {
    let mut names: Vec<PathBuf> = std::fs::read_dir(Path::new(HERE).join("tests/cli/bad"))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .collect();
    names.sort();
    assert!(names.len() >= 4);
    for path in names {
        let stem = path.file_stem().and_then(|s| s.to_str()).ok_or("name")?;
        let rel = format!("tests/cli/bad/{stem}.kin");
        for command in ["check", "run"] {
            // For `run`, the model is read before any output is created.
            let args: Vec<&str> = match command {
                "run" => vec![command, &rel, "--out", "/nonexistent/never-written.csv"],
                _ => vec![command, &rel],
            };
            // Run in this package, so that the messages name the file as
            // the snapshots have it.
            let o = kinema_in(Path::new(HERE), &args);
            assert_status(&o, 2);
            assert!(stdout(&o).is_empty(), "nothing on stdout for {rel}");
            snapshot(&format!("bad_kin__{stem}"), &stderr(&o));
        }
    }
    Ok(())
}

#[test]
fn usage_errors_give_status_2() {
    let cases: &[(&[&str], &str)] = &[
        (&["run"], "MODEL"),
        (
            &["frobnicate", "models/pendulum.kin"],
            "unrecognized subcommand",
        ),
        (
            &["run", "models/pendulum.kin", "--steps", "0"],
            "--steps must be at least 1",
        ),
        (
            &["run", "models/pendulum.kin", "--t-end=-1"],
            "--t-end must be a positive finite time",
        ),
        (
            &["run", "models/pendulum.kin", "--t-end", "inf"],
            "--t-end must be a positive finite time",
        ),
        (
            &["run", "models/pendulum.kin", "--steps", "20000000"],
            "more than one run takes",
        ),
        (
            &["run", "models/pendulum.kin", "--steps", "many"],
            "invalid value",
        ),
        (
            &["run", "models/pendulum.kin", "--backend", "gpu"],
            "invalid value",
        ),
        (
            &["run", "models/pendulum.kin", "--acf", "x.acf"],
            "--acf is for simEngine2D models",
        ),
        (
            &["run", "models/does_not_exist.kin"],
            "cannot read model file `models/does_not_exist.kin`",
        ),
        (
            &[
                "run",
                "models/pendulum.kin",
                "--out",
                "/nonexistent/dir/r.csv",
            ],
            "cannot create `/nonexistent/dir/r.csv`",
        ),
        (
            &[
                "run",
                "models/pendulum.kin",
                "--out",
                "-",
                "--plot",
                "/nonexistent/p.svg",
            ],
            "cannot create `/nonexistent/p.svg`",
        ),
        (
            &["check", "crates/kinema-cli/tests/cli/adm/one_second.acf"],
            "is a simEngine2D analysis file, not a model",
        ),
    ];
    for (args, message) in cases {
        let o = kinema(args);
        assert_status(&o, 2);
        assert!(
            stderr(&o).contains(message),
            "{args:?}: {message:?} in\n{}",
            stderr(&o)
        );
    }
}

#[test]
fn help_shows_examples() {
    let o = kinema(&["--help"]);
    assert_status(&o, 0);
    assert!(
        stdout(&o).contains("kinema run models/slider_crank.kin"),
        "{}",
        stdout(&o)
    );
    let o = kinema(&["run", "--help"]);
    assert_status(&o, 0);
    let help = stdout(&o);
    for expected in [
        "--t-end",
        "--steps",
        "--out",
        "--plot",
        "--acf",
        "--backend",
        "Examples:",
    ] {
        assert!(help.contains(expected), "{expected} in\n{help}");
    }
}

// ------------------------------------------------------------------ simEngine2D

const ADM_DATA: &str = "crates/kinema-adm/tests/data";

/// Runs an ADM file through the CLI and reads its CSV.
fn run_adm(
    dir: &TempDir,
    adm: &str,
    acf: Option<&str>,
) -> Result<(Output, Csv), Box<dyn std::error::Error>> {
    let out = dir.path("adm.csv");
    let mut args = vec!["run", adm, "--out", &out];
    if let Some(acf) = acf {
        args.extend(["--acf", acf]);
    }
    let o = kinema(&args);
    assert_status(&o, 0);
    Ok((o, Csv::read(&out)?))
}

/// ‖Φ(q, t)‖∞ at every row of a CSV, with the system of the ADM model.
fn worst_residual(adm: &Path, csv: &Csv) -> Result<f64, Box<dyn std::error::Error>> {
    let model = kinema_adm::Model::read(adm)?.0;
    let kin = kinema::Model::from_source(&kinema_adm::to_kin(&model), "imported.kin")?;
    let system = kin.system();
    let n = system.len();
    // The kinematic columns first (a model with inertia adds inverse
    // dynamics after them: tests/cli_dynamics.rs).
    let kinematic = contract_header(&coordinate_names(&kin));
    assert_eq!(
        csv.header[..kinematic.len().min(csv.header.len())],
        kinematic[..]
    );
    let mut phi = vec![0.0; n];
    let mut worst = 0.0_f64;
    for row in &csv.rows {
        system.phi(&mut system.scratch(), &row[1..=n], row[0], &mut phi);
        worst = phi.iter().fold(worst, |m, v| m.max(v.abs()));
    }
    Ok(worst)
}

#[test]
fn adm_translational_block_moves_as_its_driver() -> TestResult {
    let dir = TempDir::new("translational");
    let adm = format!("{ADM_DATA}/translational.adm");
    let (_, csv) = run_adm(
        &dir,
        &adm,
        Some("crates/kinema-cli/tests/cli/adm/two_seconds.acf"),
    )?;
    assert_eq!(csv.rows.len(), 41, "outputSteps 40 of the plain-text ACF");
    // The rail is at the origin turned by θ = atan(1/2); the block's point
    // (−0.2, 0) slides on the rail's line through its point (0.5, 0.1) with
    // (3, 4) ∥ (2, 0): φ_b = θ − atan2(4, 3); x = 1 + t²/2 (driver).
    let theta = 0.5_f64.atan();
    let phi_b = theta - 4.0_f64.atan2(3.0);
    let (st, ct) = theta.sin_cos();
    let p1 = [0.5 * ct - 0.1 * st, 0.5 * st + 0.1 * ct];
    let p = [-0.2 * phi_b.cos(), -0.2 * phi_b.sin()];
    let (x, xd, xdd) = (
        csv.column("block.x")?,
        csv.column("block.x_dot")?,
        csv.column("block.x_ddot")?,
    );
    let (y, yd, ydd) = (
        csv.column("block.y")?,
        csv.column("block.y_dot")?,
        csv.column("block.y_ddot")?,
    );
    let phi = csv.column("block.phi")?;
    for row in &csv.rows {
        let t = row[0];
        let xb = 1.0 + 0.5 * t * t;
        let yb = p1[1] - p[1] + theta.tan() * (xb + p[0] - p1[0]);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-10;
        assert!(
            close(row[x], xb) && close(row[xd], t) && close(row[xdd], 1.0),
            "x at t = {t}"
        );
        assert!(
            close(row[y], yb) && close(row[yd], 0.5 * t) && close(row[ydd], 0.5),
            "y at t = {t}"
        );
        assert!(close(row[phi], phi_b), "phi at t = {t}");
    }
    Ok(())
}

#[test]
fn adm_rack_and_pinion_matches_the_closed_form() -> TestResult {
    let dir = TempDir::new("rack");
    let adm = format!("{ADM_DATA}/rack_pinion.adm");
    let (o, csv) = run_adm(&dir, &adm, Some(&format!("{ADM_DATA}/kinematics.acf")))?;
    assert_eq!(csv.rows.len(), 41);
    assert!(
        stdout(&o).contains("41 outputs from t = 0 to 2"),
        "{}",
        stdout(&o)
    );
    let col = |name: &str| csv.column(name);
    let (rx, rxd, rxdd, ry, rphi) = (
        col("rack.x")?,
        col("rack.x_dot")?,
        col("rack.x_ddot")?,
        col("rack.y")?,
        col("rack.phi")?,
    );
    let (pphi, pphid, pphidd, px, py) = (
        col("pinion.phi")?,
        col("pinion.phi_dot")?,
        col("pinion.phi_ddot")?,
        col("pinion.x")?,
        col("pinion.y")?,
    );
    for row in &csv.rows {
        let t = row[0];
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-10;
        assert!(
            close(row[rx], -0.075 - 0.375 * PI + 0.5 * t * t),
            "rack x at t = {t}: {}",
            row[rx]
        );
        assert!(
            close(row[rxd], t) && close(row[rxdd], 1.0),
            "rack speed at t = {t}"
        );
        assert!(
            close(row[ry], -0.35) && close(row[rphi], 0.0),
            "rack y, phi at t = {t}"
        );
        assert!(
            close(row[pphi], 2.0 * t * t) && close(row[pphid], 4.0 * t) && close(row[pphidd], 4.0),
            "pinion at t = {t}"
        );
        assert!(
            close(row[px], 0.5) && close(row[py], -0.1),
            "pinion centre at t = {t}"
        );
    }
    Ok(())
}

#[test]
fn adm_slider_crank_matches_the_closed_form() -> TestResult {
    let dir = TempDir::new("adm-slider-crank");
    let adm = format!("{ADM_DATA}/slider_crank.adm");
    let (_, csv) = run_adm(
        &dir,
        &adm,
        Some("crates/kinema-cli/tests/cli/adm/one_second.acf"),
    )?;
    assert_eq!(csv.rows.len(), 21);
    check_slider_crank(&csv, 1e-10)
}

#[test]
fn adm_four_bar_matches_the_peer_reference_and_uses_its_forces() -> TestResult {
    let dir = TempDir::new("adm-four-bar");
    let adm = format!("{ADM_DATA}/four_bar.adm");
    let (o, csv) = run_adm(
        &dir,
        &adm,
        Some("crates/kinema-cli/tests/cli/adm/one_second.acf"),
    )?;
    let err = stderr(&o);
    // Masses and jbar everywhere: the RSDA2 is imported and the run writes
    // inverse dynamics after the kinematic columns (tests/cli_dynamics.rs).
    assert!(
        !err.contains("ignored by kinematic analysis: force"),
        "{err}"
    );
    assert!(
        csv.header.iter().any(|h| h.starts_with("driver.")),
        "{:?}",
        csv.header
    );
    let reference = Csv::read(&format!("{ROOT}/benches/peers/reference/traj_four_bar.csv"))?;
    assert_eq!(csv.rows.len(), reference.rows.len());
    // Reference columns: t, q0…q8, qd0…qd8, qdd0…qdd8 (same order as ours).
    for (row, r) in csv.rows.iter().zip(&reference.rows) {
        assert!((row[0] - r[0]).abs() < 1e-12);
        for (k, (a, b)) in row.iter().zip(r).enumerate().skip(1) {
            assert!(
                (a - b).abs() <= 1e-10 * b.abs().max(1.0),
                "t = {}: column {} = {a}, reference {b}",
                row[0],
                csv.header[k]
            );
        }
    }
    Ok(())
}

#[test]
fn adm_absolute_pendulum_matches_the_closed_form_and_refuses_its_m_file_force() -> TestResult {
    let dir = TempDir::new("adm-pendulum");
    let adm = format!("{ADM_DATA}/absolute_pendulum.adm");
    // Its PointForceFile cannot be run: refused, naming the m-file.
    let o = kinema(&[
        "run",
        &adm,
        "--acf",
        "crates/kinema-cli/tests/cli/adm/two_seconds.acf",
    ]);
    assert_status(&o, 2);
    assert!(stderr(&o).contains("myForce.m"), "{}", stderr(&o));
    // Without it the model runs, its other forces used.
    let text = std::fs::read_to_string(Path::new(ROOT).join(&adm))?;
    let line = text
        .lines()
        .find(|l| l.contains("PointForceFile"))
        .ok_or("the PointForceFile line")?;
    // The last force: its line and the comma before it go.
    let without = text.replace(&format!(",\n{line}"), "");
    assert_ne!(without, text);
    let adm = dir.path("absolute_pendulum.adm");
    std::fs::write(&adm, without)?;
    let (o, csv) = run_adm(
        &dir,
        &adm,
        Some("crates/kinema-cli/tests/cli/adm/two_seconds.acf"),
    )?;
    let err = stderr(&o);
    assert!(
        !err.contains("ignored by kinematic analysis: force"),
        "{err}"
    );
    // The rod's end (−1, 0) is pinned at the origin: its frame is at
    // (cos φ, sin φ), φ = −π/2 + 0.5 sin 2πt − t²/10 + 1.5e-5 t³.
    let col = |name: &str| csv.column(name);
    let c = [
        col("rod.x")?,
        col("rod.y")?,
        col("rod.phi")?,
        col("rod.x_dot")?,
        col("rod.y_dot")?,
        col("rod.phi_dot")?,
        col("rod.x_ddot")?,
        col("rod.y_ddot")?,
        col("rod.phi_ddot")?,
    ];
    for row in &csv.rows {
        let t = row[0];
        let w = 2.0 * PI;
        let p = -PI / 2.0 + 0.5 * (w * t).sin() - t * t / 10.0 + 1.5e-5 * t.powi(3);
        let pd = PI * (w * t).cos() - t / 5.0 + 4.5e-5 * t * t;
        let pdd = -2.0 * PI * PI * (w * t).sin() - 0.2 + 9e-5 * t;
        let (sn, cs) = p.sin_cos();
        let exact = [
            cs,
            sn,
            p,
            -sn * pd,
            cs * pd,
            pd,
            -cs * pd * pd - sn * pdd,
            -sn * pd * pd + cs * pdd,
            pdd,
        ];
        for (k, (&i, e)) in c.iter().zip(exact).enumerate() {
            assert!(
                (row[i] - e).abs() <= 1e-10,
                "t = {t}: column {k} = {}, closed form {e}",
                row[i]
            );
        }
    }
    Ok(())
}

#[test]
fn adm_import_prints_kin_text() -> TestResult {
    let adm = format!("{ADM_DATA}/slider_crank.adm");
    let o = kinema(&["import", &adm]);
    assert_status(&o, 0);
    let model = kinema_adm::Model::read(Path::new(ROOT).join(&adm).as_path())?.0;
    assert_eq!(stdout(&o).trim_end(), kinema_adm::to_kin(&model).trim_end());
    // What it prints is a model kinema runs.
    kinema::Model::from_source(&stdout(&o), "imported.kin")?;
    Ok(())
}

#[test]
fn adm_plot_uses_the_vis_data() -> TestResult {
    let dir = TempDir::new("adm-plot");
    let svg = dir.path("rack.svg");
    let o = kinema(&[
        "run",
        &format!("{ADM_DATA}/rack_pinion.adm"),
        "--out",
        &dir.path("r.csv"),
        "--plot",
        &svg,
    ]);
    assert_status(&o, 0);
    let text = std::fs::read_to_string(&svg)?;
    assert!(text.contains("simEngine2D model rack_pinion.adm"));
    // The pinion's RGB [1, 0.5, 0.5] fills its rectangle.
    assert!(text.contains("#FF8080"), "the pinion's colour");
    assert!(text.contains("pinion point 1"), "the vis point is traced");
    Ok(())
}

#[test]
fn adm_refusals_give_status_2_with_counts() -> TestResult {
    // A Dynamics ACF runs forward dynamics when every body has inertia…
    let dir = TempDir::new("adm_refusals");
    let acf = format!("{ADM_DATA}/dynamics.acf");
    let out = dir.path("d.csv");
    let o = kinema(&[
        "run",
        &format!("{ADM_DATA}/slider_crank.adm"),
        "--acf",
        &acf,
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    assert!(stdout(&o).contains("forward dynamics"), "{}", stdout(&o));
    // …and is refused, naming the cause, when one has none.
    let text = std::fs::read_to_string(format!("{ROOT}/{ADM_DATA}/slider_crank.adm"))?;
    let adm = dir.path("no_mass.adm");
    std::fs::write(&adm, text.replace("\"mass\": 1, \"jbar\": 0.0075,", ""))?;
    let o = kinema(&["run", &adm, "--acf", &acf, "--out", &out]);
    assert_status(&o, 2);
    let err = stderr(&o);
    assert!(err.contains("no inertia"), "{err}");
    assert!(err.contains("Dynamics"), "{err}");
    let o = kinema(&["run", &format!("{ADM_DATA}/free_pendulum.adm")]);
    assert_status(&o, 2);
    assert!(stderr(&o).contains("NDOF = n - m = 1"), "{}", stderr(&o));
    Ok(())
}

#[test]
fn bad_adm_files_give_status_2_naming_constraint_and_field() -> TestResult {
    for name in [
        "bad_json",
        "bad_type",
        "bad_body",
        "bad_fun",
        "bad_fields",
        "bad_number",
    ] {
        let o = kinema(&["run", &format!("{ADM_DATA}/{name}.adm")]);
        assert_status(&o, 2);
        let err = stderr(&o);
        assert!(
            err.contains(&format!("--> {ADM_DATA}/{name}.adm:")),
            "located: {err}"
        );
        if name != "bad_json" && name != "bad_number" {
            assert!(
                err.contains("(id "),
                "{name} names the element by id: {err}"
            );
            assert!(err.contains("field \""), "{name} names the field: {err}");
        }
        snapshot(&format!("bad_adm__{name}"), &err);
    }
    Ok(())
}

/// Every kinematic model among the real simEngine2D files runs to the end
/// with ‖Φ‖∞ < 1e-10 at every output; the others run forward dynamics to
/// the end, or are refused with status 2 (tests/cli_forward.rs checks the
/// dynamics).
#[test]
fn real_simengine2d_models() -> TestResult {
    let dir = Path::new(ROOT).join("../shared/simengine2d");
    if !dir.is_dir() {
        println!(
            "notice: {} is absent; skipping the real simEngine2D models",
            dir.display()
        );
        return Ok(());
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "adm"))
        .collect();
    files.sort();
    let tmp = TempDir::new("real");
    let (mut ran, mut refused, mut dynamics) = (0, 0, 0);
    for adm in &files {
        let stem = adm.file_stem().and_then(|s| s.to_str()).ok_or("name")?;
        let own = dir.join(format!("{stem}.acf"));
        let acf = if own.is_file() {
            own
        } else {
            dir.join("kinematics.acf")
        };
        let model = kinema_adm::Model::read(adm)?.0;
        let analysis = kinema_adm::Analysis::read(&acf)?;
        let (adm_s, acf_s, out) = (
            adm.display().to_string(),
            acf.display().to_string(),
            tmp.path(&format!("{stem}.csv")),
        );
        let o = kinema(&["run", &adm_s, "--acf", &acf_s, "--out", &out]);
        if kinema_adm::check_kinematic(&model, &analysis).is_err() {
            // Not a kinematic analysis: forward dynamics (issue 17) when
            // every body has inertia and no force comes from an m-file,
            // else refused with status 2. Either way, said.
            if o.status.code() == Some(0) {
                assert!(
                    !stderr(&o).contains("its own arithmetic"),
                    "{stem}: {}",
                    stderr(&o)
                );
                let csv = Csv::read(&out)?;
                assert_eq!(csv.rows.len(), analysis.output_steps + 1, "{stem}");
                assert_eq!(
                    csv.rows.last().map(|r| r[0]),
                    Some(analysis.tend),
                    "{stem} runs to the end"
                );
                assert!(
                    stdout(&o).contains("forward dynamics"),
                    "{stem}: {}",
                    stdout(&o)
                );
                println!("{stem}: forward dynamics, {} outputs", csv.rows.len());
                dynamics += 1;
            } else {
                assert_status(&o, 2);
                let err = stderr(&o);
                // A kinematic analysis of a model that is not one, or a
                // force computed by a MATLAB function (named).
                assert!(
                    err.contains("cannot be run as kinematics")
                        || err.contains(".m), which kinema cannot run"),
                    "{stem}: {err}"
                );
                refused += 1;
            }
            continue;
        }
        assert_status(&o, 0);
        // The course's models, evaluated as written, keep their digits.
        assert!(
            !stderr(&o).contains("its own arithmetic"),
            "{stem}: {}",
            stderr(&o)
        );
        let csv = Csv::read(&out)?;
        assert_eq!(csv.rows.len(), analysis.output_steps + 1, "{stem}");
        assert_eq!(
            csv.rows.last().map(|r| r[0]),
            Some(analysis.tend),
            "{stem} runs to the end"
        );
        let worst = worst_residual(adm, &csv)?;
        println!(
            "{stem}: {} outputs to t = {}, worst ‖Φ‖∞ = {worst:.1e}",
            csv.rows.len(),
            analysis.tend
        );
        assert!(worst < 1e-10, "{stem}: ‖Φ‖∞ = {worst:e}");
        ran += 1;
    }
    println!(
        "simEngine2D: {ran} kinematic models ran, {dynamics} ran forward dynamics, {refused} refused"
    );
    assert!(ran >= 9, "the guide's simEngine2D kinematic models run");
    Ok(())
}
