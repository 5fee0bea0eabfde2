//! The `kinema` binary under hostile input (the command line and the
//! simEngine2D importer): plots of huge or degenerate ranges finish, outputs
//! never overwrite an input or each other and never replace a good file
//! with a bad one, directions of any magnitude import as unit vectors,
//! degenerate grids and negative arguments are refused with the option and
//! its range, exit statuses follow the README, a closed pipe ends quietly,
//! and endless files are refused.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::*;

/// Waits for `child` at most `limit`; kills it and fails the test on a hang.
fn wait_at_most(child: &mut Child, limit: Duration, what: &str) -> ExitStatus {
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return status,
            Ok(None) if start.elapsed() < limit => std::thread::sleep(Duration::from_millis(20)),
            Ok(None) => {
                let _ = child.kill();
                let _ = child.wait();
                panic!("{what}: still running after {limit:?} (a hang)");
            }
            Err(e) => panic!("{what}: cannot wait: {e}"),
        }
    }
}

/// Runs the binary in `dir` with a time limit; returns the status and
/// standard error (standard output is discarded: the summary).
fn run_limited(dir: &Path, args: &[&str], limit: Duration) -> (ExitStatus, String) {
    let mut child = match Command::new(env!("CARGO_BIN_EXE_kinema"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
    {
        Ok(c) => c,
        Err(e) => panic!("cannot run kinema: {e}"),
    };
    // Standard error is read on a thread so that a long message cannot
    // block the child.
    let mut err = child.stderr.take().map(|mut s| {
        std::thread::spawn(move || {
            let mut text = String::new();
            let _ = s.read_to_string(&mut text);
            text
        })
    });
    let status = wait_at_most(&mut child, limit, &format!("{args:?}"));
    let text = err.take().and_then(|h| h.join().ok()).unwrap_or_default();
    (status, text)
}

fn write(path: &str, text: &str) {
    if let Err(e) = std::fs::write(path, text) {
        panic!("cannot write {path}: {e}");
    }
}

fn read(path: &str) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {path}: {e}"))
}

fn adm_data(name: &str) -> String {
    read(&format!("{ROOT}/crates/kinema-adm/tests/data/{name}"))
}

/// A model whose driver reaches 1.7e308 (the plot's axes then overflow).
const HUGE: &str = "mechanism Huge {
    body b { guess: (0, 0, 0) }
    constraint level: abs_y(b(0, 0), 0);
    constraint upright: b.phi == 0;
    driver push: b.x == SPEED * t;
}
";

// ---------------------------------------------------------------- item 3

#[test]
fn plots_of_huge_or_degenerate_ranges_finish() {
    let dir = TempDir::new("huge-plot");
    let limit = Duration::from_secs(60);
    // Panels that cannot be drawn are skipped with a warning naming them.
    for (speed, skipped) in [
        ("1.7e308", true),
        ("-1.7e308", true),
        ("1e299", false),
        ("1e-300", false),
    ] {
        let model = dir.path("huge.kin");
        write(&model, &HUGE.replace("SPEED", speed));
        let svg = dir.path("huge.svg");
        let (status, err) = run_limited(
            &dir.0,
            &["run", "huge.kin", "--out", "huge.csv", "--plot", "huge.svg"],
            limit,
        );
        assert_eq!(status.code(), Some(0), "speed {speed}: {err}");
        assert!(read(&svg).starts_with("<svg"), "speed {speed}");
        assert_eq!(
            err.contains("the mechanism view is not drawn"),
            skipped,
            "speed {speed}: {err}"
        );
        if skipped {
            assert!(err.contains("1.7e308"), "{err}");
        }
    }
    // simEngine2D drawing limits: huge, zero-width, reversed, far from the
    // motion; body drawing points and shapes of huge size.
    let slider = adm_data("slider_crank.adm");
    let rack = adm_data("rack_pinion.adm");
    let cases = [
        (
            "xlim huge",
            slider.replace("\"xlim\": [-0.5, 1.5]", "\"xlim\": [-1.7e308, 1.7e308]"),
            true,
        ),
        (
            "ylim zero width",
            slider.replace("\"ylim\": [-0.5, 0.5]", "\"ylim\": [0.5, 0.5]"),
            false,
        ),
        (
            "xlim reversed",
            slider.replace("\"xlim\": [-0.5, 1.5]", "\"xlim\": [1.5, -0.5]"),
            false,
        ),
        (
            "xlim far away",
            slider.replace("\"xlim\": [-0.5, 1.5]", "\"xlim\": [1e12, 1.000001e12]"),
            false,
        ),
        (
            "points and shapes huge",
            rack.replace("[ [0, 0], [0.5, 0] ]", "[ [0, 0], [1.7e308, -1.7e308] ]")
                .replace("\"size\": [3, 0.02]", "\"size\": [1.7e308, 1e308]"),
            true,
        ),
    ];
    for (what, text, skipped) in cases {
        assert_ne!(text, slider, "{what}: the fixture changed");
        assert_ne!(text, rack, "{what}: the fixture changed");
        write(&dir.path("vis.adm"), &text);
        let (status, err) = run_limited(
            &dir.0,
            &[
                "run", "vis.adm", "--steps", "20", "--out", "vis.csv", "--plot", "vis.svg",
            ],
            limit,
        );
        assert_eq!(status.code(), Some(0), "{what}: {err}");
        assert!(read(&dir.path("vis.svg")).starts_with("<svg"), "{what}");
        assert_eq!(
            err.contains("the mechanism view is not drawn"),
            skipped,
            "{what}: {err}"
        );
    }
}

