//! `kinema sweep MODEL --params TABLE.csv`: one model run over every row of
//! a parameter table, on every core, into one long CSV.
//!
//! The table is CSV: a header naming some of the model's parameters, then
//! one row of values per variant (blank lines and lines starting with `#`
//! are skipped). The output has the columns `row` (the variant's 1-based
//! number in the table), the swept parameters, then the columns of
//! `kinema run` (`t`, coordinates, `_dot`, `_ddot`, then the named points and outputs likewise; values only with
//! `--positions-only`), the variants one after
//! the other in table order. A variant whose analysis fails keeps the rows
//! computed before the failure, a warning names it, and the exit status is
//! then 1. `--shard I/N` runs the I-th of N contiguous parts of the table:
//! concatenating the parts' outputs (headers aside) in order gives the
//! whole sweep.

use std::io::Write as _;
use std::time::Instant;

use kinema::Error;
use kinema::sweep::{ModelSweep, shard};

use super::args::SweepArgs;
use super::load::{format_of, load};
use super::output::{Destination, Outputs, Sink, duration, rows_at, time, write_failure};
use super::shared::grid::{DEFAULT_STEPS, DEFAULT_T_END, Grid, check_grid_args};
use super::{Failure, print_stderr};
use kinema::CsvLine;
use kinema::Format;

/// Most rows a parameter table may have.
pub const MAX_ROWS: usize = 10_000_000;

/// Variants solved per batch: the workers fill a batch's CSV text in
/// parallel, then it is written in order.
const BATCH_PER_THREAD: usize = 16;

/// A parameter table: names and rows of values.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The parameter names of the header.
    pub names: Vec<String>,
    /// The rows, each as long as `names`.
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    /// Parses the table's text; `file` names it in messages.
    ///
    /// # Errors
    /// [`Failure::Input`] at `file:line:column` for a missing header, an
    /// empty name, a value that is not a finite number, or a row of the
    /// wrong length.
    pub fn parse(text: &str, file: &str) -> Result<Table, Failure> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l))
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((header_line, header)) = lines.next() else {
            return Err(Failure::usage(format_args!(
                "{file}: the parameter table is empty: expected a header naming parameters, \
                 then one row of values per variant"
            )));
        };
        let mut names = Vec::new();
        for (column, name) in fields(header) {
            if name.is_empty() {
                return Err(Failure::usage(format_args!(
                    "{file}:{header_line}:{column}: empty parameter name in the header"
                )));
            }
            names.push(name.to_owned());
        }
        let mut rows = Vec::new();
        for (line, text) in lines {
            if rows.len() == MAX_ROWS {
                return Err(Failure::usage(format_args!(
                    "{file}:{line}: more than {MAX_ROWS} rows"
                )));
            }
            let mut row = Vec::with_capacity(names.len());
            for (column, field) in fields(text) {
                let value = field.parse::<f64>().ok().filter(|v| v.is_finite());
                let Some(value) = value else {
                    return Err(Failure::usage(format_args!(
                        "{file}:{line}:{column}: expected a finite number, found `{}`",
                        field.escape_debug()
                    )));
                };
                row.push(value);
            }
            if row.len() != names.len() {
                return Err(Failure::usage(format_args!(
                    "{file}:{line}: {} values for {} parameters ({})",
                    row.len(),
                    names.len(),
                    names.join(", ")
                )));
            }
            rows.push(row);
        }
        Ok(Table { names, rows })
    }
}

/// The comma-separated fields of a line, trimmed, with the 1-based column
/// (in characters) where each starts.
fn fields(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut start = 0;
    line.split(',').map(move |field| {
        let lead = field.len() - field.trim_start().len();
        let column = line[..start + lead].chars().count() + 1;
        start += field.len() + 1;
        (column, field.trim())
    })
}

/// `I/N` with 1 ≤ I ≤ N.
///
/// # Errors
/// [`Failure::Input`] naming the option and the valid form.
pub fn parse_shard(text: &str) -> Result<(usize, usize), Failure> {
    let parsed = text
        .split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse().ok()?, n.trim().parse().ok()?)));
    match parsed {
        Some((i, n)) if 1 <= i && i <= n => Ok((i, n)),
        _ => Err(Failure::usage(format_args!(
            "--shard: expected I/N with 1 ≤ I ≤ N (e.g. 2/8, the second of eight parts), \
             found `{}`",
            text.escape_debug()
        ))),
    }
}

