//! `kinema run` of models with inertia: the columns of docs/src/dynamics.md, the
//! driven simEngine2D files (λ, reactions, efforts, and the power balance
//! effort × driven velocity = d(KE + PE)/dt at every row), and the refusal
//! of a `PointForceFile`.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use kinema_adm::{ConstraintKind, Model};

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// `../shared/simengine2d` beside the repository, or beside the worktree's
/// parent (`wt/NAME`).
fn shared() -> Option<PathBuf> {
    ["../shared/simengine2d", "../../shared/simengine2d"]
        .iter()
        .map(|p| Path::new(ROOT).join(p))
        .find(|p| p.is_dir())
}

/// Checks the power balance of one run of `model` (read with
/// kinema_adm): Σ effort × ν over the drivers = q̇ᵀ M q̈ − Σ m gᵀ ṙ, the
/// rate of KE + PE, at every row, to 1e-9 of the terms' scale. Returns
/// the largest rate seen.
fn power_balance(model: &Model, csv: &Csv, file: &str) -> Result<f64, Box<dyn std::error::Error>> {
    let names = kinema_adm::Names::of(model);
    let mut drivers: Vec<(usize, usize)> = Vec::new(); // (effort column, φ̇ column)
    for (c, idents) in model.constraints.iter().zip(&names.constraints) {
        let Some(ident) = idents.first() else {
            continue;
        };
        let Ok(col) = csv.column(&format!("driver.{ident}")) else {
            continue;
        };
        match &c.kind {
            ConstraintKind::AbsoluteAngle { body1, .. } => {
                let body = &names.bodies[*body1];
                drivers.push((col, csv.column(&format!("{body}.phi_dot"))?));
            }
            other => return Err(format!("{file}: a driver of kind {other:?} in the test").into()),
        }
    }
    assert!(
        !drivers.is_empty(),
        "{file}: no driver columns in {:?}",
        csv.header
    );
    let g = model.gravity;
    let mut largest: f64 = 0.0;
    for row in &csv.rows {
        let (mut rate, mut scale) = (0.0, 0.0);
        for (b, (body, ident)) in model.bodies.iter().zip(&names.bodies).enumerate() {
            let (m, j) = (body.mass.unwrap_or(0.0), body.jbar.unwrap_or(0.0));
            for (comp, inertia) in [("x", m), ("y", m), ("phi", j)] {
                let v = row[csv.column(&format!("{ident}.{comp}_dot"))?];
                let a = row[csv.column(&format!("{ident}.{comp}_ddot"))?];
                rate += inertia * v * a;
                scale += (inertia * v * a).abs();
            }
            let vx = row[csv.column(&format!("{ident}.x_dot"))?];
            let vy = row[csv.column(&format!("{ident}.y_dot"))?];
            let p = -m * (g[0] * vx + g[1] * vy);
            rate += p;
            scale += p.abs();
            let _ = b;
        }
        let supplied: f64 = drivers.iter().map(|&(e, w)| row[e] * row[w]).sum();
        let t = row[0];
        assert!(
            (supplied - rate).abs() <= 1e-9 * scale.max(supplied.abs()).max(1e-300),
            "{file} at t = {t}: effort × driven velocity = {supplied}, d(KE + PE)/dt = {rate}"
        );
        largest = largest.max(rate.abs());
    }
    Ok(largest)
}

