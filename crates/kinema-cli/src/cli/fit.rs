//! `kinema fit MODEL --target TARGET.csv --vary P1,P2`: dimensional
//! synthesis through [`kinema::fit`] — the model's params fitted to a
//! target table from many starts on every core, defect-free designs only.
//!
//! Standard output gets the summary: the best designs (rank, RMS and
//! largest error, objectives, params, how many starts ended there) and the
//! rejected starts counted by reason. `--out` writes the model's text with
//! the best design's values, `--summary` the table as CSV, `--plot` the
//! best design's path over the targets. Every input is checked, and every
//! output created, before the first start runs.

use std::fmt::Write as _;
use std::io::Write as _;
use std::time::Instant;

use kinema::fit::{Bound, FitError, Fitter, Objective, Outcome, Spec, Targets};

use super::args::FitArgs;
use super::load::{format_of, load};
use super::output::{Outputs, duration};
use super::{Failure, print_stderr, print_stdout};

mod plot;

/// Runs `kinema fit`.
///
/// # Errors
/// [`Failure::Input`] (exit 2) for a model, table or option that cannot be
/// used (with what and where); [`Failure::Analysis`] (exit 1) when every
/// start was rejected (the counts by reason), or an output cannot be
/// written.
pub fn fit(args: &FitArgs) -> Result<(), Failure> {
    let started = Instant::now();
    let format = format_of(&args.model)?;
    let loaded = load(&args.model, None)?;
    loaded.print_warnings();
    let targets = Targets::read(&args.target).map_err(Failure::usage)?;
    let plot_targets = args.plot.as_ref().map(|_| targets.clone());
    let bounds = args
        .bounds
        .iter()
        .map(|b| b.parse::<Bound>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| Failure::usage(format_args!("--bounds: {e}")))?;
    let objectives = args
        .objective
        .iter()
        .map(|o| o.parse::<Objective>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| Failure::usage(format_args!("--objective: {e}")))?;
    if let Some(t) = args.t_end
        && !(t.is_finite() && t > 0.0)
    {
        return Err(Failure::usage(format_args!(
            "--t-end {t}: the cycle's length must be a positive number"
        )));
    }
    let vary: Vec<&str> = args.vary.iter().map(String::as_str).collect();
    let mut spec = Spec::new(&vary, targets)
        .with_bounds(bounds)
        .with_objectives(objectives)
        .with_starts(args.starts as usize);
    spec.t_end = args.t_end;
    spec.full_turn.clone_from(&args.full_turn);
    spec.steps = args.steps as usize;
    spec.seed = args.seed;
    spec.threads = args.jobs.map_or(0, usize::from);
    let fitter = Fitter::new(&loaded.model, spec).map_err(|e| match e {
        FitError::Model(m) => Failure::usage(format_args!("{}: {m}", loaded.file)),
        other => Failure::usage(other),
    })?;
    if let Some((m, n)) = fitter.underdetermined() {
        print_stderr(&format!(
            "note: {m} target values for {n} unknowns: the exact designs, if any, form a family; each start ends at one of them"
        ));
    }
    // Outputs before the work: a bad path is said now, not after minutes.
    let mut outputs = Outputs::new();
    outputs.input("the model", &args.model);
    outputs.input("the target table", &args.target);
    let source = match (&args.out, format) {
        (Some(_), kinema::Format::Kin) => Some(
            kinema::Source::read(&args.model)
                .map_err(|r| Failure::Input(r.render()))?
                .text()
                .to_owned(),
        ),
        (Some(_), _) => {
            return Err(Failure::usage(
                "--out writes the fitted model as `.kin` text with the params' new values: give a `.kin` model (`kinema import` turns an `.adm` one into text)",
            ));
        }
        (None, _) => None,
    };
    let out = args
        .out
        .as_ref()
        .map(|p| outputs.create("--out", p))
        .transpose()?;
    let summary_file = args
        .summary
        .as_ref()
        .map(|p| outputs.create("--summary", p))
        .transpose()?;
    let plot_file = args
        .plot
        .as_ref()
        .map(|p| outputs.create("--plot", p))
        .transpose()?;
    let fitting = Instant::now();
    let outcome = match fitter.run() {
        Ok(o) => o,
        Err(FitError::NoDesign(rejections)) => {
            return Err(Failure::analysis(format_args!(
                "no defect-free design from {} starts: {rejections}",
                args.starts
            )));
        }
        Err(e) => return Err(Failure::analysis(e)),
    };
    let fit_time = fitting.elapsed();
    let best = &outcome.designs()[0];
    print_stdout(&summary_text(&outcome, args.designs as usize))?;
    if let (Some(mut file), Some(source)) = (out, source) {
        let fitted = fitter
            .fitted_kin(&source, best)
            .map_err(|e| Failure::analysis(format_args!("--out: {e}")))?;
        if fitted.guesses_written {
            print_stderr(&format!(
                "note: {}: the model's guesses would assemble the fitted design on another configuration, so its guesses are written as the fitted one",
                file.path().display()
            ));
        }
        file.write_all(fitted.text.as_bytes()).map_err(|e| {
            Failure::analysis(format_args!(
                "cannot write `{}`: {e}",
                file.path().display()
            ))
        })?;
        file.commit()?;
    }
    if let Some(mut file) = summary_file {
        let csv = summary_csv(&outcome, args.designs as usize);
        file.write_all(csv.as_bytes()).map_err(|e| {
            Failure::analysis(format_args!(
                "cannot write `{}`: {e}",
                file.path().display()
            ))
        })?;
        file.commit()?;
    }
    if let (Some(file), Some(targets)) = (plot_file, plot_targets) {
        let trace = fitter
            .trace(best, 4)
            .map_err(|e| Failure::analysis(format_args!("--plot: {e}")))?;
        let svg = plot::draw(&trace, targets, best)
            .map_err(|e| Failure::analysis(format_args!("--plot: {e}")))?;
        let mut file = file;
        file.write_all(svg.as_bytes()).map_err(|e| {
            Failure::analysis(format_args!(
                "cannot write `{}`: {e}",
                file.path().display()
            ))
        })?;
        file.commit()?;
    }
    print_stderr(&format!(
        "{} starts in {} ({} in all); {} defect-free design{} after merging",
        outcome.starts(),
        duration(fit_time),
        duration(started.elapsed()),
        outcome.designs().len(),
        if outcome.designs().len() == 1 {
            ""
        } else {
            "s"
        }
    ));
    Ok(())
}

