//! Redundant constraints and singular configurations in `kinema run` and
//! `kinema check` (issue 38): a parallelogram with a third crank, a
//! four-bar with its coupler pin written twice, free (forward dynamics)
//! and driven (prescribed motion, inverse dynamics), against the same
//! mechanisms without the redundant rows; the warnings a passage and a
//! redundancy print.

mod common;

use common::*;

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// A parallelogram four-bar of unit bars (cranks pinned at x = 0 and 1)
/// with a third crank pinned at x = ½ to the coupler's middle, released
/// from rest with the cranks at 60°. `third`: how the third crank holds
/// the coupler (a revolute, which makes one of its rows redundant, or a
/// single equation, which does not); `driver`: an optional driver line.
fn parallelogram(third: &str, driver: &str) -> String {
    format!(
        "mechanism Parallelogram {{
            param th = pi / 3;
            body crank0  {{ guess: (0.5 * cos(th), 0.5 * sin(th), th), mass: 1, inertia: 1 / 12 }}
            body crank1  {{ guess: (1 + 0.5 * cos(th), 0.5 * sin(th), th), mass: 1, inertia: 1 / 12 }}
            body coupler {{ guess: (cos(th) + 0.5, sin(th), 0), mass: 1, inertia: 1 / 12 }}
            body crank2  {{ guess: (0.5 + 0.5 * cos(th), 0.5 * sin(th), th), mass: 1, inertia: 1 / 12 }}
            gravity = (0, -9.81);
            joint p0: revolute(ground(0, 0), crank0(-0.5, 0));
            joint p1: revolute(ground(1, 0), crank1(-0.5, 0));
            joint a: revolute(crank0(0.5, 0), coupler(-0.5, 0));
            joint b: revolute(crank1(0.5, 0), coupler(0.5, 0));
            joint p2: revolute(ground(0.5, 0), crank2(-0.5, 0));
            {third}
            {driver}
        }}"
    )
}

const REDUNDANT: &str = "joint c: revolute(crank2(0.5, 0), coupler(0, 0));";
const SINGLE: &str = "constraint c: crank2(0.5, 0).y == coupler(0, 0).y;";

/// The largest difference between two CSVs' columns of the same names
/// (`names`), row by row.
fn max_difference(a: &Csv, b: &Csv, names: &[&str]) -> Result<f64, String> {
    let mut worst = 0.0_f64;
    for name in names {
        let (i, j) = (a.column(name)?, b.column(name)?);
        for (ra, rb) in a.rows.iter().zip(&b.rows) {
            worst = worst.max((ra[i] - rb[j]).abs());
        }
    }
    Ok(worst)
}

/// The columns of `bodies`' coordinates with the suffix `suffix` ("",
/// "_dot", "_ddot").
fn columns(bodies: &[&str], suffix: &str) -> Vec<String> {
    let mut names = Vec::new();
    for body in bodies {
        for c in ["x", "y", "phi"] {
            names.push(format!("{body}.{c}{suffix}"));
        }
    }
    names
}

const BODIES: [&str; 4] = ["crank0", "crank1", "coupler", "crank2"];

/// The largest differences in q and q̇ together, and in q̈, between two
/// runs of `bodies`.
fn motion_difference(a: &Csv, b: &Csv, bodies: &[&str]) -> Result<(f64, f64), String> {
    let mut motion = columns(bodies, "");
    motion.extend(columns(bodies, "_dot"));
    let motion: Vec<&str> = motion.iter().map(String::as_str).collect();
    let acc = columns(bodies, "_ddot");
    let acc: Vec<&str> = acc.iter().map(String::as_str).collect();
    Ok((max_difference(a, b, &motion)?, max_difference(a, b, &acc)?))
}

/// HHT solves the same discrete equations with and without the redundant
/// rows; its Newton iteration stops when the position change is 1e-13
/// (1 + ‖q‖), which leaves q̈ converged to that over β h² ≈ 3e-7 (at 1 ms):
/// q̈ is compared to 1e-6 there, q and q̇ to 1e-9.
const ACCELERATION: f64 = 1e-6;

