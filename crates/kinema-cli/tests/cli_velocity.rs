//! Initial velocities (issue 38): a `.kin` body's `velocity` item starts
//! `kinema run`'s forward dynamics, with the consistency correction
//! reported as for `.adm` files; `kinema import` writes a simEngine2D
//! body's nonzero `qd0` as that item, so the imported model reproduces the
//! `.adm` run.

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

/// Runs `adm` under its Dynamics `acf` (`tend`, `steps`, `step` the ACF's)
/// and the `.kin` text `kinema import` prints for it on the same grid;
/// every coordinate's value, velocity and acceleration column agrees.
fn round_trip(adm: &str, acf: &str, (tend, steps, step): (&str, &str, &str)) -> TestResult {
    let dir = TempDir::new("velocity_round_trip");
    let imported = kinema(&["import", adm]);
    assert_status(&imported, 0);
    let text = stdout(&imported);
    assert!(text.contains("velocity: ("), "{text}");
    let kin = dir.path("imported.kin");
    std::fs::write(&kin, &text)?;

    let (a, b) = (dir.path("adm.csv"), dir.path("kin.csv"));
    let o = kinema(&["run", adm, "--acf", acf, "--out", &a]);
    assert_status(&o, 0);
    let adm_note = stderr(&o);
    let o = kinema(&[
        "run", &kin, "--t-end", tend, "--steps", steps, "--step", step, "--out", &b,
    ]);
    assert_status(&o, 0);
    // The same start, corrected (or not) the same way.
    let kin_note = stderr(&o);
    assert_eq!(
        adm_note.contains("made consistent"),
        kin_note.contains("made consistent"),
        "{adm_note}\n{kin_note}"
    );
    let (a, b) = (Csv::read(&a)?, Csv::read(&b)?);
    assert_eq!(a.rows.len(), b.rows.len());
    let mut compared = 0;
    for (k, name) in b.header.iter().enumerate() {
        let coordinate = [".x", ".y", ".phi"].iter().any(|s| {
            name.trim_end_matches("_dot")
                .trim_end_matches("_ddot")
                .ends_with(s)
        });
        if name != "t" && !coordinate {
            continue;
        }
        let j = a.column(name)?;
        for (ra, rb) in a.rows.iter().zip(&b.rows) {
            let (x, y) = (ra[j], rb[k]);
            assert!(
                (x - y).abs() <= 1e-12 * (1.0 + x.abs()),
                "{name} at t = {}: .adm {x}, imported .kin {y}",
                ra[0]
            );
        }
        compared += 1;
    }
    assert!(compared >= 7, "{:?}", b.header);
    // The motion is the stated one: the first row's velocities are not zero.
    let first = &b.rows[0];
    let vx = first[b.column("bar.x_dot")?];
    assert!(vx != 0.0, "{first:?}");
    Ok(())
}

#[test]
fn import_keeps_initial_velocities_and_the_runs_agree() -> TestResult {
    let adm = Path::new(HERE).join("tests/cli/adm/thrown_bar.adm");
    let acf = Path::new(HERE).join("tests/cli/adm/thrown_bar.acf");
    let imported = kinema(&["import", &adm.display().to_string()]);
    assert_status(&imported, 0);
    let text = stdout(&imported);
    // A zero qd0 stays implicit; a nonzero one is the body's velocity.
    assert!(
        text.contains(
            "body slider { guess: (0, 0, 0), mass: 2, inertia: 0.5, velocity: (1.5, 0, 0) }"
        ),
        "{text}"
    );
    assert!(
        text.contains(
            "body bar { guess: (1, 0, 0), mass: 1, inertia: 0.25, velocity: (1.5, 2, 2.5) }"
        ),
        "{text}"
    );
    round_trip(
        &adm.display().to_string(),
        &acf.display().to_string(),
        ("1", "50", "0.002"),
    )
}

#[test]
fn the_course_final_exam_round_trips_through_import() -> TestResult {
    // finalExam.adm: a driven slider with a free bar, both moving at the
    // start (qd0 [4, 0, 0] and [4, 6, 3]), under finalExam.acf.
    let Some(dir) = shared() else {
        println!("notice: ../shared/simengine2d is absent; skipping");
        return Ok(());
    };
    let (adm, acf) = (dir.join("finalExam.adm"), dir.join("finalExam.acf"));
    round_trip(
        &adm.display().to_string(),
        &acf.display().to_string(),
        ("4", "400", "0.005"),
    )
}