#[test]
fn driven_simengine2d_files_balance_power() -> TestResult {
    let Some(dir) = shared() else {
        println!("notice: ../shared/simengine2d is absent; skipping");
        return Ok(());
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "adm"))
        .collect();
    files.sort();
    let tmp = TempDir::new("dynamics");
    let kinematics = kinema_adm::Analysis::read(&dir.join("kinematics.acf"))?;
    let mut ran = Vec::new();
    for adm in &files {
        let model = Model::read(adm)?.0;
        // Driven: NDOF = 0 (a Kinematics analysis of it runs).
        if kinema_adm::check_kinematic(&model, &kinematics).is_err()
            || !kinema_adm::dynamics::point_force_files(&model).is_empty()
        {
            continue;
        }
        let stem = adm.file_stem().and_then(|s| s.to_str()).ok_or("name")?;
        let out = tmp.path(&format!("{stem}.csv"));
        let adm_s = adm.display().to_string();
        let acf = dir.join("kinematics.acf").display().to_string();
        let o = kinema(&[
            "run", &adm_s, "--acf", &acf, "--steps", "200", "--out", &out,
        ]);
        assert_status(&o, 0);
        let csv = Csv::read(&out)?;
        for prefix in ["lambda.", "reaction.", "driver."] {
            assert!(
                csv.header.iter().any(|h| h.starts_with(prefix)),
                "{stem}: no {prefix} column in {:?}",
                csv.header
            );
        }
        assert!(
            csv.header
                .iter()
                .any(|h| h.contains(".body1.") || h.contains(".body2.")),
            "{stem}: reactions are named body1/body2: {:?}",
            csv.header
        );
        let largest = power_balance(&model, &csv, stem)?;
        assert!(largest > 0.0, "{stem}: the drivers do no work");
        ran.push(stem.to_string());
    }
    println!("power balance held on {}", ran.join(", "));
    assert!(ran.len() >= 5, "{ran:?}");
    Ok(())
}

#[test]
fn point_force_file_is_refused_naming_its_m_file() -> TestResult {
    let Some(dir) = shared() else {
        println!("notice: ../shared/simengine2d is absent; skipping");
        return Ok(());
    };
    // project2 is not driven (its kinematic run is refused for that
    // first): its equilibrium meets the m-file.
    let adm = dir.join("project2.adm").display().to_string();
    let o = kinema(&["run", &adm, "--equilibrium"]);
    assert_status(&o, 2);
    let err = stderr(&o);
    assert!(
        err.contains("PointForceFile") && err.contains("pistonForce.m"),
        "{err}"
    );
    Ok(())
}

const PENDULUM: &str = "mechanism Pendulum {
    gravity = (0, -9.81);
    body bar { mass: 2, inertia: 0.5, guess: (0.5, 0.5, 0.8) }
    joint pin: revolute(bar(-0.7, 0), ground(0, 0));
    driver swing: bar.phi == 0.3 + t;
}";

