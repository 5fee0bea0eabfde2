//! `kinema run --sensitivity` (issue 40): the `d(COLUMN)/d(PARAM)` columns
//! after the others, against central finite differences of whole runs of
//! the model with the param at p(1 ± 1e-6) (a temporary copy of the model
//! text), to 1e-6 relative; and the refusals (exit status 2).

mod common;
use common::*;

/// The relative step of the differences, and the agreement asked for.
const H: f64 = 1e-6;
const TOLERANCE: f64 = 1e-6;

/// `models/NAME` with `param P = …;` set to `value`.
fn with_param(name: &str, param: &str, value: f64) -> String {
    let path = format!("{ROOT}/models/{name}");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let key = format!("param {param} =");
    let start = text
        .find(&key)
        .unwrap_or_else(|| panic!("{name} declares no `{key}`"));
    let end = start + text[start..].find(';').expect("a `;`");
    format!(
        "{}param {param} = {value:e}{}",
        &text[..start],
        &text[end..]
    )
}

/// The declared value of `param` (a number literal).
fn declared(name: &str, param: &str) -> f64 {
    let path = format!("{ROOT}/models/{name}");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let key = format!("param {param} =");
    let start = text.find(&key).expect("declared") + key.len();
    let end = start + text[start..].find(';').expect("a `;`");
    text[start..end]
        .trim()
        .parse()
        .unwrap_or_else(|e| panic!("{param}: not a number literal: {e}"))
}

fn run(dir: &TempDir, model: &str, out: &str, extra: &[&str]) -> Csv {
    let mut args = vec!["run", model, "--steps", "40", "--out", out];
    args.extend_from_slice(extra);
    let o = kinema(&args);
    assert_status(&o, 0);
    let _ = dir;
    Csv::read(out).unwrap_or_else(|e| panic!("{out}: {e}"))
}

/// Runs `name` with `--sensitivity` over `params`, and each param's
/// perturbed models; returns the worst relative disagreement (each column
/// scaled by its largest magnitude over the run).
fn worst(name: &str, params: &[&str]) -> f64 {
    let dir = TempDir::new(&format!("sens-{name}"));
    let out = dir.path("base.csv");
    let list = params.join(",");
    let base = run(
        &dir,
        &format!("models/{name}"),
        &out,
        &["--sensitivity", &list],
    );
    // The header: t, the run's columns, then per param each of them.
    let plain: Vec<String> = base
        .header
        .iter()
        .take_while(|h| !h.starts_with("d("))
        .cloned()
        .collect();
    let columns = &plain[1..];
    assert_eq!(
        base.header.len(),
        plain.len() + params.len() * columns.len(),
        "{name}: header {:?}",
        base.header
    );
    let mut worst = (0.0f64, String::new());
    for (k, &param) in params.iter().enumerate() {
        for (j, c) in columns.iter().enumerate() {
            assert_eq!(
                base.header[plain.len() + k * columns.len() + j],
                format!("d({c})/d({param})"),
                "{name}: the scheme"
            );
        }
        let p = declared(name, param);
        let step = H * p.abs();
        let runs: Vec<Csv> = [p + step, p - step]
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let model = dir.path(&format!("{param}{i}.kin"));
                std::fs::write(&model, with_param(name, param, v)).expect("write model");
                run(&dir, &model, &dir.path(&format!("{param}{i}.csv")), &[])
            })
            .collect();
        for (j, c) in columns.iter().enumerate() {
            let col = base.column(&format!("d({c})/d({param})")).expect("column");
            let fd: Vec<f64> = (0..base.rows.len())
                .map(|i| (runs[0].rows[i][j + 1] - runs[1].rows[i][j + 1]) / (2.0 * step))
                .collect();
            let scale = (0..base.rows.len())
                .map(|i| fd[i].abs().max(base.rows[i][col].abs()))
                .fold(0.0, f64::max);
            for (i, row) in base.rows.iter().enumerate() {
                let (a, f) = (row[col], fd[i]);
                // The differences' rounding noise: a few ulps of the row's
                // largest value (the terms' size) over 2 h p; it matters only
                // for a column p barely moves (a structural zero).
                let magnitude = runs[0].rows[i].iter().fold(1.0, |m: f64, v| m.max(v.abs()));
                let noise = 16.0 * f64::EPSILON * magnitude / (2.0 * step);
                let err = ((a - f).abs() - noise).max(0.0) / scale.max(f64::MIN_POSITIVE);
                assert!(
                    err <= TOLERANCE,
                    "{name}: d({c})/d({param}) at t = {}: {a}, differences {f} ({err:e})",
                    row[0]
                );
                let raw = (a - f).abs() / scale.max(f64::MIN_POSITIVE);
                if scale > 1e-6 && raw > worst.0 {
                    worst = (raw, format!("d({c})/d({param}) at t = {}", row[0]));
                }
            }
        }
    }
    println!(
        "{name}: worst relative disagreement {:e} ({})",
        worst.0, worst.1
    );
    worst.0
}

