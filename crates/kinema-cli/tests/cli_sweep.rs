//! `kinema sweep`: every variant's rows are those `kinema run` writes for
//! the model with that variant's parameters; shards concatenate to the
//! whole; bad tables and arguments are refused with their position.

mod common;

use common::{Csv, TempDir, TestResult, assert_status, kinema, stderr};

const MODEL: &str = "models/slider_crank.kin";

/// The slider-crank model text with `l1` and `l2` declared as given.
fn variant(l1: f64, l2: f64) -> Result<String, std::io::Error> {
    let text = std::fs::read_to_string(format!("{}/{MODEL}", common::ROOT))?;
    Ok(text
        .replace("param l1 = 0.3;", &format!("param l1 = {l1:?};"))
        .replace("param l2 = 1.0;", &format!("param l2 = {l2:?};")))
}

#[test]
fn each_variant_is_the_run_of_its_parameters() -> TestResult {
    let dir = TempDir::new("sweep-rows");
    let table = dir.path("lengths.csv");
    std::fs::write(
        &table,
        "# crank, rod\nl1, l2\n0.3, 1.0\n\n0.25, 1.1\n0.2, 0.9\n",
    )?;
    let out = dir.path("sweep.csv");
    let o = kinema(&[
        "sweep", MODEL, "--params", &table, "--steps", "20", "--out", &out, "--jobs", "2",
    ]);
    assert_status(&o, 0);
    let sweep = Csv::read(&out)?;
    assert_eq!(sweep.header[..4], ["row", "l1", "l2", "t"]);
    assert_eq!(sweep.rows.len(), 3 * 21);
    for (k, (l1, l2)) in [(0.3, 1.0), (0.25, 1.1), (0.2, 0.9)]
        .into_iter()
        .enumerate()
    {
        let model = dir.path(&format!("v{k}.kin"));
        std::fs::write(&model, variant(l1, l2)?)?;
        let alone = dir.path(&format!("v{k}.csv"));
        assert_status(
            &kinema(&["run", &model, "--steps", "20", "--out", &alone]),
            0,
        );
        let alone = Csv::read(&alone)?;
        assert_eq!(sweep.header[3..], alone.header[..]);
        for (i, row) in alone.rows.iter().enumerate() {
            let swept = &sweep.rows[21 * k + i];
            assert_eq!(swept[..3], [(k + 1) as f64, l1, l2]);
            assert_eq!(swept[3..], row[..], "variant {k}, row {i}");
        }
    }
    Ok(())
}

#[test]
fn shards_concatenate_to_the_whole_sweep() -> TestResult {
    let dir = TempDir::new("sweep-shards");
    let table = dir.path("t.csv");
    let rows: Vec<String> = (0..7)
        .map(|k| format!("{}, {}", 0.2 + 0.01 * f64::from(k), 1.0))
        .collect();
    std::fs::write(&table, format!("l1,l2\n{}\n", rows.join("\n")))?;
    let whole = dir.path("whole.csv");
    assert_status(
        &kinema(&[
            "sweep", MODEL, "--params", &table, "--steps", "5", "--out", &whole,
        ]),
        0,
    );
    let mut parts = String::new();
    for part in 1..=3 {
        let out = dir.path(&format!("p{part}.csv"));
        let shard = format!("{part}/3");
        let o = kinema(&[
            "sweep", MODEL, "--params", &table, "--steps", "5", "--shard", &shard, "--out", &out,
        ]);
        assert_status(&o, 0);
        let text = std::fs::read_to_string(&out)?;
        let body = text.split_once('\n').map_or("", |(_, rest)| rest);
        parts.push_str(body);
    }
    let whole = std::fs::read_to_string(&whole)?;
    assert_eq!(
        whole.split_once('\n').map(|(_, rest)| rest),
        Some(parts.as_str())
    );
    Ok(())
}