#[test]
fn kin_model_with_inertia_writes_the_dynamics_columns() -> TestResult {
    let tmp = TempDir::new("dynamics_kin");
    let model = tmp.path("pendulum.kin");
    std::fs::write(&model, PENDULUM)?;
    let out = tmp.path("p.csv");
    let o = kinema(&["run", &model, "--t-end", "1", "--steps", "4", "--out", &out]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    let tail: Vec<&str> = csv.header[10..].iter().map(String::as_str).collect();
    assert_eq!(
        tail,
        [
            "lambda.pin.x",
            "lambda.pin.y",
            "lambda.swing",
            "reaction.pin.bar.Fx",
            "reaction.pin.bar.Fy",
            "reaction.pin.bar.T",
            "reaction.swing.bar.Fx",
            "reaction.swing.bar.Fy",
            "reaction.swing.bar.T",
            "driver.swing",
        ]
    );
    // --plot adds the reaction forces and the driver efforts against time.
    let svg = tmp.path("p.svg");
    let o = kinema(&[
        "run", &model, "--steps", "20", "--out", &out, "--plot", &svg,
    ]);
    assert_status(&o, 0);
    let text = std::fs::read_to_string(&svg)?;
    assert!(text.contains("Reaction forces") && text.contains("Driver efforts"));
    assert!(
        text.contains("\npin.bar\n") && text.contains("\nswing\n"),
        "legends"
    );
    // A kinematic model writes the kinematic columns only.
    let out2 = tmp.path("k.csv");
    let kin = Path::new(ROOT)
        .join("models/slider_crank.kin")
        .display()
        .to_string();
    let o = kinema(&["run", &kin, "--steps", "2", "--out", &out2]);
    assert_status(&o, 0);
    let header = Csv::read(&out2)?.header;
    assert!(
        !header.iter().any(|h| h.starts_with("lambda.")
            || h.starts_with("reaction.")
            || h.starts_with("driver.")),
        "{header:?}"
    );
    Ok(())
}

/// pendEQL's equilibrium through the CLI: one row, the stable root of
/// V'(φ) = m g cos φ + k (φ − θ0) (m = 10, k = 25, θ0 = 1: the file's),
/// stability in the summary; a plain run is refused naming --equilibrium.
#[test]
fn pend_eql_equilibrium_from_the_real_file() -> TestResult {
    let Some(dir) = shared() else {
        println!("notice: ../shared/simengine2d is absent; skipping");
        return Ok(());
    };
    let adm = dir.join("pendEQL.adm").display().to_string();
    let tmp = TempDir::new("equilibrium");
    let out = tmp.path("eq.csv");
    let o = kinema(&["run", &adm, "--equilibrium", "--out", &out]);
    assert_status(&o, 0);
    assert!(stdout(&o).contains("stability: stable"), "{}", stdout(&o));
    let csv = Csv::read(&out)?;
    assert_eq!(csv.rows.len(), 1);
    let phi = csv.rows[0][csv.column("pend.phi")?];
    let dv = |p: f64| 98.1 * p.cos() + 25.0 * (p - 1.0);
    let (mut a, mut b) = (3.0, 4.5);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if dv(a) * dv(m) <= 0.0 {
            b = m;
        } else {
            a = m;
        }
    }
    assert!((phi - a).abs() < 1e-9, "φ = {phi}, stable root {a}");
    assert!(
        csv.header
            .iter()
            .any(|h| h == "reaction.absY_pend.body1.Fy")
    );
    let o = kinema(&["run", &adm, "--out", &tmp.path("no.csv")]);
    assert_status(&o, 2);
    Ok(())
}

/// The point of body slot `slot` (0: `body1`, 1: `body2`) at which an ADM
/// element's reaction is reported (DYNAMICS.md: the element's own point on
/// that body, the origin for an angle), with the body's index.
fn reaction_point(kind: &ConstraintKind, slot: usize) -> Option<(usize, [f64; 2])> {
    match (kind, slot) {
        (
            ConstraintKind::AbsoluteX { body1, sp1, .. }
            | ConstraintKind::AbsoluteY { body1, sp1, .. },
            0,
        ) => Some((*body1, *sp1)),
        (ConstraintKind::AbsoluteAngle { body1, .. }, 0) => Some((*body1, [0.0, 0.0])),
        (
            ConstraintKind::Revolute { body1, sp1, .. }
            | ConstraintKind::Translational { body1, sp1, .. }
            | ConstraintKind::RackPinion { body1, sp1, .. },
            0,
        ) => Some((*body1, *sp1)),
        (
            ConstraintKind::Revolute { body2, sp2, .. }
            | ConstraintKind::Translational { body2, sp2, .. }
            | ConstraintKind::RackPinion { body2, sp2, .. },
            1,
        ) => Some((*body2, *sp2)),
        _ => None,
    }
}