// ---------------------------------------------------------------- item 6

#[test]
fn outputs_that_are_an_input_or_each_other_are_refused() -> TestResult {
    let dir = TempDir::new("same-file");
    let model = dir.path("m.kin");
    let text = read(&format!("{ROOT}/models/pendulum.kin"));
    write(&model, &text);
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("m.kin", dir.path("link.kin"))?;
        std::fs::hard_link(&model, dir.path("hard.kin"))?;
    }
    let sub = dir.0.join("sub");
    std::fs::create_dir_all(&sub)?;
    // (working directory, arguments, message)
    let mut cases: Vec<(&Path, Vec<&str>, &str)> = vec![
        (
            &dir.0,
            vec!["m.kin", "--out", "same.x", "--plot", "./same.x"],
            "--plot `./same.x` and --out `same.x` are the same file",
        ),
        (
            &dir.0,
            vec!["m.kin", "--out", "m.kin"],
            "--out `m.kin` is the model",
        ),
        (
            &dir.0,
            vec!["m.kin", "--out", "./m.kin"],
            "--out `./m.kin` is the model",
        ),
        (
            &sub,
            vec!["../m.kin", "--out", "-", "--plot", "../sub/../m.kin"],
            "--plot `../sub/../m.kin` is the model",
        ),
    ];
    if cfg!(unix) {
        cases.push((
            &dir.0,
            vec!["m.kin", "--out", "link.kin"],
            "--out `link.kin` is the model",
        ));
        cases.push((
            &dir.0,
            vec!["m.kin", "--out", "r.csv", "--plot", "hard.kin"],
            "--plot `hard.kin` is the model",
        ));
    }
    for (cwd, rest, message) in cases {
        let mut args = vec!["run"];
        args.extend(&rest);
        let o = kinema_in(cwd, &args);
        assert_status(&o, 2);
        assert!(
            stderr(&o).contains(message),
            "{args:?}: {message:?} in\n{}",
            stderr(&o)
        );
        assert_eq!(read(&model), text, "{args:?} changed the model");
        assert!(!Path::new(&dir.path("same.x")).exists(), "{args:?}");
        assert!(!Path::new(&dir.path("r.csv")).exists(), "{args:?}");
    }
    // The analysis file of a simEngine2D model is an input too.
    write(
        &dir.path("a.acf"),
        &read(&format!("{HERE}/tests/cli/adm/one_second.acf")),
    );
    write(&dir.path("t.adm"), &adm_data("translational.adm"));
    let o = kinema_in(
        &dir.0,
        &["run", "t.adm", "--acf", "a.acf", "--plot", "a.acf"],
    );
    assert_status(&o, 2);
    assert!(
        stderr(&o).contains("--plot `a.acf` is the analysis file"),
        "{}",
        stderr(&o)
    );
    // /dev/null may take both outputs (it is not a file that could be lost).
    if cfg!(unix) {
        let o = kinema_in(
            &dir.0,
            &["run", "m.kin", "--out", "/dev/null", "--plot", "/dev/null"],
        );
        assert_status(&o, 0);
    }
    Ok(())
}

