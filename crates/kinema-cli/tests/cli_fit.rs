//! `kinema fit` (issue 40): a fit of the function-generation example writes
//! a fitted model that, run again, meets the targets with the error the
//! summary reports; bad input is refused with exit status 2 and a message
//! that names the cause; a fit whose starts all fail says so with the
//! counts (exit status 1).

#![allow(clippy::unwrap_used)] // tests: a failure should stop the test

mod common;
use common::*;

const MODEL: &str = "models/function_generation.kin";
const TARGET: &str = "models/function_generation.csv";

fn fit(extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "fit",
        MODEL,
        "--target",
        TARGET,
        "--vary",
        "l1,l2,l3,theta_s,psi_s",
        "--bounds",
        "l1=0.05:5,l2=0.05:5,l3=0.05:5",
        "--starts",
        "6",
        "--steps",
        "90",
    ];
    args.extend_from_slice(extra);
    kinema(&args)
}

#[test]
fn a_fit_writes_a_model_that_meets_the_targets_as_reported() {
    let dir = TempDir::new("fit-fg");
    let (fitted, summary, plot) = (
        dir.path("fitted.kin"),
        dir.path("s.csv"),
        dir.path("fit.svg"),
    );
    let o = fit(&["--out", &fitted, "--summary", &summary, "--plot", &plot]);
    assert_status(&o, 0);
    let text = stdout(&o);
    assert!(text.contains("defect-free design"), "{text}");
    assert!(text.contains("rejected:"), "{text}");
    let table = Csv::read(&summary).unwrap();
    let rms = table.rows[0][table.column("rms").unwrap()];
    assert!(rms < 2e-3, "rms {rms}");
    // The fitted model keeps the example's comments, with the new values.
    let model = std::fs::read_to_string(&fitted).unwrap();
    assert!(model.contains("/// crank length (the ground link is 1)"));
    let l1 = table.rows[0][table.column("l1").unwrap()];
    assert!(model.contains(&format!("param l1 = {l1:?};")), "{model}");
    // Run again at the targets' times: the error is the one reported.
    // The task itself: ψ = (π/2) log10(x) at x = 1, 1.9, …, 10.
    let targets: Vec<f64> = (0..11)
        .map(|i| std::f64::consts::FRAC_PI_2 * (1.0 + 0.9 * f64::from(i)).log10())
        .collect();
    let out = dir.path("run.csv");
    // (ψ is steep near x = 1: steps of a tenth of the targets' spacing.)
    let o = kinema(&[
        "run",
        &fitted,
        "--t-end",
        "1.5707963267948966",
        "--steps",
        "100",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let run = Csv::read(&out).unwrap();
    let psi = run.column("psi").unwrap();
    let n = targets.len();
    let sum: f64 = (0..n)
        .map(|i| (run.rows[10 * i][psi] - targets[i]).powi(2))
        .sum();
    let again = (sum / n as f64).sqrt();
    assert!(
        (again - rms).abs() < 1e-6 * rms.max(1e-3),
        "run {again}, summary {rms}"
    );
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("psi against t"),
        "{}",
        &svg[..200.min(svg.len())]
    );
}

/// Writes `text` to `name` in `dir`, returns its path.
fn file(dir: &TempDir, name: &str, text: &str) -> String {
    let path = dir.path(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn bad_input_is_refused_with_its_cause() {
    let dir = TempDir::new("fit-bad");
    let refused = |args: &[&str], says: &str| {
        let mut all = vec!["fit", MODEL];
        all.extend_from_slice(args);
        let o = kinema(&all);
        assert_status(&o, 2);
        let err = stderr(&o);
        assert!(err.contains(says), "{args:?}: expected `{says}` in:\n{err}");
        assert!(!err.contains("panicked"), "{err}");
    };
    let t = ["--target", TARGET];
    refused(&[&t[..], &["--vary", "l9"]].concat(), "`l9`");
    refused(&[&t[..], &["--vary", "crank"]].concat(), "a body");
    refused(
        &[&t[..], &["--vary", "l1", "--bounds", "l1=2:3"]].concat(),
        "outside its bounds",
    );
    refused(
        &[&t[..], &["--vary", "l1", "--bounds", "l2=0:3"]].concat(),
        "not varied",
    );
    refused(
        &[&t[..], &["--vary", "l1", "--bounds", "l1=3:2"]].concat(),
        "empty",
    );
    refused(
        &[&t[..], &["--vary", "l1", "--objective", "mean(psi)"]].concat(),
        "not an objective",
    );
    refused(
        &[&t[..], &["--vary", "l1", "--objective", "rms(nope)"]].concat(),
        "`nope` is not a result column",
    );
    refused(
        &[&t[..], &["--vary", "l1", "--full-turn", "wheel"]].concat(),
        "no body `wheel`",
    );
    let not_result = file(&dir, "a.csv", "t,rocker.speed\n0,1\n0.1,2\n");
    refused(
        &["--target", &not_result, "--vary", "l1"],
        "a.csv:1:3: `rocker.speed` is not a result column",
    );
    let rate = file(&dir, "r.csv", "t,psi_dot\n0,1\n0.1,2\n");
    refused(&["--target", &rate, "--vary", "l1"], "a rate of `psi`");
    let empty = file(&dir, "e.csv", "# nothing\n");
    refused(&["--target", &empty, "--vary", "l1"], "empty");
    let text = file(&dir, "n.csv", "t,psi\n0,0\n0.1,abc\n");
    refused(
        &["--target", &text, "--vary", "l1"],
        "n.csv:3:5: `abc` is not a number",
    );
    let nan = file(&dir, "nan.csv", "t,psi\n0,0\n0.1,NaN\n");
    refused(
        &["--target", &nan, "--vary", "l1"],
        "`NaN` is not a finite number",
    );
    let untimed = file(&dir, "u.csv", "psi\n0\n0.5\n");
    refused(&["--target", &untimed, "--vary", "l1"], "--t-end");
    // Times whose grid cannot be run: steps below the resolution of t
    // (a cycle of 1e-323: the grid stepped by 0 and filled memory), and
    // prescribed times spanning a million cycles of the grid.
    let subnormal = file(&dir, "s.csv", "t,psi\n0,0\n5e-324,0.1\n1e-323,0.2\n");
    refused(
        &["--target", &subnormal, "--vary", "l1"],
        "give a longer cycle or fewer steps",
    );
    let far = file(&dir, "f.csv", "t,psi\n0,0\n0.5,0.1\n1e6,0.2\n");
    refused(
        &["--target", &far, "--vary", "l1", "--t-end", "1"],
        "(at most 2000000)",
    );
    refused(&["--target", "no/such.csv", "--vary", "l1"], "no/such.csv");
}

#[test]
fn a_fit_whose_starts_all_fail_says_why_with_the_counts() {
    // A crank five times the ground link's length with a short coupler and
    // rocker: no design within the bounds assembles.
    let dir = TempDir::new("fit-none");
    let text = std::fs::read_to_string(format!("{ROOT}/{MODEL}"))
        .unwrap()
        .replace("param l1 = 1.6;", "param l1 = 5.5;");
    let model = file(&dir, "m.kin", &text);
    let o = kinema(&[
        "fit", &model, "--target", TARGET, "--vary", "l1", "--bounds", "l1=5:6", "--starts", "4",
    ]);
    assert_status(&o, 1);
    let err = stderr(&o);
    assert!(
        err.contains("no defect-free design from 4 starts: 4 do not assemble"),
        "{err}"
    );
}