#[test]
fn slider_crank_columns_match_differences() {
    worst("slider_crank.kin", &["l1", "l2"]);
}

#[test]
fn four_bar_columns_match_differences() {
    // Positions by Newton; a named point and an output.
    worst("four_bar.kin", &["l1", "l2", "l3", "l0"]);
}

/// With inertia, gravity and a gas force that reads q̇: the
/// inverse-dynamics columns' sensitivities (λ, reactions, the driver's
/// effort) after the coordinates', per param (`models/../tests/dynamics`:
/// the helpers read `models/NAME`).
#[test]
fn efforts_and_reactions_match_differences() {
    worst("../tests/dynamics/slider_crank.kin", &["l1", "l2"]);
}

#[test]
fn follower_with_outputs_matches_differences() {
    worst("parabola_follower.kin", &["l1", "k", "y0"]);
}

#[test]
fn columns_follow_the_selection() -> TestResult {
    let dir = TempDir::new("sens-columns");
    let out = dir.path("c.csv");
    let o = kinema(&[
        "run",
        "models/slider_crank.kin",
        "--steps",
        "4",
        "--columns",
        "slider.x,reach",
        "--sensitivity",
        "l2",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let csv = Csv::read(&out)?;
    assert_eq!(
        csv.header,
        [
            "t",
            "slider.x",
            "slider.x_dot",
            "slider.x_ddot",
            "reach",
            "reach_dot",
            "reach_ddot",
            "d(slider.x)/d(l2)",
            "d(slider.x_dot)/d(l2)",
            "d(slider.x_ddot)/d(l2)",
            "d(reach)/d(l2)",
            "d(reach_dot)/d(l2)",
            "d(reach_ddot)/d(l2)",
        ]
    );
    // The slider's x is l1 cos θ + √(l2² − l1² sin² θ) with θ = π/4 + 2π t,
    // so ∂x/∂l2 = l2 / √(l2² − l1² sin² θ).
    let c = csv.column("d(slider.x)/d(l2)")?;
    for r in &csv.rows {
        let theta = std::f64::consts::FRAC_PI_4 + 2.0 * std::f64::consts::PI * r[0];
        let exact = 1.0 / (1.0 - (0.3 * theta.sin()).powi(2)).sqrt();
        assert!(
            (r[c] - exact).abs() < 1e-12,
            "t = {}: {} vs {exact}",
            r[0],
            r[c]
        );
    }
    Ok(())
}

#[test]
fn bad_names_are_usage_errors_naming_the_params() {
    for (names, said) in [
        ("l9", "no param named `l9`"),
        ("crank", "`crank` is a body, not a param"),
        ("reach", "`reach` is an output, not a param"),
        ("l1,l1", "asked for more than once"),
    ] {
        let o = kinema(&[
            "run",
            "models/slider_crank.kin",
            "--sensitivity",
            names,
            "--out",
            "-",
        ]);
        assert_status(&o, 2);
        let e = stderr(&o);
        assert!(e.contains(said), "{names}: {e}");
        if !names.contains("l1") {
            assert!(e.contains("the model's params are l1, l2, omega"), "{e}");
        }
        assert!(stdout(&o).is_empty(), "{names}: no rows");
    }
}

#[test]
fn refused_outside_kinematic_runs() {
    for (args, said) in [
        (
            &["models/slider_crank.kin", "--positions-only"][..],
            "--positions-only",
        ),
        (
            &["models/pendulum.kin", "--equilibrium"][..],
            "--equilibrium",
        ),
    ] {
        let mut all = vec!["run"];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--sensitivity", "l1", "--out", "-"]);
        let o = kinema(&all);
        assert_status(&o, 2);
        let e = stderr(&o);
        assert!(
            e.contains("--sensitivity cannot be used with") && e.contains(said),
            "{args:?}: {e}"
        );
    }
}

#[test]
fn refused_with_forward_dynamics() -> TestResult {
    let dir = TempDir::new("sens-forward");
    let model = dir.path("pend.kin");
    std::fs::write(
        &model,
        "mechanism P {
            param l = 1;
            body bar { guess: (l, 0, 0), mass: 2, inertia: 0.3 }
            gravity = (0, -9.81);
            constraint px: abs_x(bar(-l, 0), 0);
            constraint py: abs_y(bar(-l, 0), 0);
        }",
    )?;
    let o = kinema(&["run", &model, "--sensitivity", "l", "--out", "-"]);
    assert_status(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains("--sensitivity cannot be used with") && e.contains("forward dynamics"),
        "{e}"
    );
    Ok(())
}

/// A row at a kink (tests/kinks/fold.kin with its offset a param) is named
/// by the kink's warning and by one for its sensitivity columns; the run
/// succeeds, and the columns elsewhere are the closed form's
/// (x + |x|/2 = t − c: ∂x/∂c = −1/(1 + sign(x)/2)).
#[test]
fn rows_at_a_kink_are_flagged_for_the_sensitivities_too() -> TestResult {
    let dir = TempDir::new("sens-kink");
    let model = dir.path("fold.kin");
    std::fs::write(
        &model,
        "mechanism Fold {
            param c = 0.3;
            body bar { guess: (-1, 0, 0) }
            constraint level: bar.y == 0;
            constraint square: bar.phi == 0;
            driver slide: bar.x + abs(bar.x) / 2 == t - c;
        }",
    )?;
    let out = dir.path("fold.csv");
    let o = kinema(&[
        "run",
        &model,
        "--t-end",
        "0.8",
        "--steps",
        "8",
        "--sensitivity",
        "c",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let e = stderr(&o);
    assert!(
        e.contains("warning: 1 row at t = 0.3 (the warnings above): its `d(…)/d(…)` sensitivity columns are not determined"),
        "{e}"
    );
    let csv = Csv::read(&out)?;
    let (x, dx) = (csv.column("bar.x")?, csv.column("d(bar.x)/d(c)")?);
    for r in csv.rows.iter().filter(|r| (r[0] - 0.3).abs() > 1e-9) {
        let exact = -1.0 / (1.0 + r[x].signum() / 2.0);
        assert!((r[dx] - exact).abs() < 1e-12, "t = {}: {}", r[0], r[dx]);
    }
    Ok(())
}

/// A row exactly at a singular configuration (a parallelogram that starts
/// flat) has no ∂q/∂p: the run stops there with exit status 1 and says
/// why, where the same run without `--sensitivity` passes it.
#[test]
fn a_row_at_a_singular_configuration_stops_the_run_with_a_reason() {
    let dir = TempDir::new("sens-singular");
    let out = dir.path("p.csv");
    let o = kinema(&[
        "run",
        "tests/singular/parallelogram.kin",
        "--steps",
        "36",
        "--sensitivity",
        "l1",
        "--out",
        &out,
    ]);
    assert_status(&o, 1);
    let e = stderr(&o);
    assert!(
        e.contains("error: at t = 0: sensitivities:")
            && e.contains("at a singular configuration ∂q/∂p does not exist"),
        "{e}"
    );
}

/// With inertia (inverse dynamics' columns), the sensitivity columns come
/// after those, each param's ending with the dynamics columns' own, and
/// every other column is the run's without `--sensitivity`, bit for bit.
#[test]
fn with_inertia_the_columns_follow_the_dynamics_and_change_nothing() -> TestResult {
    let dir = TempDir::new("sens-dynamics");
    let (with, without) = (dir.path("with.csv"), dir.path("without.csv"));
    let model = "tests/dynamics/slider_crank.kin";
    let o = kinema(&["run", model, "--steps", "8", "--out", &without]);
    assert_status(&o, 0);
    let o = kinema(&[
        "run",
        model,
        "--steps",
        "8",
        "--sensitivity",
        "l2,l1",
        "--out",
        &with,
    ]);
    assert_status(&o, 0);
    let (a, b) = (Csv::read(&with)?, Csv::read(&without)?);
    let n = b.header.len();
    assert_eq!(a.header[..n], b.header[..], "the other columns first");
    assert!(b.header.iter().any(|h| h.starts_with("lambda.")));
    assert_eq!(a.header[n], "d(crank.x)/d(l2)");
    let sensitivities = a.header.len() - n;
    assert_eq!(sensitivities % 2, 0, "two params, as many columns each");
    assert_eq!(a.header[n + sensitivities / 2], "d(crank.x)/d(l1)");
    // Per param, d(…) of every column of the run but t, dynamics last.
    assert_eq!(sensitivities, 2 * (n - 1));
    assert_eq!(
        a.header[n + sensitivities / 2 - 1],
        "d(driver.crank_angle)/d(l2)"
    );
    assert_eq!(
        a.header.last().map(String::as_str),
        Some("d(driver.crank_angle)/d(l1)")
    );
    assert!(a.header.iter().any(|h| h == "d(reaction.pin.rod.T)/d(l1)"));
    for (ra, rb) in a.rows.iter().zip(&b.rows) {
        assert_eq!(ra[..n], rb[..], "t = {}", rb[0]);
    }
    Ok(())
}
