//! The target table: what a fit should make the mechanism do.
//!
//! A CSV file whose header names result columns of `kinema run` — the
//! coordinates (`rocker.phi`), named points' components (`coupler.p.x`) and
//! outputs — one target per row and column. A column named `t` prescribes
//! each row's time (the timing); without it each row's time is an unknown of
//! the fit, the rows visited in their order within one cycle. Blank lines
//! and lines starting with `#` are skipped; fields may be padded with
//! spaces.

use std::fmt;
use std::path::Path;

/// A target table, read and checked for shape and numbers (the names are
/// checked against a model by [`Fitter::new`](crate::Fitter::new)).
#[derive(Clone, Debug, PartialEq)]
pub struct Targets {
    /// Where it was read from (for messages).
    pub(crate) name: String,
    /// The result columns, in the header's order (without `t`).
    pub(crate) columns: Vec<String>,
    /// Each column's header position (1-based column of the file).
    pub(crate) header_columns: Vec<usize>,
    /// The prescribed times, if the table has a `t` column.
    pub(crate) times: Option<Vec<f64>>,
    /// The rows' target values, row-major (`columns.len()` per row).
    pub(crate) values: Vec<f64>,
    /// Each row's line in the file.
    pub(crate) lines: Vec<usize>,
    /// The header's line.
    pub(crate) header_line: usize,
}

/// A target table that cannot be used, and where.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TargetError {
    /// The file's name.
    pub file: String,
    /// 1-based line, 0 for the file as a whole.
    pub line: usize,
    /// 1-based column (character) in that line, 0 for the whole line.
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for TargetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.column) {
            (0, _) => write!(f, "{}: {}", self.file, self.message),
            (l, 0) => write!(f, "{}:{l}: {}", self.file, self.message),
            (l, c) => write!(f, "{}:{l}:{c}: {}", self.file, self.message),
        }
    }
}

impl std::error::Error for TargetError {}

/// The most a target table may hold: far more than any synthesis problem,
/// and a bound on what a fit is asked to evaluate per design.
const MAX_CELLS: usize = 1_000_000;

impl Targets {
    /// Reads a target table from a file (at most 16 MiB of UTF-8, as every
    /// file kinema reads).
    ///
    /// # Errors
    /// The file cannot be read, or [`Targets::parse`]'s.
    pub fn read(path: impl AsRef<Path>) -> Result<Targets, TargetError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let source =
            kinema_model::Source::read_text(path, &name, "target table").map_err(|report| {
                TargetError {
                    file: name.clone(),
                    line: 0,
                    column: 0,
                    message: report
                        .entries()
                        .first()
                        .map_or_else(|| "cannot read it".to_owned(), |e| e.message.clone()),
                }
            })?;
        Targets::parse(source.text(), &name)
    }

    /// Parses a target table from its text; `name` names it in messages.
    ///
    /// # Errors
    /// No header or no rows; an empty or repeated column name; a row with
    /// another number of fields than the header; a field that is not a
    /// finite number (NaN and infinities are refused: a target must say
    /// where to be); prescribed times that do not increase.
    pub fn parse(text: &str, name: &str) -> Result<Targets, TargetError> {
        let err = |line: usize, column: usize, message: String| TargetError {
            file: name.to_owned(),
            line,
            column,
            message,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l))
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((header_line, header)) = lines.next() else {
            return Err(err(
                0,
                0,
                "the target table is empty: it needs a header naming result columns (e.g. `coupler.p.x,coupler.p.y`, with `t` to prescribe the timing) and one row per target".to_owned(),
            ));
        };
        let mut columns = Vec::new();
        let mut header_columns = Vec::new();
        let mut t_field = None;
        for (k, (col, field)) in fields(header).enumerate() {
            let field = field.trim();
            if field.is_empty() {
                return Err(err(header_line, col, "an empty column name".to_owned()));
            }
            if field == "t" {
                if t_field.is_some() {
                    return Err(err(header_line, col, "`t` is named twice".to_owned()));
                }
                t_field = Some(k);
                continue;
            }
            if columns.iter().any(|c| c == field) {
                return Err(err(
                    header_line,
                    col,
                    format!("the column `{field}` is named twice"),
                ));
            }
            columns.push(field.to_owned());
            header_columns.push(col);
        }
        if columns.is_empty() {
            return Err(err(
                header_line,
                0,
                "the header names no result column to fit (only `t`)".to_owned(),
            ));
        }
        let width = columns.len() + usize::from(t_field.is_some());
        let mut times = t_field.map(|_| Vec::new());
        let mut values = Vec::new();
        let mut rows = Vec::new();
        for (line, text) in lines {
            let mut n = 0;
            for (k, (col, field)) in fields(text).enumerate() {
                n += 1;
                if n > width {
                    return Err(err(
                        line,
                        col,
                        format!("more fields than the header's {width}"),
                    ));
                }
                let field = field.trim();
                let value = parse_number(field).map_err(|why| err(line, col, why))?;
                match (&mut times, t_field) {
                    (Some(ts), Some(tk)) if tk == k => ts.push(value),
                    _ => values.push(value),
                }
            }
            if n < width {
                return Err(err(
                    line,
                    0,
                    format!("{n} fields where the header has {width}"),
                ));
            }
            rows.push(line);
            if values.len() > MAX_CELLS {
                return Err(err(line, 0, format!("more than {MAX_CELLS} target values")));
            }
        }
        if rows.is_empty() {
            return Err(err(
                header_line,
                0,
                "the target table has a header but no rows".to_owned(),
            ));
        }
        if let Some(ts) = &times {
            for (i, w) in ts.windows(2).enumerate() {
                if w[1] <= w[0] {
                    return Err(err(
                        rows[i + 1],
                        0,
                        format!(
                            "the prescribed times must increase (the rows are visited in order): t = {} after t = {}",
                            w[1], w[0]
                        ),
                    ));
                }
            }
        }
        Ok(Targets {
            name: name.to_owned(),
            columns,
            header_columns,
            times,
            values,
            lines: rows,
            header_line,
        })
    }

    /// The result columns to fit, in the header's order.
    #[must_use]
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// The number of target rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.lines.len()
    }

    /// The prescribed times, if the table has a `t` column.
    #[must_use]
    pub fn times(&self) -> Option<&[f64]> {
        self.times.as_deref()
    }

    /// Row `i`'s target values, in the order of [`columns`](Self::columns).
    ///
    /// # Panics
    /// If `i` is not below [`rows`](Self::rows).
    #[must_use]
    pub fn row(&self, i: usize) -> &[f64] {
        let w = self.columns.len();
        &self.values[i * w..(i + 1) * w]
    }

    /// Builds a table from values (no file): `times` prescribes the timing
    /// when given.
    ///
    /// # Errors
    /// As [`Targets::parse`]: no column, no row, a row of another width, a
    /// value that is not finite, times that do not increase.
    pub fn new(
        columns: &[&str],
        rows: &[Vec<f64>],
        times: Option<&[f64]>,
    ) -> Result<Targets, TargetError> {
        let mut text = String::new();
        if times.is_some() {
            text.push_str("t,");
        }
        text.push_str(&columns.join(","));
        text.push('\n');
        for (i, row) in rows.iter().enumerate() {
            let mut cells: Vec<String> = Vec::with_capacity(row.len() + 1);
            if let Some(ts) = times {
                cells.push(ts.get(i).map_or_else(String::new, |t| format!("{t:?}")));
            }
            cells.extend(row.iter().map(|v| format!("{v:?}")));
            text.push_str(&cells.join(","));
            text.push('\n');
        }
        if let Some(ts) = times
            && ts.len() != rows.len()
        {
            return Err(TargetError {
                file: "targets".to_owned(),
                line: 0,
                column: 0,
                message: format!("{} times for {} rows", ts.len(), rows.len()),
            });
        }
        Targets::parse(&text, "targets")
    }
}

