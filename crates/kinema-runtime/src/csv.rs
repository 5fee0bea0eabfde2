//! CSV output per the command-line contract of `DESIGN.md`: [`CsvWriter`].

use std::io::{self, Write};

use crate::state::State;
use crate::system::System;

/// Streams states as CSV rows: columns `t`; every coordinate name; the same
/// names suffixed `_dot` (q̇); then suffixed `_ddot` (q̈). Numbers are
/// written with Rust's `{:e}`, the shortest form that parses back to the same
/// `f64`.
///
/// Use it directly to write while stepping (nothing kept in memory), or
/// through [`Trajectory::write_csv`](crate::Trajectory::write_csv).
#[derive(Debug)]
pub struct CsvWriter<W: Write> {
    out: W,
    n: usize,
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
        write!(self.out, "{t:e}")?;
        for v in q.iter().chain(qd).chain(qdd) {
            write!(self.out, ",{v:e}")?;
        }
        self.out.write_all(b"\n")
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
}