/// The entries of a directory, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn a_failed_run_never_replaces_a_good_output_with_a_bad_one() -> TestResult {
    let dir = TempDir::new("keep");
    let (csv, svg) = (dir.path("good.csv"), dir.path("good.svg"));
    write(&csv, "earlier results\n");
    write(&svg, "<svg>earlier figure</svg>\n");
    let model = format!("{ROOT}/models/pendulum.kin");
    // Refused after the CSV was opened: the CSV is left as it was, not
    // truncated.
    let o = kinema_in(
        &dir.0,
        &["run", &model, "--out", "good.csv", "--plot", &model],
    );
    assert_status(&o, 2);
    assert_eq!(read(&csv), "earlier results\n");
    // A lock-up: the rows before it are the CSV (as promised), the figure
    // is not drawn and the earlier one stays.
    let lockup = format!("{HERE}/tests/cli/models/lockup.kin");
    let o = kinema_in(
        &dir.0,
        &["run", &lockup, "--out", "good.csv", "--plot", "good.svg"],
    );
    assert_status(&o, 1);
    let kept = Csv::read(&csv)?;
    assert!(!kept.rows.is_empty());
    assert!(
        stderr(&o).contains(&format!(
            "the {} rows computed before the failure are in `good.csv`",
            kept.rows.len()
        )),
        "{}",
        stderr(&o)
    );
    assert_eq!(read(&svg), "<svg>earlier figure</svg>\n");
    // A success replaces both; no temporary file is left behind.
    let o = kinema_in(
        &dir.0,
        &["run", &model, "--out", "good.csv", "--plot", "good.svg"],
    );
    assert_status(&o, 0);
    assert_eq!(Csv::read(&csv)?.rows.len(), 101);
    assert!(read(&svg).starts_with("<svg"));
    assert_eq!(entries(&dir.0), ["good.csv", "good.svg"]);
    Ok(())
}

// ---------------------------------------------------------------- item 8

#[test]
fn directions_of_any_magnitude_import_as_unit_vectors() -> TestResult {
    let dir = TempDir::new("directions");
    let base = adm_data("translational.adm");
    let rail = "\"vP1\": [2, 0]";
    let block = "\"vP2\": [3, 4]";
    assert!(
        base.contains(rail) && base.contains(block),
        "fixture changed"
    );
    // (same direction written at an ordinary size, at an extreme one)
    let cases = [
        (rail, "\"vP1\": [1, 1]", "\"vP1\": [1e-200, 1e-200]"),
        (rail, "\"vP1\": [1, 1]", "\"vP1\": [1e200, 1e200]"),
        (rail, "\"vP1\": [1, 1]", "\"vP1\": [1.7e308, 1.7e308]"),
        (rail, "\"vP1\": [2, 0]", "\"vP1\": [5e-324, 0]"),
        (block, "\"vP2\": [3, 4]", "\"vP2\": [3e-320, 4e-320]"),
    ];
    for (field, ordinary, extreme) in cases {
        let mut outputs = Vec::new();
        for (k, written) in [ordinary, extreme].into_iter().enumerate() {
            let adm = dir.path(&format!("t{k}.adm"));
            write(&adm, &base.replace(field, written));
            let o = kinema(&["import", &adm]);
            assert_status(&o, 0);
            let kin = stdout(&o);
            let joint = kin
                .lines()
                .find(|l| l.contains("translational("))
                .ok_or("no translational joint")?
                .to_string();
            assert!(
                !joint.contains("inf") && !joint.contains("NaN"),
                "{written}: {joint}"
            );
            let csv = dir.path(&format!("t{k}.csv"));
            let o = kinema(&["run", &adm, "--steps", "10", "--out", &csv]);
            assert_status(&o, 0);
            outputs.push((joint, read(&csv)));
        }
        assert_eq!(
            outputs[0].0, outputs[1].0,
            "{extreme}: the same joint as {ordinary}"
        );
        assert_eq!(
            outputs[0].1, outputs[1].1,
            "{extreme}: the same motion as {ordinary}"
        );
    }
    // A rack whose pitch line is longer than the largest number is refused
    // at its field.
    let rack = adm_data("rack_pinion.adm").replace(
        "\"sP1\": [0, 0], \"sQ1\": [0.5, 0]",
        "\"sP1\": [-1.7e308, 0], \"sQ1\": [1.7e308, 0]",
    );
    let adm = dir.path("rack.adm");
    write(&adm, &rack);
    for command in ["import", "run"] {
        let o = kinema(&[command, &adm]);
        assert_status(&o, 2);
        let err = stderr(&o);
        assert!(err.contains("field \"sQ1\": the pitch line"), "{err}");
        assert!(err.contains("rack.adm:14:"), "{err}");
    }
    Ok(())
}