/// Newton–Euler on every body of an ADM model's inverse dynamics, at every
/// row: m r̈ − m g = Σ F and J φ̈ = Σ (T + (A(φ) s_P) × F) over the
/// reactions on the body, each at its element's point s_P. Returns the
/// names of the reactions it read.
fn newton_euler(
    model: &Model,
    csv: &Csv,
    file: &str,
) -> Result<Vec<String>, Box<dyn std::error::Error>> {
    let names = kinema_adm::Names::of(model);
    // (body, point, Fx, Fy, T columns) of every reaction in the CSV.
    let mut reactions = Vec::new();
    let mut read = Vec::new();
    for (c, idents) in model.constraints.iter().zip(&names.constraints) {
        let ident = idents.first().ok_or("an element without a name")?;
        for slot in 0..2 {
            let Some((body, s)) = reaction_point(&c.kind, slot) else {
                continue;
            };
            let base = format!("reaction.{ident}.body{}", slot + 1);
            let col = |c: &str| csv.column(&format!("{base}.{c}"));
            reactions.push((body, s, col("Fx")?, col("Fy")?, col("T")?));
            read.push(base);
        }
    }
    let g = model.gravity;
    for row in &csv.rows {
        let t = row[0];
        for (b, (body, ident)) in model.bodies.iter().zip(&names.bodies).enumerate() {
            let (m, j) = (body.mass.unwrap_or(0.0), body.jbar.unwrap_or(0.0));
            let at = |c: &str| csv.column(&format!("{ident}.{c}")).map(|k| row[k]);
            let phi = at("phi")?;
            let (mut fx, mut fy, mut torque) = (0.0, 0.0, 0.0);
            for &(_, s, cx, cy, ct) in reactions.iter().filter(|r| r.0 == b) {
                let (f, h) = ([row[cx], row[cy]], row[ct]);
                let arm = [
                    phi.cos() * s[0] - phi.sin() * s[1],
                    phi.sin() * s[0] + phi.cos() * s[1],
                ];
                fx += f[0];
                fy += f[1];
                torque += h + arm[0] * f[1] - arm[1] * f[0];
            }
            let want = [
                m * at("x_ddot")? - m * g[0],
                m * at("y_ddot")? - m * g[1],
                j * at("phi_ddot")?,
            ];
            let scale = 1.0 + want.iter().map(|w| w.abs()).fold(0.0, f64::max);
            for (k, (have, want)) in [fx, fy, torque].into_iter().zip(want).enumerate() {
                assert!(
                    (have - want).abs() <= 1e-9 * scale,
                    "{file}, body {ident}, t = {t}: Σ reactions {} = {have}, inertia {want}",
                    ["Fx", "Fy", "T"][k]
                );
            }
        }
    }
    Ok(read)
}

/// A RackPinion's reaction is one element named like the file's
/// constraint, at its own points (sP1 on the rack, sP2 on the pinion), and
/// Newton–Euler holds on every body with it: the repository's level rack
/// and a tilting rack whose pitch line is off its origin and 2 long (the
/// engine scales its rows by that length; kinema's rows are unit).
#[test]
fn rack_and_pinion_reaction_is_one_element() -> TestResult {
    let tmp = TempDir::new("rack_reaction");
    let acf = format!("{ROOT}/crates/kinema-adm/tests/data/kinematics.acf");
    for file in ["rack_pinion", "rack_pinion_tilting"] {
        let adm = format!("{ROOT}/crates/kinema-adm/tests/data/{file}.adm");
        let model = Model::read(Path::new(&adm))?.0;
        let out = tmp.path(&format!("{file}.csv"));
        let o = kinema(&["run", &adm, "--acf", &acf, "--out", &out]);
        assert_status(&o, 0);
        let csv = Csv::read(&out)?;
        assert!(
            !csv.header.iter().any(|h| h.contains("mesh_")),
            "{file}: {:?}",
            csv.header
        );
        for h in [
            "lambda.mesh.1",
            "lambda.mesh.2",
            "reaction.mesh.body1.Fx",
            "reaction.mesh.body1.T",
            "reaction.mesh.body2.Fy",
        ] {
            csv.column(h)?;
        }
        let read = newton_euler(&model, &csv, file)?;
        assert!(
            read.contains(&"reaction.mesh.body2".to_string()),
            "{read:?}"
        );
        // The mesh carries load: the pinion drive works through it.
        let fx = csv.column("reaction.mesh.body1.Fx")?;
        assert!(csv.rows.iter().any(|r| r[fx].abs() > 1e-3), "{file}");
    }
    Ok(())
}
