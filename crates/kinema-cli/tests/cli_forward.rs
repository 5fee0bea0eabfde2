//! `kinema run` of forward dynamics: every simEngine2D model with inertia
//! (and no m-file force) under its Dynamics ACF, outputs at exactly the
//! ACF's `outputSteps + 1` times; pend1 against the elliptic closed form;
//! a `.kin` model with NDOF > 0 and inertia integrates by default.

mod common;

use std::path::{Path, PathBuf};

use common::*;

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// `../shared/simengine2d` beside the repository, or beside the worktree's
/// parent (`wt/NAME`).
fn shared() -> Option<PathBuf> {
    ["../shared/simengine2d", "../../shared/simengine2d"]
        .iter()
        .map(|p| Path::new(ROOT).join(p))
        .find(|p| p.is_dir())
}

/// A number after `key` in `text`.
fn number_after(text: &str, key: &str) -> Option<f64> {
    let rest = &text[text.find(key)? + key.len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || "+-.e".contains(c)))
        .unwrap_or(rest.len());
    rest[..end].trim_end_matches('.').parse().ok()
}

/// K(k) and sn(u, k) by the AGM (descending Landen transformation).
fn jacobi_sn(u: f64, k: f64) -> (f64, f64) {
    let (mut a, mut c) = (vec![1.0_f64], vec![k]);
    let mut b = (1.0 - k * k).sqrt();
    while c.last().is_some_and(|c| c.abs() > 1e-17) && a.len() < 40 {
        let an = a[a.len() - 1];
        a.push((an + b) / 2.0);
        c.push((an - b) / 2.0);
        b = (an * b).sqrt();
    }
    let nn = a.len() - 1;
    let mut phi = 2f64.powi(nn as i32) * a[nn] * u;
    for i in (1..=nn).rev() {
        phi = (phi + (c[i] / a[i] * phi.sin()).asin()) / 2.0;
    }
    (std::f64::consts::PI / (2.0 * a[nn]), phi.sin())
}

#[test]
fn every_simengine2d_model_with_inertia_runs_its_dynamics_acf() -> TestResult {
    let Some(dir) = shared() else {
        println!("notice: ../shared/simengine2d is absent; skipping");
        return Ok(());
    };
    let tmp = TempDir::new("forward_all");
    let mut ran = Vec::new();
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "adm"))
        .collect();
    names.sort();
    for adm in names {
        let Ok((model, _)) = kinema_adm::Model::read(&adm) else {
            continue;
        };
        let inertia = !model.bodies.is_empty()
            && model
                .bodies
                .iter()
                .all(|b| b.mass.is_some() && b.jbar.is_some());
        let text = std::fs::read_to_string(&adm)?;
        if !inertia || text.contains("PointForceFile") {
            continue;
        }
        let stem = adm.file_stem().and_then(|s| s.to_str()).unwrap_or("?");
        // The Dynamics files: free degrees of freedom, or named so; the
        // kinematic files with inertia run too (with their drivers), but
        // their energy balance is their drivers' (shurikenCatapult's does
        // 2e7 J of work in 4 s), not a test of the integrator.
        let rows = kinema_adm::Names::of(&model).rows(&model).len();
        let dynamics_file =
            rows < 3 * model.bodies.len() || stem.contains("DYN") || stem == "finalExam";
        let acf = if stem == "finalExam" {
            dir.join("finalExam.acf")
        } else {
            dir.join("dynamics.acf")
        };
        let analysis = kinema_adm::Analysis::read(&acf).map_err(|e| format!("{e:?}"))?;
        for mode in ["hht", "accurate"] {
            let out = tmp.path(&format!("{stem}_{mode}.csv"));
            let o = kinema(&[
                "run",
                &adm.display().to_string(),
                "--acf",
                &acf.display().to_string(),
                "--out",
                &out,
                "--integrator",
                mode,
            ]);
            assert_status(&o, 0);
            let csv = Csv::read(&out)?;
            // Exactly the ACF's output times, labelled as the ACF computes them.
            let times = analysis.output_times();
            assert_eq!(csv.rows.len(), analysis.output_steps + 1, "{stem}");
            for (row, t) in csv.rows.iter().zip(&times) {
                assert_eq!(row[0], *t, "{stem}: time column");
            }
            assert!(csv.column(&format!("lambda.{}", "x")).is_err());
            assert!(
                csv.header.iter().any(|h| h.starts_with("lambda.")),
                "{stem}: λ columns"
            );
            assert!(
                csv.header.iter().any(|h| h.starts_with("reaction.")),
                "{stem}: reaction columns"
            );
            // The energy balance closes to the integrator's error.
            let s = stdout(&o);
            let balance = number_after(&s, "balance error ").ok_or("balance in the summary")?;
            let ke = number_after(&s, "kinetic ").ok_or("kinetic energy in the summary")?;
            let v = number_after(&s, "potential (gravity) ").ok_or("potential")?;
            let work = number_after(&s, "drivers ").ok_or("work in the summary")?;
            let ke0 = number_after(&s, ": kinetic ").ok_or("initial kinetic energy")?;
            // A driven model's drivers do work: the balance is held to the
            // energies that flow.
            let scale = ke
                .abs()
                .max(v.abs())
                .max(work.abs())
                .max(ke0.abs())
                .max(1.0);
            // HHT's balance is its step's (1e-3 of the energies at the
            // ACF's step); the accurate mode's, its tolerance's (1e-8).
            let tolerance = if mode == "hht" { 1e-3 } else { 1e-7 };
            if dynamics_file {
                assert!(balance.abs() <= tolerance * scale, "{stem} {mode}: {s}");
            }
        }
        ran.push(stem.to_owned());
    }
    for expected in [
        "pend1",
        "pendDYN",
        "pend2",
        "pendEQL",
        "dpendVIS",
        "doublePendDYN",
        "sliderCrankDYN",
        "finalExam",
    ] {
        assert!(ran.iter().any(|r| r == expected), "{expected} ran: {ran:?}");
    }
    Ok(())
}