/// Runs `kinema sweep`.
pub fn sweep(args: &SweepArgs) -> Result<(), Failure> {
    let start = Instant::now();
    if format_of(&args.model)? == Format::Adm {
        return Err(Failure::usage(
            "kinema sweep takes .kin models: a simEngine2D model has no parameters \
             (`kinema import` it and declare the values to sweep as params)",
        ));
    }
    let steps = check_grid_args(args.t_end, args.steps)?;
    let grid = Grid::uniform(
        args.t_end.unwrap_or(DEFAULT_T_END),
        steps.unwrap_or(DEFAULT_STEPS),
    )?;
    let table_file = args.params.display().to_string();
    // The one size cap and UTF-8 rule of model files.
    let text = kinema::Source::read_text(&args.params, &table_file, "parameter table")
        .map_err(|r| Failure::Input(r.render()))?;
    let table = Table::parse(text.text(), &table_file)?;
    let (part, parts) = match &args.shard {
        Some(s) => parse_shard(s)?,
        None => (1, 1),
    };
    let range = shard(table.rows.len(), part, parts).expect("parse_shard accepts only 1 ≤ I ≤ N");

    let loaded = load(&args.model, None)?;
    loaded.print_warnings();
    let mut sweep = loaded
        .model
        .sweep(&table.names)
        .map_err(|e| Failure::usage(format_args!("{table_file}: {e}")))?;
    if let Some(jobs) = args.jobs {
        sweep = sweep.with_threads(usize::from(jobs));
    }
    if args.positions_only {
        let options = sweep.options().with_positions_only(true);
        sweep = sweep.with_options(options);
    }
    let orders = if args.positions_only { 1 } else { 3 };

    let mut outputs = Outputs::new();
    outputs.input("the model", &args.model);
    outputs.input("the parameter table", &args.params);
    let destination = Destination::of(&args.out);
    let mut out = Sink::open(&mut outputs, "--out", &destination)?;
    let derivation = loaded.model.derivation();
    let coordinates: Vec<&str> = derivation
        .coordinates
        .iter()
        .map(|c| c.name.as_str())
        .collect();
    let results: Vec<&str> = derivation.outputs.iter().map(|o| o.name.as_str()).collect();
    let header = header(&table.names, &[&coordinates, &results], orders);
    out.write_all(header.as_bytes())
        .map_err(|e| write_failure(&destination, &e))?;

    let rows = &table.rows[range.clone()];
    let threads = args.jobs.map_or_else(
        || std::thread::available_parallelism().map_or(1, usize::from),
        usize::from,
    );
    let batch = (threads * BATCH_PER_THREAD).max(1);
    let mut failures: Vec<String> = Vec::new();
    let mut flagged: Vec<String> = Vec::new();
    for (b, chunk) in rows.chunks(batch).enumerate() {
        let first = range.start + b * batch;
        let texts = sweep_chunk(&sweep, chunk, first, &grid.times, orders);
        for (k, result) in texts.into_iter().enumerate() {
            let (bytes, failure, flags) = match result {
                Ok(done) => done,
                Err(e) => (Vec::new(), Some(e), Flags::default()),
            };
            out.write_all(&bytes)
                .map_err(|e| write_failure(&destination, &e))?;
            let index = first + k;
            let values = || describe(&table.names, &table.rows[index]);
            if let Some(e) = failure {
                failures.push(format!("variant {} ({}): {e}", index + 1, values()));
            }
            if let Some(flags) = flags.describe() {
                flagged.push(format!("variant {} ({}): {flags}", index + 1, values()));
            }
        }
    }
    Sink::finish(out, &destination)?;

    let summary = format!(
        "{} ({}): {} of {} variants{}, {} each; {} failed; {} with flagged rows; {}",
        loaded.name(),
        loaded.file,
        rows.len(),
        table.rows.len(),
        if parts > 1 {
            format!(" (part {part} of {parts})")
        } else {
            String::new()
        },
        grid.description,
        failures.len(),
        flagged.len(),
        duration(start.elapsed()),
    );
    for f in &failures {
        print_stderr(&format!("warning: {f}\n"));
    }
    for f in flagged.iter().take(MAX_FLAGGED_WARNINGS) {
        print_stderr(&format!("warning: {f}\n"));
    }
    if flagged.len() > MAX_FLAGGED_WARNINGS {
        print_stderr(&format!(
            "warning: … and {} more variants with flagged rows (not listed)\n",
            flagged.len() - MAX_FLAGGED_WARNINGS
        ));
    }
    let to_stdout = destination == Destination::Stdout;
    if to_stdout {
        print_stderr(&format!("{summary}\n"));
    } else {
        println!("{summary}");
    }
    match failures.len() {
        0 => Ok(()),
        n => Err(Failure::analysis(format_args!(
            "{n} of {} variants failed (their rows up to the failure are written)",
            rows.len()
        ))),
    }
}