#[test]
fn a_failing_variant_is_named_and_the_others_are_written() -> TestResult {
    let dir = TempDir::new("sweep-fail");
    let table = dir.path("t.csv");
    // A rod shorter than the crank cannot close the loop.
    std::fs::write(&table, "l1,l2\n0.3,1\n0.3,0.1\n0.25,1.1\n")?;
    let out = dir.path("s.csv");
    let o = kinema(&[
        "sweep", MODEL, "--params", &table, "--steps", "4", "--out", &out,
    ]);
    assert_status(&o, 1);
    let err = stderr(&o);
    assert!(
        err.contains("warning: variant 2 (l1 = 0.3, l2 = 0.1)"),
        "{err}"
    );
    assert!(err.contains("1 of 3 variants failed"), "{err}");
    let csv = Csv::read(&out)?;
    let variants: Vec<f64> = csv.rows.iter().map(|r| r[0]).collect();
    assert_eq!(
        variants,
        [1.0; 5].into_iter().chain([3.0; 5]).collect::<Vec<_>>()
    );
    Ok(())
}

#[test]
fn bad_tables_and_arguments_are_refused_with_their_place() -> TestResult {
    let dir = TempDir::new("sweep-bad");
    let cases: [(&str, &[&str], &str); 6] = [
        (
            "l1,l2\n0.3,x\n",
            &[],
            "t.csv:2:5: expected a finite number, found `x`",
        ),
        (
            "l1,l2\n0.3\n",
            &[],
            "t.csv:2: 1 values for 2 parameters (l1, l2)",
        ),
        (
            "l1,crank\n0.3,1\n",
            &[],
            "unknown parameter `crank`; the model's parameters are: l1, l2, omega",
        ),
        ("", &[], "the parameter table is empty"),
        (
            "l1\n0.3\n",
            &["--shard", "0/2"],
            "--shard: expected I/N with 1 ≤ I ≤ N",
        ),
        ("l1\n0.3\n", &["--steps", "-3"], "--steps"),
    ];
    for (text, extra, expected) in cases {
        let table = dir.path("t.csv");
        std::fs::write(&table, text)?;
        let out = dir.path("s.csv");
        let mut args = vec![
            "sweep",
            MODEL,
            "--params",
            table.as_str(),
            "--out",
            out.as_str(),
        ];
        args.extend_from_slice(extra);
        let o = kinema(&args);
        assert_status(&o, 2);
        assert!(stderr(&o).contains(expected), "{text:?}: {}", stderr(&o));
    }
    let o = kinema(&["sweep", MODEL, "--params", MODEL, "--out", MODEL]);
    assert_status(&o, 2);
    Ok(())
}

/// A variant whose rows `kinema run` would warn of (here the change-point
/// four-bar's bifurcations, at l1 = 1 only) is named with what is flagged,
/// and counted in the summary; the CSV is written as for any variant.
#[test]
fn variants_with_flagged_rows_are_named() -> TestResult {
    let dir = TempDir::new("sweep-flagged");
    let table = dir.path("t.csv");
    std::fs::write(&table, "l1\n1\n0.9\n")?;
    let out = dir.path("s.csv");
    let o = kinema(&[
        "sweep",
        "tests/singular/change_point.kin",
        "--params",
        &table,
        "--t-end",
        "2",
        "--steps",
        "72",
        "--out",
        &out,
    ]);
    assert_status(&o, 0);
    let err = stderr(&o);
    let warnings: Vec<&str> = err.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(
        warnings[0].starts_with("warning: variant 1 (l1 = 1): bifurcation at t = 0.87"),
        "{err}"
    );
    assert!(warnings[0].contains("; bifurcation at t = 1.87"), "{err}");
    let summary = String::from_utf8_lossy(&o.stdout);
    assert!(
        summary.contains("0 failed; 1 with flagged rows"),
        "{summary}"
    );
    assert_eq!(Csv::read(&out)?.rows.len(), 2 * 73);
    Ok(())
}