/// A line's comma-separated fields with their 1-based character columns.
fn fields(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut col = 1;
    line.split(',').map(move |f| {
        let at = col + f.chars().take_while(|c| c.is_whitespace()).count();
        col += f.chars().count() + 1;
        (at, f)
    })
}

/// A finite number, or why not.
fn parse_number(field: &str) -> Result<f64, String> {
    if field.is_empty() {
        return Err("an empty field: every target needs a value".to_owned());
    }
    match field.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!(
            "`{field}` is not a finite number: a target must say where to be"
        )),
        Err(_) => Err(format!("`{field}` is not a number")),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests: a failure should stop the test
mod tests {
    use super::*;

    #[test]
    fn reads_a_table_with_and_without_times() {
        let t = Targets::parse("# path\nt, p.x, p.y\n0, 1, 2\n0.5, 3, 4\n", "a.csv").unwrap();
        assert_eq!(t.columns(), ["p.x", "p.y"]);
        assert_eq!(t.times(), Some(&[0.0, 0.5][..]));
        assert_eq!(t.row(1), [3.0, 4.0]);
        let t = Targets::parse("p.x,p.y\n1,2\n", "a.csv").unwrap();
        assert_eq!(t.times(), None);
        assert_eq!(t.rows(), 1);
    }

    #[test]
    fn refuses_bad_tables_with_their_place() {
        let e = |text: &str| Targets::parse(text, "a.csv").unwrap_err().to_string();
        assert!(e("").contains("empty"), "{}", e(""));
        assert!(e("p.x\n").contains("no rows"));
        assert_eq!(e("p.x,p.y\n1,oops\n"), "a.csv:2:3: `oops` is not a number");
        assert!(e("p.x\nNaN\n").starts_with("a.csv:2:1: `NaN` is not a finite number"));
        assert!(e("p.x,p.y\n1\n").contains("1 fields where the header has 2"));
        assert!(e("p.x\n1,2\n").starts_with("a.csv:2:3: more fields"));
        assert!(e("p.x,p.x\n1,2\n").contains("named twice"));
        assert!(e("t,p.x\n1,0\n1,0\n").contains("must increase"));
        assert!(e("t\n1\n").contains("only `t`"));
        assert!(e("p.x,\n1,2\n").starts_with("a.csv:1:5: an empty column name"));
    }
}