/// Most variants with flagged rows named one by one (the rest are
/// counted).
const MAX_FLAGGED_WARNINGS: usize = 20;

/// A variant's CSV text, the error that stopped it (its rows before the
/// error are in the text), and its rows that are not plain solves.
type VariantText = (Vec<u8>, Option<Error>, Flags);

/// A variant's rows that `kinema run` would warn of: near a singular
/// configuration (q̇ and q̈ the branch's limits, not solves), at a kink
/// of an equation (q̇ and q̈ not determined) or of a result (its rates not
/// determined), with an equation its own arithmetic does not determine
/// (see [`kinema::Imprecision`]), and the singular configurations passed.
#[derive(Debug, Default)]
struct Flags {
    near: Vec<f64>,
    kinks: Vec<f64>,
    output_kinks: Vec<f64>,
    imprecise: Vec<f64>,
    /// Whether a row has had the check of every equation.
    checked_all: bool,
    events: Vec<(kinema::SingularKind, f64)>,
}

impl Flags {
    /// Notes `state`, a row written (its results' rates among them if
    /// `rates`).
    fn note(
        &mut self,
        system: &kinema::TapeSystem,
        scratch: &mut Vec<f64>,
        state: &kinema::State,
        size: f64,
        rates: bool,
    ) {
        if state.near_singular() {
            self.near.push(state.t());
        }
        if state.kink().is_some() {
            self.kinks.push(state.t());
        }
        if rates && system.output_kink(scratch, state, size).is_some() {
            self.output_kinks.push(state.t());
        }
        // Every equation on the first row, those that read t after it.
        let scope = if std::mem::replace(&mut self.checked_all, true) {
            kinema::PrecisionScope::Timed
        } else {
            kinema::PrecisionScope::All
        };
        if system.imprecision(scratch, state, size, scope).is_some() {
            self.imprecise.push(state.t());
        }
    }

    /// One clause per kind of flag, `None` without any.
    fn describe(&self) -> Option<String> {
        let rows = |times: &[f64], what: &str| Some(format!("{} {what}", rows_at(times)?));
        let events = self
            .events
            .iter()
            .map(|(kind, t)| format!("{kind} at t = {}", time(*t)));
        let clauses: Vec<String> = events
            .chain(rows(
                &self.near,
                "within the threshold of a singular configuration (q̇ and q̈ are the branch's \
                 limits, not solves)",
            ))
            .chain(rows(
                &self.kinks,
                "at a kink of an equation (q̇ and q̈ are not determined)",
            ))
            .chain(rows(
                &self.output_kinks,
                "at a kink of a result (its rates are not determined)",
            ))
            .chain(rows(
                &self.imprecise,
                "with an equation that its own arithmetic does not determine (q, q̇ and q̈ are \
                 the rounding errors' as much as the model's)",
            ))
            .collect();
        (!clauses.is_empty()).then(|| clauses.join("; "))
    }
}