/// Numbers for people: six significant digits.
fn num(x: f64) -> String {
    if x == 0.0 || (1e-4..1e6).contains(&x.abs()) {
        let s = format!("{x:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".to_owned()
        } else {
            s.to_owned()
        }
    } else {
        format!("{x:.5e}")
    }
}

/// The summary for standard output: the best designs as an aligned table,
/// then the rejections.
fn summary_text(outcome: &Outcome, k: usize) -> String {
    let designs = &outcome.designs()[..k.min(outcome.designs().len())];
    let mut header = vec![
        "rank".to_owned(),
        "rms error".to_owned(),
        "max error".to_owned(),
    ];
    header.extend(designs[0].objectives().iter().map(|(n, _)| n.clone()));
    header.extend(designs[0].params().iter().map(|(n, _)| n.clone()));
    header.push("starts".to_owned());
    let mut rows = vec![header];
    for (i, d) in designs.iter().enumerate() {
        let mut row = vec![(i + 1).to_string(), num(d.rms()), num(d.max_error())];
        row.extend(d.objectives().iter().map(|(_, v)| num(*v)));
        row.extend(d.params().iter().map(|(_, v)| num(*v)));
        row.push(d.merged().to_string());
        rows.push(row);
    }
    let widths: Vec<usize> = (0..rows[0].len())
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    let mut text = String::new();
    let _ = writeln!(
        text,
        "{} defect-free design{} from {} starts (best first; `starts`: how many ended there)",
        outcome.designs().len(),
        if outcome.designs().len() == 1 {
            ""
        } else {
            "s"
        },
        outcome.starts()
    );
    for row in &rows {
        let cells: Vec<String> = row
            .iter()
            .zip(&widths)
            .map(|(c, w)| format!("{c:>w$}"))
            .collect();
        let _ = writeln!(text, "  {}", cells.join("  "));
    }
    let _ = writeln!(text, "rejected: {}", outcome.rejections());
    if outcome.moved() > 0 {
        let _ = writeln!(
            text,
            "moved: {} start{} that did not run through the targets, fitted from the first point towards the model's design that does",
            outcome.moved(),
            if outcome.moved() == 1 { "" } else { "s" }
        );
    }
    if let Some(times) = designs.first().map(|d| d.times())
        && !times.is_empty()
    {
        let shown: Vec<String> = times.iter().map(|t| num(*t)).collect();
        let _ = writeln!(text, "best design's target times: {}", shown.join(", "));
    }
    text
}

/// The summary as CSV: rank, rms, max, objectives, params, starts, then
/// the target rows' times (fitted, or the prescribed ones).
fn summary_csv(outcome: &Outcome, k: usize) -> String {
    let designs = &outcome.designs()[..k.min(outcome.designs().len())];
    let mut text = String::from("rank,rms,max");
    for (n, _) in designs[0].objectives() {
        let _ = write!(text, ",{n}");
    }
    for (n, _) in designs[0].params() {
        let _ = write!(text, ",{n}");
    }
    text.push_str(",starts");
    for i in 1..=designs[0].times().len() {
        let _ = write!(text, ",t{i}");
    }
    text.push('\n');
    for (i, d) in designs.iter().enumerate() {
        let _ = write!(text, "{},{:e},{:e}", i + 1, d.rms(), d.max_error());
        for (_, v) in d.objectives() {
            let _ = write!(text, ",{v:e}");
        }
        for (_, v) in d.params() {
            let _ = write!(text, ",{v:?}");
        }
        let _ = write!(text, ",{}", d.merged());
        for t in d.times() {
            let _ = write!(text, ",{t:?}");
        }
        text.push('\n');
    }
    text
}