// ---------------------------------------------------------------- item 9

#[test]
fn grid_arguments_are_refused_with_their_range() {
    let pendulum = "models/pendulum.kin";
    let adm = format!("{ROOT}/crates/kinema-adm/tests/data/translational.adm");
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["run", pendulum, "--steps", "-5"],
            &[
                "--steps must be at least 1",
                "from 1 to 9999999",
                "found -5",
            ],
        ),
        (
            &["run", pendulum, "--t-end", "-1"],
            &[
                "--t-end must be a positive finite time",
                "T > 0",
                "found -1",
            ],
        ),
        (
            &["run", pendulum, "--t-end", "-inf"],
            &["--t-end must be a positive finite time"],
        ),
        (
            &["run", pendulum, "--t-end", "5e-324", "--steps", "10"],
            &["--t-end 5e-324 with --steps 10", "do not increase"],
        ),
        (
            &["run", &adm, "--t-end", "5e-324", "--steps", "10"],
            &["--t-end 5e-324 with --steps 10", "do not increase"],
        ),
        (
            &["run", &adm, "--steps", "-3"],
            &["--steps must be at least 1"],
        ),
    ];
    let dir = TempDir::new("grid");
    let out = dir.path("r.csv");
    for (args, messages) in cases {
        let mut args = args.to_vec();
        args.extend(["--out", &out]);
        let o = kinema(&args);
        assert_status(&o, 2);
        for m in *messages {
            assert!(stderr(&o).contains(m), "{args:?}: {m:?} in\n{}", stderr(&o));
        }
        assert!(!Path::new(&out).exists(), "{args:?} wrote rows");
    }
    // The smallest step that still increases is run, every row written.
    let o = kinema(&[
        "run", pendulum, "--t-end", "1e-300", "--steps", "10", "--out", &out,
    ]);
    assert_status(&o, 0);
    let csv = Csv::read(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(csv.rows.len(), 11);
    assert!(csv.rows.windows(2).all(|w| w[1][0] > w[0][0]));
}

#[test]
fn acf_times_that_do_not_increase_are_refused_at_their_field() {
    let dir = TempDir::new("acf-grid");
    let adm = format!("{ROOT}/crates/kinema-adm/tests/data/translational.adm");
    let cases = [
        (
            "{ \"simulation\": \"Kinematics\", \"tend\": 5e-324, \"stepSize\": 0.01, \"outputSteps\": 10 }",
            "bad.acf:1:80",
            "field \"outputSteps\": the output times do not increase",
        ),
        (
            "simulation: kinematics\ntend: 5\nstepSize: 1e-20\noutputSteps: 10\n",
            "bad.acf:3:11",
            "field \"stepSize\": the solve times do not increase",
        ),
    ];
    for (text, at, message) in cases {
        let acf = dir.path("bad.acf");
        write(&acf, text);
        let o = kinema_in(&dir.0, &["run", &adm, "--acf", "bad.acf", "--out", "r.csv"]);
        assert_status(&o, 2);
        let err = stderr(&o);
        assert!(err.contains(message), "{err}");
        assert!(err.contains(at), "{at} in {err}");
    }
}

// ---------------------------------------------------------------- item 10