/// Free: the redundant parallelogram runs forward dynamics, reports its
/// redundant row once, and moves as the model without the redundancy
/// (to 1e-9 in q, q̇, q̈ before the first singular passage, in both
/// integrators); `kinema check` says what it found.
#[test]
fn a_redundant_parallelogram_moves_as_the_model_without_the_redundancy() -> TestResult {
    let tmp = TempDir::new("redundant_free");
    let (redundant, single) = (tmp.path("redundant.kin"), tmp.path("single.kin"));
    std::fs::write(&redundant, parallelogram(REDUNDANT, ""))?;
    std::fs::write(&single, parallelogram(SINGLE, ""))?;

    let o = kinema(&["check", &redundant]);
    assert_status(&o, 0);
    let out = stdout(&o);
    assert!(out.contains("redundant equations: c.y"), "{out}");
    assert!(out.contains("leaving 1 degree of freedom"), "{out}");

    for integrator in [
        &["--step", "1e-3"][..],
        &["--integrator", "accurate", "--rtol", "1e-11"],
    ] {
        let (a, b) = (tmp.path("a.csv"), tmp.path("b.csv"));
        let mut args = vec![
            "run", &redundant, "--t-end", "0.5", "--steps", "50", "--out", &a,
        ];
        args.extend_from_slice(integrator);
        let o = kinema(&args);
        assert_status(&o, 0);
        let err = stderr(&o);
        assert!(
            err.contains("warning: redundant constraints at the start")
                && err.contains("removing equation c.y restores full rank"),
            "{err}"
        );
        assert!(stdout(&o).contains("redundant constraints: c.y (rank 11 of 12)"));
        let mut args = vec![
            "run", &single, "--t-end", "0.5", "--steps", "50", "--out", &b,
        ];
        args.extend_from_slice(integrator);
        let o = kinema(&args);
        assert_status(&o, 0);
        assert!(!stderr(&o).contains("redundant"), "{}", stderr(&o));
        let (d, dd) = motion_difference(&Csv::read(&a)?, &Csv::read(&b)?, &BODIES)?;
        assert!(
            d < 1e-9 && dd < ACCELERATION,
            "{integrator:?}: {d:e}, q̈ {dd:e}"
        );
    }
    Ok(())
}

/// Driven: the redundant parallelogram with its crank driven has more
/// rows than coordinates; `kinema run` solves its prescribed motion and
/// inverse dynamics, equal to the kinematic run of the model without the
/// redundancy in q, q̇, q̈ and in the driver's effort (which the
/// redundancy does not touch) to 1e-9, through the singular passage at
/// t = π/3 (the cranks horizontal) as well.
#[test]
fn a_driven_redundant_parallelogram_gives_the_inverse_dynamics_of_the_plain_one() -> TestResult {
    let tmp = TempDir::new("redundant_driven");
    let driver = "driver turn: crank0.phi == pi / 3 - t;";
    let (redundant, single) = (tmp.path("redundant.kin"), tmp.path("single.kin"));
    std::fs::write(&redundant, parallelogram(REDUNDANT, driver))?;
    std::fs::write(&single, parallelogram(SINGLE, driver))?;
    let o = kinema(&["check", &redundant]);
    assert_status(&o, 0);
    assert!(stdout(&o).contains("prescribed motion and inverse dynamics"));

    let (a, b) = (tmp.path("a.csv"), tmp.path("b.csv"));
    let o = kinema(&[
        "run", &redundant, "--t-end", "1", "--steps", "40", "--out", &a,
    ]);
    assert_status(&o, 0);
    assert!(stdout(&o).contains("prescribed motion with redundant rows"));
    assert!(stderr(&o).contains("warning: redundant constraints at the start"));
    let o = kinema(&["run", &single, "--t-end", "1", "--steps", "40", "--out", &b]);
    let (ca, cb) = (Csv::read(&a)?, Csv::read(&b)?);
    let mut names = columns(&BODIES, "");
    names.extend(columns(&BODIES, "_dot"));
    names.extend(columns(&BODIES, "_ddot"));
    let mut names: Vec<&str> = names.iter().map(String::as_str).collect();
    names.push("driver.turn");
    // The plain model is kinematic with its own singular rows flagged at
    // the passage; compare away from it (the rows whose t is within 0.03
    // of π/3 are the branch limits there).
    let keep = |c: &Csv| -> Csv {
        Csv {
            header: c.header.clone(),
            rows: c
                .rows
                .iter()
                .filter(|r| (r[0] - std::f64::consts::FRAC_PI_3).abs() > 0.03)
                .cloned()
                .collect(),
        }
    };
    let d = max_difference(&keep(&ca), &keep(&cb), &names)?;
    assert!(d < 1e-9, "{d:e}; plain run: {}", stderr(&o));
    Ok(())
}

