//! `kinema run` of forward dynamics: the energy panel of `--plot` and the
//! `--project-velocity` switch of HHT.

mod common;

use common::*;

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// The forward-dynamics benchmark slider-crank (released from rest).
fn fd_slider_crank() -> String {
    format!("{ROOT}/crates/kinema-bench/models/fd_slider_crank.kin")
}

/// The number after `key` in `text` (a float in Rust's `{:e}` form).
fn number_after(text: &str, key: &str) -> Option<f64> {
    let rest = &text[text.find(key)? + key.len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || "+-.e".contains(c)))
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// `--plot` of forward dynamics draws the energy panel: kinetic, potential,
/// the work of the other forces and the balance, whose legend gives how far
/// T + V − W strayed — the same figure as the `--energy` columns give.
#[test]
fn plot_of_forward_dynamics_has_the_energy_panel() -> TestResult {
    let tmp = TempDir::new("forward_plot");
    let (out, svg) = (tmp.path("sc.csv"), tmp.path("sc.svg"));
    let model = fd_slider_crank();
    let o = kinema(&[
        "run", &model, "--steps", "50", "--energy", "--out", &out, "--plot", &svg,
    ]);
    assert_status(&o, 0);
    let text = std::fs::read_to_string(&svg)?;
    for expected in [
        "Energy",
        "kinetic T",
        "potential V (gravity)",
        "work W of the other forces",
        "balance T + V − W (strays ",
        "Reaction forces",
    ] {
        assert!(text.contains(expected), "the figure shows {expected:?}");
    }
    let strayed = number_after(&text, "balance T + V − W (strays ").ok_or("the drift")?;
    let csv = Csv::read(&out)?;
    let (ke, v, w) = (
        csv.column("energy.kinetic")?,
        csv.column("energy.potential")?,
        csv.column("energy.work")?,
    );
    let total = |r: &Vec<f64>| r[ke] + r[v] - r[w];
    let start = total(&csv.rows[0]);
    let drift = csv
        .rows
        .iter()
        .map(|r| (total(r) - start).abs())
        .fold(0.0, f64::max);
    // HHT at 1 ms: the balance strays by its truncation error, small but
    // not zero; the legend rounds to three digits.
    assert!(drift > 0.0 && drift < 1e-3, "{drift}");
    assert!(
        (strayed - drift).abs() <= 1e-2 * drift,
        "legend {strayed:e}, columns {drift:e}"
    );
    // The panel's curves: T rises from 0 as V falls by as much.
    let first = &csv.rows[0];
    let last = csv.rows.last().ok_or("rows")?;
    assert_eq!(first[ke], 0.0);
    assert!(last[ke] > 0.1 && (last[ke] + last[v] - first[v]).abs() < 1e-3);
    // A kinematic run has no energy panel.
    let o = kinema(&[
        "run",
        &format!("{ROOT}/models/slider_crank.kin"),
        "--steps",
        "5",
        "--out",
        &tmp.path("k.csv"),
        "--plot",
        &tmp.path("k.svg"),
    ]);
    assert_status(&o, 0);
    assert!(!std::fs::read_to_string(tmp.path("k.svg"))?.contains("kinetic T"));
    Ok(())
}

/// ‖Φ_q q̇ − ν‖∞ of every CSV row of a run of `model`.
fn velocity_residuals(model: &str, csv: &Csv) -> Result<Vec<f64>, Box<dyn std::error::Error>> {
    let m = kinema::Model::from_file(model)?;
    let mut sys = m.forward_system().ok_or("no inertia")?;
    use kinema::ForwardSystem as _;
    let (n, rows) = (sys.coords(), sys.rows());
    let names: Vec<String> = (0..n).map(|i| sys.coordinate_name(i).to_owned()).collect();
    let mut columns = Vec::new();
    for name in &names {
        columns.push((csv.column(name)?, csv.column(&format!("{name}_dot"))?));
    }
    let (mut jac, mut nu) = (vec![0.0; rows * n], vec![0.0; rows]);
    let mut out = Vec::new();
    for row in &csv.rows {
        let q: Vec<f64> = columns.iter().map(|&(c, _)| row[c]).collect();
        let qd: Vec<f64> = columns.iter().map(|&(_, c)| row[c]).collect();
        sys.jacobian(&q, row[0], &mut jac);
        sys.nu(&q, row[0], &mut nu);
        let worst = (0..rows)
            .map(|r| ((0..n).map(|c| jac[r * n + c] * qd[c]).sum::<f64>() - nu[r]).abs())
            .fold(0.0, f64::max);
        out.push(worst);
    }
    Ok(out)
}

