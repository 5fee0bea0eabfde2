//! CSV output per the command-line contract of `docs/src/cli.md`: one number
//! format and one row builder, [`CsvLine`], which every CSV of kinema is
//! written with ([`CsvWriter`] here, [`Table::write_csv`], the command
//! line's `run` and `sweep`).
//!
//! [`Table::write_csv`]: crate::Table::write_csv

use std::io::{self, Write};

mod number;

use crate::state::State;
use crate::system::System;

/// One CSV row being built: comma-separated numbers in the text of Rust's
/// `{:e}`, the shortest form that parses back to the same `f64` (written
/// through `ryu`, about three times faster than the standard formatter),
/// and fields given as text. Reused from row to row: no allocation once
/// the longest row has been built.
#[derive(Default, Clone)]
pub struct CsvLine {
    text: Vec<u8>,
    buffer: ryu::Buffer,
}

impl std::fmt::Debug for CsvLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CsvLine")
            .field("text", &String::from_utf8_lossy(&self.text))
            .finish_non_exhaustive()
    }
}

impl CsvLine {
    /// An empty row.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts a new row.
    pub fn clear(&mut self) {
        self.text.clear();
    }

    fn separate(&mut self) {
        if !self.text.is_empty() {
            self.text.push(b',');
        }
    }

    /// Appends a number as a field.
    pub fn number(&mut self, v: f64) {
        self.separate();
        number::push_e(&mut self.text, &mut self.buffer, v);
    }

    /// Appends numbers as fields.
    pub fn numbers<'a>(&mut self, values: impl IntoIterator<Item = &'a f64>) {
        for &v in values {
            self.number(v);
        }
    }

    /// Appends a field given as text (a name, an integer).
    pub fn text(&mut self, field: &str) {
        self.separate();
        self.text.extend_from_slice(field.as_bytes());
    }

    /// Appends a row built elsewhere as fields (a common prefix).
    pub fn fields_of(&mut self, other: &CsvLine) {
        if !other.text.is_empty() {
            self.separate();
            self.text.extend_from_slice(&other.text);
        }
    }

    /// The row so far, without its line end.
    #[must_use]
    pub fn as_bytes(&self) -> &[u8] {
        &self.text
    }

    /// Writes the row and a line end to `out`.
    ///
    /// # Errors
    /// Write errors of `out`.
    pub fn write_to<W: Write + ?Sized>(&self, out: &mut W) -> io::Result<()> {
        out.write_all(&self.text)?;
        out.write_all(b"\n")
    }
}

/// Streams states as CSV rows: columns `t`; every coordinate name; the same
/// names suffixed `_dot` (q̇); then suffixed `_ddot` (q̈). Numbers as
/// [`CsvLine`] writes them.
///
/// Use it directly to write while stepping (nothing kept in memory), or
/// through [`Trajectory::write_csv`](crate::Trajectory::write_csv).
#[derive(Debug)]
pub struct CsvWriter<W: Write> {
    out: W,
    n: usize,
    line: CsvLine,
}

impl<W: Write> CsvWriter<W> {
    /// Writes the header for the given coordinate names.
    pub fn new<N: AsRef<str>>(mut out: W, names: &[N]) -> io::Result<Self> {
        out.write_all(b"t")?;
        for suffix in ["", "_dot", "_ddot"] {
            for name in names {
                write!(out, ",{}{suffix}", name.as_ref())?;
            }
        }
        out.write_all(b"\n")?;
        Ok(Self {
            out,
            n: names.len(),
            line: CsvLine::new(),
        })
    }

    /// Writes the header with the system's coordinate names.
    pub fn for_system<S: System + ?Sized>(out: W, system: &S) -> io::Result<Self> {
        let names: Vec<&str> = (0..system.len())
            .map(|i| system.coordinate_name(i))
            .collect();
        Self::new(out, &names)
    }

    /// Writes one row: t, q, q̇, q̈ (each of the header's length).
    pub fn write_row(&mut self, t: f64, q: &[f64], qd: &[f64], qdd: &[f64]) -> io::Result<()> {
        for (what, x) in [("q", q), ("q̇", qd), ("q̈", qdd)] {
            if x.len() != self.n {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("{what} has length {}, the CSV header {}", x.len(), self.n),
                ));
            }
        }
        self.line.clear();
        self.line.number(t);
        self.line.numbers(q.iter().chain(qd).chain(qdd));
        self.line.write_to(&mut self.out)
    }

    /// Writes one state as a row.
    pub fn write_state(&mut self, state: &State) -> io::Result<()> {
        self.write_row(state.t(), state.q(), state.qd(), state.qdd())
    }

    /// Flushes the underlying writer.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// Gives the writer back.
    pub fn into_inner(self) -> W {
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_and_round_trip() -> Result<(), Box<dyn std::error::Error>> {
        let mut csv = CsvWriter::new(Vec::new(), &["b.x", "b.y"])?;
        let v = [0.1 + 0.2, -1.0 / 3.0];
        csv.write_row(0.125, &v, &[1e-300, 0.0], &[-2.5e17, 7.0])?;
        assert!(csv.write_row(0.0, &[1.0], &v, &v).is_err());
        let text = String::from_utf8(csv.into_inner())?;
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some("t,b.x,b.y,b.x_dot,b.y_dot,b.x_ddot,b.y_ddot")
        );
        let row: Vec<f64> = lines
            .next()
            .ok_or("row")?
            .split(',')
            .map(str::parse)
            .collect::<Result<_, _>>()?;
        assert_eq!(row, [0.125, v[0], v[1], 1e-300, 0.0, -2.5e17, 7.0]);
        assert_eq!(lines.next(), None);
        Ok(())
    }

    #[test]
    fn a_line_joins_text_numbers_and_a_prefix_and_is_reused()
    -> Result<(), Box<dyn std::error::Error>> {
        let mut prefix = CsvLine::new();
        prefix.text("7");
        prefix.numbers(&[0.5, -1e-300]);
        let mut line = CsvLine::new();
        let mut out = Vec::new();
        for t in [0.0, 0.1 + 0.2] {
            line.clear();
            line.fields_of(&prefix);
            line.number(t);
            line.write_to(&mut out)?;
        }
        let text = String::from_utf8(out)?;
        assert_eq!(
            text,
            format!("7,5e-1,-1e-300,0e0\n7,5e-1,-1e-300,{:e}\n", 0.1 + 0.2)
        );
        // An empty prefix adds no empty field.
        line.clear();
        line.fields_of(&CsvLine::new());
        line.number(f64::NAN);
        assert_eq!(line.as_bytes(), b"NaN");
        Ok(())
    }
}