/// A four-bar with its coupler pin written twice runs as the four-bar.
#[test]
fn a_four_bar_with_a_repeated_joint_moves_as_the_four_bar() -> TestResult {
    let tmp = TempDir::new("redundant_joint");
    let four_bar = |extra: &str| {
        format!(
            "mechanism FourBar {{
                body crank {{ guess: (0, 0.5, 1.5707963267948966), mass: 1, inertia: 1 / 12 }}
                body coupler {{ guess: (1, 1, 0), mass: 2, inertia: 2 * 4 / 12 }}
                body rocker {{ guess: (2, 0.5, 1.5707963267948966), mass: 1, inertia: 1 / 12 }}
                gravity = (0, -9.81);
                joint o: revolute(ground(0, 0), crank(0, -0.5));
                joint a: revolute(crank(0, 0.5), coupler(-1, 0));
                joint b: revolute(coupler(1, 0), rocker(0, 0.5));
                joint c: revolute(rocker(0, -0.5), ground(2, 0));
                {extra}
            }}"
        )
    };
    let (twice, once) = (tmp.path("twice.kin"), tmp.path("once.kin"));
    std::fs::write(
        &twice,
        four_bar("joint a_again: revolute(crank(0, 0.5), coupler(-1, 0));"),
    )?;
    std::fs::write(&once, four_bar(""))?;
    let (a, b) = (tmp.path("a.csv"), tmp.path("b.csv"));
    let o = kinema(&["run", &twice, "--t-end", "1", "--steps", "20", "--out", &a]);
    assert_status(&o, 0);
    assert!(
        stderr(&o).contains("removing equations a_again.x, a_again.y restores full rank"),
        "{}",
        stderr(&o)
    );
    let o = kinema(&["run", &once, "--t-end", "1", "--steps", "20", "--out", &b]);
    assert_status(&o, 0);
    let bodies = ["crank", "coupler", "rocker"];
    let (d, dd) = motion_difference(&Csv::read(&a)?, &Csv::read(&b)?, &bodies)?;
    assert!(d < 1e-9 && dd < ACCELERATION, "{d:e}, q̈ {dd:e}");
    Ok(())
}

/// A singular passage in forward dynamics is warned about on its own line
/// with its time and the dependent equations, and counted in the summary.
#[test]
fn a_singular_passage_is_warned_about() -> TestResult {
    let tmp = TempDir::new("passage_warning");
    let model = tmp.path("pg.kin");
    std::fs::write(&model, parallelogram("", ""))?;
    let out = tmp.path("pg.csv");
    let o = kinema(&[
        "run", &model, "--t-end", "0.8", "--steps", "80", "--out", &out,
    ]);
    assert_status(&o, 0);
    let err = stderr(&o);
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("warning: singular configuration passed at t = 0.5"))
        .collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].contains("p0.x") && lines[0].contains("the motion went on through it"),
        "{err}"
    );
    assert!(stdout(&o).contains("singular configurations passed: 1 (t = 0.5"));
    Ok(())
}

/// A driver that becomes unbounded (`1 / (t − p)`) stops forward dynamics
/// with a message naming it and the time, whether the pole is an output
/// time or lies between two steps (where a step could jump over it).
#[test]
fn an_unbounded_driver_stops_forward_dynamics_naming_it_and_the_time() -> TestResult {
    let tmp = TempDir::new("unbounded_driver");
    for (pole, shown) in [("0.5", "t = 0.5"), ("0.5052", "t = 0.5052")] {
        let model = tmp.path("drv.kin");
        std::fs::write(
            &model,
            format!(
                "mechanism D {{
                    body bar {{ guess: (1, 0, 0), mass: 2, inertia: 0.3 }}
                    body block {{ guess: (3, 0, 0), mass: 1, inertia: 0.1 }}
                    gravity = (0, -9.81);
                    constraint px: abs_x(bar(-1, 0), 0);
                    constraint py: abs_y(bar(-1, 0), 0);
                    constraint by: block.y == 0;
                    constraint bphi: block.phi == 0;
                    driver push: block.x == 3 + 1 / (t - {pole});
                }}"
            ),
        )?;
        let out = tmp.path("drv.csv");
        let o = kinema(&["run", &model, "--out", &out]);
        assert_status(&o, 1);
        let err = stderr(&o);
        assert!(
            err.contains("equation `push` is unbounded at ")
                && err.contains("division by 0")
                && !err.contains("cannot follow"),
            "{err}"
        );
        // The time within roundoff of the pole.
        let t: f64 = err
            .split("unbounded at t = ")
            .nth(1)
            .and_then(|r| r.split(':').next())
            .ok_or("no time")?
            .parse()?;
        let p: f64 = pole.parse()?;
        assert!((t - p).abs() < 1e-12, "{shown}: {err}");
    }
    Ok(())
}
