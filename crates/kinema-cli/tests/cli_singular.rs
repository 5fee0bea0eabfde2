//! `kinema run` and `kinema check` at singular configurations (issue 12)
//! and on badly scaled models (hostile-input items 1 and 2).

mod common;

use std::path::Path;

use common::{ROOT, TempDir, kinema};

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The times `t = …` of the lines starting with `prefix`.
fn times(stderr: &str, prefix: &str) -> Vec<f64> {
    stderr
        .lines()
        .filter(|l| l.starts_with(prefix))
        .filter_map(|l| {
            let rest = l.split("t = ").nth(1)?;
            let number: String = rest
                .chars()
                .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | '-'))
                .collect();
            number.parse().ok()
        })
        .collect()
}

#[test]
fn run_warns_of_each_bifurcation_with_its_time() {
    let dir = TempDir::new("change-point");
    let out = dir.path("cp.csv");
    for steps in ["14", "72", "720"] {
        let o = kinema(&[
            "run",
            "tests/singular/change_point.kin",
            "--t-end",
            "2",
            "--steps",
            steps,
            "--out",
            &out,
        ]);
        let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
        assert_eq!(o.status.code(), Some(0), "{stderr}");
        let found = times(&stderr, "warning: bifurcation at");
        assert_eq!(found.len(), 2, "{steps} steps: {stderr}");
        for (t, expected) in found.iter().zip([0.875, 1.875]) {
            assert!((t - expected).abs() < 1e-8, "{steps} steps: {stderr}");
        }
        assert!(stderr.contains("kept the branch on which q̇ is continuous"));
        assert!(
            stdout.contains("singular configurations: 2 (see the warnings)"),
            "{stdout}"
        );
    }
}