#[test]
fn outputs_that_cannot_be_created_are_usage_errors_and_failed_writes_analysis_errors() {
    let dir = TempDir::new("exit");
    let model = "models/pendulum.kin";
    let missing = dir.path("no/such/dir/r.csv");
    let directory = dir.0.display().to_string();
    // Detected before the analysis: exit 2.
    for args in [
        vec!["run", model, "--out", missing.as_str()],
        vec!["run", model, "--out", "-", "--plot", missing.as_str()],
        vec!["run", model, "--out", directory.as_str()],
        vec!["run", model, "--out", "no_such_dir/"],
        vec!["run", model, "--out", "-", "--plot", "models/.."],
    ] {
        let o = kinema(&args);
        assert_status(&o, 2);
        assert!(
            stderr(&o).contains("cannot create"),
            "{args:?}: {}",
            stderr(&o)
        );
    }
    // A read-only file (root may write it anyway: then there is nothing to
    // refuse).
    let ro = dir.path("read_only.csv");
    write(&ro, "keep\n");
    let mut perms = std::fs::metadata(&ro)
        .map(|m| m.permissions())
        .unwrap_or_else(|e| panic!("{e}"));
    perms.set_readonly(true);
    let _ = std::fs::set_permissions(&ro, perms);
    let writable = std::fs::OpenOptions::new().append(true).open(&ro).is_ok();
    let o = kinema(&["run", model, "--out", &ro]);
    if writable {
        eprintln!("note: running with the right to write read-only files; that case is skipped");
        assert_status(&o, 0);
    } else {
        assert_status(&o, 2);
        assert!(stderr(&o).contains("cannot create"), "{}", stderr(&o));
        assert_eq!(read(&ro), "keep\n");
    }
    // Failing once the analysis runs (a full disk): exit 1.
    if Path::new("/dev/full").exists() {
        let o = kinema(&["run", model, "--steps", "5000", "--out", "/dev/full"]);
        assert_status(&o, 1);
        assert!(
            stderr(&o).contains("cannot write `/dev/full`"),
            "{}",
            stderr(&o)
        );
    }
}

#[test]
fn a_closed_standard_output_ends_the_run_quietly() {
    let mut child = match Command::new(env!("CARGO_BIN_EXE_kinema"))
        .args([
            "run",
            "models/pendulum.kin",
            "--steps",
            "200000",
            "--out",
            "-",
        ])
        .current_dir(ROOT)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
    {
        Ok(c) => c,
        Err(e) => panic!("cannot run kinema: {e}"),
    };
    // `| head -1`: read the header, then close the pipe.
    let mut header = String::new();
    if let Some(out) = child.stdout.take() {
        let _ = BufReader::new(out).read_line(&mut header);
    }
    assert!(header.starts_with("t,bar.x"), "{header}");
    let status = wait_at_most(&mut child, Duration::from_secs(120), "--out - | head -1");
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut err);
    }
    assert_eq!(status.code(), Some(0), "{err}");
    assert_eq!(err, "", "a closed pipe is not an error");
}

#[test]
fn endless_model_files_are_refused_with_the_limit() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let dir = TempDir::new("endless");
    #[cfg(unix)]
    {
        let _ = std::os::unix::fs::symlink("/dev/zero", dir.path("zero.adm"));
        let _ = std::os::unix::fs::symlink("/dev/zero", dir.path("zero.acf"));
    }
    let adm = format!("{ROOT}/crates/kinema-adm/tests/data/translational.adm");
    let zero_adm = dir.path("zero.adm");
    let zero_acf = dir.path("zero.acf");
    let mut cases = vec![vec!["check", "/dev/zero"], vec!["run", "/dev/zero"]];
    if cfg!(unix) {
        cases.push(vec!["run", zero_adm.as_str()]);
        cases.push(vec!["import", zero_adm.as_str()]);
        cases.push(vec!["run", adm.as_str(), "--acf", zero_acf.as_str()]);
    }
    for mut args in cases {
        let out = dir.path("r.csv");
        if args[0] == "run" {
            args.extend(["--out", out.as_str()]);
        }
        let (status, err) = run_limited(&dir.0, &args, Duration::from_secs(60));
        assert_eq!(status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("larger than 16 MiB"), "{args:?}: {err}");
    }
}