#[test]
fn a_stated_velocity_starts_the_run_and_its_correction_is_reported() -> TestResult {
    let dir = TempDir::new("velocity_start");
    // Consistent: the centroid moves at L w, the pivot stays.
    let consistent = dir.path("swing.kin");
    std::fs::write(
        &consistent,
        "mechanism Swing {
            param L = 1;
            param w = 3;
            body bar { guess: (0, -L, -pi / 2), mass: 2, inertia: 0.3, velocity: (L * w, 0, w) }
            gravity = (0, -9.81);
            joint pivot: revolute(bar(-L, 0), ground(0, 0));
        }",
    )?;
    let out = dir.path("swing.csv");
    let o = kinema(&[
        "run",
        &consistent,
        "--t-end",
        "0.1",
        "--steps",
        "2",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    // Consistent up to the rounding of cos(−π/2) in the guess: any
    // correction is of that size.
    let summary = stdout(&o);
    let dqd = summary
        .split("‖Δq̇‖∞ = ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|x| x.parse::<f64>().ok())
        .ok_or("the summary's start line")?;
    assert!(dqd < 1e-15, "{summary}");
    let csv = Csv::read(&out)?;
    let first = &csv.rows[0];
    for (name, v) in [("bar.x_dot", 3.0), ("bar.y_dot", 0.0), ("bar.phi_dot", 3.0)] {
        let got = first[csv.column(name)?];
        assert!((got - v).abs() < 1e-15, "{name}: {got}");
    }
    // Kinetic energy at the start: ½ m (L w)² + ½ J w² = 9 + 1.35.
    assert!(
        stdout(&o).contains("at t = 0: kinetic 1.035000000e1"),
        "{}",
        stdout(&o)
    );

    // Inconsistent: the pivot would move up at 0.5 m/s; the start is
    // projected and said so, on standard error and in the summary.
    let inconsistent = dir.path("swing_off.kin");
    std::fs::write(
        &inconsistent,
        "mechanism Swing {
            body bar { guess: (0, -1, -pi / 2), mass: 2, inertia: 0.3, velocity: (3, 0.5, 3) }
            gravity = (0, -9.81);
            joint pivot: revolute(bar(-1, 0), ground(0, 0));
        }",
    )?;
    let o = kinema(&[
        "run",
        &inconsistent,
        "--t-end",
        "0.1",
        "--steps",
        "2",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let note = stderr(&o);
    assert!(
        note.contains(
            "note: the initial conditions were made consistent: q moved by ‖Δq‖∞ = 0.000e0"
        ) && note.contains("q̇ by ‖Δq̇‖∞ = 5.000e-1 (‖Φ_q q̇ − ν‖∞ was 5.000e-1)"),
        "{note}"
    );
    assert!(
        stdout(&o).contains("start: ‖Δq‖∞ = 0.00e0, ‖Δq̇‖∞ = 5.00e-1"),
        "{}",
        stdout(&o)
    );
    let csv = Csv::read(&out)?;
    assert!(csv.rows[0][csv.column("bar.y_dot")?].abs() < 1e-15);
    Ok(())
}

#[test]
fn a_velocity_without_inertia_is_refused_at_its_place() -> TestResult {
    let dir = TempDir::new("velocity_refused");
    let model = dir.path("bad.kin");
    std::fs::write(
        &model,
        "mechanism Bad {\n    body crank { guess: (0.5, 0, 0), velocity: (0, 1, 2) }\n    \
         joint pivot: revolute(ground(0, 0), crank(-0.5, 0));\n    driver swing: crank.phi == t;\n}\n",
    )?;
    let o = kinema(&["run", &model]);
    assert_status(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains(
            "error: body `crank` states a `velocity`, but the model has no inertia: an initial \
             velocity is where forward dynamics starts"
        ) && e.contains("bad.kin:2:38"),
        "{e}"
    );
    Ok(())
}