/// The crank angle at t = 1 of a run of `model` with `args`.
fn crank_at_1(
    model: &str,
    out: &str,
    args: &[&str],
) -> Result<(Csv, f64), Box<dyn std::error::Error>> {
    let mut all = vec!["run", model, "--steps", "20", "--out", out];
    all.extend_from_slice(args);
    let o = kinema(&all);
    assert_status(&o, 0);
    assert_eq!(
        stdout(&o).contains("with velocity projection"),
        args.contains(&"--project-velocity"),
        "{}",
        stdout(&o)
    );
    let csv = Csv::read(out)?;
    let phi = csv.rows.last().ok_or("rows")?[csv.column("crank.phi")?];
    Ok((csv, phi))
}

/// `--project-velocity` keeps Φ_q q̇ = ν to roundoff at every output row,
/// where plain HHT meets it only to its truncation error. Both converge to
/// the accurate mode's answer as the step shrinks, the projected run (the
/// library's `HhtOptions::project_velocity`) at second order like the plain
/// one: only the reported q̇ is projected, HHT's state is not.
#[test]
fn project_velocity_keeps_the_velocity_constraint() -> TestResult {
    let tmp = TempDir::new("forward_project");
    let model = fd_slider_crank();
    let (_, reference) = crank_at_1(
        &model,
        &tmp.path("ref.csv"),
        &["--integrator", "accurate", "--rtol", "1e-10"],
    )?;
    let mut worst = Vec::new();
    let mut errors = Vec::new();
    for (step, projected) in [("4e-3", false), ("4e-3", true), ("2e-3", true)] {
        let out = tmp.path(&format!("p{step}{projected}.csv"));
        let mut args = vec!["--step", step];
        if projected {
            args.push("--project-velocity");
        }
        let (csv, phi) = crank_at_1(&model, &out, &args)?;
        let r = velocity_residuals(&model, &csv)?;
        worst.push(r.iter().skip(1).copied().fold(0.0, f64::max));
        errors.push((phi - reference).abs());
    }
    eprintln!(
        "max ‖Φ_q q̇ − ν‖∞ at h = 4 ms without and with --project-velocity, then with at 2 ms: \
         {worst:?}; error in the crank angle at t = 1: {errors:?}"
    );
    assert!(worst[0] > 1e-9, "{worst:?}");
    assert!(worst[1] < 1e-12 && worst[2] < 1e-12, "{worst:?}");
    assert!(errors[0] < 2e-3 && errors[1] < 2e-3, "{errors:?}");
    // Projection changes only the reported q̇: the positions are those of
    // the plain run.
    assert!((errors[0] - errors[1]).abs() < 1e-12, "{errors:?}");
    let ratio = errors[1] / errors[2];
    assert!((3.2..4.8).contains(&ratio), "{errors:?}");
    // The accurate mode and kinematic runs refuse it.
    let o = kinema(&[
        "run",
        &model,
        "--integrator",
        "accurate",
        "--project-velocity",
        "--out",
        &tmp.path("a.csv"),
    ]);
    assert_status(&o, 2);
    assert!(stderr(&o).contains("--project-velocity is for --integrator hht"));
    let o = kinema(&[
        "run",
        &format!("{ROOT}/models/slider_crank.kin"),
        "--project-velocity",
        "--out",
        &tmp.path("k.csv"),
    ]);
    assert_status(&o, 2);
    assert!(stderr(&o).contains("--project-velocity and --energy are for forward dynamics"));
    Ok(())
}