#[test]
fn stop_at_singular_stops_at_the_first_event_and_keeps_the_rows() {
    let dir = TempDir::new("stop");
    let out = dir.path("cp.csv");
    let o = kinema(&[
        "run",
        "tests/singular/change_point.kin",
        "--t-end",
        "2",
        "--steps",
        "72",
        "--out",
        &out,
        "--stop-at-singular",
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("error: stopped at a singular configuration: bifurcation at t = 0.87"),
        "{stderr}"
    );
    // Rows t = 0 … 31/36 (the last before t* = 0.875) are kept.
    let csv = std::fs::read_to_string(&out).unwrap_or_default();
    assert_eq!(csv.lines().count(), 1 + 32, "{stderr}");
}

#[test]
fn lock_up_exits_1_at_the_last_good_row_with_the_dead_point_time() {
    let t_star = (0.4_f64.acos() - std::f64::consts::FRAC_PI_4) / std::f64::consts::TAU;
    let dir = TempDir::new("dead-point");
    let out = dir.path("dp.csv");
    let o = kinema(&[
        "run",
        "tests/singular/dead_point.kin",
        "--steps",
        "360",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    let found = times(&stderr, "error: lock-up");
    assert_eq!(found.len(), 1, "{stderr}");
    assert!((found[0] - t_star).abs() < 1e-6, "{stderr}");
    assert!(stderr.contains("crank_angle"), "{stderr}");
    assert!(stderr.contains("coordinates left free"), "{stderr}");
    // Rows at k/360 ≤ t*: k = 0 … 21.
    let csv = std::fs::read_to_string(&out).unwrap_or_default();
    let rows = (t_star * 360.0).floor() as usize + 1;
    assert_eq!(csv.lines().count(), 1 + rows, "{stderr}");
}

#[test]
fn check_warns_instead_of_ok_at_a_singular_start() {
    let o = kinema(&["check", "tests/singular/parallelogram.kin"]);
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert!(!stdout.contains("ok:"), "{stdout}");
    assert!(
        stdout.contains("warning: `Parallelogram` assembles at or near a singular configuration")
    );
    assert!(
        stdout.contains("dependent equations: o.x, a.x, b.x, d.x"),
        "{stdout}"
    );
    assert!(stderr.contains("condition number"), "{stderr}");
    assert!(stderr.contains("t = 0"), "{stderr}");

    let dir = TempDir::new("flat-run");
    let out = dir.path("p.csv");
    let o = kinema(&[
        "run",
        "tests/singular/parallelogram.kin",
        "--steps",
        "36",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("warning: toggle at t = 0:"), "{stderr}");
    assert!(stderr.contains("lie within the threshold of a singular configuration"));
}

/// The pendulum of models/pendulum.kin with L replaced.
fn pendulum(dir: &TempDir, length: &str) -> String {
    let source =
        std::fs::read_to_string(Path::new(ROOT).join("models/pendulum.kin")).unwrap_or_default();
    let path = dir.path(&format!("pendulum_{length}.kin"));
    let changed = source.replace("param L = 1;", &format!("param L = {length};"));
    assert_ne!(changed, source, "the model sets L");
    if let Err(e) = std::fs::write(&path, changed) {
        panic!("{e}");
    }
    path
}

#[test]
fn rank_decisions_do_not_depend_on_units_and_never_panic() {
    let dir = TempDir::new("scaled");
    for length in ["1e5", "1e10", "1e160"] {
        let model = pendulum(&dir, length);
        let o = kinema(&["check", &model]);
        let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
        assert_eq!(o.status.code(), Some(0), "L = {length}: {stdout}{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!stdout.contains("rank-deficient"), "L = {length}: {stdout}");
        assert!(
            stdout.contains("at the assembled configuration: 3 of 3 (full"),
            "L = {length}: {stdout}"
        );
        assert!(stdout.contains("ready to run"), "L = {length}: {stdout}");
        let out = dir.path("p.csv");
        let o = kinema(&["run", &model, "--out", &out]);
        let stderr = text(&o.stderr);
        assert!(!stderr.contains("panicked"), "{stderr}");
        if length != "1e160" {
            assert_eq!(o.status.code(), Some(0), "L = {length}: {stderr}");
            assert!(!stderr.contains("warning"), "L = {length}: {stderr}");
        }
    }
}

#[test]
fn assembly_far_from_the_guess_is_a_warning() {
    // The crank's angle guessed a turn away from the driver's π/4.
    let source =
        std::fs::read_to_string(Path::new(ROOT).join("models/four_bar.kin")).unwrap_or_default();
    let changed = source.replace(
        "body crank   { guess: (0.1, 0.1, 0.8) }",
        "body crank   { guess: (0.1, 0.1, 7.08) }",
    );
    assert_ne!(changed, source, "the model has that guess");
    let dir = TempDir::new("far-guess");
    let model = dir.path("four_bar.kin");
    if let Err(e) = std::fs::write(&model, changed) {
        panic!("{e}");
    }
    let o = kinema(&["check", &model]);
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("warning: assembly at t = 0 moved `crank.phi` from its guess 7.08"),
        "{stderr}"
    );
    assert!(stderr.contains("mirror image"), "{stderr}");
}

/// A run that passes many singular configurations (the parallelogram's
/// bifurcations, two per turn over 20 turns) gets the first 20 warnings and
/// a count of the rest: stderr stays bounded.
#[test]
fn many_singular_configurations_are_counted_not_listed() {
    let dir = TempDir::new("many");
    let out = dir.path("out.csv");
    let o = kinema(&[
        "run",
        "tests/singular/parallelogram.kin",
        "--t-end",
        "20",
        "--steps",
        "4000",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    let listed = stderr
        .lines()
        .filter(|l| l.starts_with("warning: toggle") || l.starts_with("warning: bifurcation"))
        .count();
    assert_eq!(listed, 20, "{stderr}");
    let more = stderr
        .lines()
        .find(|l| l.starts_with("warning: … and "))
        .unwrap_or_else(|| panic!("no count of the rest: {stderr}"));
    let n: usize = more
        .trim_start_matches("warning: … and ")
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{more}"));
    assert!(n >= 20, "{more}");
    assert!(stderr.len() < 20_000, "{} bytes on stderr", stderr.len());
}

/// The fuzzer's lingering model (a rack-and-pinion whose direction is
/// subnormal; it once printed one warning per solve, 123 KB) is singular
/// from its start: the tape's fixed-order LU reports a small pivot ratio at
/// t = 0, which the SVD confirms, so the run stops there with the diagnosis
/// (its contact row, `c6.1` since the element is the library's `rack_pinion`)
/// instead of lingering.
#[test]
fn the_lingering_model_is_diagnosed_at_its_start() {
    let dir = TempDir::new("lingering");
    let out = dir.path("out.csv");
    let o = kinema(&["run", "tests/singular/lingering.adm", "--out", &out]);
    let stderr = text(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    assert!(
        stderr.contains("at t = 0: equations c6.1, c5 are dependent"),
        "{stderr}"
    );
    assert!(stderr.len() < 20_000, "{} bytes on stderr", stderr.len());
}

/// A coordinate that crosses the kink of `abs` (tests/kinks/fold.kin): the
/// row whose q is on it, within roundoff, is named in one warning with its
/// equation and function (fuzz finding F16); the run succeeds (q is a
/// solution) and the other rows are not flagged.
#[test]
fn run_warns_of_the_rows_at_a_kink_with_their_equation() {
    let dir = TempDir::new("kink");
    let out = dir.path("fold.csv");
    let o = kinema(&[
        "run",
        "tests/kinks/fold.kin",
        "--t-end",
        "0.8",
        "--steps",
        "8",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].starts_with("warning: 1 row at t = 0.3: equation `slide` has abs where"),
        "{stderr}"
    );
    assert!(
        warnings[0].contains("q̇ and q̈ are not determined"),
        "{stderr}"
    );
    // With positions only, no rate is written: nothing to flag.
    let o = kinema(&[
        "run",
        "tests/kinks/gap.kin",
        "--t-end",
        "0.8",
        "--steps",
        "8",
        "--positions-only",
        "--out",
        &out,
    ]);
    assert!(o.status.success());
    assert!(!text(&o.stderr).contains("warning"), "{}", text(&o.stderr));
    // A result column at its kink: its rates are named.
    let o = kinema(&[
        "run",
        "tests/kinks/gap.kin",
        "--t-end",
        "0.8",
        "--steps",
        "8",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(
            "warning: 1 row at t = 0.3: result `gap` has a square root or norm where it is not \
             differentiable (its argument is 0 within roundoff): its `gap_dot` and `gap_ddot` are \
             not determined"
        ),
        "{stderr}"
    );
    // The solution away from the kink is silent.
    let o = kinema(&["run", "tests/kinks/ring.kin", "--out", &out]);
    assert!(o.status.success());
    assert!(!text(&o.stderr).contains("warning"), "{}", text(&o.stderr));
}

/// A drive whose argument is beyond f64's precision: every row is named
/// in one warning with its equation, the run goes on (q solves the
/// equations as evaluated); a step that then fails says why more steps
/// will not help; `check` warns instead of "ok"; forward dynamics warns
/// alike; a sweep names the rows per variant.
#[test]
fn run_warns_of_equations_lost_to_rounding() {
    let dir = TempDir::new("precision");
    let out = dir.path("rounded.csv");
    let o = kinema(&[
        "run",
        "tests/precision/rounded_drive.kin",
        "--steps",
        "4",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].starts_with(
            "warning: 5 rows at t = 0 … 1: equation `swing` is not determined by its own \
             arithmetic: its rounding error, up to 1.0e0, moves the coordinates by up to 1.0e0"
        ),
        "{stderr}"
    );
    assert!(
        warnings[0].ends_with("their q, q̇ and q̈ are the rounding errors' as much as the model's"),
        "{stderr}"
    );

    let o = kinema(&[
        "run",
        "tests/precision/fast_drive.kin",
        "--steps",
        "10",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("warning: 1 row at t = 0.1: equation `swing` is not determined"),
        "{stderr}"
    );
    assert!(
        stderr.contains(
            "= note: at t = 0.1, where the step started, equation `swing` was not determined by \
             its own arithmetic (the warning above): no step size follows rounding errors"
        ),
        "{stderr}"
    );

    // `check` warns instead of "ok".
    let o = kinema(&["check", "tests/precision/rounded_drive.kin"]);
    assert_eq!(o.status.code(), Some(0));
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert!(
        stdout.trim_end().ends_with(
            "warning: `RoundedDrive` assembles with equation `swing` not determined by its own \
             arithmetic; `kinema run` will flag the rows there"
        ),
        "{stdout}"
    );
    assert!(
        stderr.starts_with(
            "warning: at the assembled configuration (t = 0), equation `swing` is not determined"
        ),
        "{stderr}"
    );

    // Forward dynamics: the same check, the same warning.
    let o = kinema(&[
        "run",
        "tests/precision/forward_drive.kin",
        "--steps",
        "4",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(
            "warning: 5 rows at t = 0 … 1: equation `swing` is not determined by its own \
             arithmetic"
        ),
        "{stderr}"
    );

    let params = dir.path("params.csv");
    std::fs::write(&params, "L\n1\n2\n").expect("a parameter table");
    let o = kinema(&[
        "sweep",
        "tests/precision/rounded_drive.kin",
        "--params",
        &params,
        "--steps",
        "4",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(
            "warning: variant 2 (L = 2): 5 rows at t = 0 … 1 with an equation that its own \
             arithmetic does not determine"
        ),
        "{stderr}"
    );
}

/// A run whose step fails after a state at a kink (the F16 model, solved
/// only at the origin, where `norm` has its kink): the error's note names
/// the kink as the likely cause, whatever the failure's own message.
#[test]
fn a_failure_after_a_kink_names_it() {
    let dir = TempDir::new("kink-failure");
    let out = dir.path("at_origin.csv");
    let o = kinema(&[
        "run",
        "tests/kinks/at_origin.kin",
        "--steps",
        "10",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(
            "= note: the last state solved (t = 0) lies where a square root or norm in \
             equation `tip.x` is not differentiable"
        ),
        "{stderr}"
    );
    // A failure with no kink before it (a lock-up) has no such note.
    let o = kinema(&[
        "run",
        "tests/singular/dead_point.kin",
        "--steps",
        "360",
        "--out",
        &out,
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("error: lock-up"), "{stderr}");
    assert!(!stderr.contains("not differentiable"), "{stderr}");
}

/// `kinema check` on a model that assembles on a kink (the F16 model):
/// a warning naming the equation and the function, never "ok".
#[test]
fn check_warns_of_an_assembly_at_a_kink() {
    let o = kinema(&["check", "tests/kinks/at_origin.kin"]);
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert!(
        stdout.contains(
            "warning: `AtOrigin` assembles with equation `tip.x` at a kink of its `sqrt`"
        ),
        "{stdout}"
    );
    assert!(!stdout.contains("ok:"), "{stdout}");
    assert!(
        stderr.contains("q̇ and q̈ there are not determined"),
        "{stderr}"
    );
    let o = kinema(&["check", "tests/kinks/ring.kin"]);
    assert!(text(&o.stdout).contains("ok: `Ring` assembles and is ready to run"));
}