/// pend1: a bar (m = 2, J̄ = 0.3) pinned 2 from its centroid, released
/// horizontal. φ from the closed form θ = 2 asin(k sn(K − ω₀t, k)),
/// k = sin(π/4), ω₀² = m g d / (J̄ + m d²), θ = φ + π/2; HHT's error falls
/// 4× when the step halves.
#[test]
fn pend1_against_the_elliptic_solution() -> TestResult {
    let Some(dir) = shared() else {
        println!("notice: ../shared/simengine2d is absent; skipping");
        return Ok(());
    };
    let adm = dir.join("pend1.adm").display().to_string();
    let acf = dir.join("dynamics.acf").display().to_string();
    let (m, j, d, g): (f64, f64, f64, f64) = (2.0, 0.3, 2.0, 9.81);
    let w0 = (m * g * d / (j + m * d * d)).sqrt();
    let k = std::f64::consts::FRAC_PI_4.sin();
    let (big_k, _) = jacobi_sn(0.0, k);
    let phi =
        |t: f64| 2.0 * (k * jacobi_sn(big_k - w0 * t, k).1).asin() - std::f64::consts::FRAC_PI_2;
    let tmp = TempDir::new("forward_pend1");
    let mut errors = Vec::new();
    for step in ["0.005", "0.0025", "0.00125"] {
        let out = tmp.path(&format!("p{step}.csv"));
        let o = kinema(&["run", &adm, "--acf", &acf, "--step", step, "--out", &out]);
        assert_status(&o, 0);
        let csv = Csv::read(&out)?;
        let c = csv.column("pend.phi")?;
        let err = csv
            .rows
            .iter()
            .take(101) // t ≤ 1
            .map(|r| (r[c] - phi(r[0])).abs())
            .fold(0.0, f64::max);
        errors.push(err);
    }
    eprintln!("pend1: max |φ − φ_exact| over t ≤ 1: {errors:?}");
    assert!(errors[0] < 1e-3, "{errors:?}");
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!((3.5..4.6).contains(&ratio), "ratio {ratio}: {errors:?}");
    }
    // The accurate mode at rtol 1e-10: to 1e-8 over the whole run (4 s).
    let out = tmp.path("accurate.csv");
    let o = kinema(&[
        "run",
        &adm,
        "--acf",
        &acf,
        "--integrator",
        "accurate",
        "--rtol",
        "1e-10",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    let c = csv.column("pend.phi")?;
    let err = csv
        .rows
        .iter()
        .map(|r| (r[c] - phi(r[0])).abs())
        .fold(0.0, f64::max);
    eprintln!("pend1 accurate, rtol 1e-10: max |φ − φ_exact| over 4 s: {err:.3e}");
    assert!(err <= 1e-8, "{err}");
    Ok(())
}

#[test]
fn a_kin_model_with_free_dof_and_inertia_integrates_by_default() -> TestResult {
    let tmp = TempDir::new("forward_kin");
    let model = tmp.path("pend.kin");
    std::fs::write(
        &model,
        "mechanism P {
            body bar { guess: (1, 0, 0), mass: 2, inertia: 0.3 }
            gravity = (0, -9.81);
            constraint px: abs_x(bar(-1, 0), 0);
            constraint py: abs_y(bar(-1, 0), 0);
        }",
    )?;
    let out = tmp.path("p.csv");
    let o = kinema(&[
        "run",
        &model,
        "--integrator",
        "hht",
        "--step",
        "1e-3",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    assert!(stdout(&o).contains("HHT-α"), "{}", stdout(&o));
    let csv = Csv::read(&out)?;
    assert_eq!(csv.rows.len(), 101);
    // At release the pivot carries m g − m ÿ, ÿ = −m g d² / (J̄ + m d²).
    let fy = csv.rows[0][csv.column("reaction.py.bar.Fy")?];
    let ydd = -2.0 * 9.81 / (0.3 + 2.0);
    assert!((fy - (2.0 * 9.81 + 2.0 * ydd)).abs() < 1e-9, "{fy}");
    // --step is for forward dynamics only.
    let o = kinema(&[
        "run",
        &format!("{ROOT}/models/slider_crank.kin"),
        "--step",
        "1e-3",
        "--out",
        &tmp.path("k.csv"),
    ]);
    assert_status(&o, 2);
    assert!(stderr(&o).contains("--step is for forward dynamics"));
    Ok(())
}

/// A force that blows up at t = 0.5 stops the run there, naming the time
/// and the quantity, with the rows before it kept; a step far too large
/// for the motion is warned about from the energy balance.
#[test]
fn failures_and_inaccuracy_are_said() -> TestResult {
    let tmp = TempDir::new("forward_fail");
    let model = tmp.path("bad.kin");
    std::fs::write(
        &model,
        "mechanism P {
            body bar { guess: (1, 0, 0), mass: 2, inertia: 0.3 }
            gravity = (0, -9.81);
            force kick: point_force(bar(0, 0), (0, 1 / (0.5 - t)));
            constraint px: abs_x(bar(-1, 0), 0);
            constraint py: abs_y(bar(-1, 0), 0);
        }",
    )?;
    let out = tmp.path("bad.csv");
    let o = kinema(&["run", &model, "--out", &out]);
    assert_status(&o, 1);
    let err = stderr(&o);
    assert!(
        err.contains("at t = 0.5") && err.contains("Q_A at bar.y"),
        "{err}"
    );
    assert!(
        err.contains("the 50 rows computed before the failure"),
        "{err}"
    );
    assert_eq!(Csv::read(&out)?.rows.len(), 50);

    let good = tmp.path("pend.kin");
    std::fs::write(
        &good,
        "mechanism P {
            body bar { guess: (1, 0, 0), mass: 2, inertia: 0.3 }
            gravity = (0, -9.81);
            constraint px: abs_x(bar(-1, 0), 0);
            constraint py: abs_y(bar(-1, 0), 0);
        }",
    )?;
    let o = kinema(&[
        "run", &good, "--t-end", "20", "--steps", "2", "--step", "10", "--out", &out,
    ]);
    assert_status(&o, 0);
    assert!(
        stderr(&o).contains("warning: the energy balance is off"),
        "{}",
        stderr(&o)
    );
    // At a sensible step, no warning.
    let o = kinema(&["run", &good, "--out", &out]);
    assert_status(&o, 0);
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    // Options of the other integrator are refused.
    let o = kinema(&["run", &good, "--rtol", "1e-9", "--out", &out]);
    assert_status(&o, 2);
    let o = kinema(&[
        "run",
        &good,
        "--integrator",
        "accurate",
        "--step",
        "1e-3",
        "--out",
        &out,
    ]);
    assert_status(&o, 2);
    // A step too small to take is refused, the step written readably.
    let o = kinema(&["run", &good, "--step", "1e-300", "--out", &out]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("steps of 1e-300") && err.contains("too many"),
        "{err}"
    );
    assert!(err.len() < 400, "{err}");
    Ok(())
}

