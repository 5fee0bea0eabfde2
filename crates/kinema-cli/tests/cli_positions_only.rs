//! `kinema run --positions-only` and `kinema sweep --positions-only`: the
//! position columns alone, with the values of the full analysis; refused
//! where positions alone make no sense.

mod common;

use common::{Csv, ROOT, TempDir, TestResult, assert_status, kinema, stderr};

/// Runs `args` with and without `--positions-only`; both CSVs.
fn both(dir: &TempDir, args: &[&str]) -> Result<(Csv, Csv), Box<dyn std::error::Error>> {
    let full = dir.path("full.csv");
    let only = dir.path("only.csv");
    let mut a: Vec<&str> = args.to_vec();
    a.extend(["--out", &full]);
    assert_status(&kinema(&a), 0);
    a.truncate(args.len());
    a.extend(["--out", &only, "--positions-only"]);
    assert_status(&kinema(&a), 0);
    Ok((Csv::read(&full)?, Csv::read(&only)?))
}

/// Every column of `only` is the column of that name in `full`, to Newton's
/// tolerance, and `only` has exactly the columns of `full` that are not
/// rates or dynamics.
fn assert_positions_of(full: &Csv, only: &Csv, keep: impl Fn(&str) -> bool) -> TestResult {
    let expected: Vec<&String> = full.header.iter().filter(|h| keep(h)).collect();
    assert_eq!(only.header.iter().collect::<Vec<_>>(), expected);
    assert_eq!(only.rows.len(), full.rows.len());
    for (j, name) in only.header.iter().enumerate() {
        let k = full.column(name)?;
        for (a, b) in full.rows.iter().zip(&only.rows) {
            let (u, v) = (a[k], b[j]);
            assert!(
                (u - v).abs() <= 1e-10 * (1.0 + u.abs()),
                "{name} at t = {}: {u} against {v}",
                a[0]
            );
        }
    }
    Ok(())
}

fn is_position(name: &str) -> bool {
    !name.ends_with("_dot") && !name.ends_with("_ddot")
}

#[test]
fn run_writes_the_positions_of_the_full_run() -> TestResult {
    let dir = TempDir::new("positions-only-run");
    for model in [
        "models/slider_crank.kin",
        "models/four_bar.kin",
        "models/eccentric_cam.kin",
        "tests/singular/six_bar.kin",
    ] {
        let path = format!("{ROOT}/{model}");
        let (full, only) = both(&dir, &["run", &path, "--steps", "200", "--t-end", "2"])?;
        assert!(full.header.iter().any(|h| h.ends_with("_ddot")));
        assert!(only.header.iter().all(|h| is_position(h)), "{model}");
        assert_positions_of(&full, &only, is_position)?;
    }
    Ok(())
}

#[test]
fn run_with_inertia_drops_the_dynamics_columns() -> TestResult {
    let dir = TempDir::new("positions-only-dynamics");
    let path = format!("{ROOT}/tests/dynamics/slider_crank.kin");
    let (full, only) = both(&dir, &["run", &path, "--steps", "50"])?;
    assert!(full.header.iter().any(|h| h.starts_with("reaction.")));
    let dynamics = |h: &str| {
        ["lambda.", "reaction.", "driver."]
            .iter()
            .any(|p| h.starts_with(p))
    };
    assert_positions_of(&full, &only, |h| is_position(h) && !dynamics(h))?;
    Ok(())
}

#[test]
fn columns_select_among_the_positions() -> TestResult {
    let dir = TempDir::new("positions-only-columns");
    let path = format!("{ROOT}/models/slider_crank.kin");
    let out = dir.path("s.csv");
    let o = kinema(&[
        "run",
        &path,
        "--columns",
        "slider",
        "--positions-only",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    assert_eq!(csv.header, ["t", "slider.x", "slider.y", "slider.phi"]);
    Ok(())
}

#[test]
fn sweep_writes_the_positions_of_the_full_sweep() -> TestResult {
    let dir = TempDir::new("positions-only-sweep");
    let table = dir.path("lengths.csv");
    std::fs::write(&table, "l1, l2\n0.3, 1.0\n0.25, 1.1\n0.2, 0.9\n")?;
    let path = format!("{ROOT}/models/slider_crank.kin");
    let (full, only) = both(&dir, &["sweep", &path, "--params", &table, "--steps", "40"])?;
    assert_eq!(only.header[..4], ["row", "l1", "l2", "t"]);
    assert!(only.header.iter().all(|h| is_position(h)));
    assert_positions_of(&full, &only, is_position)?;
    Ok(())
}

#[test]
fn refused_where_positions_alone_make_no_sense() -> TestResult {
    let dir = TempDir::new("positions-only-refused");
    let out = dir.path("x.csv");
    let kinematic = format!("{ROOT}/models/slider_crank.kin");
    let o = kinema(&[
        "run",
        &kinematic,
        "--positions-only",
        "--plot",
        &dir.path("p.svg"),
        "--out",
        &out,
    ]);
    assert_status(&o, 2);
    assert!(stderr(&o).contains("--positions-only cannot be used with --plot"));

    let pendulum = dir.path("pend.kin");
    std::fs::write(
        &pendulum,
        "mechanism P {
            body bar { guess: (1, 0, 0), mass: 2, inertia: 0.3 }
            gravity = (0, -9.81);
            constraint px: abs_x(bar(-1, 0), 0);
            constraint py: abs_y(bar(-1, 0), 0);
        }",
    )?;
    let o = kinema(&["run", &pendulum, "--positions-only", "--out", &out]);
    assert_status(&o, 2);
    assert!(
        stderr(&o).contains("--positions-only cannot be used with forward dynamics"),
        "{}",
        stderr(&o)
    );
    let o = kinema(&[
        "run",
        &pendulum,
        "--equilibrium",
        "--positions-only",
        "--out",
        &out,
    ]);
    assert_status(&o, 2);
    assert!(stderr(&o).contains("--positions-only cannot be used with --equilibrium"));
    Ok(())
}