/// One batch: each variant's CSV text, and the error that stopped it (its
/// rows before the error are in the text).
fn sweep_chunk(
    sweep: &ModelSweep,
    rows: &[Vec<f64>],
    first: usize,
    times: &[f64],
    orders: usize,
) -> Vec<Result<VariantText, Error>> {
    sweep.map(rows, |k, solver| {
        let row = &rows[k];
        let mut prefix = CsvLine::new();
        prefix.text(&(first + k + 1).to_string());
        prefix.numbers(row);
        let mut line = CsvLine::new();
        let mut text = Vec::new();
        // The named points and outputs, evaluated per state as `run` does.
        let m = kinema::Outputs::output_len(solver.system());
        let mut scratch = kinema::System::scratch(solver.system());
        let mut results = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
        let mut flags = Flags::default();
        for &t in times {
            if let Err(e) = solver.step(t) {
                flags.events = events(solver.events());
                return Ok((text, Some(e), flags));
            }
            let Some(state) = solver.state() else { break };
            kinema::Outputs::outputs_of(solver.system(), &mut scratch, state, &mut results);
            flags.note(
                solver.system(),
                &mut scratch,
                state,
                solver.model_size(),
                orders > 1,
            );
            line.clear();
            line.fields_of(&prefix);
            line.number(state.t());
            let states = [state.q(), state.qd(), state.qdd()];
            let values = states[..orders].iter().flat_map(|v| v.iter());
            line.numbers(values.chain(results[..orders].iter().flatten()));
            text.extend_from_slice(line.as_bytes());
            text.push(b'\n');
        }
        flags.events = events(solver.close_events());
        Ok((text, None, flags))
    })
}

/// The kind and time of each singular configuration met.
fn events(events: &[kinema::SingularEvent]) -> Vec<(kinema::SingularKind, f64)> {
    events.iter().map(|e| (e.kind, e.t)).collect()
}

/// `row,<params>,t,<coordinates>,<_dot>,<_ddot>,<results>,<_dot>,<_ddot>`
/// (the first `orders` of the value, `_dot`, `_ddot` blocks).
fn header(params: &[String], blocks: &[&[&str]], orders: usize) -> String {
    let mut header = String::from("row");
    for p in params {
        header.push(',');
        header.push_str(p);
    }
    header.push_str(",t");
    for names in blocks {
        for suffix in &["", "_dot", "_ddot"][..orders] {
            for c in *names {
                header.push(',');
                header.push_str(c);
                header.push_str(suffix);
            }
        }
    }
    header.push('\n');
    header
}

/// `l1 = 0.3, l2 = 1` for messages.
fn describe(names: &[String], values: &[f64]) -> String {
    names
        .iter()
        .zip(values)
        .map(|(n, v)| format!("{n} = {}", time(*v)))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_parse_with_comments_and_blank_lines() {
        let table = Table::parse("# lengths\nl1, l2\n\n0.3, 1\n0.25,1.1\n", "t.csv")
            .expect("a valid table");
        assert_eq!(table.names, ["l1", "l2"]);
        assert_eq!(table.rows, [vec![0.3, 1.0], vec![0.25, 1.1]]);
    }

    #[test]
    fn table_errors_point_at_line_and_column() {
        let message = |text: &str| match Table::parse(text, "t.csv") {
            Err(Failure::Input(m)) => m,
            other => panic!("expected an input failure, got {other:?}"),
        };
        assert_eq!(
            message("l1,l2\n0.3, nan\n"),
            "error: t.csv:2:6: expected a finite number, found `nan`"
        );
        assert_eq!(
            message("l1,l2\n0.3\n"),
            "error: t.csv:2: 1 values for 2 parameters (l1, l2)"
        );
        assert_eq!(
            message("l1,,l2\n"),
            "error: t.csv:1:4: empty parameter name in the header"
        );
        assert!(message("# only a comment\n").contains("the parameter table is empty"));
    }

    #[test]
    fn shards_are_i_of_n() {
        assert_eq!(parse_shard("2/8").ok(), Some((2, 8)));
        for bad in ["0/3", "4/3", "1", "a/b", "-1/2"] {
            assert!(parse_shard(bad).is_err(), "{bad}");
        }
    }
}