/// sliderCrankDYN (released from rest under gravity): HHT's error in q at
/// t = 1 against the accurate mode at rtol 1e-11 falls 4× when the step
/// halves from the ACF's 0.005.
#[test]
fn slider_crank_dyn_hht_is_second_order_against_the_accurate_mode() -> TestResult {
    let Some(dir) = shared() else {
        println!("notice: ../shared/simengine2d is absent; skipping");
        return Ok(());
    };
    let adm = dir.join("sliderCrankDYN.adm").display().to_string();
    let acf = dir.join("dynamics.acf").display().to_string();
    let tmp = TempDir::new("forward_sc");
    let run = |extra: &[&str], name: &str| -> Result<Csv, Box<dyn std::error::Error>> {
        let out = tmp.path(name);
        let mut args = vec![
            "run",
            adm.as_str(),
            "--acf",
            acf.as_str(),
            "--out",
            out.as_str(),
        ];
        args.extend_from_slice(extra);
        let o = kinema(&args);
        assert_status(&o, 0);
        Csv::read(&out)
    };
    let reference = run(&["--integrator", "accurate", "--rtol", "1e-11"], "ref.csv")?;
    let coords: Vec<usize> = reference
        .header
        .iter()
        .enumerate()
        .filter(|(_, h)| h.ends_with(".x") || h.ends_with(".y") || h.ends_with(".phi"))
        .map(|(i, _)| i)
        .collect();
    assert!(coords.len() >= 9, "{:?}", reference.header);
    let mut errors = Vec::new();
    for step in ["0.005", "0.0025"] {
        let csv = run(&["--step", step], &format!("h{step}.csv"))?;
        let row = 100; // t = 1
        assert_eq!(csv.rows[row][0], 1.0);
        let err = coords
            .iter()
            .map(|&c| (csv.rows[row][c] - reference.rows[row][c]).abs())
            .fold(0.0, f64::max);
        errors.push(err);
    }
    eprintln!("sliderCrankDYN: HHT error in q at t = 1: {errors:?}");
    let ratio = errors[0] / errors[1];
    assert!((3.5..4.6).contains(&ratio), "ratio {ratio}: {errors:?}");
    Ok(())
}

/// `--energy` writes the kinetic and potential energy and the work of the
/// other forces; with a damper doing work, kinetic + potential − work stays
/// at its start value to the accurate mode's tolerance at every row, and the
/// damper's work is negative.
#[test]
fn energy_columns_balance_at_every_row() -> TestResult {
    let tmp = TempDir::new("forward_energy");
    let model = tmp.path("pend.kin");
    std::fs::write(
        &model,
        "mechanism P {
            body bar { guess: (1, 0, 0), mass: 2, inertia: 0.3 }
            gravity = (0, -9.81);
            constraint px: abs_x(bar(-1, 0), 0);
            constraint py: abs_y(bar(-1, 0), 0);
            force damp: rsda(ground, bar, 0, 0.4, 0);
        }",
    )?;
    let out = tmp.path("p.csv");
    let o = kinema(&[
        "run",
        &model,
        "--integrator",
        "accurate",
        "--rtol",
        "1e-10",
        "--energy",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    let (ke, v, w) = (
        csv.column("energy.kinetic")?,
        csv.column("energy.potential")?,
        csv.column("energy.work")?,
    );
    let start = csv.rows[0][ke] + csv.rows[0][v] - csv.rows[0][w];
    let scale = csv.rows.iter().map(|r| r[v].abs()).fold(1.0, f64::max);
    for row in &csv.rows {
        let drift = (row[ke] + row[v] - row[w] - start).abs() / scale;
        assert!(drift < 1e-7, "t = {}: drift {drift:e}", row[0]);
    }
    let last = csv.rows.last().ok_or("rows")?;
    assert!(last[w] < 0.0, "the damper dissipates: work {}", last[w]);
    // Kinematic runs refuse it.
    let o = kinema(&[
        "run",
        &format!("{ROOT}/models/slider_crank.kin"),
        "--energy",
        "--out",
        &tmp.path("k.csv"),
    ]);
    assert_status(&o, 2);
    assert!(
        stderr(&o).contains("--energy are for forward dynamics"),
        "{}",
        stderr(&o)
    );
    Ok(())
}
